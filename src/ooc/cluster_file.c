/*
 * Grid clustering of a file that need not fit in memory (mr_cluster_file),
 * after Lindstrom's out-of-core simplification (OoCS, 2000), on one rank or
 * on the ranks of a distributed job (ooc_cluster_file). The input is read
 * in passes through an ooc_source (a binary PLY file in place; a binary STL
 * welded, or an OBJ file parsed, into temporary files): its bounding box;
 * its vertices in blocks into their cells (a provisional cell id per
 * vertex, 4 bytes, and each cell's sums); its faces in batches, each
 * surviving triangle's quadric added to its three cells (its corners'
 * positions read at random from the source, whose pages are given back as
 * the passes go). Memory: the 4 bytes a vertex, and what grows with the
 * output (the cells, the surviving triangles).
 *
 * The sums run over the same members in the same order as mr_mesh_cluster's
 * (a cell's vertices by index, its triangles by index), and the cells are
 * numbered by key as there, so the output is mr_mesh_cluster's of the mesh
 * mr_mesh_read would give, byte for byte.
 *
 * On several ranks: the box from each rank's share of the vertex blocks;
 * the cells shared out by a hash of their key, each rank reading every
 * vertex block but summing only the vertices of its cells (so that each
 * cell's sum is one rank's, in index order); the cell numbering and the
 * labels agreed (keys to rank 0, the numbers back, the labels summed); the
 * faces shared out by chunk, each rank's survivors and quadrics sent to
 * rank 0, which adds them in rank order (the file's), places the cells'
 * vertices and writes. The same bytes at any rank and thread count. A
 * target count's search runs on every rank, over all the vertices.
 */
#define _GNU_SOURCE
#include "comm.h"
#include "source.h"
#include "../cluster/grid.h"
#include "../core/omp_compat.h"
#include "../io/io_internal.h"

#include <math.h>
#include <sys/stat.h>

/* Vertices decoded a block; triangles a face batch (at least one chunk);
 * the mapped pages given back every RELEASE_EVERY face chunks; a batch's
 * vertices mapped ahead when they span fewer rows than PREFETCH_ROWS;
 * triangles a step of the survivors' ordered filter. */
enum {
    VERTEX_BLOCK = 1 << 18,
    FACE_BATCH = 1 << 18,
    RELEASE_EVERY = 64,
    PREFETCH_ROWS = 1 << 21,
    FILTER_STEP = 4096
};

/* An input whose in-memory clustering fits the budget at this many bytes a
 * triangle (the mesh read whole and the clustering's arrays) is read whole
 * when it is an OBJ or STL file (a binary PLY file is read in place
 * always: no temporary files). */
#define INCORE_BYTES_PER_TRIANGLE 64

/* Bytes a message carries at most; survivors a message. */
#define MESSAGE_BYTES ((size_t)8 << 20)
enum { SURVIVORS_A_MESSAGE = 1 << 16 };

#define EMPTY UINT32_MAX

/* ---- the cells by key -------------------------------------------------------- */

/* Cells by key, in the order of first appearance: an open-addressing
 * table of keys to provisional ids, and each cell's key and sums in slabs
 * of SLAB cells (allocated whole, on huge pages where the system gives
 * them: growing one array by copies would fault its pages in again and
 * again). */
enum { SUMS = 13, SLAB_BITS = 16, SLAB = 1 << SLAB_BITS };

typedef struct slot {
    uint64_t key;
    uint32_t id; /* EMPTY: a free slot */
} slot;

typedef struct cell_table {
    slot *slots;
    size_t mask;      /* slots - 1 */
    size_t count;     /* cells */
    size_t nslabs;
    uint64_t **keys;  /* per slab: SLAB keys */
    double **sums;    /* per slab: SLAB x (count, position (3), normal (3), uv (2), color (4)) */
} cell_table;

static void table_free(cell_table *t)
{
    free(t->slots);
    for (size_t i = 0; i < t->nslabs; i++) {
        free(t->keys[i]);
        free(t->sums[i]);
    }
    free(t->keys);
    free(t->sums);
    memset(t, 0, sizeof *t);
}

static inline double *cell_sums(const cell_table *t, uint32_t id)
{
    return t->sums[id >> SLAB_BITS] + SUMS * (size_t)(id & (SLAB - 1));
}

static inline uint64_t cell_key(const cell_table *t, uint32_t id)
{
    return t->keys[id >> SLAB_BITS][id & (SLAB - 1)];
}

static inline size_t slot_of(uint64_t key, size_t mask) { return (size_t)(mr_mix64(key) & mask); }

static bool table_grow(cell_table *t)
{
    const size_t n = t->mask ? 2 * (t->mask + 1) : 1u << 16;
    slot *ns = mr_alloc_array(n, sizeof *ns);
    if (!ns)
        return false;
    for (size_t i = 0; i < n; i++)
        ns[i].id = EMPTY;
    for (size_t i = 0; t->mask && i <= t->mask; i++) {
        if (t->slots[i].id == EMPTY)
            continue;
        size_t j = slot_of(t->slots[i].key, n - 1);
        while (ns[j].id != EMPTY)
            j = (j + 1) & (n - 1);
        ns[j] = t->slots[i];
    }
    free(t->slots);
    t->slots = ns;
    t->mask = n - 1;
    return true;
}

/* The provisional id of the cell `key`, made when new; EMPTY when out of
 * memory. */
