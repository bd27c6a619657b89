/*
 * The vector kernels on each CPU path (kernels.h): the default path, built
 * for the baseline CPU, and where the compiler can target it an AVX2 path,
 * picked at run time when the CPU has it. The bodies are the kernels.h
 * inline functions, compiled once per path.
 */
#include "kernels.h"

#include "collapse.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(MR_NO_CLONES)
#define MR_HAVE_AVX2_PATH 1
#define MR_TARGET_AVX2 __attribute__((target("avx2")))
#include <immintrin.h>
#else
#define MR_HAVE_AVX2_PATH 0
#endif

/* ---- the default path ------------------------------------------------------ */

static void free_costs_default(const float *in, size_t n, double *cost, double *x,
                               const double box[3])
{
    const double bx[3] = {box[0], box[1], box[2]};
#pragma omp simd
    for (size_t i = 0; i < n; i++)
        cost[i] = mr_free_cost(in + i, MR_COST_BATCH, x + i, MR_COST_BATCH, bx);
}

static void plane_terms_default(const double *in, size_t n, double *out)
{
    mr_plane_terms_body(in, n, out);
}

static bool fan_ok_default(const double *in, size_t n, const double t[3], double min_cos)
{
    return mr_fan_ok_body(in, n, t, min_cos);
}

static void merge_default(mr_quadricf *k, const mr_quadricf *r, const double dk[3],
                          const double dr[3])
{
    mr_merge_body(k, r, dk, dr);
}

/* List entry c's triangle, seen from its corner: the next corner a and
 * the one after, b; false for a deleted triangle or one with corner skip. */
static inline bool fan_corners(const mr_fan_input *in, uint32_t c, uint32_t skip, uint32_t *a,
                               uint32_t *b)
{
    const uint32_t j = c % 3, *tri = in->tris + (c - j);
    *a = tri[mr_local_next(j)];
    *b = tri[mr_local_prev(j)];
    return tri[0] != MR_COLLAPSE_NONE && *a != skip && *b != skip;
}

/* Corners a and b relative to o, and the normal n = ua x ub. */
static inline void fan_normal(const float *pos, uint32_t a, uint32_t b, const double o[3],
                              double ua[3], double ub[3], double n[3])
{
    const float *pa = pos + 3 * (size_t)a, *pb = pos + 3 * (size_t)b;
    for (int i = 0; i < 3; i++) {
        ua[i] = pa[i] - o[i];
        ub[i] = pb[i] - o[i];
    }
    n[0] = ua[1] * ub[2] - ua[2] * ub[1];
    n[1] = ua[2] * ub[0] - ua[0] * ub[2];
    n[2] = ua[0] * ub[1] - ua[1] * ub[0];
}

/* A (6 entries of a symmetric matrix) += v v^T. */
static inline void add_outer(double A[6], const double v[3])
{
    A[0] += v[0] * v[0];
    A[1] += v[0] * v[1];
    A[2] += v[0] * v[2];
    A[3] += v[1] * v[1];
    A[4] += v[1] * v[2];
    A[5] += v[2] * v[2];
}

/* The fan sums, a triangle at a time. r's triangles (a, r, b): w = r, away
 * from o; their normal n = (a - o) x (b - o) adds to g and the volume
 * (w - o).n to h (an edge triangle's volume too: it goes, and its volume
 * with it), and for the others the normal nw = (a - w) x (b - w) and d =
 * nw.(w - o) add nw nw^T to A, nw d to b and d^2 to c. k's triangles: w =
 * k = o, so their volumes and d are 0 and nw is n. */
static void fan_sums_default(const mr_fan_input *in, const double o[3], bool full, double *sum)
{
    double *g = sum + MR_FAN_G, *A = sum + MR_FAN_A, *bv = sum + MR_FAN_B;
    const float *pw = in->pos + 3 * (size_t)in->r;
    const double uw[3] = {pw[0] - o[0], pw[1] - o[1], pw[2] - o[2]};
    for (uint32_t i = 0; i < in->nr; i++) {
        uint32_t a, b;
        if (!fan_corners(in, in->lr[i], UINT32_MAX, &a, &b))
            continue;
        double ua[3], ub[3], n[3];
        fan_normal(in->pos, a, b, o, ua, ub, n);
        sum[MR_FAN_H] += uw[0] * n[0] + uw[1] * n[1] + uw[2] * n[2];
        if (a == in->k || b == in->k)
            continue;
        g[0] += n[0];
        g[1] += n[1];
        g[2] += n[2];
        if (!full)
            continue;
        const double va[3] = {ua[0] - uw[0], ua[1] - uw[1], ua[2] - uw[2]};
        const double vb[3] = {ub[0] - uw[0], ub[1] - uw[1], ub[2] - uw[2]};
        const double nw[3] = {va[1] * vb[2] - va[2] * vb[1], va[2] * vb[0] - va[0] * vb[2],
                              va[0] * vb[1] - va[1] * vb[0]};
        const double d = nw[0] * uw[0] + nw[1] * uw[1] + nw[2] * uw[2];
        add_outer(A, nw);
        bv[0] += nw[0] * d;
        bv[1] += nw[1] * d;
        bv[2] += nw[2] * d;
        sum[MR_FAN_C] += d * d;
    }
    for (uint32_t i = 0; i < in->nk; i++) {
        uint32_t a, b;
        if (!fan_corners(in, in->lk[i], in->r, &a, &b))
            continue; /* deleted, or on the edge */
        double ua[3], ub[3], n[3];
        fan_normal(in->pos, a, b, o, ua, ub, n);
        g[0] += n[0];
        g[1] += n[1];
        g[2] += n[2];
        if (!full)
            continue;
        add_outer(A, n);
    }
}

