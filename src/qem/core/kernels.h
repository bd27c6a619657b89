/*
 * The simplifier's vector kernels, each built for every CPU path the
 * build has and picked once at run time: the cost and plan of a batch of
 * free edges (the quadric solve, mr_free_costs), the area-weighted plane
 * terms a vertex's initial quadric sums (construction), the normal test
 * of a collapse's fans, the merge of two quadrics at a collapse
 * (addition), and the fan sums of a memoryless plan (MR_QUALITY_BEST's
 * ranking: a triangle's vectors in lanes, its terms added to each sum in
 * the default path's order). Internal.
 *
 * Every path computes the same bits: the same expressions in the same
 * order, no fused multiply-add (the build has -ffp-contract=off, and the
 * AVX2 path is AVX2 without FMA), IEEE division and square root. A
 * vector path only spreads independent work over lanes -- edges,
 * triangles, or a quadric's entries -- never reassociates a sum.
 * tests/test_kernels.c checks each path against the default one bit for
 * bit; bench/bench_kernels measures each alone and end to end, and a
 * vector form is kept for a kernel only where it is faster: the merge,
 * whose AVX2 forms were slower, has its scalar form on every path.
 *
 * Paths: MR_PATH_DEFAULT, the baseline the library is compiled for
 * (x86-64: SSE2); MR_PATH_AVX2, built where the compiler can target it
 * and used where the CPU has it. The environment variable MR_SIMD=default
 * makes a process use the default path throughout (to measure what the
 * vector paths bring).
 */
#ifndef MR_QEM_KERNELS_H
#define MR_QEM_KERNELS_H

#include "quadric.h"

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Edges per batch of mr_kernels.free_costs. */
#define MR_COST_BATCH 64

/* Row length of mr_kernels.plane_terms' input and output (room for
 * MR_PLANE_FAN triangles and three lanes of padding). */
#define MR_PLANE_FAN 32
#define MR_PLANE_ROW (MR_PLANE_FAN + 4)

/* Row length of mr_kernels.fan_ok's input. */
#define MR_FAN_ROW 256

/*
 * The full collapse of an edge (u, w) with no pinned end: u's quadric moved
 * to w's origin and added to w's, the target x (relative to w) at the
 * optimum of the sum or, where the system is ill-conditioned or its optimum
 * lies far from the edge, at the best point of the edge; returns the cost.
 * Input k of the edge (FREE_*) is in[k * st], x[k] is x[k * xst]. Written
 * without branches (every quotient is computed, then selected), so that a
 * loop over edges vectorises (mr_simplifier_plan_edges); the scalar path
 * calls the same code, so both give the same bits.
 */
enum { FREE_QU = 0, FREE_QW = 11, FREE_PU = 22, FREE_PW = 25, FREE_INPUTS = 28 };