static uint32_t table_id(cell_table *t, uint64_t key)
{
    if (2 * (t->count + 1) > t->mask + 1 && !table_grow(t))
        return EMPTY;
    size_t j = slot_of(key, t->mask);
    while (t->slots[j].id != EMPTY) {
        if (t->slots[j].key == key)
            return t->slots[j].id;
        j = (j + 1) & t->mask;
    }
    if (t->count == t->nslabs * SLAB) {
        uint64_t **k = mr_realloc_array(t->keys, t->nslabs + 1, sizeof *k);
        if (!k)
            return EMPTY;
        t->keys = k;
        double **sm = mr_realloc_array(t->sums, t->nslabs + 1, sizeof *sm);
        if (!sm)
            return EMPTY;
        t->sums = sm;
        k[t->nslabs] = mr_alloc_array(SLAB, sizeof **k);
        sm[t->nslabs] = mr_alloc_array(SLAB, SUMS * sizeof **sm);
        if (!k[t->nslabs] || !sm[t->nslabs]) {
            free(k[t->nslabs]);
            free(sm[t->nslabs]);
            return EMPTY;
        }
        t->nslabs++;
    }
    const uint32_t id = (uint32_t)t->count++;
    t->slots[j].key = key;
    t->slots[j].id = id;
    t->keys[id >> SLAB_BITS][id & (SLAB - 1)] = key;
    memset(cell_sums(t, id), 0, SUMS * sizeof(double));
    return id;
}

/* ---- the job ------------------------------------------------------------------- */

typedef struct cjob {
    const char *in_path;
    const mr_cluster_options *o;
    ooc_source *src;
    ooc_comm *comm; /* NULL: one rank */
    int rank, ranks, threads;
    size_t n, tc;
    unsigned attrs;
} cjob;

static mr_status agree(const cjob *j, mr_status st, mr_error *err)
{
    return j->ranks > 1 ? j->comm->agree(j->comm, st, err) : st;
}

/* This rank's share [*first, *last) of n things. */
static void share(const cjob *j, size_t n, size_t *first, size_t *last)
{
    *first = (size_t)((unsigned __int128)n * (unsigned)j->rank / (unsigned)j->ranks);
    *last = (size_t)((unsigned __int128)n * (unsigned)(j->rank + 1) / (unsigned)j->ranks);
}

/* The rank whose cell `key` is (its sums are that rank's alone). */
static inline int owner_of(const cjob *j, uint64_t key)
{
    return j->ranks > 1 ? (int)((mr_mix64(key) >> 40) % (uint64_t)j->ranks) : 0;
}

/* n bytes to / from one rank, in messages of MESSAGE_BYTES at most. */
static mr_status send_all(const cjob *j, int to, const void *buf, size_t n, mr_error *err)
{
    mr_status st = MR_OK;
    for (size_t at = 0; at < n && st == MR_OK; at += MESSAGE_BYTES)
        st = j->comm->send(j->comm, to, (const char *)buf + at,
                           n - at < MESSAGE_BYTES ? n - at : MESSAGE_BYTES, err);
    return st;
}

static mr_status recv_all(const cjob *j, int from, void *buf, size_t n, mr_error *err)
{
    mr_status st = MR_OK;
    for (size_t at = 0; at < n && st == MR_OK; at += MESSAGE_BYTES)
        st = j->comm->recv(j->comm, from, (char *)buf + at,
                           n - at < MESSAGE_BYTES ? n - at : MESSAGE_BYTES, err);
    return st;
}

/* Every rank's one count, in rank order into all (ranks). */
static mr_status gather_count(const cjob *j, uint64_t mine, uint64_t *all, mr_error *err)
{
    if (j->ranks == 1) {
        all[0] = mine;
        return MR_OK;
    }
    return j->comm->gather(j->comm, &mine, 1, all, err);
}

/* ---- the target count's search ------------------------------------------------- */

/* K(c) of the file's vertices (every stride-th), a pass over them: on
 * bitmaps where the grid is small, else in a cell table. The same counts
 * as mr_mesh_cluster's of the same points. */
typedef struct file_count {
    ooc_source *src;
    size_t n, stride;
    int threads;
    const double *lo, *hi;
    mr_mesh *block; /* positions only */
} file_count;

static mr_status count_file(double cell, void *user, size_t *k, mr_error *err)
{
    const file_count *fc = user;
    mr_grid grid;
    mr_grid_init(&grid, fc->lo, fc->hi, cell);
    const size_t total = mr_grid_cells_total(&grid);
    const bool bitmap = total <= MR_GRID_BITMAP_CELLS;
    const size_t words = bitmap ? (total + 63) / 64 : 0;
    uint64_t *bits = bitmap ? mr_calloc_array(words * (size_t)fc->threads, sizeof *bits) : NULL;
    if (bitmap && !bits)
        return mr_fail_nomem(err, NULL, words * 8 * (size_t)fc->threads);
    cell_table t;
    memset(&t, 0, sizeof t);
    mr_status s = MR_OK;
    for (size_t v0 = 0; v0 < fc->n && s == MR_OK; v0 += VERTEX_BLOCK) {
        const size_t m = fc->n - v0 < VERTEX_BLOCK ? fc->n - v0 : VERTEX_BLOCK;
        fc->block->vertex_count = m;
        if ((s = fc->src->vertices(fc->src->impl, v0, m, fc->block, err)) != MR_OK)
            break;
        /* the sample: the vertices whose index is a multiple of stride */
        const size_t first = (fc->stride - v0 % fc->stride) % fc->stride;
        if (first >= m)
            continue;
        const size_t count = (m - first + fc->stride - 1) / fc->stride;
        const float *p = fc->block->positions + 3 * first;
        if (bitmap) {
            mr_grid_mark(&grid, p, count, fc->stride, fc->threads, bits, words);
            continue;
        }
        for (size_t i = 0; i < count; i++)
            if (table_id(&t, mr_grid_key(&grid, p + 3 * fc->stride * i)) == EMPTY) {
                s = mr_fail_nomem(err, NULL, t.count * (SUMS * 8 + 32));
                break;
            }
    }
    fc->src->release(fc->src->impl);
    *k = bitmap ? mr_grid_marked(bits, words, fc->threads) : t.count;
    free(bits);
    table_free(&t);
    return s;
}

/* ---- the passes ------------------------------------------------------------------ */

/* Pass 1: the bounding box of every vertex (each rank its share of the
 * blocks: minima and maxima are exact however they are combined). */
