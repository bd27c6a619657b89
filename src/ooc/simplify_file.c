/*
 * mr_simplify_file: simplification of a mesh file in bounded memory, after
 * the external-memory octree simplification of Cignoni et al. (OEMM) and
 * the locked-border group hierarchies of clustered LOD builders, with the
 * quadrics carried up the hierarchy (chunk.h).
 *
 * The budget B (bytes) sets a chunk's capacity C: what B leaves after the
 * per-vertex table (4 bytes a vertex) and the buffers, at
 * CHUNK_BYTES_PER_TRIANGLE. An input of at most B / INCORE_BYTES_PER_TRIANGLE
 * triangles is read whole and simplified by mr_mesh_simplify: its bytes.
 * Larger ones, out of core:
 *   1. a pass over the vertices: the bounding box (and the check that
 *      every position is finite);
 *   2. passes over the faces: their centroids counted into the chunk tree
 *      (tree.h) until every leaf holds at most C triangles;
 *   3. a pass that spills each triangle into its leaf's run of a
 *      temporary file, each vertex noting the first and last leaf that
 *      uses it (vertex_range: a vertex whose run leaves a node's is on
 *      that node's cut);
 *   4. the tree in post-order: a leaf is read back, its vertices' positions
 *      fetched, and simplified with its cut locked; an inner node joins
 *      its two children's results (their shared cut vertices are one
 *      vertex, their quadrics summed) and simplifies that with the cut
 *      that is left locked; each result goes to a temporary file until its
 *      parent reads it. The root takes the options' targets; the nodes
 *      below aim at SLACK times their share of the target (by input
 *      triangles), at most C / 2 so that two of them fit a parent, so that
 *      the root still chooses among SLACK times the collapses it needs --
 *      and no more than memory requires is decided where the other chunks
 *      cannot be seen;
 *   5. the root's result is written.
 * The counts, splits, orders and sums depend on the file and the options
 * only: the same bytes on any number of threads.
 */
#include "comm.h"
#include "extsort.h"
#include "source.h"
#include "temp.h"
#include "tree.h"
#include "../qem/chunk.h"
#include "../qem/core/simplifier.h"
#include "../io/io_internal.h"
#include "../mesh/adjacency.h"

#include "../core/omp_compat.h"

#include <math.h>
#include <sys/stat.h>

/* What a whole-mesh simplification takes, a triangle, at most (the
 * process's peak over the input's triangles: about 122 measured); what a
 * chunk's takes (its arrays, the simplifier, its result and the
 * quadrics carried in and out). */
#define INCORE_BYTES_PER_TRIANGLE 160
#define CHUNK_BYTES_PER_TRIANGLE 200
/* What attributes add to a chunk's, a triangle, at most: the wedges'
 * arrays and their copies, the surface points, the corners' wedges
 * (mr_mesh_simplify's path). */
#define ATTR_BYTES_PER_TRIANGLE 160
/* The nodes below the root aim at this many times their share. */
#define SLACK 4
/* The smallest chunk worth the name. */
#define MIN_CAPACITY 1024
/* Leaves at most: a vertex notes its first and last in 16 bits each. */
#define MAX_LEAVES 65535u
/* Passes that refine the tree at most. */
#define MAX_REFINEMENTS 6

/* Vertices decoded a block; faces a batch (centroids on every thread). */
enum { VERTEX_BLOCK = 1 << 18, FACE_BATCH = 1 << 18, RELEASE_EVERY = 64 };

/* A vertex's leaves: the first in the low 16 bits, the last in the high;
 * none yet: first 0xFFFF, last 0. */
#define RANGE_NONE 0x0000FFFFu
static inline uint32_t range_first(uint32_t r) { return r & 0xFFFFu; }
static inline uint32_t range_last(uint32_t r) { return r >> 16; }
static inline bool range_outside(uint32_t r, uint32_t first, uint32_t last)
{
    return range_first(r) < first || range_last(r) > last;
}

void mr_out_of_core_options_default(mr_out_of_core_options *o)
{
    memset(o, 0, sizeof *o);
    o->memory = MR_MEMORY_DEFAULT;
}

/* One node's result: its vertices (input vertex ids, positions,
 * quadrics) and triangles, on a temporary file until its parent reads it. */
typedef struct piece {
    size_t nv, nt;
    uint32_t *gid;
    float *pos;
    mr_quadricf *q;
    uint32_t *idx;
    /* the attributes carried (job.attrs): normals, texture coordinates,
     * colors (attr_bit's order), or NULL */
    float *attr[3];
    ooc_file file;
} piece;

static void piece_free(piece *p)
{
    free(p->gid);
    free(p->pos);
    free(p->q);
    free(p->idx);
    for (int a = 0; a < 3; a++) {
        free(p->attr[a]);
        p->attr[a] = NULL;
    }
    p->gid = p->idx = NULL;
    p->pos = NULL;
    p->q = NULL;
}

/* Floats a vertex of each attribute (MR_ATTR_* order: normals, texture
 * coordinates, colors). */
static const unsigned attr_bit[3] = {MR_ATTR_NORMALS, MR_ATTR_TEXCOORDS, MR_ATTR_COLORS};
static const size_t attr_floats[3] = {3, 2, 4};

/* The bytes a vertex's carried attributes take. */
static size_t attr_bytes(unsigned attrs)
{
    size_t n = 0;
    for (int a = 0; a < 3; a++)
        n += attrs & attr_bit[a] ? 4 * attr_floats[a] : 0;
    return n;
}


typedef struct job {
    const char *in_path;
    const mr_simplify_options *o;
    mr_simplify_file_stats *st;
    ooc_source src;
    ooc_temp temp;
    ooc_tree tree;
    int threads;
    size_t batch;            /* faces a batch of a pass */
    size_t nv, nt;           /* the input's counts */
    size_t referenced;       /* vertices some triangle uses (with attributes:
                                their positions, as the vertex targets count
                                surface points) */
    size_t points;           /* with attributes: the referenced positions */
    double lo[3], hi[3];     /* every vertex's box */
    double diagonal;         /* its diagonal: the quadrics' unit and the base
                                of relative errors */
    uint64_t capacity;       /* C */
    uint32_t *range;         /* per vertex: its first and last leaf (with
                                attributes: of every vertex at its position) */
    unsigned attrs;          /* MR_ATTR_* carried through the chunks */
    bool wedges;             /* the vertices are wedges, joined into surface
                                points in each chunk: with attributes
                                carried, or a PLY's dropped (its vertices
                                stay split at their seams) */
    ooc_file spill;          /* the leaves' triangles */
    uint64_t *leaf_at;       /* the triangle each leaf's run starts at */
    uint64_t *leaf_count;    /* triangles written to it */
    piece *pieces;           /* per node */
    /* the targets, resolved on the whole input */
    size_t target_vertices, target_triangles;
    double share_triangles;  /* the targets as triangles (0: none) */
    double max_error;        /* absolute (0: none) */
    /* progress over the whole job, in triangles worked */
    double done, total;
    bool cancelled;
    /* the ranks (comm NULL: one) */
    ooc_comm *comm;
    int rank, ranks;
    int *owner;              /* per node: the rank that simplifies it */
    /* an output larger than a chunk (the forest): the nodes that end the
     * tree (tops, each with its share of the target) and those above them,
     * which reduce their cut in a band; the pieces left (segments), each
     * over a run of leaves */
    uint8_t *top, *above;
    size_t *top_target;
    size_t band_t, band_v;   /* an above node's band: its targets */
    mr_simplify_stop band_stop; /* why the root's band stopped */
    piece *seg;
    uint32_t *seg_first, *seg_last;
    size_t nseg;
} job;

/* Arrays for n vertices of each attribute the job carries (the others
 * NULL); false when one could not be had (those that were stay set). */
static bool attrs_alloc(const job *j, size_t n, float *attr[3])
{
    bool ok = true;
    for (int a = 0; a < 3; a++) {
        attr[a] = NULL;
        if (j->attrs & attr_bit[a])
            ok &= (attr[a] = mr_alloc_array(n, 4 * attr_floats[a])) != NULL;
    }
    return ok;
}

/* A piece's arrays in their order on its file, with their bytes; the
 * total. */
static uint64_t piece_parts(const job *j, piece *p, void *data[7], uint64_t bytes[7])
{
    const uint64_t nv = p->nv;
    void *d[7] = {p->gid, p->pos, p->q, p->idx, p->attr[0], p->attr[1], p->attr[2]};
    uint64_t b[7] = {4 * nv, 12 * nv, sizeof(mr_quadricf) * nv, 12 * (uint64_t)p->nt, 0, 0, 0};
    for (int a = 0; a < 3; a++)
        b[4 + a] = j->attrs & attr_bit[a] ? 4 * attr_floats[a] * nv : 0;
    uint64_t total = 0;
    for (int i = 0; i < 7; i++) {
        data[i] = d[i];
        bytes[i] = b[i];
        total += b[i];
    }
    return total;
}

/* The caller's lock of vertex v (options.vertex_lock is by the input's
 * vertices: an OBJ's v lines where its vertices are (v, vt, vn)). */
static inline bool input_locked(const job *j, uint32_t v)
{
    return j->o->vertex_lock[j->src.origin ? j->src.origin(j->src.impl, v) : v] != 0;
}

/* ---- the ranks ------------------------------------------------------------------ */

/* Every rank's outcome (one rank: its own). */
static mr_status agree(job *j, mr_status st, mr_error *err)
{
    return j->ranks > 1 ? j->comm->agree(j->comm, st, err) : st;
}

static mr_status reduce(job *j, void *data, size_t n, ooc_type type, ooc_op op, mr_error *err)
{
    return j->ranks > 1 && n ? j->comm->reduce(j->comm, data, n, type, op, err) : MR_OK;
}

/* This rank's share [*first, *last) of n things. */
static void share(const job *j, size_t n, size_t *first, size_t *last)
{
    *first = (size_t)((unsigned __int128)n * (unsigned)j->rank / (unsigned)j->ranks);
    *last = (size_t)((unsigned __int128)n * (unsigned)(j->rank + 1) / (unsigned)j->ranks);
}

/* ---- progress -------------------------------------------------------------- */

typedef struct progress_span {
    job *j;
    double base, span;
} progress_span;

static int span_progress(double fraction, void *user)
{
    progress_span *p = user;
    job *j = p->j;
    const double f = j->total > 0 ? (p->base + p->span * fraction) / j->total : 1;
    if (j->o->progress && j->o->progress(f > 1 ? 1 : f, j->o->progress_user) != 0) {
        j->cancelled = true;
        return 1;
    }
    return 0;
}

/* Report work done; false when the callback asks to stop. */
static bool report(job *j, double worked, mr_error *err, mr_status *st)
{
    j->done += worked;
    progress_span p = {j, j->done, 0};
    if (span_progress(0, &p)) {
        *st = mr_fail_plain(err, MR_ERR_CANCELLED, NULL,
                            "simplify: cancelled by the progress callback");
        return false;
    }
    return true;
}

/* ---- passes over the input --------------------------------------------------- */

/* Pass 1: every vertex's box (the source checks each position). */
static mr_status bounds_pass(job *j, mr_error *err)
{
    mr_mesh b;
    mr_mesh_init(&b);
    mr_status st = mr_mesh_alloc(&b, VERTEX_BLOCK, 0, j->src.attributes, err);
    for (int k = 0; k < 3; k++) {
        j->lo[k] = INFINITY;
        j->hi[k] = -INFINITY;
    }
    size_t first, last;
    share(j, j->nv, &first, &last);
    for (size_t v0 = first; v0 < last && st == MR_OK; v0 += VERTEX_BLOCK) {
        const size_t m = last - v0 < VERTEX_BLOCK ? last - v0 : VERTEX_BLOCK;
        b.vertex_count = m;
        if ((st = j->src.vertices(j->src.impl, v0, m, &b, err)) != MR_OK)
            break;
        for (size_t i = 0; i < m; i++)
            for (int k = 0; k < 3; k++) {
                const double x = b.positions[3 * i + (size_t)k];
                j->lo[k] = x < j->lo[k] ? x : j->lo[k];
                j->hi[k] = x > j->hi[k] ? x : j->hi[k];
            }
    }
    b.vertex_count = VERTEX_BLOCK;
    mr_mesh_free(&b);
    j->src.release(j->src.impl);
    /* min and max: exact, in any order */
    if ((st = agree(j, st, err)) != MR_OK || (st = reduce(j, j->lo, 3, OOC_F64, OOC_MIN, err)) ||
        (st = reduce(j, j->hi, 3, OOC_F64, OOC_MAX, err)))
        return st;
    const double dx = j->hi[0] - j->lo[0], dy = j->hi[1] - j->lo[1], dz = j->hi[2] - j->lo[2];
    j->diagonal = sqrt(dx * dx + dy * dy + dz * dz);
    if (!(j->diagonal > 0))
        j->diagonal = 1;
    return st;
}

/* A pass over the faces in batches: each batch's triangles and their
 * centroids (on every thread) handed to fn in file order. */
typedef mr_status (*batch_fn)(job *j, const uint32_t *idx, const double *c, size_t n,
                              void *user, mr_error *err);

static mr_status face_pass(job *j, batch_fn fn, void *user, mr_error *err)
{
    const size_t per = j->src.max_faces + 1;
    const size_t cap = per > j->batch ? per : j->batch;
    uint32_t *idx = mr_alloc_array(cap + per, 3 * sizeof *idx);
    double *c = mr_alloc_array(cap + per, 3 * sizeof *c);
    if (!idx || !c) {
        free(idx);
        free(c);
        return mr_fail_nomem(err, j->in_path, (cap + per) * 36);
    }
    /* this rank's run of the face chunks */
    size_t first, last;
    share(j, j->src.face_chunks, &first, &last);
    j->src.seek(j->src.impl, first);
    mr_status st = MR_OK;
    for (size_t chunk = 0, done = 0; st == MR_OK && !done;) {
        size_t got = 0;
        while (got < cap && st == MR_OK) {
            if (first + chunk >= last) {
                done = 1;
                break;
            }
            size_t n3 = 0;
            if ((st = j->src.next_faces(j->src.impl, idx + 3 * got, &n3, err)) != MR_OK)
                break;
            got += n3;
            if (++chunk % RELEASE_EVERY == 0)
                j->src.release(j->src.impl);
        }
        if (st != MR_OK || got == 0)
            break;
        const ptrdiff_t ng = (ptrdiff_t)got;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (ng > 4096)
        for (ptrdiff_t f = 0; f < ng; f++) {
            float p[3][3];
            for (int e = 0; e < 3; e++)
                j->src.position(j->src.impl, idx[3 * f + e], p[e]);
            for (int k = 0; k < 3; k++)
                c[3 * f + k] = ooc_centroid(p[0], p[1], p[2], k);
        }
        st = fn(j, idx, c, got, user, err);
        if (st == MR_OK)
            report(j, 0.1 * (double)got, err, &st);
    }
    j->src.release(j->src.impl);
    free(idx);
    free(c);
    j->st->passes++;
    return st;
}

static mr_status count_batch(job *j, const uint32_t *idx, const double *c, size_t n, void *user,
                             mr_error *err)
{
    (void)idx, (void)user, (void)err;
    for (size_t f = 0; f < n; f++)
        ooc_tree_count(&j->tree, c + 3 * f);
    return MR_OK;
}

