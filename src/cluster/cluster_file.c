/*
 * Grid clustering of a file that need not fit in memory (mr_cluster_file),
 * after Lindstrom's out-of-core simplification (OoCS, 2000): a binary PLY
 * input is read in passes -- its bounding box, then its vertices in blocks
 * into their cells (a provisional cell id per vertex, 4 bytes, and each
 * cell's sums), then its faces chunk by chunk, each surviving triangle's
 * quadric added to its three cells (its corners' positions read from the
 * mapped file, whose pages are given back as the passes go). Memory: the
 * 4 bytes a vertex, and what grows with the output (the cells, the
 * surviving triangles). The sums run over the same members in the same
 * order as mr_mesh_cluster's (vertices by index within a cell, a cell's
 * triangles by index), and the cells are numbered by key as there, so the
 * output is mr_mesh_cluster's of the mesh mr_mesh_read would give, byte
 * for byte. Other inputs (OBJ, STL, ascii PLY) are read whole and
 * clustered in memory.
 */
#include "grid.h"
#include "../io/io_internal.h"

#include <math.h>

/* Vertices decoded a block. */
enum { VERTEX_BLOCK = 1 << 18 };

/* Give the mapped vertex pages back every this many face chunks; faces a
 * batch (at least); map a batch's vertices ahead when they span fewer
 * rows than this. */
enum { RELEASE_EVERY = 64, FACE_BATCH = 1 << 18, PREFETCH_ROWS = 1 << 21 };

#define EMPTY UINT32_MAX

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

/* K(c) of the file's vertices (every stride-th), a pass over them: on
 * bitmaps where the grid is small, else in a cell table. The same counts
 * as mr_mesh_cluster's of the same points. */
typedef struct file_count {
    mr_ply_source *src;
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
        if ((s = mr_ply_source_vertices(fc->src, v0, m, fc->block, err)) != MR_OK)
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
    mr_ply_source_release(fc->src);
    *k = bitmap ? mr_grid_marked(bits, words, fc->threads) : t.count;
    free(bits);
    table_free(&t);
    return s;
}

/* A block of vertices with the arrays the source has attributes for. */
static mr_status block_alloc(mr_mesh *b, unsigned attrs, mr_error *err)
{
    mr_mesh_init(b);
    return mr_mesh_alloc(b, VERTEX_BLOCK, 0, attrs, err);
}