static mr_status bounds_pass(const cjob *j, mr_mesh *b, double lo[3], double hi[3],
                             mr_error *err)
{
    const size_t blocks = (j->n + VERTEX_BLOCK - 1) / VERTEX_BLOCK;
    size_t b0, b1;
    share(j, blocks, &b0, &b1);
    double l0 = INFINITY, l1 = INFINITY, l2 = INFINITY;
    double h0 = -INFINITY, h1 = -INFINITY, h2 = -INFINITY;
    mr_status s = MR_OK;
    for (size_t bi = b0; bi < b1 && s == MR_OK; bi++) {
        const size_t v0 = bi * VERTEX_BLOCK;
        const size_t m = j->n - v0 < VERTEX_BLOCK ? j->n - v0 : VERTEX_BLOCK;
        b->vertex_count = m;
        if ((s = j->src->vertices(j->src->impl, v0, m, b, err)) != MR_OK)
            break;
        const float *p = b->positions;
        const ptrdiff_t nm = (ptrdiff_t)m;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (nm > 65536) \
    reduction(min : l0, l1, l2) reduction(max : h0, h1, h2)
        for (ptrdiff_t i = 0; i < nm; i++) {
            const double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
            l0 = x < l0 ? x : l0, l1 = y < l1 ? y : l1, l2 = z < l2 ? z : l2;
            h0 = x > h0 ? x : h0, h1 = y > h1 ? y : h1, h2 = z > h2 ? z : h2;
        }
    }
    j->src->release(j->src->impl);
    lo[0] = l0, lo[1] = l1, lo[2] = l2;
    hi[0] = h0, hi[1] = h1, hi[2] = h2;
    s = agree(j, s, err);
    if (s == MR_OK && j->ranks > 1 &&
        (s = j->comm->reduce(j->comm, lo, 3, OOC_F64, OOC_MIN, err)) == MR_OK)
        s = j->comm->reduce(j->comm, hi, 3, OOC_F64, OOC_MAX, err);
    return s;
}

/* The cell size: the options', or a fraction of the box's diagonal, or the
 * target count's (a sample's search, checked on every vertex, searched on
 * every vertex from there if the sample missed). */
static mr_status cell_size(const cjob *j, const double lo[3], const double hi[3], double *cell,
                           mr_error *err)
{
    const mr_cluster_options *o = j->o;
    *cell = o->cell;
    if (o->target_vertices == 0 && o->cell_rel > 0) {
        const double dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
        const double diagonal = sqrt(dx * dx + dy * dy + dz * dz);
        *cell = o->cell_rel * diagonal;
        if (diagonal == 0)
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, j->in_path,
                                 "all %zu vertices are at one point, so a cell of %g of the "
                                 "bounding-box diagonal (0) is no cell size; give a cell or a "
                                 "target vertex count",
                                 j->n, o->cell_rel);
        if (!(*cell > 0) || isinf(*cell))
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, j->in_path,
                                 "a cell of %g of the bounding-box diagonal (%g) is no usable "
                                 "cell size",
                                 o->cell_rel, diagonal);
    }
    const size_t target = o->target_vertices;
    if (!target)
        return MR_OK;
    mr_mesh pos;
    mr_mesh_init(&pos);
    mr_status s = mr_mesh_alloc(&pos, VERTEX_BLOCK, 0, 0, err);
    if (s == MR_OK) {
        file_count fc = {j->src, j->n, mr_cluster_sample_stride(j->n, target), j->threads,
                         lo, hi, &pos};
        s = mr_cluster_search(lo, hi, target, 0, count_file, &fc, cell, err);
        size_t k = 0;
        if (s == MR_OK && fc.stride > 1) {
            fc.stride = 1;
            s = count_file(*cell, &fc, &k, err);
            if (s == MR_OK && !mr_cluster_count_close(k, target))
                s = mr_cluster_search(lo, hi, target, *cell, count_file, &fc, cell, err);
        }
    }
    mr_mesh_free(&pos);
    return s;
}

/* Pass 2: each vertex of this rank's cells into its cell, in index order:
 * label[v] its cell's provisional id (EMPTY: another rank's cell). Each
 * block's keys on every thread, sorted (stable: a cell's vertices stay in
 * index order); each run of one cell looked up once, then the runs (each
 * a different cell) summed on every thread. */
