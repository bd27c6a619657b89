/*
 * The vector kernels on each CPU path (kernels.h): the default path, built
 * for the baseline CPU, and where the compiler can target it an AVX2 path,
 * picked at run time when the CPU has it. The bodies are the kernels.h
 * inline functions, compiled once per path.
 */
#include "kernels.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(MR_NO_CLONES)
#define MR_HAVE_AVX2_PATH 1
#define MR_TARGET_AVX2 __attribute__((target("avx2")))
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

static const mr_kernels default_kernels = {"default", free_costs_default, plane_terms_default,
                                           fan_ok_default, merge_default};

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

/* The merge has one form on every path: an AVX2 form, hand-written with a
 * quadric's entries in lanes or left to the compiler, ran at 0.94x the
 * default path's speed (bench_kernels), so it was not kept. */
static const mr_kernels avx2_kernels = {"avx2", free_costs_avx2, plane_terms_avx2, fan_ok_avx2,
                                        merge_default};
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
