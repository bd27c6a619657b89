/*
 * Fixed-radius neighbour graph on a uniform grid, the spatial index of the
 * epsilon welders. Internal, not part of the public API.
 *
 * The graph is stored the way P-Weld consumes it (Algorithm 2, lines 1-4):
 * for every point only its neighbours of larger index, sorted, in one
 * compressed-sparse-row array, plus the number of its neighbours of smaller
 * index (the dependency count). The full symmetric graph is never stored:
 * every edge appears once, under its smaller end.
 */
#ifndef MR_CLUSTER_GRID_H
#define MR_CLUSTER_GRID_H

#include "../mesh/adjacency.h"

#include <stdatomic.h>

typedef struct mr_radius_graph {
    size_t n;
    size_t edge_count;         /* unordered pairs within the radius */
    size_t *offsets;           /* n + 1 */
    uint32_t *adj;             /* edge_count: larger neighbours, ascending */
    _Atomic int32_t *depend;   /* n: count of smaller neighbours */
    size_t bytes;              /* memory held by the three arrays */
    size_t peak_bytes;         /* most memory held at once while building */
} mr_radius_graph;

/*
 * Build the graph of the n packed points `pos` for the radius eps >= 0:
 * i and j are neighbours when their squared distance, computed in double
 * as dx*dx + dy*dy + dz*dz, is <= eps*eps (or < eps*eps when strict).
 * Points must be finite, and `box` their bounds as lo[3] then hi[3], both
 * from the caller's mr_points_bounds. Parallel with `threads` threads; the
 * result does not depend on the thread count. On failure the graph is left
 * empty (safe to free).
 */
mr_status mr_radius_graph_build(mr_radius_graph *g, const float *pos, size_t n, double eps,
                                int strict, const double box[6], int threads, mr_error *err);
void mr_radius_graph_free(mr_radius_graph *g);

/* Axis-aligned bounds of packed points, in double; returns false (and the
 * index of the first offender in *bad) when a coordinate is not finite. */
bool mr_points_bounds(const float *pos, size_t n, int threads, double lo[3], double hi[3],
                      size_t *bad);

/* Grid of cells of size `cell` over the box [lo, hi]: dims[k] cells along
 * axis k, with cell grown where needed so that no axis has more than
 * 2^20 cells. A cell's key packs its coordinates in bit fields, x in the
 * low bits[0] bits, then y, then z: decoding is shifts, not divisions, and
 * the cells x-1 .. x+1 of one row are still consecutive keys. */
typedef struct mr_grid {
    double lo[3];
    double cell;
    uint64_t dims[3];
    unsigned bits[3];
} mr_grid;

void mr_grid_init(mr_grid *grid, const double lo[3], const double hi[3], double cell);

static inline uint64_t mr_grid_pack(const mr_grid *g, uint64_t x, uint64_t y, uint64_t z)
{
    return (z << (g->bits[0] + g->bits[1])) | (y << g->bits[0]) | x;
}

static inline void mr_grid_unpack(const mr_grid *g, uint64_t key, uint64_t c[3])
{
    c[0] = key & ((UINT64_C(1) << g->bits[0]) - 1);
    c[1] = (key >> g->bits[0]) & ((UINT64_C(1) << g->bits[1]) - 1);
    c[2] = key >> (g->bits[0] + g->bits[1]);
}

/* Key of the cell holding point p. */
static inline uint64_t mr_grid_key(const mr_grid *g, const float *p)
{
    uint64_t c[3];
    for (int k = 0; k < 3; k++) {
        double t = ((double)p[k] - g->lo[k]) / g->cell;
        uint64_t i = t > 0 ? (uint64_t)t : 0;
        c[k] = i < g->dims[k] ? i : g->dims[k] - 1;
    }
    return mr_grid_pack(g, c[0], c[1], c[2]);
}

static inline unsigned mr_grid_key_bits(const mr_grid *g)
{
    return g->bits[0] + g->bits[1] + g->bits[2];
}

/* Grid clustering's pieces, shared by the in-core (mr_mesh_cluster) and
 * the file path (mr_cluster_file), so that both give the same bytes
 * (gridcluster.c). */
/* Quadric of one triangle: area * (n n^T, n d, d^2) for its unit normal n
 * and plane offset d, as 10 numbers a00 a01 a02 a11 a12 a22 b0 b1 b2 c. */
void mr_cluster_triangle_quadric(const float *p0, const float *p1, const float *p2,
                                 double q[10]);
/* Cell cc of out (key `key` in grid): its vertex where its quadric q is
 * least about the mean of its `count` members (pos_sum / count), kept in
 * the cell and the box [lo, hi]; its attributes the members' means where
 * out has arrays for them. */
void mr_cluster_represent(const mr_grid *grid, uint64_t key, const double q[10],
                          const double pos_sum[3], const double nrm_sum[3],
                          const double uv_sum[2], const double col_sum[4], double count,
                          const double lo[3], const double hi[3], mr_mesh *out, size_t cc);

/* Occupied cells counted on bitmaps of every cell of the grid (when it is
 * small enough to hold them: MR_GRID_BITMAP_CELLS): the cells in all
 * (dims' product); the points' cells marked with `words` 64-bit words of
 * bits a thread (bits: threads x words, zeroed), and counted: the same
 * count on any number of threads. */
#define MR_GRID_BITMAP_CELLS ((size_t)1 << 25)
size_t mr_grid_cells_total(const mr_grid *g);
/* Mark the cells of points pos[3 stride i], i < n, in bits (threads x
 * words, each thread its own `words`); then the cells marked in any. */
void mr_grid_mark(const mr_grid *g, const float *pos, size_t n, size_t stride, int threads,
                  uint64_t *bits, size_t words);
size_t mr_grid_marked(const uint64_t *bits, size_t words, int threads);

/* The occupied cells of a grid of cell size `cell` over the caller's box. */
typedef mr_status (*mr_cell_count_fn)(double cell, void *user, size_t *count, mr_error *err);
/* The cell size whose grid over [lo, hi] has about `target` occupied
 * cells (within 2 %, else the nearest count its steps met), from a few
 * counts (gridcluster.c). */
mr_status mr_cluster_search(const double lo[3], const double hi[3], size_t target,
                            double start, mr_cell_count_fn count, void *user, double *cell_out,
                            mr_error *err);
/* Of n points, every how many a target of `target` cells may be searched
 * on (a coarse grid's cells hold many points: a sample finds them all). */
size_t mr_cluster_sample_stride(size_t n, size_t target);
/* Whether `count` cells meet the target (within the search's tolerance). */
bool mr_cluster_count_close(size_t count, size_t target);

#endif /* MR_CLUSTER_GRID_H */