static mr_status label_pass(const cjob *j, const mr_grid *grid, mr_mesh *b, cell_table *t,
                            uint32_t *label, mr_error *err)
{
    uint64_t *key = mr_alloc_array(VERTEX_BLOCK, sizeof *key);
    uint32_t *kid = mr_alloc_array(VERTEX_BLOCK, sizeof *kid);
    uint32_t *run = mr_alloc_array(VERTEX_BLOCK + 1, sizeof *run);
    uint32_t *run_id = mr_alloc_array(VERTEX_BLOCK, sizeof *run_id);
    /* the sort's scratch once: not faulted in again for every block */
    uint64_t *tmp_key = mr_alloc_array(VERTEX_BLOCK, sizeof *tmp_key);
    uint32_t *tmp_kid = mr_alloc_array(VERTEX_BLOCK, sizeof *tmp_kid);
    mr_status s = key && kid && run && run_id && tmp_key && tmp_kid
                      ? MR_OK
                      : mr_fail_nomem(err, j->in_path, VERTEX_BLOCK * 32);
    if (s == MR_OK && j->ranks > 1)
        memset(label, 0xFF, j->n * sizeof *label);
    const unsigned key_bits = mr_grid_key_bits(grid);
    for (size_t v0 = 0; v0 < j->n && s == MR_OK; v0 += VERTEX_BLOCK) {
        const size_t m = j->n - v0 < VERTEX_BLOCK ? j->n - v0 : VERTEX_BLOCK;
        b->vertex_count = m;
        if ((s = j->src->vertices(j->src->impl, v0, m, b, err)) != MR_OK)
            break;
        const ptrdiff_t nm = (ptrdiff_t)m;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (nm > 16384)
        for (ptrdiff_t i = 0; i < nm; i++) {
            key[i] = mr_grid_key(grid, b->positions + 3 * i);
            kid[i] = (uint32_t)i;
        }
        size_t mine = m;
        if (j->ranks > 1) {
            mine = 0;
            for (size_t i = 0; i < m; i++)
                if (owner_of(j, key[i]) == j->rank) {
                    key[mine] = key[i];
                    kid[mine++] = kid[i];
                }
        }
        if ((s = mr_radix_sort_u64_scratch(key, kid, mine, key_bits, j->threads, tmp_key,
                                           tmp_kid, err)) != MR_OK)
            break;
        size_t runs = 0;
        for (size_t i = 0; i < mine; runs++) {
            const uint32_t id = table_id(t, key[i]);
            if (id == EMPTY) {
                s = mr_fail_nomem(err, j->in_path, t->count * (SUMS * 8 + 32));
                break;
            }
            run[runs] = (uint32_t)i;
            run_id[runs] = id;
            const uint64_t k0 = key[i];
            while (i < mine && key[i] == k0)
                i++;
        }
        if (s != MR_OK)
            break;
        run[runs] = (uint32_t)mine;
        const ptrdiff_t nr = (ptrdiff_t)runs;
        const float *pos = b->positions, *nrm = b->normals, *uv = b->texcoords,
                    *col = b->colors;
#pragma omp parallel for schedule(dynamic, 256) num_threads(j->threads) if (nr > 1024)
        for (ptrdiff_t r = 0; r < nr; r++) {
            const uint32_t id = run_id[r];
            double *sm = cell_sums(t, id);
            for (size_t q = run[r]; q < run[r + 1]; q++) {
                const size_t v = kid[q];
                label[v0 + v] = id;
                sm[0] += 1;
                for (int c = 0; c < 3; c++)
                    sm[1 + c] += pos[3 * v + (size_t)c];
                if (nrm)
                    for (int c = 0; c < 3; c++)
                        sm[4 + c] += nrm[3 * v + (size_t)c];
                if (uv)
                    for (int c = 0; c < 2; c++)
                        sm[7 + c] += uv[2 * v + (size_t)c];
                if (col)
                    for (int c = 0; c < 4; c++)
                        sm[9 + c] += col[4 * v + (size_t)c];
            }
        }
    }
    j->src->release(j->src->impl);
    free(key);
    free(kid);
    free(run);
    free(run_id);
    free(tmp_key);
    free(tmp_kid);
    return s;
}

/* The cells, numbered by key as mr_mesh_cluster numbers them: on rank 0
 * *keys (*k of them, by number) and *sums (SUMS each, by number); every
 * rank's labels turned into the numbers. Each rank's keys go to rank 0
 * (in rank order: the cells' places in the sort), the numbers come back,
 * the labels of each rank's cells are summed over the ranks (each vertex
 * is one rank's: the others add 0), and the sums go to rank 0. */
