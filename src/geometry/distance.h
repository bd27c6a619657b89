/*
 * Exact point-to-surface distances: the closest point of a triangle to a
 * point, a bounding-volume hierarchy over triangles for the nearest
 * triangle of a mesh, and the same hierarchy over points for the nearest
 * vertex. Internal, not part of the public API; used by mr_compare and
 * meant for anything else that needs the distance of a point to a mesh
 * (heat maps, the simplifier's tests).
 *
 * Precision: positions are floats, as everywhere in the library; all
 * distance arithmetic is done in double on the exact double values of
 * those floats. Query points are doubles (surface samples are not rounded
 * back to float). Box pruning uses float boxes read as doubles, which are
 * exact bounds of the float vertices, so pruning never drops a triangle
 * that could be nearer (up to the last-bit rounding of the distance
 * arithmetic itself).
 *
 * The hierarchy is built top-down with a binned surface-area heuristic
 * (median split where the heuristic finds nothing), subtrees in parallel
 * as OpenMP tasks, and then laid out depth-first. Its shape depends only
 * on the input, never on the thread count, so every query returns the
 * same bits for every thread count. Long thin triangles, when there are
 * enough of them to matter, get a hierarchy of oriented boxes of their own
 * (mr_tri_bvh below): a fan of N slivers around one vertex costs a query
 * about log N node visits rather than N triangle tests.
 */
#ifndef MR_DISTANCE_H
#define MR_DISTANCE_H

#include "../core/internal.h"

/* ---- point to triangle ---------------------------------------------------- */

/*
 * Closest point of triangle (a, b, c) to p and its squared distance.
 * Ericson's Voronoi-region tests (Real-Time Collision Detection, 5.1.5):
 * three vertex regions, three edge regions, the face. A degenerate
 * triangle (coincident vertices, or so thin that the face region is
 * numerically meaningless: sine of the angle at a below 1e-10) is treated
 * as the union of its three edges, which is then within 1e-10 of its
 * longest edge length of the exact answer. With the angle at a below 1e-3
 * (a needle or a cap) the face region's point is p's projection onto the
 * plane, not the barycentric formula, whose cancellation would be off by
 * about 1e-16 / sin^2 of the triangle's size. `closest` may be NULL.
 */
double mr_point_triangle_dist2(const double p[3], const double a[3], const double b[3],
                               const double c[3], double closest[3]);

/* The coordinates of point x of triangle (a, b, c)'s plane along its edges,
 * x - a = bb (b - a) + bc (c - a): *bb and *bc when the edges' Gram
 * determinant, returned, exceeds `floor` times the product of their
 * squared lengths (else they are left alone: a sliver). */