/* The spill's buffers: a run of triangles per leaf, written when full. */
/* A run of one leaf's triangles in a rank's own spill (several ranks). */
typedef struct spill_block {
    uint32_t leaf;
    uint32_t count;
    uint64_t at;       /* byte offset */
} spill_block;

typedef struct spill_buffers {
    uint32_t *buf;     /* leaves x per x 3 */
    size_t per;        /* triangles a leaf's buffer holds */
    size_t *fill;
    uint32_t *leaf;    /* a batch's leaves */
    /* several ranks: this rank's triangles, block by block */
    ooc_file local;
    spill_block *blocks;
    size_t nblocks, cap;
} spill_buffers;

static mr_status flush_leaf(job *j, spill_buffers *b, size_t l, mr_error *err)
{
    if (b->fill[l] == 0)
        return MR_OK;
    const uint32_t *data = b->buf + 3 * b->per * l;
    mr_status st;
    if (j->ranks > 1) {
        if (b->nblocks == b->cap) {
            const size_t ncap = b->cap ? 2 * b->cap : 1024;
            spill_block *nb = mr_realloc_array(b->blocks, ncap, sizeof *nb);
            if (!nb)
                return mr_fail_nomem(err, NULL, ncap * sizeof *nb);
            b->blocks = nb;
            b->cap = ncap;
        }
        spill_block *k = &b->blocks[b->nblocks++];
        k->leaf = (uint32_t)l;
        k->count = (uint32_t)b->fill[l];
        k->at = b->local.size;
        st = ooc_file_write(&j->temp, &b->local, k->at, data, 12 * b->fill[l], err);
    } else {
        const uint64_t at = (j->leaf_at[l] + j->leaf_count[l]) * 12;
        st = ooc_file_write(&j->temp, &j->spill, at, data, 12 * b->fill[l], err);
    }
    j->leaf_count[l] += b->fill[l];
    b->fill[l] = 0;
    return st;
}

/* Bytes a message carries at most. */
#define MESSAGE_BYTES ((size_t)8 << 20)

/* Several ranks: the ranks' blocks of each leaf into its owner's spill,
 * the ranks in order (each rank's faces are a run of the file's, so the
 * leaf's triangles come in the file's order, as one rank spills them).
 * Every rank goes through the leaves in order: a leaf's owner receives
 * from each other rank that has some of it, the others send theirs. A
 * rank that fails goes on with the exchange (writing nothing, or sending
 * zeros) so that no other waits on it; agree() says at the end. */
static int block_order(const void *a, const void *b)
{
    const spill_block *x = a, *y = b;
    if (x->leaf != y->leaf)
        return x->leaf < y->leaf ? -1 : 1;
    return x->at < y->at ? -1 : x->at > y->at;
}

static mr_status assemble_spill(job *j, spill_buffers *b, mr_error *err)
{
    ooc_tree *t = &j->tree;
    const size_t nl = t->leaves, nr = (size_t)j->ranks;
    uint64_t *all = mr_alloc_array(nl * nr, sizeof *all);
    char *buf = mr_alloc_array(MESSAGE_BYTES, 1);
    if (!all || !buf) {
        free(all);
        free(buf);
        return mr_fail_nomem(err, NULL, nl * nr * 8 + MESSAGE_BYTES);
    }
    mr_status st = j->comm->gather(j->comm, j->leaf_count, nl, all, err);
    if (st != MR_OK) {
        free(all);
        free(buf);
        return st;
    }
    qsort(b->blocks, b->nblocks, sizeof *b->blocks, block_order);
    mr_status local = ooc_file_open(&j->temp, &j->spill, err);
    mr_error local_err = err ? *err : (mr_error){0};
    size_t k = 0; /* this rank's next block */
    for (size_t l = 0; l < nl && st == MR_OK; l++) {
        const int owner = j->owner[t->leaf_node[l]];
        const uint64_t mine = all[(size_t)j->rank * nl + l];
        if (owner == j->rank) {
            uint64_t at = j->leaf_at[l] * 12;
            for (size_t r = 0; r < nr && st == MR_OK; r++) {
                uint64_t left = 12 * all[r * nl + l];
                if ((int)r == j->rank) {
                    for (; k < b->nblocks && b->blocks[k].leaf == l; k++) {
                        const size_t n = 12 * (size_t)b->blocks[k].count;
                        for (size_t off = 0; off < n && local == MR_OK;) {
                            const size_t m = n - off < MESSAGE_BYTES ? n - off : MESSAGE_BYTES;
                            local = ooc_file_read(&j->temp, &b->local, b->blocks[k].at + off,
                                                  buf, m, &local_err);
                            if (local == MR_OK)
                                local = ooc_file_write(&j->temp, &j->spill, at, buf, m,
                                                       &local_err);
                            off += m;
                            at += m;
                        }
                    }
                    continue;
                }
                while (left > 0 && st == MR_OK) {
                    const size_t m = left < MESSAGE_BYTES ? (size_t)left : MESSAGE_BYTES;
                    st = j->comm->recv(j->comm, (int)r, buf, m, err);
                    if (st == MR_OK && local == MR_OK)
                        local = ooc_file_write(&j->temp, &j->spill, at, buf, m, &local_err);
                    at += m;
                    left -= m;
                }
            }
            j->leaf_count[l] = 0;
            for (size_t r = 0; r < nr; r++)
                j->leaf_count[l] += all[r * nl + l];
        } else if (mine) {
            /* this rank's blocks of the leaf, as one stream in messages */
            size_t fill = 0;
            for (; k < b->nblocks && b->blocks[k].leaf == l && st == MR_OK; k++) {
                const size_t n = 12 * (size_t)b->blocks[k].count;
                for (size_t off = 0; off < n && st == MR_OK;) {
                    const size_t m = n - off < MESSAGE_BYTES - fill ? n - off : MESSAGE_BYTES - fill;
                    if (local == MR_OK)
                        local = ooc_file_read(&j->temp, &b->local, b->blocks[k].at + off,
                                              buf + fill, m, &local_err);
                    if (local != MR_OK)
                        memset(buf + fill, 0, m);
                    fill += m;
                    off += m;
                    if (fill == MESSAGE_BYTES) {
                        st = j->comm->send(j->comm, owner, buf, fill, err);
                        fill = 0;
                    }
                }
            }
            if (fill && st == MR_OK)
                st = j->comm->send(j->comm, owner, buf, fill, err);
        } else {
            while (k < b->nblocks && b->blocks[k].leaf == l)
                k++;
        }
    }
    free(all);
    free(buf);
    if (st == MR_OK && local != MR_OK) {
        if (err)
            *err = local_err;
        st = local;
    }
    return st;
}

/* Several ranks: every vertex's first and last leaf over all of them. */
static mr_status reduce_ranges(job *j, mr_error *err)
{
    enum { BLOCK = 1 << 20 };
    uint16_t *lo = mr_alloc_array(BLOCK, sizeof *lo), *hi = mr_alloc_array(BLOCK, sizeof *hi);
    mr_status st = lo && hi ? MR_OK : mr_fail_nomem(err, NULL, 4 * BLOCK);
    for (size_t v0 = 0; v0 < j->nv && st == MR_OK; v0 += BLOCK) {
        const size_t n = j->nv - v0 < BLOCK ? j->nv - v0 : BLOCK;
        for (size_t i = 0; i < n; i++) {
            lo[i] = (uint16_t)range_first(j->range[v0 + i]);
            hi[i] = (uint16_t)range_last(j->range[v0 + i]);
        }
        if ((st = reduce(j, lo, n, OOC_U16, OOC_MIN, err)) == MR_OK &&
            (st = reduce(j, hi, n, OOC_U16, OOC_MAX, err)) == MR_OK)
            for (size_t i = 0; i < n; i++)
                j->range[v0 + i] = (uint32_t)lo[i] | (uint32_t)hi[i] << 16;
    }
    free(lo);
    free(hi);
    return st;
}

static mr_status spill_batch(job *j, const uint32_t *idx, const double *c, size_t n, void *user,
                             mr_error *err)
{
    spill_buffers *b = user;
    const ptrdiff_t nn = (ptrdiff_t)n;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (nn > 4096)
    for (ptrdiff_t f = 0; f < nn; f++)
        b->leaf[f] = j->tree.nodes[ooc_tree_locate(&j->tree, c + 3 * f)].leaf;
    for (size_t f = 0; f < n; f++) {
        const uint32_t *t = idx + 3 * f;
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            continue; /* no triangle: the simplifier would drop it */
        const uint32_t l = b->leaf[f];
        for (int e = 0; e < 3; e++) {
            uint32_t r = j->range[t[e]];
            const uint32_t first = range_first(r) < l ? range_first(r) : l;
            const uint32_t last = range_last(r) > l ? range_last(r) : l;
            j->range[t[e]] = first | last << 16;
        }
        uint32_t *dst = b->buf + 3 * (b->per * l + b->fill[l]);
        dst[0] = t[0], dst[1] = t[1], dst[2] = t[2];
        if (++b->fill[l] == b->per) {
            mr_status st = flush_leaf(j, b, l, err);
            if (st != MR_OK)
                return st;
        }
    }
    return MR_OK;
}

/* ---- vertices at one position ------------------------------------------------ */

/* A referenced vertex by its position's bits. */
typedef struct at_point {
    uint32_t bits[3];
    uint32_t v;
} at_point;

static uint64_t at_point_key(const void *a)
{
    return ooc_position_key(((const at_point *)a)->bits);
}

static int at_point_cmp(const void *a, const void *b)
{
    const at_point *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->bits[k] != y->bits[k])
            return x->bits[k] < y->bits[k] ? -1 : 1;
    return x->v < y->v ? -1 : x->v > y->v;
}

/* The vertices (only the referenced: those with a range) by position,
 * sorted in *x (an external sort in runs of about memory/2 bytes). */
static mr_status sort_positions(job *j, uint64_t memory, bool referenced, ooc_extsort *x,
                                mr_error *err)
{
    const size_t run = (size_t)(memory < ((uint64_t)16 << 20) ? (uint64_t)8 << 20 : memory / 2);
    memset(x, 0, sizeof *x);
    x->file.fd = -1;
    mr_mesh b;
    mr_mesh_init(&b);
    mr_status st = ooc_extsort_init(x, &j->temp, sizeof(at_point), run, at_point_key, 64,
                                    at_point_cmp, j->threads, err);
    if (st == MR_OK)
        st = mr_mesh_alloc(&b, VERTEX_BLOCK, 0, 0, err);
    for (size_t v0 = 0; v0 < j->nv && st == MR_OK; v0 += VERTEX_BLOCK) {
        const size_t m = j->nv - v0 < VERTEX_BLOCK ? j->nv - v0 : VERTEX_BLOCK;
        b.vertex_count = m;
        if ((st = j->src.vertices(j->src.impl, v0, m, &b, err)) != MR_OK)
            break;
        for (size_t i = 0; i < m && st == MR_OK; i++) {
            if (referenced && j->range[v0 + i] == RANGE_NONE)
                continue;
            at_point r;
            memcpy(r.bits, b.positions + 3 * i, 12);
            r.v = (uint32_t)(v0 + i);
            st = ooc_extsort_add(x, &r, err);
        }
        if (st == MR_OK)
            report(j, 0, err, &st); /* the callback may cancel */
    }
    b.vertex_count = VERTEX_BLOCK;
    mr_mesh_free(&b);
    j->src.release(j->src.impl);
    if (st == MR_OK)
        st = ooc_extsort_finish(x, run, err);
    return st;
}

/* Without attributes, does a position repeat among the vertices (an
 * export that did not weld them)? In memory, mr_simplify's surface points
 * join such vertices; out of core they then go as wedges (job.wedges),
 * else each copy would be a boundary that the chunks move apart. Every
 * vertex counts, referenced or not: the chunks are sized before the
 * passes tell which are. */
static mr_status find_coincident(job *j, uint64_t memory, bool *found, mr_error *err)
{
    *found = false;
    /* first, where they fit half the budget, the positions' 64-bit keys
     * sorted in memory: no two equal, no two positions equal (the common
     * case, settled in a fraction of the exact sort's time); else the
     * exact sort decides */
    if (16 * (uint64_t)j->nv <= memory / 2) {
        uint64_t *key = mr_alloc_array(j->nv + 1, sizeof *key);
        mr_mesh b;
        mr_mesh_init(&b);
        mr_status st = key ? mr_mesh_alloc(&b, VERTEX_BLOCK, 0, 0, err)
                           : mr_fail_nomem(err, j->in_path, j->nv * 8);
        for (size_t v0 = 0; v0 < j->nv && st == MR_OK; v0 += VERTEX_BLOCK) {
            const size_t m = j->nv - v0 < VERTEX_BLOCK ? j->nv - v0 : VERTEX_BLOCK;
            b.vertex_count = m;
            if ((st = j->src.vertices(j->src.impl, v0, m, &b, err)) != MR_OK)
                break;
            for (size_t i = 0; i < m; i++) {
                uint32_t bits[3];
                memcpy(bits, b.positions + 3 * i, 12);
                key[v0 + i] = ooc_position_key(bits);
            }
            report(j, 0, err, &st);
        }
        b.vertex_count = VERTEX_BLOCK;
        mr_mesh_free(&b);
        j->src.release(j->src.impl);
        if (st == MR_OK)
            st = mr_radix_sort_u64(key, NULL, j->nv, 64, j->threads, err);
        bool twice = false;
        for (size_t v = 1; st == MR_OK && v < j->nv && !twice; v++)
            twice = key[v] == key[v - 1];
        free(key);
        if (st != MR_OK || !twice)
            return st;
    }
    ooc_extsort x;
    mr_status st = sort_positions(j, memory, false, &x, err);
    uint32_t bits[3];
    for (uint64_t k = 1; st == MR_OK && !*found; k++) {
        const void *rec = NULL;
        st = ooc_extsort_next(&x, &rec, err);
        if (st == MR_OK && k % (1u << 20) == 0)
            report(j, 0, err, &st);
        if (!rec)
            break;
        const at_point *r = rec;
        *found = k > 1 && memcmp(r->bits, bits, 12) == 0;
        memcpy(bits, r->bits, 12);
    }
    ooc_extsort_free(&x);
    return st;
}

/* With wedges, a surface point's vertices (a UV seam, a hard edge, an
 * unwelded export) may sit in different leaves, each the only one at that point in
 * its leaf, so that no vertex id tells a cut: every vertex at one position
 * (bitwise, as mr_surface_points joins them) takes the leaves of all of
 * them, so that a node's cut locks each of its wedges, and the node above
 * joins them; j->points counts the positions (the surface points of
 * mr_surface_points, but for parts that only touch at a point, which it
 * keeps apart). The vertices by position through an external sort (16
 * bytes a referenced vertex on disk), runs in about `memory` bytes. Every
 * rank does the same with the same (reduced) ranges. */