static inline __attribute__((always_inline)) double mr_free_cost(const float *in, size_t st,
                                                              double *x, size_t xst,
                                                              const double box[3])
{
#define IN(k) ((double)in[(size_t)(k) * st])
    const double d0 = IN(FREE_PU) - IN(FREE_PW);
    const double d1 = IN(FREE_PU + 1) - IN(FREE_PW + 1);
    const double d2 = IN(FREE_PU + 2) - IN(FREE_PW + 2);
    const double k0 = -d0, k1 = -d1, k2 = -d2; /* u's origin seen from w */
    double a00 = IN(0), a01 = IN(1), a02 = IN(2), a11 = IN(3), a12 = IN(4), a22 = IN(5);
    double b0 = IN(6), b1 = IN(7), b2 = IN(8), c = IN(9), w = IN(10);
    /* shift u's quadric by k (mr_quadric_shift) */
    const double ad0 = a00 * k0 + a01 * k1 + a02 * k2;
    const double ad1 = a01 * k0 + a11 * k1 + a12 * k2;
    const double ad2 = a02 * k0 + a12 * k1 + a22 * k2;
    c += k0 * ad0 + k1 * ad1 + k2 * ad2 + 2 * (b0 * k0 + b1 * k1 + b2 * k2);
    b0 += ad0;
    b1 += ad1;
    b2 += ad2;
    /* add w's (mr_quadric_add) */
    a00 += IN(FREE_QW + 0); a01 += IN(FREE_QW + 1); a02 += IN(FREE_QW + 2);
    a11 += IN(FREE_QW + 3); a12 += IN(FREE_QW + 4); a22 += IN(FREE_QW + 5);
    b0 += IN(FREE_QW + 6); b1 += IN(FREE_QW + 7); b2 += IN(FREE_QW + 8);
    c += IN(FREE_QW + 9);
    w += IN(FREE_QW + 10);
#undef IN
    /* the optimum (mr_quadric_optimum) */
    const double c00 = a11 * a22 - a12 * a12;
    const double c01 = a02 * a12 - a01 * a22;
    const double c02 = a01 * a12 - a02 * a11;
    const double det = a00 * c00 + a01 * c01 + a02 * c02;
    const double diag = a00 * a11 * a22;
    const double c11 = a00 * a22 - a02 * a02;
    const double c12 = a01 * a02 - a00 * a12;
    const double c22 = a00 * a11 - a01 * a01;
    const double inv = -1.0 / det;
    const double o0 = inv * (c00 * b0 + c01 * b1 + c02 * b2);
    const double o1 = inv * (c01 * b0 + c11 * b1 + c12 * b2);
    const double o2 = inv * (c02 * b0 + c12 * b1 + c22 * b2);
    /* an optimum far from the edge comes from a barely conditioned system;
     * one outside the mesh's bounding box (box: its half extents, w at
     * IN(FREE_PW)) is no place for a vertex, and might leave the float
     * range of the input */
    const double len2 = d0 * d0 + d1 * d1 + d2 * d2;
    const double e0 = o0 - 0.5 * d0, e1 = o1 - 0.5 * d1, e2 = o2 - 0.5 * d2;
    const bool inside = (fabs(o0 + (double)in[(size_t)FREE_PW * st]) <= box[0]) &
                        (fabs(o1 + (double)in[(size_t)(FREE_PW + 1) * st]) <= box[1]) &
                        (fabs(o2 + (double)in[(size_t)(FREE_PW + 2) * st]) <= box[2]);
    const bool ok = (fabs(det) > MR_QUADRIC_DET_EPS * diag) & (diag > 0) &
                    (e0 * e0 + e1 * e1 + e2 * e2 <= 4 * len2) & inside;
    /* the best point of the edge from w (0) to u (d):
     * mr_quadric_segment_optimum */
    const double z = 0;
    const double sd0 = d0 - z, sd1 = d1 - z, sd2 = d2 - z;
    const double sa0 = a00 * sd0 + a01 * sd1 + a02 * sd2;
    const double sa1 = a01 * sd0 + a11 * sd1 + a12 * sd2;
    const double sa2 = a02 * sd0 + a12 * sd1 + a22 * sd2;
    const double dad = sd0 * sa0 + sd1 * sa1 + sd2 * sa2;
    const double g = z * sa0 + z * sa1 + z * sa2 + b0 * sd0 + b1 * sd1 + b2 * sd2;
    const double sq = -g / dad;
    const double s0 = sq < 0 ? 0 : sq;
    const double sc = s0 > 1 ? 1 : s0;
    const double sg0 = g < 0 ? 1 : 0.5;
    const double sg = g > 0 ? 0 : sg0;
    const double s = dad > 0 ? sc : sg;
    const double x0 = ok ? o0 : z + s * sd0;
    const double x1 = ok ? o1 : z + s * sd1;
    const double x2 = ok ? o2 : z + s * sd2;
    x[0] = x0;
    x[xst] = x1;
    x[2 * xst] = x2;
    /* its cost (mr_quadric_eval) */
    const double ax = a00 * x0 + a01 * x1 + a02 * x2;
    const double ay = a01 * x0 + a11 * x1 + a12 * x2;
    const double az = a02 * x0 + a12 * x1 + a22 * x2;
    const double q = x0 * ax + x1 * ay + x2 * az + 2 * (b0 * x0 + b1 * x1 + b2 * x2) + c;
    const double qn = q / w;
    const double err = w > 0 ? qn : 0;
    return err > 0 ? err : 0;
}

