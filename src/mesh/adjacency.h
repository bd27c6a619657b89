/*
 * Connectivity building blocks shared by the statistics, the cleanup passes
 * and the simplifiers. Internal, not part of the public API.
 *
 * Everything here works on flat arrays with 32-bit ids and never allocates
 * per element. Terms:
 *   - corner c = 3 * t + k is the k-th corner of triangle t; it stands for
 *     the vertex indices[c] of that triangle;
 *   - the half-edge of corner c runs from indices[c] to
 *     indices[mr_corner_next(c)], so a triangle's three half-edges follow
 *     its orientation;
 *   - a triangle is degenerate when it uses a vertex twice.
 * Corner ids are uint32_t, so 3 * triangle_count must fit in 32 bits
 * (about 1.4 billion triangles); the builders check this and return
 * MR_ERR_TOO_LARGE.
 */
#ifndef MR_ADJACENCY_H
#define MR_ADJACENCY_H

#include "../core/internal.h"

/* ---- corners ------------------------------------------------------------ */

static inline uint32_t mr_corner_next(uint32_t c) { return c % 3 == 2 ? c - 2 : c + 1; }
static inline uint32_t mr_corner_prev(uint32_t c) { return c % 3 == 0 ? c + 2 : c - 1; }

/* The same within a triangle: the corner after / before corner j (0..2),
 * without a branch (which corner holds a vertex is a coin toss to a
 * branch predictor). */
static inline uint32_t mr_local_next(uint32_t j) { return (0x09u >> (2 * j)) & 3u; }
static inline uint32_t mr_local_prev(uint32_t j) { return (0x12u >> (2 * j)) & 3u; }

static inline bool mr_triangle_is_degenerate(const uint32_t *tri)
{
    return tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
}

/* Number of bits needed to write any of 0 .. count - 1 (at least 1). */
unsigned mr_index_bits(size_t count);

/* MR_OK when every index is < vertex_count; else MR_ERR_INVALID_ARGUMENT
 * naming the first bad triangle. Also rejects counts that corner ids
 * cannot address (MR_ERR_TOO_LARGE). */
mr_status mr_check_indices(const uint32_t *indices, size_t triangle_count,
                           size_t vertex_count, mr_error *err);

/* ---- sorting ------------------------------------------------------------ */

/*
 * Stable least-significant-digit radix sort of `keys`, carrying `values`
 * along (values may be NULL). Only the low `key_bits` bits of the keys are
 * looked at, so callers that pack small ids should pass the packed width:
 * the cost is one pass per 8 bits. Passes whose digit is the same for every
 * key are skipped. Parallel with `threads` OpenMP threads (0: the default
 * team size); as the sort is stable its result does not depend on the
 * thread count. Allocates n * (sizeof key + 4) bytes of scratch. The 32-bit
 * version moves a third less memory per pass: use it when the key fits.
 */
mr_status mr_radix_sort_u64(uint64_t *keys, uint32_t *values, size_t n, unsigned key_bits,
                            int threads, mr_error *err);
mr_status mr_radix_sort_u32(uint32_t *keys, uint32_t *values, size_t n, unsigned key_bits,
                            int threads, mr_error *err);
/* The same on the caller's scratch (n keys, and n values where values is
 * not NULL): a caller that sorts block after block allocates it once, so
 * that no block's sort faults fresh pages in. */
mr_status mr_radix_sort_u64_scratch(uint64_t *keys, uint32_t *values, size_t n,
                                    unsigned key_bits, int threads, uint64_t *tmp_keys,
                                    uint32_t *tmp_values, mr_error *err);
mr_status mr_radix_sort_u32_scratch(uint32_t *keys, uint32_t *values, size_t n,
                                    unsigned key_bits, int threads, uint32_t *tmp_keys,
                                    uint32_t *tmp_values, mr_error *err);

/*
 * pairs[i] = ((uint64_t)group << 32) | id with distinct ids. Sorts the
 * pairs and, for every id whose group equals that of a smaller id, sets
 * flags[id] = 1 (flags may be NULL). Returns how many ids that is. Meant
 * for the short runs left by a sort on a coarser key: e.g. the triangles
 * over one edge, grouped by their third vertex, to find duplicates.
 */
size_t mr_mark_repeats(uint64_t *pairs, size_t n, uint8_t *flags);

/* ---- fans ---------------------------------------------------------------- */

/* A triangle around a centre vertex c, by the vertices after and before c
 * in it: the triangle runs c -> next and prev -> c. */
typedef struct mr_fan_entry {
    uint32_t next, prev;
} mr_fan_entry;

/*
 * The shape of the n triangles around centre c: 0 when they form one
 * closed manifold fan (a disk), 1 one open fan (a half-disk, two boundary
 * edges), -1 anything else -- a degenerate triangle, an edge of three or
 * more triangles or of two wound the same way (two equal nexts or prevs),
 * several fans. Sorts e by next; seen is n bytes of scratch. O(n log n),
 * whatever the valence.
 */
int mr_fan_classify(uint32_t c, mr_fan_entry *e, size_t n, uint8_t *seen);

/* ---- union-find --------------------------------------------------------- */

/* A disjoint-set forest is a plain uint32_t parent array (parent[i] == i
 * for a root). Path halving keeps the trees flat without recursion. */