static mr_status join_coincident(job *j, uint64_t memory, mr_error *err)
{
    ooc_extsort x;
    mr_status st = sort_positions(j, memory, true, &x, err);
    /* each run of one position: its members' leaves joined */
    uint32_t *group = NULL;
    size_t n = 0, cap = 0;
    uint32_t bits[3] = {0, 0, 0};
    for (uint64_t k = 1;; k++) {
        const void *rec = NULL;
        if (st == MR_OK)
            st = ooc_extsort_next(&x, &rec, err);
        if (st == MR_OK && k % (1u << 20) == 0)
            report(j, 0, err, &st);
        const at_point *r = rec;
        if (n && (!r || memcmp(r->bits, bits, 12) != 0)) {
            if (n > 1) {
                uint32_t first = RANGE_NONE & 0xFFFFu, last = 0;
                for (size_t i = 0; i < n; i++) {
                    const uint32_t g = j->range[group[i]];
                    first = range_first(g) < first ? range_first(g) : first;
                    last = range_last(g) > last ? range_last(g) : last;
                }
                for (size_t i = 0; i < n; i++)
                    j->range[group[i]] = first | last << 16;
            }
            j->points++;
            n = 0;
        }
        if (!r)
            break;
        if (n == cap) {
            cap = cap ? 2 * cap : 16;
            uint32_t *g = realloc(group, cap * sizeof *g);
            if (!g) {
                st = mr_fail_nomem(err, NULL, cap * sizeof *g);
                break;
            }
            group = g;
        }
        memcpy(bits, r->bits, 12);
        group[n++] = r->v;
    }
    free(group);
    ooc_extsort_free(&x);
    return st;
}

/* ---- pieces on disk ---------------------------------------------------------- */

static mr_status piece_store(job *j, piece *p, mr_error *err)
{
    mr_status st = ooc_file_open(&j->temp, &p->file, err);
    uint64_t at = 0;
    void *data[7];
    uint64_t bytes[7];
    piece_parts(j, p, data, bytes);
    for (int i = 0; i < 7 && st == MR_OK; i++) {
        st = ooc_file_write(&j->temp, &p->file, at, data[i], bytes[i], err);
        at += bytes[i];
    }
    piece_free(p);
    return st;
}

static mr_status piece_read(job *j, piece *p, bool keep, mr_error *err);

static mr_status piece_load(job *j, piece *p, mr_error *err)
{
    return piece_read(j, p, false, err);
}

/* The piece's arrays from its file, which goes unless `keep`. */
static mr_status piece_read(job *j, piece *p, bool keep, mr_error *err)
{
    p->gid = mr_alloc_array(p->nv + 1, sizeof *p->gid);
    p->pos = mr_alloc_array(p->nv + 1, 3 * sizeof *p->pos);
    p->q = mr_alloc_array(p->nv + 1, sizeof *p->q);
    p->idx = mr_alloc_array(p->nt + 1, 3 * sizeof *p->idx);
    const bool attrs = attrs_alloc(j, p->nv + 1, p->attr);
    if (!p->gid || !p->pos || !p->q || !p->idx || !attrs) {
        piece_free(p);
        return mr_fail_nomem(err, NULL, p->nv * (60 + attr_bytes(j->attrs)) + p->nt * 12);
    }
    uint64_t at = 0;
    mr_status st = MR_OK;
    void *data[7];
    uint64_t bytes[7];
    piece_parts(j, p, data, bytes);
    for (int i = 0; i < 7 && st == MR_OK; i++) {
        st = ooc_file_read(&j->temp, &p->file, at, data[i], bytes[i], err);
        at += bytes[i];
    }
    if (!keep)
        ooc_file_close(&j->temp, &p->file);
    if (st != MR_OK)
        piece_free(p);
    return st;
}

/* ---- the nodes ----------------------------------------------------------------- */

/* What a node below the root aims at: SLACK times its share of the
 * target, and two triangles for each vertex of its cut (which stays,
 * locked, for the levels above to reduce: counted in, the triangles
 * inside are not spent on it), at most half a chunk, at most its input. */
static size_t node_target(const job *j, const ooc_node *n, size_t cuts)
{
    /* half a chunk; but the inside keeps a quarter of one whatever the
     * cut takes (a small chunk high in the tree) */
    double t = (double)(j->capacity / 2);
    if (2 * (double)cuts + (double)(j->capacity / 4) > t)
        t = 2 * (double)cuts + (double)(j->capacity / 4);
    if (j->share_triangles > 0) {
        const double share =
            ceil(SLACK * j->share_triangles * (double)n->triangles / (double)j->nt) +
            2 * (double)cuts;
        t = share < t ? share : t;
    }
    return t < 1 ? 1 : (size_t)t;
}

/* The options of node i's run on nt triangles and nv vertices. */
static void node_options(job *j, uint32_t i, size_t nt, size_t nv, size_t cuts,
                         progress_span *ps, mr_simplify_options *o)
{
    *o = *j->o;
    o->vertex_lock = NULL;
    o->progress = span_progress;
    o->progress_user = ps;
    o->target_ratio = 0;
    o->max_error = j->max_error;
    o->error_absolute = 1;
    const ooc_node *n = &j->tree.nodes[i];
    if (j->above && j->above[i]) {
        /* a band of the forest: what run_band set */
        o->target_vertices = j->band_v;
        o->target_triangles = j->band_t < nt ? j->band_t : nt;
        o->prune = 0;
        return;
    }
    if (n->parent < 0) {
        /* the root: the targets, as the whole input counts them */
        o->target_vertices = j->target_vertices < nv ? j->target_vertices : nv;
        o->target_triangles = j->target_triangles < nt ? j->target_triangles : nt;
        return;
    }
    o->target_vertices = 0;
    o->prune = 0;
    if (j->top && j->top[i]) {
        /* a top of the forest: its share of the target, exactly */
        const size_t t = j->top_target[i] + cuts; /* a triangle a cut vertex, for the bands */
        o->target_triangles = t < nt ? t : nt;
        return;
    }
    o->until_error = 0;
    const size_t t = node_target(j, n, cuts);
    o->target_triangles = t < nt ? t : nt;
}

static mr_status keep_result(job *j, piece *p, mr_chunk_result *rp, const uint32_t *gid,
                             mr_error *err);

/* Run the chunk and keep its result as node i's piece (or, for the root,
 * hand it back in *root). gid: each chunk vertex's input vertex. */
static mr_status run_chunk(job *j, uint32_t i, const mr_chunk *c, const uint32_t *gid,
                           mr_chunk_result *root, mr_error *err)
{
    const ooc_node *n = &j->tree.nodes[i];
    progress_span ps = {j, j->done, (double)c->triangle_count};
    size_t cuts = 0;
    for (size_t v = 0; v < c->vertex_count; v++)
        cuts += c->cut[v] != 0;
    mr_simplify_options o;
    node_options(j, i, c->triangle_count, c->vertex_count, cuts, &ps, &o);
    const double t0 = mr_now_seconds();
    mr_chunk_result r;
    mr_status st = mr_simplify_chunk(c, &o, &r, err);
    if (st != MR_OK)
        return st;
    j->done += (double)c->triangle_count;
    mr_simplify_file_stats *fs = j->st;
    const int level = n->height < MR_LEVELS_MAX ? n->height : MR_LEVELS_MAX - 1;
    fs->level_chunks[level]++;
    fs->level_triangles[level] += c->triangle_count;
    fs->level_seconds[level] += mr_now_seconds() - t0;
    mr_simplify_stats *s = &fs->simplify;
    s->collapses += r.mesh.stats.collapses;
    s->seconds_setup += r.mesh.stats.seconds_setup;
    s->seconds_collapse += r.mesh.stats.seconds_collapse;
    s->seconds_output += r.mesh.stats.seconds_output;
    s->max_error = r.mesh.stats.max_error > s->max_error ? r.mesh.stats.max_error : s->max_error;
    if (n->parent < 0) {
        *root = r;
        return MR_OK;
    }
    return keep_result(j, &j->pieces[i], &r, gid, err);
}

/* A chunk's result as a piece on disk (gid: each chunk vertex's input
 * vertex). */
static mr_status keep_result(job *j, piece *p, mr_chunk_result *rp, const uint32_t *gid,
                             mr_error *err)
{
    mr_chunk_result r = *rp;
    memset(rp, 0, sizeof *rp);
    p->nv = r.mesh.vertex_count;
    p->nt = r.mesh.triangle_count;
    p->gid = mr_alloc_array(p->nv + 1, sizeof *p->gid);
    if (!p->gid) {
        mr_chunk_result_free(&r);
        return mr_fail_nomem(err, NULL, p->nv * 4);
    }
    for (size_t v = 0; v < p->nv; v++)
        p->gid[v] = gid[r.mesh.origin[v]];
    p->pos = r.mesh.positions;
    p->idx = r.mesh.indices;
    p->q = r.quadrics;
    p->attr[0] = r.normals;
    p->attr[1] = r.texcoords;
    p->attr[2] = r.colors;
    r.mesh.positions = NULL;
    r.mesh.indices = NULL;
    r.quadrics = NULL;
    r.normals = r.texcoords = r.colors = NULL;
    mr_chunk_result_free(&r);
    return piece_store(j, p, err);
}

/* A leaf: its triangles read back, its vertices numbered in input order,
 * their positions fetched. */
static mr_status run_leaf(job *j, uint32_t i, mr_chunk_result *root, mr_error *err)
{
    const ooc_node *n = &j->tree.nodes[i];
    const uint32_t l = n->leaf;
    const size_t nt = (size_t)j->leaf_count[l];
    if (nt == 0) {
        if (n->parent < 0)
            return mr_fail_plain(err, MR_ERR_EMPTY, j->in_path,
                                 "every one of its triangles uses a vertex twice: no surface "
                                 "to simplify");
        memset(&j->pieces[i], 0, sizeof j->pieces[i]);
        j->pieces[i].file.fd = -1;
        return MR_OK; /* nothing here */
    }
    uint32_t *idx = mr_alloc_array(nt, 3 * sizeof *idx);
    uint32_t *key = mr_alloc_array(nt, 3 * sizeof *key);
    uint32_t *val = mr_alloc_array(nt, 3 * sizeof *val);
    if (!idx || !key || !val) {
        free(idx);
        free(key);
        free(val);
        return mr_fail_nomem(err, NULL, nt * 36);
    }
    mr_status st = ooc_file_read(&j->temp, &j->spill, j->leaf_at[l] * 12, idx, 12 * nt, err);
    const size_t nc = 3 * nt;
    for (size_t c = 0; c < nc; c++) {
        key[c] = idx[c];
        val[c] = (uint32_t)c;
    }
    if (st == MR_OK)
        st = mr_radix_sort_u32(key, val, nc, 32, j->threads, err);
    /* the vertices in input order; each corner's local id */
    size_t nv = 0;
    for (size_t c = 0; st == MR_OK && c < nc; c++) {
        if (c == 0 || key[c] != key[c - 1])
            key[nv++] = key[c];
        idx[val[c]] = (uint32_t)(nv - 1);
    }
    free(val);
    float *pos = st == MR_OK ? mr_alloc_array(nv, 3 * sizeof *pos) : NULL;
    uint8_t *cut = st == MR_OK ? mr_alloc_array(nv, 1) : NULL;
    uint8_t *lock = st == MR_OK && j->o->vertex_lock ? mr_alloc_array(nv, 1) : NULL;
    float *attr[3] = {NULL, NULL, NULL};
    const bool attrs = st != MR_OK || attrs_alloc(j, nv, attr);
    if (st == MR_OK && (!pos || !cut || (j->o->vertex_lock && !lock) || !attrs))
        st = mr_fail_nomem(err, NULL, nv * (14 + attr_bytes(j->attrs)));
    if (st == MR_OK) {
        const uint32_t *gid = key;
        /* mapped ahead only where the leaf's vertices fill most of their
         * range of the file: the mapped pages count in the resident set */
        if (key[nv - 1] - key[0] < (uint32_t)(2 * nv))
            j->src.prefetch(j->src.impl, key[0], key[nv - 1]);
        const ptrdiff_t n3 = (ptrdiff_t)nv;
#pragma omp parallel for schedule(static) num_threads(j->threads) if (n3 > 16384)
        for (ptrdiff_t v = 0; v < n3; v++) {
            if (j->attrs) {
                const mr_mesh one = {.vertex_count = 1,
                                     .positions = pos + 3 * v,
                                     .normals = attr[0] ? attr[0] + 3 * v : NULL,
                                     .texcoords = attr[1] ? attr[1] + 2 * v : NULL,
                                     .colors = attr[2] ? attr[2] + 4 * v : NULL};
                j->src.vertex(j->src.impl, gid[v], &one);
            } else {
                j->src.position(j->src.impl, gid[v], pos + 3 * v);
            }
            cut[v] = range_outside(j->range[gid[v]], l, l);
            if (lock)
                lock[v] = input_locked(j, gid[v]);
        }
        j->src.release(j->src.impl);
        const mr_chunk c = {.positions = pos,
                            .vertex_count = nv,
                            .indices = idx,
                            .triangle_count = nt,
                            .cut = cut,
                            .locked = lock,
                            .unit = j->diagonal,
                            .normals = attr[0],
                            .texcoords = attr[1],
                            .colors = attr[2],
                            .wedges = j->wedges};
        st = run_chunk(j, i, &c, gid, root, err);
    }
    free(idx);
    free(key);
    free(pos);
    free(cut);
    free(lock);
    for (int a = 0; a < 3; a++)
        free(attr[a]);
    return st;
}

/* Open-addressing table of input vertex ids to a piece's vertices. */
static inline size_t slot_of(uint32_t g, size_t mask) { return (size_t)(mr_mix64(g) & mask); }

/* An inner node: its children's pieces joined (A's vertices, then B's
 * that A does not have; a vertex both have, on both their cuts, once,
 * with both quadrics), its cut that is left locked. */