static mr_status cluster_stream(mr_ply_source *src, const char *in_path,
                                const mr_cluster_options *o, mr_mesh *out, mr_cluster_stats *st,
                                mr_error *err)
{
    const size_t n = mr_ply_source_vertex_count(src), tc = mr_ply_source_triangle_count(src);
    const unsigned attrs = mr_ply_source_attributes(src);
    const double t0 = mr_now_seconds();
    st->input_vertices = n;
    st->input_triangles = tc;
    mr_mesh b;
    mr_status s = block_alloc(&b, attrs, err);
    if (s != MR_OK)
        return s;
    uint32_t *label = NULL, *idx = NULL, *tri_out = NULL, *rank = NULL;
    double *quad = NULL;
    cell_table t;
    memset(&t, 0, sizeof t);

    /* pass 1: the bounding box of every vertex */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v0 = 0; v0 < n && s == MR_OK; v0 += VERTEX_BLOCK) {
        const size_t m = n - v0 < VERTEX_BLOCK ? n - v0 : VERTEX_BLOCK;
        b.vertex_count = m;
        if ((s = mr_ply_source_vertices(src, v0, m, &b, err)) != MR_OK)
            break;
        for (size_t i = 0; i < m; i++)
            for (int k = 0; k < 3; k++) {
                const double x = b.positions[3 * i + (size_t)k];
                lo[k] = x < lo[k] ? x : lo[k];
                hi[k] = x > hi[k] ? x : hi[k];
            }
    }
    mr_ply_source_release(src);
    double cell = o->cell;
    if (s == MR_OK && o->target_vertices == 0 && o->cell_rel > 0) {
        const double dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
        const double diagonal = sqrt(dx * dx + dy * dy + dz * dz);
        cell = o->cell_rel * diagonal;
        if (diagonal == 0)
            s = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, in_path,
                              "all %zu vertices are at one point, so a cell of %g of the "
                              "bounding-box diagonal (0) is no cell size; give a cell or a "
                              "target vertex count",
                              n, o->cell_rel);
        else if (!(cell > 0) || isinf(cell))
            s = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, in_path,
                              "a cell of %g of the bounding-box diagonal (%g) is no usable "
                              "cell size",
                              o->cell_rel, diagonal);
    }
    /* A target: the cells as mr_mesh_cluster finds them (a sample's
     * search, checked on every vertex, searched on every vertex from there
     * if the sample missed) */
    const size_t target = o->target_vertices;
    if (s == MR_OK && target) {
        mr_mesh pos;
        mr_mesh_init(&pos);
        if ((s = mr_mesh_alloc(&pos, VERTEX_BLOCK, 0, 0, err)) == MR_OK) {
            file_count fc = {src, n, mr_cluster_sample_stride(n, target),
                             mr_thread_count(o->threads), lo, hi, &pos};
            s = mr_cluster_search(lo, hi, target, 0, count_file, &fc, &cell, err);
            size_t k = 0;
            if (s == MR_OK && fc.stride > 1) {
                fc.stride = 1;
                s = count_file(cell, &fc, &k, err);
                if (s == MR_OK && !mr_cluster_count_close(k, target))
                    s = mr_cluster_search(lo, hi, target, cell, count_file, &fc, &cell, err);
            }
        }
        mr_mesh_free(&pos);
    }
    mr_grid grid;
    if (s == MR_OK)
        mr_grid_init(&grid, lo, hi, cell);

    /* pass 2: each vertex into its cell, in index order */
    const int threads = mr_thread_count(o->threads);
    uint64_t *key = mr_alloc_array(VERTEX_BLOCK, sizeof *key);
    uint32_t *kid = mr_alloc_array(VERTEX_BLOCK, sizeof *kid);
    if (s == MR_OK && (!(label = mr_alloc_array(n, sizeof *label)) || !key || !kid))
        s = mr_fail_nomem(err, in_path, n * sizeof *label);
    for (size_t v0 = 0; v0 < n && s == MR_OK; v0 += VERTEX_BLOCK) {
        const size_t m = n - v0 < VERTEX_BLOCK ? n - v0 : VERTEX_BLOCK;
        b.vertex_count = m;
        if ((s = mr_ply_source_vertices(src, v0, m, &b, err)) != MR_OK)
            break;
        /* the keys on every thread, sorted (stable: a cell's vertices stay
         * in index order); then each run of one cell looked up once and
         * its vertices added in order */
        const ptrdiff_t nm = (ptrdiff_t)m;
#pragma omp parallel for schedule(static) num_threads(threads) if (nm > 16384)
        for (ptrdiff_t i = 0; i < nm; i++) {
            key[i] = mr_grid_key(&grid, b.positions + 3 * i);
            kid[i] = (uint32_t)i;
        }
        if ((s = mr_radix_sort_u64(key, kid, m, mr_grid_key_bits(&grid), threads, err)) != MR_OK)
            break;
        for (size_t i = 0; i < m && s == MR_OK;) {
            const uint32_t id = table_id(&t, key[i]);
            if (id == EMPTY) {
                s = mr_fail_nomem(err, in_path, t.count * (SUMS * 8 + 32));
                break;
            }
            double *sm = cell_sums(&t, id);
            size_t j = i;
            for (; j < m && key[j] == key[i]; j++) {
                const size_t v = kid[j];
                label[v0 + v] = id;
                sm[0] += 1;
                for (int c = 0; c < 3; c++)
                    sm[1 + c] += b.positions[3 * v + (size_t)c];
                if (b.normals)
                    for (int c = 0; c < 3; c++)
                        sm[4 + c] += b.normals[3 * v + (size_t)c];
                if (b.texcoords)
                    for (int c = 0; c < 2; c++)
                        sm[7 + c] += b.texcoords[2 * v + (size_t)c];
                if (b.colors)
                    for (int c = 0; c < 4; c++)
                        sm[9 + c] += b.colors[4 * v + (size_t)c];
            }
            i = j;
        }
    }
    mr_ply_source_release(src);
    mr_mesh_free(&b);
    free(key);
    free(kid);
    const size_t k = t.count;
    /* the cells numbered by key, as mr_mesh_cluster numbers them */
    uint64_t *keys = NULL;
    if (s == MR_OK) {
        keys = mr_alloc_array(k, sizeof *keys);
        rank = mr_alloc_array(k, sizeof *rank);
        uint32_t *ids = mr_alloc_array(k, sizeof *ids);
        if (!keys || !rank || !ids) {
            free(ids);
            s = mr_fail_nomem(err, in_path, k * 16);
        } else {
            for (size_t i = 0; i < k; i++) {
                keys[i] = cell_key(&t, (uint32_t)i);
                ids[i] = (uint32_t)i;
            }
            s = mr_radix_sort_u64(keys, ids, k, mr_grid_key_bits(&grid),
                                  mr_thread_count(o->threads), err);
            for (size_t i = 0; s == MR_OK && i < k; i++)
                rank[ids[i]] = (uint32_t)i;
            free(ids);
        }
    }
    if (s == MR_OK)
        for (size_t v = 0; v < n; v++)
            label[v] = rank[label[v]];
    st->cells = k;
    st->cell = s == MR_OK ? grid.cell : 0;
    st->seconds_cells = mr_now_seconds() - t0;

    /* pass 3: the faces, the survivors' quadrics into their cells */
    const double t1 = mr_now_seconds();
    size_t survivors = 0, cap = 0;
    if (s == MR_OK && !(quad = mr_calloc_array(k, 10 * sizeof *quad)))
        s = mr_fail_nomem(err, in_path, k * 80);
    /* the faces in batches of chunks: one parallel step a batch */
    const size_t per = mr_ply_source_max_faces(src) + 1;
    const size_t batch_cap = per > FACE_BATCH ? per : FACE_BATCH;
    double *tq = NULL; /* a batch's triangle quadrics (NaN: collapsed) */
    if (s == MR_OK) {
        idx = mr_alloc_array(batch_cap + per, 3 * sizeof *idx);
        tq = mr_alloc_array(batch_cap + per, 10 * sizeof *tq);
        if (!idx || !tq)
            s = mr_fail_nomem(err, in_path, (batch_cap + per) * 92);
    }
    for (size_t chunk = 0, done = 0; s == MR_OK && !done;) {
        size_t got = 0;
        while (got < batch_cap && s == MR_OK) {
            size_t n3;
            if ((s = mr_ply_source_next_faces(src, idx + 3 * got, &n3, err)) != MR_OK)
                break;
            if (n3 == 0) {
                done = 1;
                break;
            }
            got += n3;
            if (++chunk % RELEASE_EVERY == 0)
                mr_ply_source_release(src);
        }
        if (s != MR_OK || got == 0)
            break;
        /* the vertices the batch uses, mapped ahead when they are near
         * one another (a coherent file), else read as they come */
        uint32_t vmin = UINT32_MAX, vmax = 0;
        for (size_t c = 0; c < 3 * got; c++) {
            vmin = idx[c] < vmin ? idx[c] : vmin;
            vmax = idx[c] > vmax ? idx[c] : vmax;
        }
        if ((size_t)(vmax - vmin) < PREFETCH_ROWS)
            mr_ply_source_prefetch(src, vmin, vmax);
        /* the survivors' quadrics on every thread; then, in triangle
         * order, each into its three cells */
        const ptrdiff_t ng = (ptrdiff_t)got;
#pragma omp parallel for schedule(static) num_threads(threads) if (ng > 4096)
        for (ptrdiff_t f = 0; f < ng; f++) {
            const uint32_t *tri = idx + 3 * f;
            const uint32_t a = label[tri[0]], c = label[tri[1]], d = label[tri[2]];
            double *q = tq + 10 * f;
            if (a == c || c == d || a == d) {
                q[0] = NAN; /* collapsed */
                continue;
            }
            float p[3][3];
            for (int e = 0; e < 3; e++)
                mr_ply_source_position(src, tri[e], p[e]);
            mr_cluster_triangle_quadric(p[0], p[1], p[2], q);
        }
        for (size_t f = 0; f < got; f++) {
            const double *q = tq + 10 * f;
            if (q[0] != q[0])
                continue;
            const uint32_t *tri = idx + 3 * f;
            if (survivors == cap) {
                /* grown into a new block (huge pages) rather than by realloc */
                const size_t ncap = cap ? 2 * cap : 1u << 16;
                uint32_t *grown = mr_alloc_array(ncap, 3 * sizeof *grown);
                if (!grown) {
                    s = mr_fail_nomem(err, in_path, ncap * 12);
                    break;
                }
                if (survivors)
                    memcpy(grown, tri_out, 12 * survivors);
                free(tri_out);
                tri_out = grown;
                cap = ncap;
            }
            uint32_t *o3 = tri_out + 3 * survivors++;
            o3[0] = label[tri[0]], o3[1] = label[tri[1]], o3[2] = label[tri[2]];
            for (int e = 0; e < 3; e++) {
                double *acc = quad + 10 * (size_t)o3[e];
                for (int j = 0; j < 10; j++)
                    acc[j] += q[j];
            }
        }
    }
    free(tq);
    mr_ply_source_release(src);

    /* the cells' vertices, in key order */
    if (s == MR_OK)
        s = mr_mesh_alloc(out, k, 0, attrs, err);
    if (s == MR_OK) {
        uint32_t *prov = label; /* reused: final cell -> provisional id */
        for (size_t i = 0; i < k; i++)
            prov[rank[i]] = (uint32_t)i;
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads) if (k > 1024)
        for (size_t cc = 0; cc < k; cc++) {
            const double *sm = cell_sums(&t, prov[cc]);
            mr_cluster_represent(&grid, keys[cc], quad + 10 * cc, sm + 1, sm + 4, sm + 7, sm + 9,
                                 sm[0], lo, hi, out, cc);
        }
    }
    st->seconds_representatives = mr_now_seconds() - t1;
    const double t2 = mr_now_seconds();
    if (s == MR_OK) {
        free(out->indices); /* the placeholder mr_mesh_alloc made for 0 triangles */
        out->indices = tri_out ? tri_out : mr_alloc_array(1, 12);
        out->triangle_count = survivors;
        tri_out = NULL;
        s = mr_mesh_remove_degenerate(out, 1, NULL, err);
    }
    if (s == MR_OK && tc > 0)
        s = mr_mesh_remove_unreferenced(out, NULL, err);
    st->seconds_triangles = mr_now_seconds() - t2;
    st->output_vertices = out->vertex_count;
    st->output_triangles = out->triangle_count;
    free(label);
    free(idx);
    free(tri_out);
    free(rank);
    free(keys);
    free(quad);
    table_free(&t);
    return s;
}