static mr_status number_cells(const cjob *j, const mr_grid *grid, cell_table *t,
                              uint32_t *label, uint64_t **keys_out, double **sums_out,
                              size_t *k_out, mr_error *err)
{
    const size_t nr = (size_t)j->ranks, mine = t->count;
    uint64_t *counts = mr_alloc_array(nr, sizeof *counts);
    uint64_t *keys = NULL;
    uint32_t *number = NULL, *ids = NULL;
    double *sums = NULL;
    mr_status s = agree(j, counts ? MR_OK : mr_fail_nomem(err, NULL, nr * 8), err);
    if (s == MR_OK)
        s = gather_count(j, mine, counts, err);
    size_t k = 0; /* every rank's cells */
    for (size_t r = 0; s == MR_OK && r < nr; r++)
        k += (size_t)counts[r];
    if (s == MR_OK && k > UINT32_MAX)
        s = mr_fail_plain(err, MR_ERR_TOO_LARGE, j->in_path,
                          "%zu occupied cells exceed the 32-bit index limit", k);
    /* rank 0: every key, by place; the places sorted into the numbers */
    const size_t held = j->rank == 0 ? k : mine;
    if (s == MR_OK) {
        keys = mr_alloc_array(held ? held : 1, sizeof *keys);
        number = mr_alloc_array(held ? held : 1, sizeof *number);
        if (!keys || !number)
            s = mr_fail_nomem(err, j->in_path, held * 12);
    }
    for (size_t i = 0; s == MR_OK && i < mine; i++)
        keys[i] = cell_key(t, (uint32_t)i);
    s = agree(j, s, err);
    if (s == MR_OK && j->rank != 0)
        s = send_all(j, 0, keys, mine * sizeof *keys, err);
    for (size_t r = 1, off = mine; s == MR_OK && j->rank == 0 && r < nr; r++) {
        s = recv_all(j, (int)r, keys + off, (size_t)counts[r] * sizeof *keys, err);
        off += (size_t)counts[r];
    }
    if (s == MR_OK && j->rank == 0) {
        if (!(ids = mr_alloc_array(k ? k : 1, sizeof *ids)))
            s = mr_fail_nomem(err, j->in_path, k * 4);
        for (size_t i = 0; s == MR_OK && i < k; i++)
            ids[i] = (uint32_t)i;
        if (s == MR_OK)
            s = mr_radix_sort_u64(keys, ids, k, mr_grid_key_bits(grid), j->threads, err);
        for (size_t i = 0; s == MR_OK && i < k; i++)
            number[ids[i]] = (uint32_t)i;
    }
    free(ids);
    s = agree(j, s, err);
    /* the numbers of each rank's cells back to it */
    for (size_t r = 1, off = mine; s == MR_OK && j->rank == 0 && r < nr; r++) {
        s = send_all(j, (int)r, number + off, (size_t)counts[r] * sizeof *number, err);
        off += (size_t)counts[r];
    }
    if (s == MR_OK && j->rank != 0)
        s = recv_all(j, 0, number, mine * sizeof *number, err);
    s = agree(j, s, err);
    /* the labels: each vertex's number (several ranks: summed in pieces,
     * each vertex's from the rank of its cell) */
    if (s == MR_OK) {
        const ptrdiff_t n = (ptrdiff_t)j->n;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (n > 65536)
        for (ptrdiff_t v = 0; v < n; v++)
            label[v] = label[v] == EMPTY ? 0 : number[label[v]];
    }
    enum { PIECE = 1 << 22 };
    for (size_t v0 = 0; s == MR_OK && j->ranks > 1 && v0 < j->n; v0 += PIECE)
        s = j->comm->reduce(j->comm, label + v0, j->n - v0 < PIECE ? j->n - v0 : PIECE, OOC_U32,
                            OOC_SUM, err);
    /* the sums, by number, on rank 0 (the other ranks' a slab at a time) */
    if (s == MR_OK && j->rank == 0 && !(sums = mr_alloc_array(k ? k : 1, SUMS * sizeof *sums)))
        s = mr_fail_nomem(err, j->in_path, k * SUMS * 8);
    for (size_t i = 0; s == MR_OK && j->rank == 0 && i < mine; i++)
        memcpy(sums + SUMS * (size_t)number[i], cell_sums(t, (uint32_t)i), SUMS * 8);
    s = agree(j, s, err);
    for (size_t sl = 0; s == MR_OK && j->rank != 0 && sl < t->nslabs; sl++) {
        const size_t c = mine - sl * SLAB < SLAB ? mine - sl * SLAB : SLAB;
        s = send_all(j, 0, t->sums[sl], c * SUMS * sizeof(double), err);
    }
    if (s == MR_OK && j->rank == 0 && nr > 1) {
        double *slab = mr_alloc_array(SLAB, SUMS * sizeof *slab);
        if (!slab)
            s = mr_fail_nomem(err, j->in_path, SLAB * SUMS * 8);
        for (size_t r = 1, off = mine; s == MR_OK && r < nr; r++) {
            for (size_t i = 0; s == MR_OK && i < (size_t)counts[r]; i += SLAB) {
                const size_t c = (size_t)counts[r] - i < SLAB ? (size_t)counts[r] - i : SLAB;
                s = recv_all(j, (int)r, slab, c * SUMS * sizeof *slab, err);
                for (size_t q = 0; s == MR_OK && q < c; q++)
                    memcpy(sums + SUMS * (size_t)number[off + i + q], slab + SUMS * q,
                           SUMS * 8);
            }
            off += (size_t)counts[r];
        }
        free(slab);
    }
    free(counts);
    free(number);
    s = agree(j, s, err);
    if (s != MR_OK || j->rank != 0) {
        free(keys);
        free(sums);
        keys = NULL;
        sums = NULL;
    }
    *keys_out = keys;
    *sums_out = sums;
    *k_out = k;
    return s;
}

/* The surviving triangles, in file order: their cells' numbers (3 each)
 * and, on rank 0, their quadrics added into their cells; on the other
 * ranks kept with them, for rank 0. */
typedef struct survivors {
    uint32_t *tri;
    double *q;    /* 10 each (ranks past 0) */
    size_t count, cap;
} survivors;

static mr_status survivors_grow(survivors *sv, size_t more, bool quadrics, mr_error *err)
{
    if (sv->count + more <= sv->cap)
        return MR_OK;
    size_t cap = sv->cap ? sv->cap : 1u << 16;
    while (cap < sv->count + more)
        cap *= 2;
    /* grown into new blocks (huge pages) rather than by realloc */
    uint32_t *t = mr_alloc_array(cap, 3 * sizeof *t);
    double *q = quadrics ? mr_alloc_array(cap, 10 * sizeof *q) : NULL;
    if (!t || (quadrics && !q)) {
        free(t);
        free(q);
        return mr_fail_nomem(err, NULL, cap * (quadrics ? 92 : 12));
    }
    if (sv->count) {
        memcpy(t, sv->tri, 12 * sv->count);
        if (quadrics)
            memcpy(q, sv->q, 80 * sv->count);
    }
    free(sv->tri);
    free(sv->q);
    sv->tri = t;
    sv->q = q;
    sv->cap = cap;
    return MR_OK;
}

static void add_quadric(double *quad, const uint32_t *tri, const double *q)
{
    for (int e = 0; e < 3; e++) {
        double *acc = quad + 10 * (size_t)tri[e];
        for (int c = 0; c < 10; c++)
            acc[c] += q[c];
    }
}

/* Pass 3: this rank's share of the face chunks in batches: the survivors
 * (no two corners in one cell) picked on every thread in order, their
 * quadrics on every thread, then (rank 0) added in order into quad (10 a
 * cell) or (other ranks) kept. */