static inline uint32_t mr_uf_find(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* Join the sets of a and b; the smaller root id becomes the root, so the
 * root of every set is its smallest id, whatever the order of the unions. */
static inline void mr_uf_union(uint32_t *parent, uint32_t a, uint32_t b)
{
    a = mr_uf_find(parent, a);
    b = mr_uf_find(parent, b);
    if (a < b)
        parent[b] = a;
    else if (b < a)
        parent[a] = b;
}

/*
 * The same for several threads working on one forest at once. Lock-free: a
 * root is linked by compare-and-swap, and, as above, only under a smaller
 * id, so parent[x] <= x always holds and no cycle can form; the stores of
 * path halving only ever replace a parent by one of its ancestors, so racing
 * ones are harmless. As every link puts the larger root under the smaller,
 * the root of a set is always its smallest id: the result is the same as
 * the sequential one for any thread count and schedule. (GCC/Clang atomic
 * builtins on plain arrays.)
 */
static inline uint32_t mr_uf_find_shared(uint32_t *parent, uint32_t x)
{
    for (;;) {
        uint32_t p = __atomic_load_n(&parent[x], __ATOMIC_RELAXED);
        if (p == x)
            return x;
        uint32_t g = __atomic_load_n(&parent[p], __ATOMIC_RELAXED);
        if (g != p)
            __atomic_store_n(&parent[x], g, __ATOMIC_RELAXED);
        x = g;
    }
}

static inline void mr_uf_union_shared(uint32_t *parent, uint32_t a, uint32_t b)
{
    for (;;) {
        a = mr_uf_find_shared(parent, a);
        b = mr_uf_find_shared(parent, b);
        if (a == b)
            return;
        uint32_t big = a > b ? a : b, small = a > b ? b : a, expected = big;
        if (__atomic_compare_exchange_n(&parent[big], &expected, small, false,
                                        __ATOMIC_ACQ_REL, __ATOMIC_RELAXED))
            return;
        /* big was linked meanwhile: start again from the new roots */
    }
}

/* parent[i] = i for i < n (parallel). */
void mr_uf_init(uint32_t *parent, size_t n);

/* ---- vertex -> triangles ------------------------------------------------ */

/*
 * Triangles around each vertex in compressed-sparse-row form: the triangles
 * of vertex v are triangles[offsets[v] .. offsets[v + 1]), in increasing
 * triangle order. A triangle is listed once under each distinct vertex it
 * uses (a degenerate triangle a a b is listed once under a and once under
 * b).
 */
typedef struct mr_vertex_triangles {
    size_t vertex_count;
    uint32_t *offsets;   /* vertex_count + 1 */
    uint32_t *triangles; /* offsets[vertex_count] */
} mr_vertex_triangles;

/* Build the table; the indices must be in range (mr_check_indices). On
 * failure `vt` is left empty (safe to free). */
mr_status mr_vertex_triangles_build(mr_vertex_triangles *vt, const uint32_t *indices,
                                    size_t triangle_count, size_t vertex_count,
                                    mr_error *err);
void mr_vertex_triangles_free(mr_vertex_triangles *vt);

/* ---- undirected edges --------------------------------------------------- */

/*
 * Every half-edge of every non-degenerate triangle, grouped by undirected
 * edge. The table is in compressed-sparse-row form over the smaller vertex
 * `lo` of each edge: entries[offsets[lo] .. offsets[lo + 1]) are the
 * half-edges whose smaller end is lo, each as (hi << 32) | corner, sorted,
 * i.e. by the other end hi and then by corner. So the half-edges of one
 * edge are adjacent (a "run"), in increasing corner order, and the table is
 * the same for every thread count. A run of length 1 is a boundary edge, 2
 * an edge between two triangles, 3 or more a non-manifold edge. Degenerate
 * triangles contribute no half-edges.
 *
 *     for (uint32_t lo = 0; lo < et.vertex_count; lo++)
 *         for (size_t i = et.offsets[lo], j; i < et.offsets[lo + 1]; i = j) {
 *             j = mr_edge_run_end(&et, lo, i);
 *             ... edge (lo, mr_edge_hi(et.entries[i])), corners of i .. j-1
 *         }
 */
typedef struct mr_edge_table {
    size_t vertex_count;
    size_t count;      /* half-edges = offsets[vertex_count] */
    uint32_t *offsets; /* vertex_count + 1 */
    uint64_t *entries; /* count */
} mr_edge_table;

/* Build the table; the indices must be in range (mr_check_indices). On
 * failure `et` is left empty (safe to free). */
mr_status mr_edge_table_build(mr_edge_table *et, const uint32_t *indices,
                              size_t triangle_count, size_t vertex_count, mr_error *err);
void mr_edge_table_free(mr_edge_table *et);

static inline uint32_t mr_edge_hi(uint64_t entry) { return (uint32_t)(entry >> 32); }
static inline uint32_t mr_edge_corner(uint64_t entry) { return (uint32_t)entry; }

/* Whether the half-edges of corners c0 and c1, both on the edge whose
 * smaller end is lo, run it the same way: two triangles wound against
 * each other across that edge. */
static inline bool mr_edge_same_way(const uint32_t *indices, uint32_t c0, uint32_t c1,
                                    uint32_t lo)
{
    return (indices[c0] == lo) == (indices[c1] == lo);
}

/* End of the run that starts at entry i of vertex lo's range. */
static inline size_t mr_edge_run_end(const mr_edge_table *et, uint32_t lo, size_t i)
{
    const size_t end = et->offsets[lo + 1];
    const uint32_t hi = mr_edge_hi(et->entries[i]);
    size_t j = i + 1;
    while (j < end && mr_edge_hi(et->entries[j]) == hi)
        j++;
    return j;
}

#endif /* MR_ADJACENCY_H */