static mr_status run_inner(job *j, uint32_t i, mr_chunk_result *root, mr_error *err)
{
    const ooc_node *n = &j->tree.nodes[i];
    piece *a = &j->pieces[n->child[0]], *b = &j->pieces[n->child[1]];
    const ooc_node *na = &j->tree.nodes[n->child[0]], *nb = &j->tree.nodes[n->child[1]];
    mr_status st = MR_OK;
    if (a->nt && (st = piece_load(j, a, err)) != MR_OK)
        return st;
    if (b->nt && (st = piece_load(j, b, err)) != MR_OK) {
        piece_free(a);
        return st;
    }
    const size_t nv_max = a->nv + b->nv, nt = a->nt + b->nt;
    if (nt == 0) {
        if (n->parent < 0)
            return mr_fail_plain(err, MR_ERR_EMPTY, j->in_path,
                                 "every one of its triangles uses a vertex twice: no surface "
                                 "to simplify");
        memset(&j->pieces[i], 0, sizeof j->pieces[i]);
        j->pieces[i].file.fd = -1;
        return MR_OK;
    }
    size_t cuts = 0;
    for (size_t v = 0; v < a->nv; v++)
        cuts += range_outside(j->range[a->gid[v]], na->first_leaf, na->last_leaf);
    size_t mask = 15;
    while (mask + 1 < 2 * cuts)
        mask = 2 * mask + 1;
    uint32_t *table = mr_alloc_array(mask + 1, sizeof *table);
    uint32_t *gid = mr_alloc_array(nv_max + 1, sizeof *gid);
    float *pos = mr_alloc_array(nv_max + 1, 3 * sizeof *pos);
    mr_quadricf *q = mr_alloc_array(nv_max + 1, sizeof *q);
    uint8_t *cut = mr_alloc_array(nv_max + 1, 1), *was = mr_alloc_array(nv_max + 1, 1);
    uint8_t *lock = j->o->vertex_lock ? mr_alloc_array(nv_max + 1, 1) : NULL;
    uint32_t *idx = mr_alloc_array(nt, 3 * sizeof *idx);
    uint32_t *bmap = mr_alloc_array(b->nv + 1, sizeof *bmap);
    float *attr[3];
    const bool attrs = attrs_alloc(j, nv_max + 1, attr);
    if (!table || !gid || !pos || !q || !cut || !was || (j->o->vertex_lock && !lock) || !idx ||
        !bmap || !attrs) {
        st = mr_fail_nomem(err, NULL, nv_max * (70 + attr_bytes(j->attrs)) + nt * 12);
        goto done;
    }
    for (size_t s = 0; s <= mask; s++)
        table[s] = UINT32_MAX;
    size_t nv = 0;
    for (size_t v = 0; v < a->nv; v++, nv++) {
        gid[nv] = a->gid[v];
        memcpy(pos + 3 * nv, a->pos + 3 * v, 12);
        for (int k = 0; k < 3; k++)
            if (attr[k])
                memcpy(attr[k] + attr_floats[k] * nv, a->attr[k] + attr_floats[k] * v,
                       4 * attr_floats[k]);
        q[nv] = a->q[v];
        was[nv] = range_outside(j->range[a->gid[v]], na->first_leaf, na->last_leaf);
        if (was[nv]) {
            size_t s = slot_of(a->gid[v], mask);
            while (table[s] != UINT32_MAX)
                s = (s + 1) & mask;
            table[s] = (uint32_t)v;
        }
    }
    for (size_t v = 0; v < b->nv; v++) {
        const uint32_t g = b->gid[v];
        const bool on_cut = range_outside(j->range[g], nb->first_leaf, nb->last_leaf);
        if (on_cut) {
            size_t s = slot_of(g, mask);
            while (table[s] != UINT32_MAX && a->gid[table[s]] != g)
                s = (s + 1) & mask;
            if (table[s] != UINT32_MAX) {
                /* one vertex of both: A's position (bit for bit B's: a cut
                 * vertex never moves), both quadrics */
                const uint32_t at = table[s];
                mr_quadric qa, qb;
                mr_quadric_load(&qa, &q[at]);
                mr_quadric_load(&qb, &b->q[v]);
                mr_quadric_add(&qa, &qb);
                mr_quadric_store(&q[at], &qa);
                bmap[v] = at;
                continue;
            }
        }
        bmap[v] = (uint32_t)nv;
        gid[nv] = g;
        memcpy(pos + 3 * nv, b->pos + 3 * v, 12);
        for (int k = 0; k < 3; k++)
            if (attr[k])
                memcpy(attr[k] + attr_floats[k] * nv, b->attr[k] + attr_floats[k] * v,
                       4 * attr_floats[k]);
        q[nv] = b->q[v];
        was[nv] = on_cut;
        nv++;
    }
    memcpy(idx, a->idx, 12 * a->nt);
    for (size_t c = 0; c < 3 * b->nt; c++)
        idx[3 * a->nt + c] = bmap[b->idx[c]];
    for (size_t v = 0; v < nv; v++) {
        cut[v] = range_outside(j->range[gid[v]], n->first_leaf, n->last_leaf);
        if (lock)
            lock[v] = input_locked(j, gid[v]);
    }
    piece_free(a);
    piece_free(b);
    free(bmap);
    bmap = NULL;
    free(table);
    table = NULL;
    const mr_chunk c = {.positions = pos,
                        .vertex_count = nv,
                        .indices = idx,
                        .triangle_count = nt,
                        .cut = cut,
                        .locked = lock,
                        .quadrics = q,
                        .was_cut = was,
                        .unit = j->diagonal,
                        .normals = attr[0],
                        .texcoords = attr[1],
                        .colors = attr[2],
                        .wedges = j->wedges};
    st = run_chunk(j, i, &c, gid, root, err);
done:
    for (int k = 0; k < 3; k++)
        free(attr[k]);
    piece_free(a);
    piece_free(b);
    free(table);
    free(gid);
    free(pos);
    free(q);
    free(cut);
    free(was);
    free(lock);
    free(idx);
    free(bmap);
    return st;
}

/* The tree in post-order; the root's result into *root. */
static mr_status run_tree(job *j, mr_chunk_result *root, mr_error *err)
{
    ooc_tree *t = &j->tree;
    j->pieces = mr_calloc_array(t->nnodes, sizeof *j->pieces);
    int32_t *stack = mr_alloc_array(2 * t->nnodes + 2, sizeof *stack);
    if (!j->pieces || !stack) {
        free(stack);
        return mr_fail_nomem(err, NULL, t->nnodes * (sizeof *j->pieces + 8));
    }
    for (size_t i = 0; i < t->nnodes; i++)
        j->pieces[i].file.fd = -1;
    const double t0 = mr_now_seconds();
    mr_status st = MR_OK;
    size_t sp = 0;
    stack[sp++] = 0;
    stack[sp++] = 0;
    while (sp && st == MR_OK) {
        const int32_t state = stack[--sp], i = stack[--sp];
        const ooc_node *n = &t->nodes[i];
        if (n->child[0] < 0) {
            st = run_leaf(j, (uint32_t)i, root, err);
        } else if (state == 0) {
            stack[sp++] = i;
            stack[sp++] = 1;
            stack[sp++] = n->child[1];
            stack[sp++] = 0;
            stack[sp++] = n->child[0];
            stack[sp++] = 0;
        } else if (!(j->above && j->above[i])) {
            st = run_inner(j, (uint32_t)i, root, err);
        }
        if (st == MR_OK && j->cancelled)
            st = mr_fail_plain(err, MR_ERR_CANCELLED, NULL,
                               "simplify: cancelled by the progress callback");
    }
    free(stack);
    j->st->seconds_simplify = mr_now_seconds() - t0;
    return st;
}

/* The tree's first inner nodes, breadth first, into the stats: each one's
 * axis and plane (its grid's bin boundary, in model units). */
static void record_splits(const ooc_tree *t, mr_simplify_file_stats *fs)
{
    uint32_t queue[2 * MR_SPLITS_MAX + 2];
    size_t head = 0, tail = 0;
    queue[tail++] = 0;
    fs->splits = 0;
    while (head < tail && fs->splits < MR_SPLITS_MAX) {
        const ooc_node *n = &t->nodes[queue[head++]];
        if (n->child[0] < 0)
            continue;
        const ooc_grid *g = &t->grids[n->grid];
        fs->split_axis[fs->splits] = n->axis;
        fs->split_at[fs->splits] = g->lo[n->axis] + (double)n->split / g->scale[n->axis];
        fs->splits++;
        if (tail + 2 <= sizeof queue / sizeof *queue) {
            queue[tail++] = (uint32_t)n->child[0];
            queue[tail++] = (uint32_t)n->child[1];
        }
    }
}

/* ---- the tree over several ranks ------------------------------------------------ */

/* Who simplifies each node: the leaves in runs of about equal triangles,
 * a rank a run (a leaf goes to the rank its middle triangle falls to);
 * an inner node to the rank of its first child. */
static mr_status assign_owners(job *j, mr_error *err)
{
    ooc_tree *t = &j->tree;
    j->owner = mr_calloc_array(t->nnodes, sizeof *j->owner);
    if (!j->owner)
        return mr_fail_nomem(err, NULL, t->nnodes * sizeof *j->owner);
    if (j->ranks == 1)
        return MR_OK;
    uint64_t total = 0;
    for (size_t l = 0; l < t->leaves; l++)
        total += t->nodes[t->leaf_node[l]].triangles;
    uint64_t at = 0;
    for (size_t l = 0; l < t->leaves; l++) {
        const uint64_t n = t->nodes[t->leaf_node[l]].triangles;
        const double mid = total ? ((double)at + 0.5 * (double)n) / (double)total : 0;
        int r = (int)(mid * j->ranks);
        j->owner[t->leaf_node[l]] = r < j->ranks ? r : j->ranks - 1;
        at += n;
    }
    /* children come after their parent in the node array */
    for (size_t i = t->nnodes; i-- > 0;)
        if (t->nodes[i].child[0] >= 0)
            j->owner[i] = j->owner[t->nodes[i].child[0]];
    return MR_OK;
}

/* Node i's piece from its owner to `to`: its counts, then its file's
 * bytes in messages. */
static mr_status send_piece(job *j, uint32_t i, int to, mr_error *err)
{
    piece *p = &j->pieces[i];
    uint64_t head[2] = {p->nv, p->nt};
    mr_status st = j->comm->send(j->comm, to, head, sizeof head, err);
    const uint64_t bytes = p->nt ? p->file.size : 0;
    char *buf = bytes ? mr_alloc_array(MESSAGE_BYTES, 1) : NULL;
    mr_status local = bytes && !buf ? mr_fail_nomem(err, NULL, MESSAGE_BYTES) : MR_OK;
    char zeros[4096] = {0};
    for (uint64_t off = 0; off < bytes && st == MR_OK;) {
        const size_t m = bytes - off < (buf ? MESSAGE_BYTES : sizeof zeros)
                             ? (size_t)(bytes - off)
                             : (buf ? MESSAGE_BYTES : sizeof zeros);
        if (local == MR_OK)
            local = ooc_file_read(&j->temp, &p->file, off, buf, m, err);
        st = j->comm->send(j->comm, to, local == MR_OK ? buf : (buf ? memset(buf, 0, m) : zeros),
                           m, err);
        off += m;
    }
    free(buf);
    ooc_file_close(&j->temp, &p->file);
    return st != MR_OK ? st : local;
}

static mr_status recv_piece(job *j, uint32_t i, int from, mr_error *err)
{
    piece *p = &j->pieces[i];
    uint64_t head[2];
    mr_status st = j->comm->recv(j->comm, from, head, sizeof head, err);
    if (st != MR_OK)
        return st;
    p->nv = (size_t)head[0];
    p->nt = (size_t)head[1];
    void *data[7];
    uint64_t sizes[7];
    const uint64_t bytes = p->nt ? piece_parts(j, p, data, sizes) : 0; /* piece_store's */
    char *buf = bytes ? mr_alloc_array(MESSAGE_BYTES, 1) : NULL;
    mr_status local = bytes && !buf ? mr_fail_nomem(err, NULL, MESSAGE_BYTES) : MR_OK;
    if (bytes && local == MR_OK)
        local = ooc_file_open(&j->temp, &p->file, err);
    char sink[4096];
    for (uint64_t off = 0; off < bytes && st == MR_OK;) {
        const size_t cap = buf ? MESSAGE_BYTES : sizeof sink;
        const size_t m = bytes - off < cap ? (size_t)(bytes - off) : cap;
        st = j->comm->recv(j->comm, from, buf ? buf : sink, m, err);
        if (st == MR_OK && local == MR_OK)
            local = ooc_file_write(&j->temp, &p->file, off, buf, m, err);
        off += m;
    }
    free(buf);
    return st != MR_OK ? st : local;
}

/* Several ranks: the tree's levels as supersteps -- each rank simplifies
 * its nodes of the level, then the results whose parent another rank owns
 * go to it; the root's result (rank 0's: it owns the first leaf) into
 * *root. */
static mr_status run_levels(job *j, mr_chunk_result *root, mr_error *err)
{
    ooc_tree *t = &j->tree;
    j->pieces = mr_calloc_array(t->nnodes, sizeof *j->pieces);
    mr_status st = j->pieces ? MR_OK : mr_fail_nomem(err, NULL, t->nnodes * sizeof *j->pieces);
    for (size_t i = 0; st == MR_OK && i < t->nnodes; i++)
        j->pieces[i].file.fd = -1;
    st = agree(j, st, err);
    const double t0 = mr_now_seconds();
    for (int h = 0; h <= t->height && st == MR_OK; h++) {
        mr_status local = MR_OK;
        for (size_t i = 0; i < t->nnodes && local == MR_OK; i++) {
            const ooc_node *n = &t->nodes[i];
            if (n->height != h || j->owner[i] != j->rank || (j->above && j->above[i]))
                continue;
            local = n->child[0] < 0 ? run_leaf(j, (uint32_t)i, root, err)
                                    : run_inner(j, (uint32_t)i, root, err);
            if (local == MR_OK && j->cancelled)
                local = mr_fail_plain(err, MR_ERR_CANCELLED, NULL,
                                      "simplify: cancelled by the progress callback");
        }
        st = agree(j, local, err);
        /* in node order on every rank: each pair's messages in one order */
        for (size_t i = 0; i < t->nnodes && st == MR_OK; i++) {
            const ooc_node *n = &t->nodes[i];
            if (n->height != h || n->parent < 0 || (j->above && j->above[i]))
                continue;
            /* a top of the forest: to rank 0, which reduces the cuts */
            const int from = j->owner[i],
                      to = j->above && j->above[n->parent] ? 0 : j->owner[n->parent];
            if (from == to)
                continue;
            if (j->rank == from)
                local = send_piece(j, (uint32_t)i, to, err);
            else if (j->rank == to)
                local = recv_piece(j, (uint32_t)i, from, err);
        }
        st = agree(j, st == MR_OK ? local : st, err);
    }
    j->st->seconds_simplify = mr_now_seconds() - t0;
    return st;
}

/* Several ranks: the figures summed (counts, times of work) or the most
 * (a level's time, the largest error, temporary disk) over them. */
static mr_status gather_stats(job *j, mr_error *err)
{
    if (j->ranks == 1)
        return MR_OK;
    mr_simplify_file_stats *fs = j->st;
    fs->temp_bytes_peak = j->temp.peak;
    uint64_t u[2 * MR_LEVELS_MAX + 1];
    double sum[3], most[MR_LEVELS_MAX + 1];
    for (int l = 0; l < MR_LEVELS_MAX; l++) {
        u[l] = fs->level_chunks[l];
        u[MR_LEVELS_MAX + l] = fs->level_triangles[l];
        most[l] = fs->level_seconds[l];
    }
    u[2 * MR_LEVELS_MAX] = fs->simplify.collapses;
    most[MR_LEVELS_MAX] = fs->simplify.max_error;
    sum[0] = fs->simplify.seconds_setup;
    sum[1] = fs->simplify.seconds_collapse;
    sum[2] = fs->simplify.seconds_output;
    uint64_t peak = fs->temp_bytes_peak;
    mr_status st;
    if ((st = reduce(j, u, 2 * MR_LEVELS_MAX + 1, OOC_U64, OOC_SUM, err)) != MR_OK ||
        (st = reduce(j, most, MR_LEVELS_MAX + 1, OOC_F64, OOC_MAX, err)) != MR_OK ||
        (st = reduce(j, sum, 3, OOC_F64, OOC_SUM, err)) != MR_OK ||
        (st = reduce(j, &peak, 1, OOC_U64, OOC_MAX, err)) != MR_OK)
        return st;
    for (int l = 0; l < MR_LEVELS_MAX; l++) {
        fs->level_chunks[l] = (size_t)u[l];
        fs->level_triangles[l] = (size_t)u[MR_LEVELS_MAX + l];
        fs->level_seconds[l] = most[l];
    }
    fs->simplify.collapses = (size_t)u[2 * MR_LEVELS_MAX];
    fs->simplify.max_error = most[MR_LEVELS_MAX];
    fs->simplify.seconds_setup = sum[0];
    fs->simplify.seconds_collapse = sum[1];
    fs->simplify.seconds_output = sum[2];
    fs->temp_bytes_peak = peak;
    return MR_OK;
}