static const mr_kernels default_kernels = {"default",      free_costs_default, plane_terms_default,
                                           fan_ok_default, merge_default,      fan_sums_default};

/* ---- AVX2 ------------------------------------------------------------------ */

#if MR_HAVE_AVX2_PATH
MR_TARGET_AVX2 static void free_costs_avx2(const float *in, size_t n, double *cost, double *x,
                                           const double box[3])
{
    const double bx[3] = {box[0], box[1], box[2]};
#pragma omp simd
    for (size_t i = 0; i < n; i++)
        cost[i] = mr_free_cost(in + i, MR_COST_BATCH, x + i, MR_COST_BATCH, bx);
}

MR_TARGET_AVX2 static void plane_terms_avx2(const double *in, size_t n, double *out)
{
    mr_plane_terms_body(in, n, out);
}

MR_TARGET_AVX2 static bool fan_ok_avx2(const double *in, size_t n, const double t[3],
                                       double min_cos)
{
    return mr_fan_ok_body(in, n, t, min_cos);
}

/* Lanes (a[x], a[y], a[z], a[w]). */
#define LANES(a, x, y, z, w) _mm256_permute4x64_pd(a, _MM_SHUFFLE(w, z, y, x))

/* A vertex's position minus o in lanes 0-2, 0 in lane 3. */
MR_TARGET_AVX2 static inline __m256d rel_avx2(const float *p, __m256d o)
{
    const __m256d x = _mm256_sub_pd(_mm256_cvtps_pd(_mm_loadu_ps(p)), o);
    return _mm256_blend_pd(x, _mm256_setzero_pd(), 0x8);
}

/* a x b in lanes 0-2: the default path's products and differences. */
MR_TARGET_AVX2 static inline __m256d cross_avx2(__m256d a, __m256d b)
{
    return _mm256_sub_pd(_mm256_mul_pd(LANES(a, 1, 2, 0, 3), LANES(b, 2, 0, 1, 3)),
                         _mm256_mul_pd(LANES(a, 2, 0, 1, 3), LANES(b, 1, 2, 0, 3)));
}

/* (p[0] + p[1]) + p[2]: a dot product's sum in the default path's order. */
MR_TARGET_AVX2 static inline double sum3_avx2(__m256d p)
{
    const __m128d lo = _mm256_castpd256_pd128(p);
    return (_mm_cvtsd_f64(lo) + _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo))) +
           _mm_cvtsd_f64(_mm256_extractf128_pd(p, 1));
}

/* fan_sums_default with a triangle's vectors in lanes: each sum still
 * takes its triangles' terms one after the other, in the same order, so
 * the bits are the default path's. The sums live in lanes too: (g, -),
 * (A0, A1, A2, A3), (A4, A5, b0, b1), (b2, c). */