static mr_status face_pass(const cjob *j, const uint32_t *label, double *quad, survivors *sv,
                           mr_error *err)
{
    ooc_source *src = j->src;
    size_t c0, c1;
    share(j, src->face_chunks, &c0, &c1);
    const size_t per = src->max_faces + 1;
    const size_t cap = per > FACE_BATCH ? per : FACE_BATCH;
    uint32_t *idx = mr_alloc_array(cap, 3 * sizeof *idx);
    uint32_t *pick = mr_alloc_array(cap, sizeof *pick);
    double *tq = mr_alloc_array(cap, 10 * sizeof *tq);
    const size_t steps_cap = cap / FILTER_STEP + 2;
    size_t *step = mr_alloc_array(steps_cap, sizeof *step);
    mr_status s = idx && pick && tq && step ? MR_OK : mr_fail_nomem(err, j->in_path, cap * 96);
    if (s == MR_OK && c0 < c1)
        src->seek(src->impl, c0);
    const bool keep = j->rank != 0;
    for (size_t at = c0, since = 0; s == MR_OK && at < c1;) {
        size_t got = 0, chunks = 0;
        if ((s = src->next_batch(src->impl, idx, cap, c1 - at, &got, &chunks, err)) != MR_OK ||
            chunks == 0)
            break;
        at += chunks;
        if ((since += chunks) >= RELEASE_EVERY) {
            src->release(src->impl);
            since = 0;
        }
        if (got == 0)
            continue;
        /* the survivors, in order: counted a step each, then written */
        const size_t steps = (got + FILTER_STEP - 1) / FILTER_STEP;
        const ptrdiff_t ns = (ptrdiff_t)steps;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (ns > 4)
        for (ptrdiff_t q = 0; q < ns; q++) {
            const size_t f0 = (size_t)q * FILTER_STEP,
                         f1 = f0 + FILTER_STEP < got ? f0 + FILTER_STEP : got;
            size_t c = 0;
            for (size_t f = f0; f < f1; f++) {
                const uint32_t *t = idx + 3 * f;
                const uint32_t a = label[t[0]], b = label[t[1]], d = label[t[2]];
                c += a != b && b != d && a != d;
            }
            step[q + 1] = c;
        }
        step[0] = 0;
        for (size_t q = 0; q < steps; q++)
            step[q + 1] += step[q];
        const size_t alive = step[steps];
        uint32_t vmin = UINT32_MAX, vmax = 0;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (ns > 4) \
    reduction(min : vmin) reduction(max : vmax)
        for (ptrdiff_t q = 0; q < ns; q++) {
            const size_t f0 = (size_t)q * FILTER_STEP,
                         f1 = f0 + FILTER_STEP < got ? f0 + FILTER_STEP : got;
            size_t w = step[q];
            for (size_t f = f0; f < f1; f++) {
                const uint32_t *t = idx + 3 * f;
                const uint32_t a = label[t[0]], b = label[t[1]], d = label[t[2]];
                if (a != b && b != d && a != d) {
                    pick[w++] = (uint32_t)f;
                    for (int e = 0; e < 3; e++) {
                        vmin = t[e] < vmin ? t[e] : vmin;
                        vmax = t[e] > vmax ? t[e] : vmax;
                    }
                }
            }
        }
        if (alive == 0)
            continue;
        /* their corners, mapped ahead when they are near one another (a
         * coherent file), else read as they come */
        if ((size_t)(vmax - vmin) < PREFETCH_ROWS)
            src->prefetch(src->impl, vmin, vmax);
        if ((s = survivors_grow(sv, alive, keep, err)) != MR_OK)
            break;
        double *qout = keep ? sv->q + 10 * sv->count : tq;
        uint32_t *tout = sv->tri + 3 * sv->count;
        const ptrdiff_t na = (ptrdiff_t)alive;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (na > 4096)
        for (ptrdiff_t i = 0; i < na; i++) {
            const uint32_t *t = idx + 3 * (size_t)pick[i];
            float p[3][3];
            for (int e = 0; e < 3; e++) {
                src->position(src->impl, t[e], p[e]);
                tout[3 * i + e] = label[t[e]];
            }
            mr_cluster_triangle_quadric(p[0], p[1], p[2], qout + 10 * i);
        }
        if (!keep)
            for (size_t i = 0; i < alive; i++)
                add_quadric(quad, tout + 3 * i, tq + 10 * i);
        sv->count += alive;
    }
    src->release(src->impl);
    free(idx);
    free(pick);
    free(tq);
    free(step);
    return s;
}

/* Several ranks: every other rank's survivors to rank 0, in rank order
 * (the file's), their quadrics added there. */
static mr_status collect_survivors(const cjob *j, double *quad, survivors *sv, mr_error *err)
{
    const size_t nr = (size_t)j->ranks;
    uint64_t *counts = mr_alloc_array(nr, sizeof *counts);
    mr_status s = agree(j, counts ? MR_OK : mr_fail_nomem(err, NULL, nr * 8), err);
    if (s == MR_OK)
        s = gather_count(j, sv->count, counts, err);
    if (j->rank != 0) {
        for (size_t i = 0; s == MR_OK && i < sv->count; i += SURVIVORS_A_MESSAGE) {
            const size_t c = sv->count - i < SURVIVORS_A_MESSAGE ? sv->count - i
                                                                 : SURVIVORS_A_MESSAGE;
            if ((s = send_all(j, 0, sv->tri + 3 * i, 12 * c, err)) == MR_OK)
                s = send_all(j, 0, sv->q + 10 * i, 80 * c, err);
        }
        free(counts);
        return s;
    }
    double *q = s == MR_OK ? mr_alloc_array(SURVIVORS_A_MESSAGE, 10 * sizeof *q) : NULL;
    if (s == MR_OK && !q)
        s = mr_fail_nomem(err, NULL, SURVIVORS_A_MESSAGE * 80);
    for (size_t r = 1; s == MR_OK && r < nr; r++) {
        const size_t total = (size_t)counts[r];
        if ((s = survivors_grow(sv, total, false, err)) != MR_OK)
            break;
        for (size_t i = 0; s == MR_OK && i < total; i += SURVIVORS_A_MESSAGE) {
            const size_t c = total - i < SURVIVORS_A_MESSAGE ? total - i : SURVIVORS_A_MESSAGE;
            uint32_t *t = sv->tri + 3 * sv->count;
            if ((s = recv_all(j, (int)r, t, 12 * c, err)) == MR_OK)
                s = recv_all(j, (int)r, q, 80 * c, err);
            for (size_t f = 0; s == MR_OK && f < c; f++)
                add_quadric(quad, t + 3 * f, q + 10 * f);
            sv->count += c;
        }
    }
    free(q);
    free(counts);
    return s;
}