/* ---- the forest: an output larger than a chunk -------------------------------- */

/* When the output does not fit one chunk (output_fits), the tree ends at
 * its highest nodes whose share of the target does (the tops): each is
 * simplified to its share (by input triangles) and a triangle for each
 * vertex of its cut, which stays locked. Then each node above them,
 * children first, reduces the cut
 * between its two sides: the triangles within BAND_RINGS rings of the
 * vertices that cut (a band, small beside a chunk) are taken out of the
 * pieces on both sides, joined with their quadrics, and simplified with
 * the band's rim (vertices the pieces still use) and the cuts further up
 * locked; the band's result becomes a piece of its own. The bands take
 * the excess the locked cuts left, in proportion to their cut vertices,
 * and the last (the root's) takes what the targets still ask: the
 * triangles exactly, the vertices but for the rim vertices that lose
 * their last band triangle there (a few in thousands). The pieces are
 * written as one PLY stream, a vertex they share once. */
enum { BAND_RINGS = 6 };

/* Input vertex ids to a value, open addressing (growing). */
typedef struct gidmap {
    uint32_t *key, *val;
    size_t mask, count;
} gidmap;

/* An open-addressing table's slots for `hint` entries: a power of two,
 * at most half full. */
static size_t table_capacity(size_t hint)
{
    size_t cap = 64;
    while (cap < 2 * hint)
        cap *= 2;
    return cap;
}

static bool gidmap_init(gidmap *m, size_t hint)
{
    const size_t cap = table_capacity(hint);
    m->key = mr_alloc_array(cap, sizeof *m->key);
    m->val = mr_alloc_array(cap, sizeof *m->val);
    m->mask = cap - 1;
    m->count = 0;
    if (!m->key || !m->val)
        return false;
    memset(m->key, 0xFF, cap * sizeof *m->key);
    return true;
}

static void gidmap_free(gidmap *m)
{
    free(m->key);
    free(m->val);
    memset(m, 0, sizeof *m);
}

static uint32_t *gidmap_find(const gidmap *m, uint32_t g)
{
    for (size_t s = slot_of(g, m->mask);; s = (s + 1) & m->mask) {
        if (m->key[s] == g)
            return &m->val[s];
        if (m->key[s] == UINT32_MAX)
            return NULL;
    }
}

/* g -> v unless g is there; *added says which. false: no memory. */
static bool gidmap_put(gidmap *m, uint32_t g, uint32_t v, bool *added)
{
    if (2 * (m->count + 1) > m->mask + 1) {
        gidmap n;
        if (!gidmap_init(&n, m->mask + 1))
            return gidmap_free(&n), false;
        for (size_t s = 0; s <= m->mask; s++)
            if (m->key[s] != UINT32_MAX) {
                size_t t = slot_of(m->key[s], n.mask);
                while (n.key[t] != UINT32_MAX)
                    t = (t + 1) & n.mask;
                n.key[t] = m->key[s];
                n.val[t] = m->val[s];
            }
        n.count = m->count;
        gidmap_free(m);
        *m = n;
    }
    size_t s = slot_of(g, m->mask);
    while (m->key[s] != UINT32_MAX && m->key[s] != g)
        s = (s + 1) & m->mask;
    *added = m->key[s] == UINT32_MAX;
    if (*added) {
        m->key[s] = g;
        m->val[s] = v;
        m->count++;
    }
    return true;
}

/* Positions (three floats' bits) as a set, open addressing (growing):
 * with wedges, the forest finds the wedges of one surface point in
 * different pieces, or in a band and its piece's rest, by their position
 * (join_coincident's rule). */
typedef struct posset {
    uint32_t (*key)[3];
    uint8_t *used;
    size_t mask, count;
} posset;

static bool posset_init(posset *m, size_t hint)
{
    const size_t cap = table_capacity(hint);
    m->key = mr_alloc_array(cap, sizeof *m->key);
    m->used = mr_calloc_array(cap, 1);
    m->mask = cap - 1;
    m->count = 0;
    return m->key && m->used;
}

static void posset_free(posset *m)
{
    free(m->key);
    free(m->used);
    memset(m, 0, sizeof *m);
}

/* The slot of position p: its own, or the empty one where it would go. */
static size_t posset_slot(const posset *m, const float p[3])
{
    uint32_t b[3];
    memcpy(b, p, sizeof b);
    size_t s = (size_t)(ooc_position_key(b) & m->mask);
    while (m->used[s] && memcmp(m->key[s], b, sizeof b) != 0)
        s = (s + 1) & m->mask;
    return s;
}

static bool posset_has(const posset *m, const float p[3])
{
    return m->used[posset_slot(m, p)] != 0;
}

/* p into the set; *added says whether it was new. false: no memory. */
static bool posset_put(posset *m, const float p[3], bool *added)
{
    if (2 * (m->count + 1) > m->mask + 1) {
        posset n;
        if (!posset_init(&n, m->mask + 1))
            return posset_free(&n), false;
        for (size_t s = 0; s <= m->mask; s++)
            if (m->used[s]) {
                float q[3];
                memcpy(q, m->key[s], sizeof q);
                const size_t t = posset_slot(&n, q);
                memcpy(n.key[t], m->key[s], sizeof n.key[t]);
                n.used[t] = 1;
            }
        n.count = m->count;
        posset_free(m);
        *m = n;
    }
    const size_t s = posset_slot(m, p);
    *added = !m->used[s];
    if (*added) {
        memcpy(m->key[s], p, sizeof m->key[s]);
        m->used[s] = 1;
        m->count++;
    }
    return true;
}

static bool fits_as_root(const job *j, const ooc_node *n)
{
    const double s =
        j->share_triangles * (double)n->triangles / (double)j->tree.nodes[0].triangles;
    return 4 * s <= 3 * (double)j->capacity;
}

/* The tops, the nodes above them and the tops' shares of the target. */
static mr_status plan_forest(job *j, mr_error *err)
{
    const ooc_tree *t = &j->tree;
    j->top = mr_calloc_array(t->nnodes, 1);
    j->above = mr_calloc_array(t->nnodes, 1);
    j->top_target = mr_calloc_array(t->nnodes, sizeof *j->top_target);
    if (!j->top || !j->above || !j->top_target)
        return mr_fail_nomem(err, NULL, t->nnodes * 10);
    /* children come after their parent in the node array */
    for (size_t i = 0; i < t->nnodes; i++) {
        const ooc_node *n = &t->nodes[i];
        if (n->parent >= 0 && !j->above[n->parent])
            continue;
        if (n->child[0] < 0 || fits_as_root(j, n))
            j->top[i] = 1;
        else
            j->above[i] = 1;
    }
    const double goal = floor(j->share_triangles + 0.5), all = (double)t->nodes[0].triangles;
    uint64_t cum = 0;
    size_t prev = 0;
    for (size_t i = 0; i < t->nnodes; i++)
        if (j->top[i]) {
            cum += t->nodes[i].triangles;
            const size_t at = (size_t)floor(goal * (double)cum / all + 0.5);
            j->top_target[i] = at - prev;
            prev = at;
            j->st->top_chunks++;
        }
    return MR_OK;
}

static inline bool seg_shared(const job *j, const gidmap *rim, size_t s, uint32_t g)
{
    return range_outside(j->range[g], j->seg_first[s], j->seg_last[s]) || gidmap_find(rim, g);
}

/* Piece s's input vertex ids and, unless pos is NULL, positions (the
 * first two of piece_parts' arrays). */
static mr_status piece_ids(job *j, size_t s, uint32_t **gid, float **pos, mr_error *err)
{
    const piece *p = &j->seg[s];
    const size_t per = pos ? 16 : 4;
    uint8_t *buf = mr_alloc_array(p->nv + 1, per);
    *gid = (uint32_t *)buf;
    if (pos)
        *pos = (float *)(buf + 4 * p->nv);
    if (!buf)
        return mr_fail_nomem(err, NULL, p->nv * per);
    mr_status st = ooc_file_read(&j->temp, &j->seg[s].file, 0, buf, per * p->nv, err);
    if (st != MR_OK)
        free(buf), *gid = NULL;
    return st;
}

/* The pieces' vertices, a shared one once (*nv), their surface points
 * (*np: with wedges, their distinct positions, join_coincident's rule;
 * else *nv) and their triangles. */
static mr_status count_forest(job *j, const gidmap *rim, size_t *nv, size_t *np, size_t *nt,
                              mr_error *err)
{
    gidmap seen;
    posset shared = {0};
    bool ok = gidmap_init(&seen, rim->count + 1024);
    if (j->wedges)
        ok &= posset_init(&shared, rim->count + 1024);
    mr_status st = ok ? MR_OK : mr_fail_nomem(err, NULL, rim->count * 32);
    *nv = *np = *nt = 0;
    /* with wedges, first the positions of the shared vertices: a position
     * that more than one piece holds is one of these */
    for (size_t s = 0; j->wedges && s < j->nseg && st == MR_OK; s++) {
        uint32_t *gid;
        float *pos;
        if (!j->seg[s].nt || (st = piece_ids(j, s, &gid, &pos, err)) != MR_OK)
            continue;
        for (size_t v = 0; v < j->seg[s].nv && st == MR_OK; v++) {
            bool added;
            if (seg_shared(j, rim, s, gid[v]) && !posset_put(&shared, pos + 3 * v, &added))
                st = mr_fail_nomem(err, NULL, shared.count * 32);
        }
        free(gid);
    }
    for (size_t s = 0; s < j->nseg && st == MR_OK; s++) {
        const piece *p = &j->seg[s];
        if (!p->nt)
            continue;
        uint32_t *gid;
        float *pos = NULL;
        if ((st = piece_ids(j, s, &gid, j->wedges ? &pos : NULL, err)) != MR_OK)
            break;
        posset own = {0};
        if (j->wedges && !posset_init(&own, p->nv))
            st = mr_fail_nomem(err, NULL, p->nv * 32);
        for (size_t v = 0; v < p->nv && st == MR_OK; v++) {
            bool added = true;
            if (seg_shared(j, rim, s, gid[v]) && !gidmap_put(&seen, gid[v], 0, &added))
                st = mr_fail_nomem(err, NULL, seen.count * 16);
            *nv += added;
            if (j->wedges && !posset_has(&shared, pos + 3 * v) &&
                !posset_put(&own, pos + 3 * v, &added))
                st = mr_fail_nomem(err, NULL, own.count * 32);
        }
        *np += own.count;
        *nt += p->nt;
        posset_free(&own);
        free(gid);
    }
    *np = j->wedges ? *np + shared.count : *nv;
    gidmap_free(&seen);
    posset_free(&shared);
    return st;
}

/* In the loaded piece p, the triangles within `rings` rings of the
 * vertices on node n's own cut (between its children l and r): tin[f] is
 * a triangle's ring (0: outside the band); mark, per vertex, scratch. The
 * rings do not grow past a vertex on a cut further up. */
static void band_marks(const job *j, const piece *p, const ooc_node *n, const ooc_node *l,
                       const ooc_node *r, int rings, uint8_t *mark, uint8_t *tin)
{
    bool any = false;
    memset(mark, 0, p->nv);
    memset(tin, 0, p->nt);
    for (size_t v = 0; v < p->nv; v++) {
        const uint32_t g = j->range[p->gid[v]];
        if (!range_outside(g, n->first_leaf, n->last_leaf) &&
            range_outside(g, l->first_leaf, l->last_leaf) &&
            range_outside(g, r->first_leaf, r->last_leaf))
            mark[v] = 1, any = true;
    }
    for (uint8_t ring = 1; any && ring <= rings; ring++) {
        for (size_t f = 0; f < p->nt; f++) {
            const uint32_t *c = p->idx + 3 * f;
            if (!tin[f] && ((mark[c[0]] && mark[c[0]] <= ring) ||
                            (mark[c[1]] && mark[c[1]] <= ring) ||
                            (mark[c[2]] && mark[c[2]] <= ring)))
                tin[f] = ring;
        }
        for (size_t f = 0; f < p->nt; f++)
            if (tin[f] == ring)
                for (int k = 0; k < 3; k++) {
                    const uint32_t v = p->idx[3 * f + k];
                    if (!mark[v] &&
                        !range_outside(j->range[p->gid[v]], n->first_leaf, n->last_leaf))
                        mark[v] = (uint8_t)(ring + 1);
                }
    }
}

/* The rings a band of node n takes: BAND_RINGS, or fewer where those do
 * not fit a chunk (0: not even one); *triangles: the band's with them. */
static mr_status band_width(job *j, const ooc_node *n, const ooc_node *l, const ooc_node *r,
                            int *rings, size_t *triangles, mr_error *err)
{
    uint64_t count[BAND_RINGS + 1] = {0};
    mr_status st = MR_OK;
    for (size_t s = 0; s < j->nseg && st == MR_OK; s++) {
        piece *p = &j->seg[s];
        if (!p->nt || j->seg_first[s] < n->first_leaf || j->seg_last[s] > n->last_leaf)
            continue;
        if ((st = piece_read(j, p, true, err)) != MR_OK)
            break;
        uint8_t *mark = mr_alloc_array(p->nv + 1, 1), *tin = mr_alloc_array(p->nt + 1, 1);
        if (!mark || !tin)
            st = mr_fail_nomem(err, NULL, p->nv + p->nt);
        else
            band_marks(j, p, n, l, r, BAND_RINGS, mark, tin);
        for (size_t f = 0; st == MR_OK && f < p->nt; f++)
            count[tin[f]]++;
        free(mark);
        free(tin);
        piece_free(p);
    }
    uint64_t sum = 0;
    *rings = 0;
    for (int k = 1; k <= BAND_RINGS && sum + count[k] <= j->capacity; k++) {
        sum += count[k];
        *rings = k;
    }
    *triangles = (size_t)sum;
    return st;
}

/* The band's surface points (mr_surface_points) over its distinct
 * positions: *apart. */
static mr_status band_apart(const float *pos, size_t nv, const uint32_t *idx, size_t nt,
                            size_t *apart, mr_error *err)
{
    uint32_t *point = mr_alloc_array(nv + 1, sizeof *point);
    posset at = {0};
    if (!point || !posset_init(&at, nv)) {
        free(point), posset_free(&at);
        return mr_fail_nomem(err, NULL, nv * 36);
    }
    mr_status st = mr_surface_points(pos, nv, idx, nt, point, NULL, err);
    size_t points = 0;
    for (size_t v = 0; v < nv && st == MR_OK; v++) {
        bool added;
        points += point[v] == v;
        if (!posset_put(&at, pos + 3 * v, &added))
            st = mr_fail_nomem(err, NULL, at.count * 32);
    }
    *apart = st == MR_OK && points > at.count ? points - at.count : 0;
    free(point);
    posset_free(&at);
    return st;
}