MR_TARGET_AVX2 static void fan_sums_avx2(const mr_fan_input *in, const double o[3], bool full,
                                         double *sum)
{
    const __m256d O = _mm256_setr_pd(o[0], o[1], o[2], 0);
    const __m256d uw = rel_avx2(in->pos + 3 * (size_t)in->r, O);
    __m256d g = _mm256_setr_pd(sum[MR_FAN_G], sum[MR_FAN_G + 1], sum[MR_FAN_G + 2], 0);
    __m256d a03 = _mm256_loadu_pd(sum + MR_FAN_A);
    __m256d a4b1 = _mm256_loadu_pd(sum + MR_FAN_A + 4);
    __m128d b2c = _mm_loadu_pd(sum + MR_FAN_B + 2);
    double h = sum[MR_FAN_H];
    for (uint32_t i = 0; i < in->nr; i++) {
        uint32_t a, b;
        if (!fan_corners(in, in->lr[i], UINT32_MAX, &a, &b))
            continue;
        const __m256d ua = rel_avx2(in->pos + 3 * (size_t)a, O);
        const __m256d ub = rel_avx2(in->pos + 3 * (size_t)b, O);
        const __m256d n = cross_avx2(ua, ub);
        h += sum3_avx2(_mm256_mul_pd(uw, n));
        if (a == in->k || b == in->k)
            continue;
        g = _mm256_add_pd(g, n);
        if (!full)
            continue;
        const __m256d nw = cross_avx2(_mm256_sub_pd(ua, uw), _mm256_sub_pd(ub, uw));
        const double d = sum3_avx2(_mm256_mul_pd(nw, uw));
        const __m256d dd = _mm256_set1_pd(d);
        a03 = _mm256_add_pd(a03, _mm256_mul_pd(LANES(nw, 0, 0, 0, 1), LANES(nw, 0, 1, 2, 1)));
        a4b1 = _mm256_add_pd(a4b1, _mm256_mul_pd(LANES(nw, 1, 2, 0, 1),
                                                 _mm256_blend_pd(LANES(nw, 2, 2, 2, 2), dd, 0xC)));
        const __m128d n2d = _mm_setr_pd(_mm_cvtsd_f64(_mm256_extractf128_pd(nw, 1)), d);
        b2c = _mm_add_pd(b2c, _mm_mul_pd(n2d, _mm256_castpd256_pd128(dd)));
    }
    /* k's triangles add to g and A only: A4 and A5 alone from here */
    __m128d a45 = _mm256_castpd256_pd128(a4b1);
    for (uint32_t i = 0; i < in->nk; i++) {
        uint32_t a, b;
        if (!fan_corners(in, in->lk[i], in->r, &a, &b))
            continue; /* deleted, or on the edge */
        const __m256d n = cross_avx2(rel_avx2(in->pos + 3 * (size_t)a, O),
                                     rel_avx2(in->pos + 3 * (size_t)b, O));
        g = _mm256_add_pd(g, n);
        if (!full)
            continue;
        a03 = _mm256_add_pd(a03, _mm256_mul_pd(LANES(n, 0, 0, 0, 1), LANES(n, 0, 1, 2, 1)));
        const __m256d p = _mm256_mul_pd(LANES(n, 1, 2, 1, 2), LANES(n, 2, 2, 2, 2));
        a45 = _mm_add_pd(a45, _mm256_castpd256_pd128(p));
    }
    double t[4];
    _mm256_storeu_pd(t, g);
    memcpy(sum + MR_FAN_G, t, 3 * sizeof *t);
    sum[MR_FAN_H] = h;
    if (!full)
        return;
    _mm256_storeu_pd(sum + MR_FAN_A, a03);
    _mm256_storeu_pd(sum + MR_FAN_A + 4, a4b1);
    _mm_storeu_pd(sum + MR_FAN_A + 4, a45);
    _mm_storeu_pd(sum + MR_FAN_B + 2, b2c);
}
#undef LANES

/* The merge has one form on every path: an AVX2 form, hand-written with a
 * quadric's entries in lanes or left to the compiler, ran at 0.94x the
 * default path's speed (bench_kernels), so it was not kept. */
static const mr_kernels avx2_kernels = {"avx2",      free_costs_avx2, plane_terms_avx2,
                                        fan_ok_avx2, merge_default,   fan_sums_avx2};
#endif

/* ---- choice ---------------------------------------------------------------- */

const mr_kernels *mr_kernels_path(int p)
{
    if (p == MR_PATH_DEFAULT)
        return &default_kernels;
#if MR_HAVE_AVX2_PATH
    if (p == MR_PATH_AVX2) {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") ? &avx2_kernels : NULL;
    }
#endif
    return NULL;
}

static const mr_kernels *chosen;

const mr_kernels *mr_kernels_get(void)
{
    const mr_kernels *k = __atomic_load_n(&chosen, __ATOMIC_ACQUIRE);
    if (k)
        return k;
    /* every thread that gets here finds the same answer */
    const char *force = getenv("MR_SIMD");
    k = NULL;
    if (!force || strcmp(force, "default") != 0)
        for (int p = MR_PATHS - 1; p > MR_PATH_DEFAULT && !k; p--)
            k = mr_kernels_path(p);
    if (!k)
        k = &default_kernels;
    __atomic_store_n(&chosen, k, __ATOMIC_RELEASE);
    return k;
}

void mr_kernels_use(const mr_kernels *k)
{
    __atomic_store_n(&chosen, k, __ATOMIC_RELEASE);
}