/* Each triangle's area-weighted plane term c c^T / (2 |c|) (6 entries)
 * and area |c| / 2 for the cross products c of the edges (u, w) in
 * in[k * MR_PLANE_ROW + i] (u: k = 0..2, w: 3..5); zero for a triangle
 * without area. The same expressions as initial_quadric's scalar loop,
 * so the same bits. */
static inline __attribute__((always_inline)) void mr_plane_terms_body(const double *in, size_t n,
                                                                       double *out)
{
#pragma omp simd
    for (size_t i = 0; i < n; i++) {
        const double u0 = in[i], u1 = in[MR_PLANE_ROW + i], u2 = in[2 * MR_PLANE_ROW + i];
        const double w0 = in[3 * MR_PLANE_ROW + i], w1 = in[4 * MR_PLANE_ROW + i],
                     w2 = in[5 * MR_PLANE_ROW + i];
        const double c0 = u1 * w2 - u2 * w1, c1 = u2 * w0 - u0 * w2, c2 = u0 * w1 - u1 * w0;
        const double len = sqrt(c0 * c0 + c1 * c1 + c2 * c2);
        const bool area = len > 0;
        const double f = 0.5 / (area ? len : 1.0);
        out[i] = area ? f * c0 * c0 : 0;
        out[MR_PLANE_ROW + i] = area ? f * c0 * c1 : 0;
        out[2 * MR_PLANE_ROW + i] = area ? f * c0 * c2 : 0;
        out[3 * MR_PLANE_ROW + i] = area ? f * c1 * c1 : 0;
        out[4 * MR_PLANE_ROW + i] = area ? f * c1 * c2 : 0;
        out[5 * MR_PLANE_ROW + i] = area ? f * c2 * c2 : 0;
        out[6 * MR_PLANE_ROW + i] = area ? 0.5 * len : 0;
    }
}

/*
 * Condition (2) for n triangles (o, a, b) of the fans, o the vertex that
 * moves to t: in[k * MR_FAN_ROW + i] holds, for triangle i, the coordinates of
 * o (k = 0..2), a (3..5) and b (6..8). Each normal may turn by an angle
 * whose cosine is at least min_cos (never flip) and the area may not
 * collapse (ratio 1e-6). Unnormalised normals (twice the area): the tests
 * are the unit normals' cos > min_cos and the area ratio, squared, without
 * a square root or a division; a degenerate normal is 0 and fails. A
 * branch-free loop, vectorised.
 */
static inline __attribute__((always_inline)) bool mr_fan_ok_body(const double *in, size_t n,
                                                                  const double t[3],
                                                                  double min_cos)
{
    const double mc2 = min_cos * min_cos;
    int bad = 0;
#pragma omp simd reduction(| : bad)
    for (size_t i = 0; i < n; i++) {
        const double ox = in[i], oy = in[MR_FAN_ROW + i], oz = in[2 * MR_FAN_ROW + i];
        const double ax = in[3 * MR_FAN_ROW + i], ay = in[4 * MR_FAN_ROW + i], az = in[5 * MR_FAN_ROW + i];
        const double bx = in[6 * MR_FAN_ROW + i], by = in[7 * MR_FAN_ROW + i], bz = in[8 * MR_FAN_ROW + i];
        const double u0 = ax - ox, u1 = ay - oy, u2 = az - oz;
        const double v0 = bx - ox, v1 = by - oy, v2 = bz - oz;
        const double n00 = u1 * v2 - u2 * v1, n01 = u2 * v0 - u0 * v2, n02 = u0 * v1 - u1 * v0;
        const double s0 = ax - t[0], s1 = ay - t[1], s2 = az - t[2];
        const double w0 = bx - t[0], w1 = by - t[1], w2 = bz - t[2];
        const double n10 = s1 * w2 - s2 * w1, n11 = s2 * w0 - s0 * w2, n12 = s0 * w1 - s1 * w0;
        const double d = n00 * n10 + n01 * n11 + n02 * n12;
        const double l0 = n00 * n00 + n01 * n01 + n02 * n02;
        const double l1 = n10 * n10 + n11 * n11 + n12 * n12;
        bad |= !((d > 0) & (d * d > mc2 * l0 * l1) & (l1 > 1e-12 * l0));
    }
    return !bad;
}