/* The band of above node N: out of every piece inside N, the triangles
 * within BAND_RINGS rings of the vertices on N's own cut, simplified to
 * `reduce` fewer triangles (the last band: to the targets); its result a
 * new piece. *in and *out: its triangles before and after. */
static mr_status run_band(job *j, uint32_t N, double reduce, bool last, gidmap *rim, size_t *in,
                          size_t *out, mr_error *err)
{
    const ooc_tree *t = &j->tree;
    const ooc_node *n = &t->nodes[N], *l = &t->nodes[n->child[0]], *r = &t->nodes[n->child[1]];
    *in = *out = 0;
    /* the band, growing: its vertices (by input id), their quadrics and
     * marks, its triangles */
    gidmap at = {0}, kept = {0};
    /* with wedges, the rests' kept shared vertices by position, and the
     * positions of the band's rim (a seam's two wedges may fall on the
     * two sides of the band's edge) */
    posset keptpos = {0}, rimpos = {0};
    size_t bnv = 0, bnt = 0, rimmed = 0;
    uint32_t *bgid = NULL, *bidx = NULL;
    float *bpos = NULL, *battr[3] = {NULL, NULL, NULL};
    mr_quadricf *bq = NULL;
    uint8_t *bcut = NULL, *bwas = NULL, *brim = NULL, *block = NULL;
    /* the shared vertices (cut or rim) the pieces' rests keep: locked in
     * the band too, whichever piece brought them */
    mr_status st = gidmap_init(&at, 4096) && gidmap_init(&kept, 4096) &&
                           (!j->wedges || (posset_init(&keptpos, 4096) &&
                                           posset_init(&rimpos, 4096)))
                       ? MR_OK
                       : mr_fail_nomem(err, NULL, 1 << 17);
    int rings = 0;
    size_t cap = 0; /* the band's triangles; its vertices at most three times that */
    if (st == MR_OK)
        st = band_width(j, n, l, r, &rings, &cap, err);
    if (st == MR_OK && rings == 0)
        st = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, j->in_path,
                           "the band across a cut of the forest holds more triangles than a "
                           "chunk's %llu: give a larger memory budget",
                           (unsigned long long)j->capacity);
    if (st == MR_OK) {
        bgid = mr_alloc_array(3 * cap + 1, sizeof *bgid);
        bpos = mr_alloc_array(3 * cap + 1, 3 * sizeof *bpos);
        bq = mr_alloc_array(3 * cap + 1, sizeof *bq);
        bcut = mr_alloc_array(3 * cap + 1, 1);
        bwas = mr_alloc_array(3 * cap + 1, 1);
        brim = mr_alloc_array(3 * cap + 1, 1);
        bidx = mr_alloc_array(cap + 1, 3 * sizeof *bidx);
        const bool attrs = attrs_alloc(j, 3 * cap + 1, battr);
        if (!bgid || !bpos || !bq || !bcut || !bwas || !brim || !bidx || !attrs)
            st = mr_fail_nomem(err, NULL,
                               cap * (3 * (19 + sizeof *bq + attr_bytes(j->attrs)) + 12));
    }
    for (size_t s = 0; s < j->nseg && st == MR_OK; s++) {
        piece *p = &j->seg[s];
        if (!p->nt || j->seg_first[s] < n->first_leaf || j->seg_last[s] > n->last_leaf)
            continue;
        if ((st = piece_load(j, p, err)) != MR_OK)
            break;
        uint8_t *mark = mr_calloc_array(p->nv + 1, 1), *use = mr_calloc_array(p->nv + 1, 1);
        uint8_t *tin = mr_calloc_array(p->nt + 1, 1);
        uint32_t *map = mr_alloc_array(p->nv + 1, sizeof *map);
        posset own = {0}; /* with wedges: the positions of its band part */
        if (!mark || !use || !tin || !map || (j->wedges && !posset_init(&own, 1024))) {
            free(mark), free(use), free(tin), free(map), posset_free(&own);
            st = mr_fail_nomem(err, NULL, p->nv * 6 + p->nt);
            piece_free(p);
            break;
        }
        band_marks(j, p, n, l, r, rings, mark, tin);
        for (size_t f = 0; f < p->nt; f++)
            for (int k = 0; k < 3; k++)
                use[p->idx[3 * f + k]] |= tin[f] ? 2 : 1;
        /* the band's part: its vertices into the band (a rim vertex's
         * quadric stays with the piece) */
        for (size_t v = 0; v < p->nv && st == MR_OK; v++) {
            if (!(use[v] & 2))
                continue;
            const uint32_t g = p->gid[v];
            const bool was = seg_shared(j, rim, s, g); /* cut where its quadric was made */
            bool added;
            if (j->wedges && !posset_put(&own, p->pos + 3 * v, &added)) {
                st = mr_fail_nomem(err, NULL, own.count * 32);
                break;
            }
            if (!gidmap_put(&at, g, (uint32_t)bnv, &added)) {
                st = mr_fail_nomem(err, NULL, at.count * 16);
                break;
            }
            if (added) {
                bgid[bnv] = g;
                memcpy(bpos + 3 * bnv, p->pos + 3 * v, 12);
                for (int k = 0; k < 3; k++)
                    if (battr[k])
                        memcpy(battr[k] + attr_floats[k] * bnv, p->attr[k] + attr_floats[k] * v,
                               4 * attr_floats[k]);
                memset(&bq[bnv], 0, sizeof *bq);
                bcut[bnv] = bwas[bnv] = brim[bnv] = 0;
                bnv++;
            }
            const uint32_t b = *gidmap_find(&at, g);
            map[v] = b;
            if (use[v] & 1) {
                brim[b] = 1; /* the piece keeps it, and its quadric */
                if (!gidmap_put(rim, g, 0, &added)) {
                    st = mr_fail_nomem(err, NULL, rim->count * 16);
                    break;
                }
            } else {
                mr_quadric qa, qb;
                mr_quadric_load(&qa, &bq[b]);
                mr_quadric_load(&qb, &p->q[v]);
                mr_quadric_add(&qa, &qb);
                mr_quadric_store(&bq[b], &qa);
            }
            bcut[b] |= brim[b] || range_outside(j->range[g], n->first_leaf, n->last_leaf);
            bwas[b] |= was;
        }
        for (size_t f = 0; f < p->nt && st == MR_OK; f++) {
            if (!tin[f])
                continue;
            for (int k = 0; k < 3; k++)
                bidx[3 * bnt + (size_t)k] = map[p->idx[3 * f + k]];
            bnt++;
        }
        /* the piece's rest, kept (with wedges, by position: a shared
         * vertex, or a wedge of a surface point whose other wedges went
         * into the band) */
        size_t nv = 0, nt = 0;
        for (size_t v = 0; v < p->nv && st == MR_OK; v++) {
            bool added;
            if (!(use[v] & 1))
                continue;
            if (j->wedges) {
                /* a wedge whose surface point is in the band too is on
                 * the rim from now on, as the band's wedges there are:
                 * shared, so that the bands above find it */
                bool shared = seg_shared(j, rim, s, p->gid[v]);
                if (!shared && posset_has(&own, p->pos + 3 * v)) {
                    shared = true;
                    if (!gidmap_put(rim, p->gid[v], 0, &added))
                        st = mr_fail_nomem(err, NULL, rim->count * 16);
                }
                if (shared && st == MR_OK && !posset_put(&keptpos, p->pos + 3 * v, &added))
                    st = mr_fail_nomem(err, NULL, keptpos.count * 32);
            } else if (seg_shared(j, rim, s, p->gid[v]) &&
                       !gidmap_put(&kept, p->gid[v], 0, &added)) {
                st = mr_fail_nomem(err, NULL, kept.count * 16);
            }
        }
        posset_free(&own);
        for (size_t v = 0; v < p->nv; v++)
            if (use[v] & 1) {
                map[v] = (uint32_t)nv;
                p->gid[nv] = p->gid[v];
                memcpy(p->pos + 3 * nv, p->pos + 3 * v, 12);
                p->q[nv] = p->q[v];
                for (int k = 0; k < 3; k++)
                    if (p->attr[k])
                        memmove(p->attr[k] + attr_floats[k] * nv,
                                p->attr[k] + attr_floats[k] * v, 4 * attr_floats[k]);
                nv++;
            }
        for (size_t f = 0; f < p->nt; f++)
            if (!tin[f]) {
                for (int k = 0; k < 3; k++)
                    p->idx[3 * nt + (size_t)k] = map[p->idx[3 * f + (size_t)k]];
                nt++;
            }
        p->nv = nt ? nv : 0;
        p->nt = nt;
        free(mark), free(use), free(tin), free(map);
        if (st == MR_OK && nt)
            st = piece_store(j, p, err);
        else
            piece_free(p);
    }
    for (size_t v = 0; v < bnv && st == MR_OK; v++) {
        bool added;
        if (!brim[v] && (j->wedges ? posset_has(&keptpos, bpos + 3 * v)
                                   : gidmap_find(&kept, bgid[v]) != NULL)) {
            brim[v] = bcut[v] = 1;
            if (!gidmap_put(rim, bgid[v], 0, &added))
                st = mr_fail_nomem(err, NULL, rim->count * 16);
        }
        if (!j->wedges)
            rimmed += brim[v];
        else if (brim[v] && !posset_put(&rimpos, bpos + 3 * v, &added))
            st = mr_fail_nomem(err, NULL, rimpos.count * 32);
    }
    if (j->wedges)
        rimmed = rimpos.count; /* the targets count surface points */
    gidmap_free(&kept);
    posset_free(&keptpos);
    posset_free(&rimpos);
    if (st == MR_OK && bnt) {
        if (last) {
            /* what the targets still ask, exactly: the pieces' rest counts */
            size_t rest_nv = 0, rest_np = 0, rest_nt = 0;
            st = count_forest(j, rim, &rest_nv, &rest_np, &rest_nt, err);
            const double tt = j->target_triangles ? (double)j->target_triangles - (double)rest_nt : 0;
            const double tv = j->target_vertices
                                  ? (double)j->target_vertices - (double)rest_np + (double)rimmed
                                  : 0;
            j->band_t = !j->target_triangles ? 0 : tt < 1 ? 1 : (size_t)tt;
            j->band_v = !j->target_vertices ? 0 : tv < 1 ? 1 : (size_t)tv;
            /* the band counts its surface points, which keep apart the
             * wedges of a position whose seam edge lies outside it (at
             * its rim, locked): those it counts over the positions */
            size_t apart = 0;
            if (st == MR_OK && j->wedges && j->band_v)
                st = band_apart(bpos, bnv, bidx, bnt, &apart, err);
            j->band_v += apart;
        } else {
            const double tt = (double)bnt - (reduce > 0 ? reduce : 0);
            j->band_t = tt < 1 ? 1 : (size_t)tt;
            j->band_v = 0;
        }
        if (j->o->vertex_lock && st == MR_OK) {
            block = mr_alloc_array(bnv, 1);
            if (!block)
                st = mr_fail_nomem(err, NULL, bnv);
            for (size_t v = 0; st == MR_OK && v < bnv; v++)
                block[v] = input_locked(j, bgid[v]);
        }
        mr_chunk_result root;
        memset(&root, 0, sizeof root);
        const mr_chunk c = {.positions = bpos,
                            .vertex_count = bnv,
                            .indices = bidx,
                            .triangle_count = bnt,
                            .cut = bcut,
                            .locked = block,
                            .quadrics = bq,
                            .was_cut = bwas,
                            .unit = j->diagonal,
                            .normals = battr[0],
                            .texcoords = battr[1],
                            .colors = battr[2],
                            .wedges = j->wedges};
        if (st == MR_OK)
            st = run_chunk(j, N, &c, bgid, &root, err);
        piece *p = &j->seg[j->nseg];
        memset(p, 0, sizeof *p);
        p->file.fd = -1;
        if (st == MR_OK && n->parent < 0) {
            j->band_stop = root.mesh.stats.stop;
            st = keep_result(j, p, &root, bgid, err);
        } else if (st == MR_OK) {
            *p = j->pieces[N];
            memset(&j->pieces[N], 0, sizeof j->pieces[N]);
            j->pieces[N].file.fd = -1;
        }
        mr_chunk_result_free(&root);
        if (st == MR_OK) {
            j->seg_first[j->nseg] = n->first_leaf;
            j->seg_last[j->nseg] = n->last_leaf;
            j->nseg++;
            *in = bnt;
            *out = p->nt;
        } else {
            ooc_file_close(&j->temp, &p->file);
        }
    }
    gidmap_free(&at);
    posset_free(&keptpos);
    posset_free(&rimpos);
    free(bgid), free(bidx), free(bpos), free(bq), free(bcut), free(bwas), free(brim), free(block);
    for (int k = 0; k < 3; k++)
        free(battr[k]);
    return st;
}

/* The pieces as one PLY stream: the vertices, a shared one at its first
 * piece, then the triangles. */
static mr_status write_forest(job *j, const char *out_path, const mr_write_options *write,
                              const gidmap *rim, mr_error *err)
{
    mr_write_options defaults;
    if (!write) {
        mr_write_options_default(&defaults);
        write = &defaults;
    }
    size_t nv, np, nt;
    mr_status st = count_forest(j, rim, &nv, &np, &nt, err);
    if (st != MR_OK)
        return st;
    mr_simplify_stats *s = &j->st->simplify;
    s->output_vertices = nv;
    s->output_points = np;
    s->output_triangles = nt;
    enum { BLOCK = 1 << 16 };
    float *pos = mr_alloc_array(3 * (size_t)BLOCK, sizeof *pos), *attr[3];
    size_t *base = mr_alloc_array(j->nseg + 1, sizeof *base);
    gidmap id;
    const bool ok = gidmap_init(&id, rim->count + 1024);
    const bool attrs = attrs_alloc(j, BLOCK, attr);
    if (!pos || !base || !ok || !attrs) {
        free(pos), free(base), gidmap_free(&id);
        for (int k = 0; k < 3; k++)
            free(attr[k]);
        return mr_fail_nomem(err, NULL, (12 + attr_bytes(j->attrs)) * (size_t)BLOCK);
    }
    const double t0 = mr_now_seconds();
    mr_output_file of;
    st = mr_output_open(&of, out_path, err);
    if (st != MR_OK) {
        free(pos), free(base), gidmap_free(&id);
        return st;
    }
    static const size_t bufsize = 1 << 20;
    char *buf = malloc(bufsize);
    if (buf)
        setvbuf(of.f, buf, _IOFBF, bufsize);
    mr_ply_stream ps;
    st = mr_ply_stream_begin(&ps, of.f, nv, nt, j->attrs, write, out_path, err);
    const mr_mesh block = {.positions = pos,
                           .normals = attr[0],
                           .texcoords = attr[1],
                           .colors = attr[2]};
    size_t next = 0, fill = 0;
    for (size_t k = 0; k < j->nseg && st == MR_OK; k++) {
        piece *p = &j->seg[k];
        base[k] = next;
        if (!p->nt || (st = piece_read(j, p, true, err)) != MR_OK)
            continue;
        for (size_t v = 0; v < p->nv && st == MR_OK; v++) {
            bool added = true;
            if (seg_shared(j, rim, k, p->gid[v]) &&
                !gidmap_put(&id, p->gid[v], (uint32_t)next, &added))
                st = mr_fail_nomem(err, NULL, id.count * 16);
            if (!added)
                continue;
            memcpy(pos + 3 * fill, p->pos + 3 * v, 12);
            for (int a = 0; a < 3; a++)
                if (attr[a])
                    memcpy(attr[a] + attr_floats[a] * fill, p->attr[a] + attr_floats[a] * v,
                           4 * attr_floats[a]);
            next++;
            if (++fill == BLOCK) {
                mr_mesh b = block;
                b.vertex_count = fill;
                st = mr_ply_stream_vertices(&ps, &b, err);
                fill = 0;
            }
        }
        piece_free(p);
    }
    if (st == MR_OK && fill) {
        mr_mesh b = block;
        b.vertex_count = fill;
        st = mr_ply_stream_vertices(&ps, &b, err);
    }
    for (size_t k = 0; k < j->nseg && st == MR_OK; k++) {
        piece *p = &j->seg[k];
        if (!p->nt || (st = piece_read(j, p, false, err)) != MR_OK)
            continue;
        uint32_t *local = mr_alloc_array(p->nv + 1, sizeof *local);
        if (!local) {
            st = mr_fail_nomem(err, NULL, p->nv * 4);
            piece_free(p);
            break;
        }
        size_t counter = base[k];
        for (size_t v = 0; v < p->nv; v++) {
            if (seg_shared(j, rim, k, p->gid[v])) {
                const uint32_t o = *gidmap_find(&id, p->gid[v]);
                counter += o == counter;
                local[v] = o;
            } else {
                local[v] = (uint32_t)counter++;
            }
        }
        for (size_t c = 0; c < 3 * p->nt; c++)
            p->idx[c] = local[p->idx[c]];
        st = mr_ply_stream_faces(&ps, p->idx, p->nt, err);
        free(local);
        piece_free(p);
    }
    if (st == MR_OK)
        st = mr_ply_stream_end(&ps, err);
    st = mr_output_close(&of, out_path, st, err);
    free(buf);
    free(pos);
    for (int k = 0; k < 3; k++)
        free(attr[k]);
    free(base);
    gidmap_free(&id);
    j->st->seconds_write = mr_now_seconds() - t0;
    return st;
}