mr_status mr_cluster_file(const char *in_path, const char *out_path,
                          const mr_cluster_options *options, const mr_write_options *write,
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
    mr_mesh out;
    mr_mesh_init(&out);
    mr_ply_source *src = NULL;
    mr_status s = MR_ERR_UNSUPPORTED;
    if (mr_format_from_path(in_path) == MR_FORMAT_PLY) {
        mr_error quiet;
        s = mr_ply_source_open(in_path, mr_thread_count(options->threads), &src, &quiet);
        if (s != MR_OK && s != MR_ERR_UNSUPPORTED) {
            if (err)
                *err = quiet;
            return s;
        }
    }
    if (s == MR_OK) {
        s = cluster_stream(src, in_path, options, &out, &st, err);
        mr_ply_source_close(src);
    } else {
        /* read whole: the in-core clustering of the same mesh */
        mr_mesh in;
        mr_read_options ro;
        mr_read_options_default(&ro);
        ro.threads = options->threads;
        s = mr_mesh_read(in_path, &ro, &in, err);
        if (s == MR_OK)
            s = mr_mesh_cluster(&in, options, &out, &st, err);
        mr_mesh_free(&in);
    }
    if (s == MR_OK)
        s = mr_mesh_write(out_path, &out, write, err);
    mr_mesh_free(&out);
    st.seconds_total = mr_now_seconds() - t0;
    if (stats)
        *stats = st;
    return s;
}