/*
 * Merge two quadrics at a collapse: r's quadric moved by dr and k's by dk
 * (mr_quadric_shift, each to the survivor's new position), r's added to
 * k's (mr_quadric_add), the sum stored as floats in *k. The scalar form,
 * on doubles as the rest of the core computes quadrics.
 */
static inline __attribute__((always_inline)) void mr_merge_body(mr_quadricf *k,
                                                                const mr_quadricf *r,
                                                                const double dk[3],
                                                                const double dr[3])
{
    mr_quadric qr, qk;
    mr_quadric_load(&qr, r);
    mr_quadric_load(&qk, k);
    mr_quadric_shift(&qr, dr);
    mr_quadric_shift(&qk, dk);
    mr_quadric_add(&qk, &qr);
    mr_quadric_store(k, &qk);
}

/* The fans of a collapse of r into k, as the memoryless plan sums them
 * (mr_kernels.fan_sums; cost.c: fan_sums). */
typedef struct mr_fan_input {
    const float *pos;         /* 3 per vertex, and one float of padding after
                                 the last (read as 4: the extra lane unused) */
    const uint32_t *tris;     /* 3 per triangle; a deleted one starts with
                                 MR_COLLAPSE_NONE (collapse.h) */
    const uint32_t *lr, *lk;  /* r's and k's lists: 3 * triangle + corner */
    uint32_t nr, nk, r, k;
} mr_fan_input;

/* Entries of fan_sums' sums. */
enum { MR_FAN_G = 0, MR_FAN_H = 3, MR_FAN_A = 4, MR_FAN_B = 10, MR_FAN_C = 13, MR_FAN_SUMS = 14 };

/* The paths. */
enum { MR_PATH_DEFAULT = 0, MR_PATH_AVX2 = 1, MR_PATHS = 2 };

typedef struct mr_kernels {
    const char *name; /* "default", "avx2" */
    /* costs and targets (relative to w) of n <= MR_COST_BATCH free edges
     * whose inputs are in in[k * MR_COST_BATCH + i] (mr_free_cost) */
    void (*free_costs)(const float *in, size_t n, double *cost, double *x, const double box[3]);
    /* plane terms of n (a multiple of 4) <= MR_PLANE_ROW triangles */
    void (*plane_terms)(const double *in, size_t n, double *out);
    /* the normal test of n (a multiple of 4) <= MR_FAN_ROW fan triangles */
    bool (*fan_ok)(const double *in, size_t n, const double t[3], double min_cos);
    /* the merge of two quadrics (mr_merge_body); k may not alias r */
    void (*merge)(mr_quadricf *k, const mr_quadricf *r, const double dk[3], const double dr[3]);
    /* a collapse's fan sums relative to o (k's position), added to
     * sum[MR_FAN_SUMS]: g (3), the volume h, and when full also the swept
     * volumes' normal equations A (6), b (3) and c (cost.c: fan_sums) */
    void (*fan_sums)(const mr_fan_input *in, const double o[3], bool full, double *sum);
} mr_kernels;

/* free_costs' inputs of the edges (u[l], w[l]), l < n <= MR_COST_BATCH, of
 * the quadrics q and positions pos (3 floats a vertex) into the batch's rows
 * in[k * MR_COST_BATCH + l] (src/qem/core/cost.c). */
void mr_cost_pack_inputs(const mr_quadricf *q, const float *pos, const uint32_t *u,
                         const uint32_t *w, size_t n, float *in);

/* The kernels of path p, or NULL when the build or the CPU lacks it. */
const mr_kernels *mr_kernels_path(int p);

/* The kernels a run uses: the fastest path the CPU has (set once, on the
 * first call), or the default one when MR_SIMD=default. */
const mr_kernels *mr_kernels_get(void);

/* Use k from now on (NULL: choose again as above). For benchmarks and
 * tests, between runs: a run in progress must not see it change. */
void mr_kernels_use(const mr_kernels *k);

#endif /* MR_QEM_KERNELS_H */