/* Rank 0, after the tops: the bands, then the output. */
static mr_status run_forest(job *j, const char *out_path, const mr_write_options *write,
                            mr_error *err)
{
    const ooc_tree *t = &j->tree;
    size_t ntop = 0, nabove = 0;
    for (size_t i = 0; i < t->nnodes; i++)
        ntop += j->top[i], nabove += j->above[i];
    j->seg = mr_calloc_array(ntop + nabove + 1, sizeof *j->seg);
    j->seg_first = mr_alloc_array(ntop + nabove + 1, sizeof *j->seg_first);
    j->seg_last = mr_alloc_array(ntop + nabove + 1, sizeof *j->seg_last);
    uint64_t *w = mr_calloc_array(t->nnodes, sizeof *w);
    gidmap rim;
    const bool ok = gidmap_init(&rim, 4096);
    if (!j->seg || !j->seg_first || !j->seg_last || !w || !ok) {
        free(w), gidmap_free(&rim);
        return mr_fail_nomem(err, NULL, (ntop + nabove) * sizeof *j->seg);
    }
    double now = 0;
    for (size_t i = 0; i < t->nnodes; i++)
        if (j->top[i]) {
            j->seg[j->nseg] = j->pieces[i];
            memset(&j->pieces[i], 0, sizeof j->pieces[i]);
            j->pieces[i].file.fd = -1;
            j->seg_first[j->nseg] = t->nodes[i].first_leaf;
            j->seg_last[j->nseg] = t->nodes[i].last_leaf;
            now += (double)j->seg[j->nseg].nt;
            j->nseg++;
        }
    /* each above node's weight: the vertices on its own cut */
    uint64_t all = 0;
    for (size_t v = 0; v < j->nv; v++) {
        const uint32_t r = j->range[v];
        if (r == RANGE_NONE)
            continue;
        int32_t i = 0;
        while (j->above[i]) {
            const ooc_node *n = &t->nodes[i];
            const ooc_node *a = &t->nodes[n->child[0]], *b = &t->nodes[n->child[1]];
            if (!range_outside(r, a->first_leaf, a->last_leaf))
                i = n->child[0];
            else if (!range_outside(r, b->first_leaf, b->last_leaf))
                i = n->child[1];
            else {
                w[i]++, all++;
                break;
            }
        }
    }
    const double excess = now - floor(j->share_triangles + 0.5);
    double done = 0;
    uint64_t cum = 0;
    mr_status st = MR_OK;
    for (size_t i = t->nnodes; i-- > 0 && st == MR_OK;) {
        if (!j->above[i])
            continue;
        cum += w[i];
        const double plan = all ? floor(excess * (double)cum / (double)all + 0.5) : 0;
        size_t in, out;
        st = run_band(j, (uint32_t)i, plan - done, i == 0, &rim, &in, &out, err);
        done += (double)in - (double)out;
        if (st == MR_OK && j->cancelled)
            st = mr_fail_plain(err, MR_ERR_CANCELLED, NULL,
                               "simplify: cancelled by the progress callback");
    }
    free(w);
    if (st == MR_OK)
        st = write_forest(j, out_path, write, &rim, err);
    gidmap_free(&rim);
    return st;
}

/* ---- the job --------------------------------------------------------------------- */

static char *size_text(char *buf, size_t cap, uint64_t n)
{
    if (n >= (uint64_t)1 << 30)
        snprintf(buf, cap, "%.2f GiB", (double)n / (double)((uint64_t)1 << 30));
    else if (n >= (uint64_t)1 << 20)
        snprintf(buf, cap, "%.1f MiB", (double)n / (double)((uint64_t)1 << 20));
    else
        snprintf(buf, cap, "%llu KiB", (unsigned long long)(n >> 10));
    return buf;
}

/* A size rounded up, for "give at least". */
static char *size_up(char *buf, size_t cap, uint64_t n)
{
    const double mib = (double)n / (double)((uint64_t)1 << 20);
    if (mib >= 1024)
        snprintf(buf, cap, "%.2f GiB", ceil(mib / 1024 * 100) / 100);
    else
        snprintf(buf, cap, "%.1f MiB", ceil(mib * 10) / 10);
    return buf;
}

/* The targets on the whole input: the vertex target as mr_simplify's
 * set-up resolves it (a ratio of the referenced vertices, the first of
 * ratio and count reached), and all as triangles for the nodes' shares. */
static mr_status resolve_targets(job *j, mr_error *err)
{
    const mr_simplify_options *o = j->o;
    if (o->target_triangles > j->nt)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: target of %zu triangles exceeds the input's %zu",
                             o->target_triangles, j->nt);
    if (o->target_vertices > j->referenced)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: target of %zu vertices exceeds the input's %zu "
                             "referenced vertices",
                             o->target_vertices, j->referenced);
    size_t tv = 0;
    if (o->target_ratio > 0)
        tv = (size_t)floor(o->target_ratio * (double)j->referenced + 0.5);
    if (o->target_vertices)
        tv = tv > o->target_vertices ? tv : o->target_vertices;
    j->target_vertices = tv;
    j->target_triangles = o->target_triangles;
    double share = 0;
    if (tv)
        share = (double)tv * (double)j->nt / (double)j->referenced;
    if (o->target_triangles && (share == 0 || (double)o->target_triangles > share))
        share = (double)o->target_triangles;
    j->share_triangles = share;
    j->max_error =
        o->max_error > 0 ? (o->error_absolute ? o->max_error : o->max_error * j->diagonal) : 0;
    return MR_OK;
}

/* The root holds two halves of a chunk, from which it makes the output:
 * at most three quarters of a chunk, so that it still chooses among a
 * third more collapses than it makes. */
static mr_status output_fits(const job *j, uint64_t memory, const char *out_path,
                             const mr_write_options *write, bool *forest, mr_error *err)
{
    *forest = false;
    if (4 * j->share_triangles <= 3 * (double)j->capacity)
        return MR_OK;
    /* a forest, written as a PLY stream */
    const mr_format fmt = write && write->format != MR_FORMAT_AUTO ? write->format
                                                                   : mr_format_from_path(out_path);
    char a[32], b[32];
    if (fmt == MR_FORMAT_PLY) {
        *forest = true;
        return MR_OK;
    }
    const uint64_t need =
        memory +
        (uint64_t)ceil(4 * j->share_triangles / 3 - (double)j->capacity) *
            (CHUNK_BYTES_PER_TRIANGLE + (j->wedges ? ATTR_BYTES_PER_TRIANGLE : 0));
    return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, j->in_path,
                         "the output (about %.0f triangles) does not fit the memory budget "
                         "of %s: its chunks hold %llu triangles, and the last one makes the "
                         "output from at most a chunk's worth (3/4 of one at most); write it "
                         "as PLY (the chunks' results are then written as one stream) or give "
                         "at least %s",
                         j->share_triangles, size_text(a, sizeof a, memory),
                         (unsigned long long)j->capacity, size_up(b, sizeof b, need));
}

static mr_status write_root(job *j, const char *out_path, mr_chunk_result *r,
                            const mr_write_options *write, mr_error *err)
{
    mr_mesh m;
    mr_mesh_init(&m);
    m.vertex_count = r->mesh.vertex_count;
    m.triangle_count = r->mesh.triangle_count;
    m.positions = r->mesh.positions;
    m.indices = r->mesh.indices;
    m.normals = r->normals;
    m.texcoords = r->texcoords;
    m.colors = r->colors;
    const double t0 = mr_now_seconds();
    mr_status st = mr_mesh_write(out_path, &m, write, err);
    j->st->seconds_write = mr_now_seconds() - t0;
    return st;
}

/* The attributes the write options keep (MR_ATTR_*). */
static unsigned written_attributes(const mr_write_options *write)
{
    unsigned dropped = 0;
    if (write) {
        dropped |= write->write_normals ? 0 : MR_ATTR_NORMALS;
        dropped |= write->write_texcoords ? 0 : MR_ATTR_TEXCOORDS;
        dropped |= write->write_colors ? 0 : MR_ATTR_COLORS;
    }
    return (MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS) & ~dropped;
}

static unsigned kept_attributes(const job *j, const mr_write_options *write)
{
    return j->src.attributes & written_attributes(write);
}

/* The input's attributes that the output would keep: carried through
 * the chunks where the source fills them (ooc_source.carried), else
 * refused. */
static mr_status check_attributes(job *j, const mr_write_options *write, mr_error *err)
{
    const unsigned kept = kept_attributes(j, write);
    if (!(kept & ~j->src.carried)) {
        j->attrs = kept; /* carried through the chunks */
        return MR_OK;
    }
    char a[32], what[64] = "";
    const char *names[3] = {"normals", "texture coordinates", "colors"};
    const unsigned bits[3] = {MR_ATTR_NORMALS, MR_ATTR_TEXCOORDS, MR_ATTR_COLORS};
    for (int i = 0; i < 3; i++)
        if (kept & bits[i])
            snprintf(what + strlen(what), sizeof what - strlen(what), "%s%s",
                     what[0] ? " and " : "", names[i]);
    return mr_fail_plain(err, MR_ERR_UNSUPPORTED, j->in_path,
                         "its vertices have %s, which the out-of-core path does not carry "
                         "here (an OBJ's colors are kept where the first v line of a window of "
                         "its parse has one): drop them from the output (--no-normals, --no-texcoords, "
                         "--no-colors) for a simplification of the geometry, or give a "
                         "memory budget of %s for the in-memory path",
                         what, size_up(a, sizeof a, (uint64_t)j->nt * INCORE_BYTES_PER_TRIANGLE));
}

/* The chunk's capacity C from the budget: what the vertex table, the
 * tree's grid, the spill's buffers and a face batch leave, at
 * CHUNK_BYTES_PER_TRIANGLE a triangle (and ATTR_BYTES_PER_TRIANGLE with
 * attributes); an error where C is too small. */
static mr_status size_chunks(job *j, uint64_t memory, uint32_t grid_bins, uint64_t buffers,
                             mr_error *err)
{
    char a[32], b[32];
    if (j->nv > UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, j->in_path,
                             "%zu vertices exceed the 32-bit index limit", j->nv);
    const uint64_t fixed = 4 * (uint64_t)j->nv + (j->o->vertex_lock ? (uint64_t)j->nv : 0) +
                           4 * (uint64_t)grid_bins * grid_bins * grid_bins + buffers +
                           (uint64_t)j->batch * 40;
    const uint64_t per_triangle =
        CHUNK_BYTES_PER_TRIANGLE + (j->wedges ? ATTR_BYTES_PER_TRIANGLE : 0);
    const uint64_t capacity = memory > fixed ? (memory - fixed) / per_triangle : 0;
    /* a chunk well above its cut: 16 sqrt(T) (a cut of a chunk high in
     * the tree is about that long, at the input's resolution) */
    uint64_t least = (uint64_t)ceil(16 * sqrt((double)j->nt));
    least = least > MIN_CAPACITY ? least : MIN_CAPACITY;
    if (2 * (uint64_t)j->nt / (MAX_LEAVES / 2) > least)
        least = 2 * (uint64_t)j->nt / (MAX_LEAVES / 2);
    if (capacity < least)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, j->in_path,
                             "a memory budget of %s is too small for %zu vertices and %zu "
                             "triangles out of core%s: give at least %s",
                             size_text(a, sizeof a, memory), j->nv, j->nt,
                             j->attrs ? " with their attributes" : "",
                             size_up(b, sizeof b, fixed + per_triangle * least));
    j->capacity = capacity;
    j->st->chunk_capacity = (size_t)capacity;
    return MR_OK;
}