static mr_status cluster_stream(const cjob *j, mr_mesh *out, mr_cluster_stats *st,
                                mr_error *err)
{
    const double t0 = mr_now_seconds();
    st->input_vertices = j->n;
    st->input_triangles = j->tc;
    mr_mesh b;
    mr_mesh_init(&b);
    mr_status s = mr_mesh_alloc(&b, VERTEX_BLOCK, 0, j->attrs, err);
    s = agree(j, s, err);
    uint32_t *label = NULL;
    uint64_t *keys = NULL;
    double *sums = NULL, *quad = NULL;
    size_t k = 0;
    survivors sv = {0};
    cell_table t;
    memset(&t, 0, sizeof t);
    double lo[3], hi[3], cell = 0;
    if (s == MR_OK)
        s = bounds_pass(j, &b, lo, hi, err);
    if (s == MR_OK)
        s = agree(j, cell_size(j, lo, hi, &cell, err), err);
    mr_grid grid;
    if (s == MR_OK) {
        mr_grid_init(&grid, lo, hi, cell);
        if (!(label = mr_alloc_array(j->n ? j->n : 1, sizeof *label)))
            s = mr_fail_nomem(err, j->in_path, j->n * sizeof *label);
        if (s == MR_OK)
            s = label_pass(j, &grid, &b, &t, label, err);
        s = agree(j, s, err);
    }
    mr_mesh_free(&b);
    if (s == MR_OK)
        s = number_cells(j, &grid, &t, label, &keys, &sums, &k, err);
    table_free(&t);
    st->cells = k;
    st->cell = s == MR_OK ? grid.cell : 0;
    st->seconds_cells = mr_now_seconds() - t0;

    /* pass 3: the faces, the survivors' quadrics into their cells */
    const double t1 = mr_now_seconds();
    if (s == MR_OK && j->rank == 0 && !(quad = mr_calloc_array(k ? k : 1, 10 * sizeof *quad)))
        s = mr_fail_nomem(err, j->in_path, k * 80);
    s = agree(j, s, err);
    if (s == MR_OK)
        s = agree(j, face_pass(j, label, quad, &sv, err), err);
    free(label);
    if (s == MR_OK && j->ranks > 1)
        s = agree(j, collect_survivors(j, quad, &sv, err), err);
    if (j->rank != 0) {
        free(sv.tri);
        free(sv.q);
        st->seconds_representatives = mr_now_seconds() - t1;
        return s;
    }

    /* the cells' vertices, in key order */
    if (s == MR_OK)
        s = mr_mesh_alloc(out, k, 0, j->attrs, err);
    if (s == MR_OK) {
        const ptrdiff_t nk = (ptrdiff_t)k;
#pragma omp parallel for schedule(dynamic, 256) num_threads(j->threads) if (nk > 1024)
        for (ptrdiff_t cc = 0; cc < nk; cc++) {
            const double *sm = sums + SUMS * (size_t)cc;
            mr_cluster_represent(&grid, keys[cc], quad + 10 * cc, sm + 1, sm + 4, sm + 7, sm + 9,
                                 sm[0], lo, hi, out, (size_t)cc);
        }
    }
    free(keys);
    free(sums);
    free(quad);
    st->seconds_representatives = mr_now_seconds() - t1;
    const double t2 = mr_now_seconds();
    if (s == MR_OK) {
        free(out->indices); /* the placeholder mr_mesh_alloc made for 0 triangles */
        out->indices = sv.tri ? sv.tri : mr_alloc_array(1, 12);
        out->triangle_count = sv.count;
        sv.tri = NULL;
        s = mr_mesh_remove_degenerate(out, 1, NULL, err);
    }
    free(sv.tri);
    free(sv.q);
    if (s == MR_OK && j->tc > 0)
        s = mr_mesh_remove_unreferenced(out, NULL, err);
    st->seconds_triangles = mr_now_seconds() - t2;
    st->output_vertices = out->vertex_count;
    st->output_triangles = out->triangle_count;
    return s;
}

/* ---- the entry -------------------------------------------------------------------- */

/* An OBJ file's attributes that the output would keep: the streaming path
 * carries none of an OBJ file's (the write options may drop them: then
 * its v lines are clustered as they are). */
static mr_status check_obj_attributes(const char *path, unsigned attrs,
                                      const mr_write_options *write, uint64_t triangles,
                                      mr_error *err)
{
    unsigned dropped = 0;
    if (write) {
        dropped |= write->write_normals ? 0 : MR_ATTR_NORMALS;
        dropped |= write->write_texcoords ? 0 : MR_ATTR_TEXCOORDS;
        dropped |= write->write_colors ? 0 : MR_ATTR_COLORS;
    }
    const unsigned kept = attrs & ~dropped;
    if (!kept)
        return MR_OK;
    char what[64] = "";
    const char *names[3] = {"normals", "texture coordinates", "colors"};
    const unsigned bits[3] = {MR_ATTR_NORMALS, MR_ATTR_TEXCOORDS, MR_ATTR_COLORS};
    for (int i = 0; i < 3; i++)
        if (kept & bits[i])
            snprintf(what + strlen(what), sizeof what - strlen(what), "%s%s",
                     what[0] ? " and " : "", names[i]);
    return mr_fail_plain(err, MR_ERR_UNSUPPORTED, path,
                         "its vertices have %s, which the streaming clustering of an OBJ "
                         "file does not carry: drop them from the output (--no-normals, "
                         "--no-texcoords, --no-colors) for a clustering of its v lines, or "
                         "give a memory budget of at least %llu MB to read it whole",
                         what,
                         (unsigned long long)((triangles * INCORE_BYTES_PER_TRIANGLE >> 20) + 1));
}