static inline double mr_edge_coords(const double a[3], const double b[3], const double c[3],
                                     const double x[3], double floor, double *bb,
                                     double *bc)
{
    const double e0[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double e1[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double e2[3] = {x[0] - a[0], x[1] - a[1], x[2] - a[2]};
    const double d00 = e0[0] * e0[0] + e0[1] * e0[1] + e0[2] * e0[2];
    const double d01 = e0[0] * e1[0] + e0[1] * e1[1] + e0[2] * e1[2];
    const double d11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
    const double d20 = e2[0] * e0[0] + e2[1] * e0[1] + e2[2] * e0[2];
    const double d21 = e2[0] * e1[0] + e2[1] * e1[1] + e2[2] * e1[2];
    const double den = d00 * d11 - d01 * d01;
    if (den > floor * d00 * d11) {
        *bb = (d11 * d20 - d01 * d21) / den;
        *bc = (d00 * d21 - d01 * d20) / den;
    }
    return den > floor * d00 * d11 ? den : 0;
}

/* Closest point of segment (a, b) to p; a == b is allowed. */
double mr_point_segment_dist2(const double p[3], const double a[3], const double b[3],
                              double closest[3]);

/* ---- the hierarchy -------------------------------------------------------- */

/* A node: float box; an interior node's children are `a` and `b` (= a + 1,
 * both in one cache line); a leaf (b & MR_BVH_LEAF) holds primitives a ..
 * a + (b & ~MR_BVH_LEAF) - 1 in the hierarchy's order. 32 bytes. */
#define MR_BVH_LEAF 0x80000000u
typedef struct mr_bvh_node {
    float lo[3], hi[3];
    uint32_t a, b;
} mr_bvh_node;

typedef struct mr_bvh {
    size_t node_count;
    size_t prim_count;
    mr_bvh_node *nodes; /* node 0 is the root, node 1 padding; 64-byte aligned */
    uint32_t *order;    /* prim_count: primitive id at each hierarchy slot */
} mr_bvh;

/*
 * Build over `count` primitives given by their float boxes (lo, hi: 3 *
 * count each, finite; the box centres are what is binned). count must be
 * at least 1 and below 2^31.
 * threads: 0 = all cores (the shape is the same for every count).
 * On failure `bvh` is left empty (safe to free).
 */
mr_status mr_bvh_build(mr_bvh *bvh, const float *lo, const float *hi, size_t count,
                       int threads, mr_error *err);
void mr_bvh_free(mr_bvh *bvh);

/* ---- nearest triangle ----------------------------------------------------- */

/* A triangle as the queries read it: the corners, and a unit normal for a
 * cheap lower bound (the distance to the triangle's plane) that skips most
 * exact tests; n is zero for slivers. 52 bytes. */
typedef struct mr_tri_rec {
    float v[9];
    float n[3];
    uint32_t id;      /* the triangle's id in the input */
} mr_tri_rec;

/*
 * Two hierarchies over one mesh. A long thin triangle's axis-aligned box
 * can be far larger than the triangle, and where many such boxes overlap
 * (a fan of slivers around one vertex) a query near the surface is inside
 * most of them. So when slivers make up much of the boxes' area (see
 * distance.c), they get a tree of oriented boxes instead: each node is the
 * intersection of three slabs along its own orthonormal frame, fitted to
 * its triangles. The records of both trees are in `tri`: the box tree's
 * first, then the thin tree's; a query searches both and gets the same
 * exact distance either way. Ordinary meshes have no thin tree at all.
 */
typedef struct mr_tri_bvh {
    mr_bvh bvh;       /* axis-aligned, records tri[0 .. bvh.prim_count) */
    mr_bvh thin;      /* oriented, records tri[bvh.prim_count ..); nodes'
                         lo/hi are slab bounds along their axes */
    double *thin_axes; /* 9 per thin node: its three unit axes, row by row */
    double thin_reach; /* largest |x|_1 of a thin triangle's corner */
    mr_tri_rec *tri;  /* triangle_count, in hierarchy order */
    uint32_t *slot;   /* triangle id -> record slot (for hints) */
    size_t triangle_count;
} mr_tri_bvh;

/*
 * Hierarchy over the triangles of a mesh (packed float positions; the
 * indices must be in range). Degenerate triangles are kept: their points
 * are part of the surface too. triangle_count must be at least 1. The
 * shape depends only on the input, never on `threads`.
 */
mr_status mr_tri_bvh_build(mr_tri_bvh *t, const float *positions, const uint32_t *indices,
                           size_t triangle_count, int threads, mr_error *err);
void mr_tri_bvh_free(mr_tri_bvh *t);

/* No hint: UINT32_MAX. */
#define MR_NO_HINT UINT32_MAX

/*
 * The nearest triangle to p: returns the squared distance and sets
 * *triangle (its id in the input, may be NULL) and closest (may be NULL).
 * `hint` is a triangle id believed to be near (e.g. the answer for the
 * previous, nearby query) or MR_NO_HINT; it only makes the query faster,
 * never changes the distance.
 */
double mr_tri_bvh_nearest(const mr_tri_bvh *t, const double p[3], uint32_t hint,
                          uint32_t *triangle, double closest[3]);

/* ---- nearest point -------------------------------------------------------- */

typedef struct mr_point_bvh {
    mr_bvh bvh;
    float *pts;       /* 3 * point_count, in hierarchy order */
    uint32_t *slot;   /* point id -> hierarchy slot */
    size_t point_count;
} mr_point_bvh;

/* Hierarchy over `count` points given as positions[ids[i]] (ids NULL:
 * the points 0 .. count - 1). Point ids in queries are indices into `ids`
 * (or the positions when ids is NULL). count must be at least 1. */
mr_status mr_point_bvh_build(mr_point_bvh *t, const float *positions, const uint32_t *ids,
                             size_t count, int threads, mr_error *err);
void mr_point_bvh_free(mr_point_bvh *t);

/* The nearest point to p: squared distance, its id in *point (may be
 * NULL). `hint` as for triangles. */
double mr_point_bvh_nearest(const mr_point_bvh *t, const double p[3], uint32_t hint,
                            uint32_t *point);

#endif /* MR_DISTANCE_H */