static mr_status out_of_core(job *j, const char *out_path, uint64_t memory,
                             const mr_out_of_core_options *ooc, const mr_write_options *write,
                             mr_obj_stream *os, bool stl, mr_error *err)
{
    mr_simplify_file_stats *fs = j->st;
    mr_status st;
    const double t_weld = mr_now_seconds();
    if (stl) {
        /* a binary STL's vertices come from its weld: that first */
        st = ooc_temp_init(&j->temp, ooc ? ooc->temp_dir : NULL, out_path,
                           ooc ? ooc->temp_budget : 0, err);
        if ((st = agree(j, st, err)) != MR_OK)
            return st;
        st = agree(j, ooc_source_from_stl(j->in_path, &j->temp, memory, j->threads, &j->src, err), err);
        if (st != MR_OK)
            return st;
        j->nv = j->src.vertex_count;
    }
    /* the budget's parts (a binary PLY's attributes known now; an OBJ's
     * once it is parsed, when the chunks are sized again) */
    const uint32_t grid_bins = memory >= ((uint64_t)256 << 20) ? 64 : 32;
    const uint64_t buffers = memory / 16 < ((uint64_t)64 << 20) ? memory / 16 : (uint64_t)64 << 20;
    const uint64_t batch = memory / 640;
    j->batch = batch < 4096 ? 4096 : batch > FACE_BATCH ? FACE_BATCH : (size_t)batch;
    j->attrs = kept_attributes(j, write) & j->src.carried;
    /* a PLY's vertices split by attributes stay split when they are dropped */
    j->wedges = j->attrs || (j->src.carried & j->src.attributes);
    if ((st = size_chunks(j, memory, grid_bins, buffers, err)) != MR_OK) {
        mr_obj_stream_close(os);
        return st;
    }
    /* the targets' triangles as far as the counts tell before the passes
     * (the vertex count's at least), to say early what does not fit */
    j->referenced = j->nv;
    bool forest = false;
    if ((st = resolve_targets(j, err)) == MR_OK &&
        (st = output_fits(j, memory, out_path, write, &forest, err)) == MR_OK && !stl)
        st = ooc_temp_init(&j->temp, ooc ? ooc->temp_dir : NULL, out_path,
                           ooc ? ooc->temp_budget : 0, err);
    /* the passes: an OBJ file's parse into temporary files (a binary STL's
     * weld came first), the box, the tree's counts, the spill */
    const double t0 = stl ? t_weld : mr_now_seconds();
    j->total = 0.1 * (double)j->nt * 4 + (double)j->nt * 2;
    if (os && st == MR_OK)
    {
        st = ooc_source_from_obj(os, j->in_path, &j->temp,
                                 written_attributes(write) & mr_obj_stream_may_have(os), memory,
                                 j->threads, &j->src, err);
        /* with attributes its vertices are the corners' distinct (v, vt, vn),
         * and its chunks take them */
        if (st == MR_OK) {
            j->nv = j->src.vertex_count;
            j->attrs = kept_attributes(j, write) & j->src.carried;
            j->wedges = j->attrs != 0; /* dropped: the v lines, not split */
            st = size_chunks(j, memory, grid_bins, buffers, err);
        }
    } else {
        mr_obj_stream_close(os);
    }
    /* without attributes, vertices that repeat a position (an unwelded
     * export) go as wedges too, joined into surface points as in memory
     * (a binary STL's are welded) */
    if (st == MR_OK && !j->wedges && !stl) {
        bool found = false;
        st = agree(j, find_coincident(j, memory, &found, err), err);
        if (st == MR_OK && found) {
            j->wedges = true;
            st = size_chunks(j, memory, grid_bins, buffers, err);
        }
    }
    /* the output against the chunks as sized now */
    if (st == MR_OK)
        st = output_fits(j, memory, out_path, write, &forest, err);
    if (st == MR_OK)
        st = check_attributes(j, write, err);
    if ((st = agree(j, st, err)) == MR_OK)
        st = bounds_pass(j, err);
    if (st == MR_OK)
        st = ooc_tree_init(&j->tree, j->lo, j->hi, grid_bins, j->capacity, err);
    for (int round = 0; st == MR_OK && ooc_tree_open(&j->tree); round++) {
        st = agree(j, face_pass(j, count_batch, NULL, err), err);
        /* every rank's counts: sums of integers, exact */
        for (size_t i = 0; st == MR_OK && i < j->tree.nnodes; i++)
            if (j->tree.nodes[i].open) {
                const ooc_grid *g = &j->tree.grids[j->tree.nodes[i].grid];
                st = reduce(j, g->count, (size_t)g->n * g->n * g->n, OOC_U32, OOC_SUM, err);
            }
        if (st == MR_OK)
            st = agree(j, ooc_tree_split(&j->tree, round + 1 >= MAX_REFINEMENTS, err), err);
    }
    if (st == MR_OK)
        st = agree(j, ooc_tree_number(&j->tree, err), err);
    if (st != MR_OK)
        return st;
    ooc_tree *t = &j->tree;
    fs->chunks = t->leaves;
    fs->oversized_chunks = t->oversized;
    fs->levels = (unsigned)t->height + 1;
    record_splits(t, fs);
    if (t->leaves > MAX_LEAVES)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, j->in_path,
                             "%zu chunks: more than %u (give a larger memory budget)",
                             t->leaves, MAX_LEAVES);
    /* the spill: each leaf's run at its count's offset (several ranks:
     * each rank's triangles spilled in blocks, then every leaf's sent to
     * the rank that owns it, in rank order: the file's order) */
    st = assign_owners(j, err);
    j->leaf_at = st == MR_OK ? mr_alloc_array(t->leaves, sizeof *j->leaf_at) : NULL;
    j->leaf_count = st == MR_OK ? mr_calloc_array(t->leaves, sizeof *j->leaf_count) : NULL;
    j->range = st == MR_OK ? mr_alloc_array(j->nv + 1, sizeof *j->range) : NULL;
    spill_buffers sb = {0};
    sb.local.fd = -1;
    sb.per = (size_t)(buffers / 12 / t->leaves);
    sb.per = sb.per < 64 ? 64 : sb.per > (1u << 16) ? 1u << 16 : sb.per;
    sb.buf = mr_alloc_array(t->leaves * sb.per, 12);
    sb.fill = mr_calloc_array(t->leaves, sizeof *sb.fill);
    sb.leaf = mr_alloc_array(2 * (j->batch + j->src.max_faces + 1), sizeof *sb.leaf);
    if (st == MR_OK &&
        (!j->leaf_at || !j->leaf_count || !j->range || !sb.buf || !sb.fill || !sb.leaf))
        st = mr_fail_nomem(err, NULL, j->nv * 4 + t->leaves * sb.per * 12);
    if (st == MR_OK) {
        uint64_t at = 0;
        for (size_t l = 0; l < t->leaves; l++) {
            j->leaf_at[l] = at;
            at += t->nodes[t->leaf_node[l]].triangles;
        }
        for (size_t v = 0; v < j->nv; v++)
            j->range[v] = RANGE_NONE;
        st = ooc_file_open(&j->temp, j->ranks > 1 ? &sb.local : &j->spill, err);
    }
    if (st == MR_OK)
        st = face_pass(j, spill_batch, &sb, err);
    for (size_t l = 0; st == MR_OK && l < t->leaves; l++)
        st = flush_leaf(j, &sb, l, err);
    free(sb.buf);
    free(sb.fill);
    free(sb.leaf);
    st = agree(j, st, err);
    if (st == MR_OK && j->ranks > 1)
        st = agree(j, assemble_spill(j, &sb, err), err);
    ooc_file_close(&j->temp, &sb.local);
    free(sb.blocks);
    /* every vertex's leaves over all ranks */
    if (st == MR_OK && j->ranks > 1)
        st = reduce_ranges(j, err);
    fs->seconds_read = mr_now_seconds() - t0;
    if (st != MR_OK)
        return st;
    for (size_t l = 0; l < t->leaves; l++)
        if (j->owner[t->leaf_node[l]] == j->rank &&
            j->leaf_count[l] > t->nodes[t->leaf_node[l]].triangles)
            st = mr_fail_plain(err, MR_ERR_IO, j->in_path,
                               "the faces changed between two passes over the file");
    if ((st = agree(j, st, err)) != MR_OK)
        return st;
    if (j->wedges && (st = agree(j, join_coincident(j, memory, err), err)) != MR_OK)
        return st;
    j->referenced = 0;
    for (size_t v = 0; v < j->nv; v++)
        j->referenced += j->range[v] != RANGE_NONE;
    fs->simplify.input_vertices = j->referenced;
    if (j->wedges)
        j->referenced = j->points;
    if ((st = resolve_targets(j, err)) != MR_OK ||
        (st = output_fits(j, memory, out_path, write, &forest, err)) != MR_OK)
        return st;
    if (forest && (st = plan_forest(j, err)) != MR_OK)
        return st;

    /* the tree */
    mr_chunk_result root;
    memset(&root, 0, sizeof root);
    st = j->ranks > 1 ? run_levels(j, &root, err) : run_tree(j, &root, err);
    ooc_file_close(&j->temp, &j->spill);
    if (st == MR_OK && forest)
        st = agree(j, j->rank == 0 ? run_forest(j, out_path, write, err) : MR_OK, err);
    if (st == MR_OK)
        st = gather_stats(j, err);
    if (st == MR_OK && j->rank == 0 && forest) {
        mr_simplify_stats *s = &fs->simplify;
        const bool counts =
            (j->target_triangles && s->output_triangles <= j->target_triangles) ||
            (j->target_vertices && s->output_points <= j->target_vertices);
        /* short of the counts: why the last band stopped (the error bound
         * counts as reached, as in memory) */
        s->stop = counts ? MR_STOP_TARGET
                         : j->band_stop == MR_STOP_TARGET ? MR_STOP_REFUSED : j->band_stop;
        s->target_reached = j->o->until_error || s->stop <= MR_STOP_MAX_ERROR;
        if (!j->o->error_absolute)
            s->max_error /= j->diagonal;
    } else if (st == MR_OK && j->rank == 0) {
        mr_simplify_stats *s = &fs->simplify;
        s->output_vertices = root.mesh.vertex_count;
        s->output_points = j->wedges ? root.mesh.stats.output_points : root.mesh.vertex_count;
        s->output_triangles = root.mesh.triangle_count;
        s->stop = root.mesh.stats.stop;
        s->target_reached = root.mesh.stats.target_reached;
        s->pruned_parts = root.mesh.stats.pruned_parts;
        s->locked_vertices = root.mesh.stats.locked_vertices;
        if (!j->o->error_absolute)
            s->max_error /= j->diagonal;
        st = write_root(j, out_path, &root, write, err);
    }
    mr_chunk_result_free(&root);
    if (fs->temp_bytes_peak < j->temp.peak)
        fs->temp_bytes_peak = j->temp.peak;
    return agree(j, st, err);
}

/* The in-memory path: read whole, mr_mesh_simplify, write. */
static mr_status in_core(const char *in_path, const char *out_path,
                         const mr_simplify_options *o, const mr_write_options *write,
                         mr_simplify_file_stats *fs, mr_error *err)
{
    mr_mesh in, out;
    mr_mesh_init(&in);
    mr_mesh_init(&out);
    const double t0 = mr_now_seconds();
    mr_status st = mr_mesh_read(in_path, NULL, &in, err);
    fs->seconds_read = mr_now_seconds() - t0;
    if (st == MR_OK && in.triangle_count == 0)
        st = mr_fail_plain(err, MR_ERR_EMPTY, in_path,
                           "a point cloud (%zu vertices, no triangles): simplify needs a "
                           "triangle mesh",
                           in.vertex_count);
    if (st == MR_OK)
        st = mr_mesh_simplify(&in, o, &out, NULL, &fs->simplify, err);
    mr_mesh_free(&in);
    const double t1 = mr_now_seconds();
    fs->seconds_simplify = t1 - t0 - fs->seconds_read;
    if (st == MR_OK)
        st = mr_mesh_write(out_path, &out, write, err);
    fs->seconds_write = mr_now_seconds() - t1;
    mr_mesh_free(&out);
    return st;
}

mr_status mr_simplify_file(const char *in_path, const char *out_path,
                           const mr_simplify_options *options,
                           const mr_out_of_core_options *ooc, const mr_write_options *write,
                           mr_simplify_file_stats *stats, mr_error *err)
{
    return ooc_simplify_file(in_path, out_path, options, ooc, write, NULL, stats, err);
}

mr_status ooc_simplify_file(const char *in_path, const char *out_path,
                            const mr_simplify_options *options,
                            const mr_out_of_core_options *ooc, const mr_write_options *write,
                            ooc_comm *comm, mr_simplify_file_stats *stats, mr_error *err)
{
    mr_error_clear(err);
    mr_simplify_file_stats fs;
    memset(&fs, 0, sizeof fs);
    if (stats)
        *stats = fs;
    if (!in_path || !out_path)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no input or output path");
    mr_status st = mr_simplify_check_options(options, SIZE_MAX, err);
    if (st != MR_OK)
        return st;
    const uint64_t memory = ooc && ooc->memory ? ooc->memory : MR_MEMORY_DEFAULT;
    fs.memory = memory;
    const double t0 = mr_now_seconds();
    job j;
    memset(&j, 0, sizeof j);
    j.in_path = in_path;
    j.o = options;
    j.st = &fs;
    j.threads = mr_thread_count(options->threads);
    j.spill.fd = -1;
    j.temp.dir[0] = '\0';
    j.comm = comm && comm->size > 1 ? comm : NULL;
    j.rank = j.comm ? comm->rank : 0;
    j.ranks = j.comm ? comm->size : 1;
    /* the counts: a binary PLY's header; an OBJ file's count of its lines,
     * unless its size says it fits (a face line takes 8 bytes at least) */
    mr_error quiet;
    mr_obj_stream *os = NULL;
    bool stl = false;
    const mr_format format = mr_format_from_path(in_path);
    st = MR_ERR_UNSUPPORTED;
    if (format == MR_FORMAT_PLY) {
        st = ooc_source_open(in_path, j.threads, &j.src, &quiet);
        if (st == MR_OK) {
            j.nv = j.src.vertex_count;
            j.nt = j.src.triangle_count;
        }
    } else if (format == MR_FORMAT_STL) {
        /* the header's count: the weld waits for the out-of-core path */
        const uint64_t n = ooc_stl_triangles(in_path);
        if (n) {
            j.nt = (size_t)n;
            stl = true;
            st = MR_OK;
        }
    } else if (format == MR_FORMAT_OBJ) {
        struct stat sb;
        const bool small = stat(in_path, &sb) == 0 && S_ISREG(sb.st_mode) &&
                           (uint64_t)sb.st_size / 8 * INCORE_BYTES_PER_TRIANGLE <= memory;
        if (!small) {
            uint64_t window = memory / 8;
            window = window < ((uint64_t)1 << 20)   ? (uint64_t)1 << 20
                     : window > ((uint64_t)64 << 20) ? (uint64_t)64 << 20
                                                     : window;
            st = mr_obj_stream_open(in_path, j.threads, (size_t)window, &os, &quiet);
            if (st == MR_OK) {
                j.nv = mr_obj_stream_vertex_count(os);
                j.nt = mr_obj_stream_triangle_count(os);
            }
        }
    }
    if (st != MR_OK && st != MR_ERR_UNSUPPORTED) {
        if (err)
            *err = quiet;
        return agree(&j, st, err);
    }
    if (st != MR_OK || (uint64_t)j.nt * INCORE_BYTES_PER_TRIANGLE <= memory) {
        ooc_source_close(&j.src);
        mr_obj_stream_close(os);
        st = j.rank == 0 ? in_core(in_path, out_path, options, write, &fs, err) : MR_OK;
        st = agree(&j, st, err);
    } else {
        fs.out_of_core = 1;
        fs.simplify.input_triangles = j.nt;
        st = out_of_core(&j, out_path, memory, ooc, write, os, stl, err);
        ooc_source_close(&j.src);
        ooc_file_close(&j.temp, &j.spill);
        if (j.pieces)
            for (size_t i = 0; i < j.tree.nnodes; i++) {
                piece_free(&j.pieces[i]);
                ooc_file_close(&j.temp, &j.pieces[i].file);
            }
        free(j.pieces);
        for (size_t i = 0; i < j.nseg; i++) {
            piece_free(&j.seg[i]);
            ooc_file_close(&j.temp, &j.seg[i].file);
        }
        free(j.seg);
        free(j.seg_first);
        free(j.seg_last);
        free(j.top);
        free(j.above);
        free(j.top_target);
        free(j.owner);
        free(j.range);
        free(j.leaf_at);
        free(j.leaf_count);
        ooc_tree_free(&j.tree);
    }
    fs.seconds_total = mr_now_seconds() - t0;
    if (stats)
        *stats = fs;
    return st;
}