/* The in-memory path: read whole, mr_mesh_cluster. */
static mr_status in_core(const char *in_path, const mr_cluster_options *o, mr_mesh *out,
                         mr_cluster_stats *st, mr_error *err)
{
    mr_mesh in;
    mr_read_options ro;
    mr_read_options_default(&ro);
    ro.threads = o->threads;
    mr_status s = mr_mesh_read(in_path, &ro, &in, err);
    if (s == MR_OK && (s = mr_mesh_cluster(&in, o, out, st, err)) == MR_ERR_INVALID_ARGUMENT) {
        /* the clustering's refusal is about this file's points: name it */
        char text[sizeof err->message];
        snprintf(text, sizeof text, "%s", err->message);
        s = mr_fail_plain(err, s, in_path, "%s", text);
    }
    mr_mesh_free(&in);
    return s;
}

mr_status ooc_cluster_file(const char *in_path, const char *out_path,
                           const mr_cluster_options *options, const mr_out_of_core_options *ooc,
                           const mr_write_options *write, ooc_comm *comm,
                           mr_cluster_stats *stats, mr_error *err)
{
    mr_error_clear(err);
    mr_cluster_options defaults;
    if (!options) {
        mr_cluster_options_default(&defaults);
        options = &defaults;
    }
    mr_cluster_stats st;
    memset(&st, 0, sizeof st);
    if (stats)
        *stats = st;
    if (!in_path || !out_path)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no input or output path");
    if (options->target_vertices == 0 && options->cell_rel == 0 &&
        !(options->cell > 0 && isfinite(options->cell)))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "grid cell size must be a finite number > 0 when no target "
                             "vertex count is set, got %g",
                             options->cell);
    const double t0 = mr_now_seconds();
    cjob j;
    memset(&j, 0, sizeof j);
    j.in_path = in_path;
    j.o = options;
    j.threads = mr_thread_count(options->threads);
    j.comm = comm && comm->size > 1 ? comm : NULL;
    j.rank = j.comm ? comm->rank : 0;
    j.ranks = j.comm ? comm->size : 1;
    const uint64_t memory = ooc && ooc->memory ? ooc->memory : MR_MEMORY_DEFAULT;
    ooc_source src;
    memset(&src, 0, sizeof src);
    ooc_temp temp;
    memset(&temp, 0, sizeof temp);
    mr_mesh out;
    mr_mesh_init(&out);
    /* the source: a binary PLY file in place; a binary STL or OBJ file
     * that does not fit the budget through temporary files; anything else
     * (ascii, small) is read whole */
    mr_error quiet;
    mr_status s = MR_OK;
    bool whole = true;
    const mr_format format = mr_format_from_path(in_path);
    if (format == MR_FORMAT_PLY) {
        s = ooc_source_open(in_path, j.threads, &src, &quiet);
        whole = s == MR_ERR_UNSUPPORTED;
        if (whole)
            s = MR_OK;
        else if (s != MR_OK && err)
            *err = quiet;
    } else if (format == MR_FORMAT_STL) {
        const uint64_t n = ooc_stl_triangles(in_path);
        if (n && n * INCORE_BYTES_PER_TRIANGLE > memory) {
            whole = false;
            s = ooc_temp_init(&temp, ooc ? ooc->temp_dir : NULL, out_path,
                              ooc ? ooc->temp_budget : 0, err);
            if (s == MR_OK)
                s = ooc_source_from_stl(in_path, &temp, memory, j.threads, &src, err);
        }
    } else if (format == MR_FORMAT_OBJ) {
        struct stat sb;
        if (stat(in_path, &sb) == 0 && S_ISREG(sb.st_mode) &&
            (uint64_t)sb.st_size / 8 * INCORE_BYTES_PER_TRIANGLE > memory) {
            /* counted first (the windows): read whole if it fits */
            uint64_t window = memory / 8;
            window = window < ((uint64_t)1 << 20)   ? (uint64_t)1 << 20
                     : window > ((uint64_t)64 << 20) ? (uint64_t)64 << 20
                                                     : window;
            mr_obj_stream *os = NULL;
            s = mr_obj_stream_open(in_path, j.threads, (size_t)window, &os, &quiet);
            if (s != MR_OK && err)
                *err = quiet;
            whole = s == MR_OK && (uint64_t)mr_obj_stream_triangle_count(os) *
                                          INCORE_BYTES_PER_TRIANGLE <= memory;
            if (s == MR_OK && whole) {
                mr_obj_stream_close(os);
            } else if (s == MR_OK) {
                s = ooc_temp_init(&temp, ooc ? ooc->temp_dir : NULL, out_path,
                                  ooc ? ooc->temp_budget : 0, err);
                if (s == MR_OK)
                    s = ooc_source_from_obj(os, in_path, &temp, 0, 0, 1, &src, err);
                else
                    mr_obj_stream_close(os);
                if (s == MR_OK)
                    s = check_obj_attributes(in_path, src.attributes, write,
                                             src.triangle_count, err);
                src.attributes = 0; /* the source has the positions only */
            }
        }
    }
    /* every rank opened the same file the same way (or one failed) */
    s = agree(&j, s, err);
    if (s == MR_OK && whole) {
        ooc_source_close(&src);
        s = j.rank == 0 ? in_core(in_path, options, &out, &st, err) : MR_OK;
    } else if (s == MR_OK) {
        j.src = &src;
        j.n = src.vertex_count;
        j.tc = src.triangle_count;
        j.attrs = src.attributes;
        st.streamed = 1;
        s = cluster_stream(&j, &out, &st, err);
    }
    ooc_source_close(&src);
    st.temp_bytes_peak = temp.peak;
    s = agree(&j, s, err);
    if (s == MR_OK && j.rank == 0)
        s = mr_mesh_write(out_path, &out, write, err);
    mr_mesh_free(&out);
    s = agree(&j, s, err);
    st.seconds_total = mr_now_seconds() - t0;
    if (stats)
        *stats = st;
    return s;
}

mr_status mr_cluster_file(const char *in_path, const char *out_path,
                          const mr_cluster_options *options, const mr_out_of_core_options *ooc,
                          const mr_write_options *write, mr_cluster_stats *stats, mr_error *err)
{
    return ooc_cluster_file(in_path, out_path, options, ooc, write, NULL, stats, err);
}
