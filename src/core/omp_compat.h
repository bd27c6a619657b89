/*
 * The OpenMP runtime calls the library makes, for both builds: with OpenMP
 * (_OPENMP defined: -fopenmp) this is <omp.h>; in the serial build
 * (cmake -DMR_OPENMP=OFF) the same names are inline stubs of a one-thread
 * team, and the `#pragma omp` lines are ignored (only `omp simd` stays, by
 * -fopenmp-simd, so loops vectorise as in the OpenMP build). Code includes
 * this instead of <omp.h> and needs no #ifdef _OPENMP of its own: a parallel
 * loop then runs as one thread, which by the library's rule gives the same
 * bytes as any number of threads.
 */
#ifndef MR_OMP_COMPAT_H
#define MR_OMP_COMPAT_H

#ifdef _OPENMP
#include <omp.h>
#else
static inline int omp_get_max_threads(void) { return 1; }
static inline int omp_get_num_threads(void) { return 1; }
static inline int omp_get_thread_num(void) { return 0; }
static inline int omp_get_num_procs(void) { return 1; }
static inline int omp_in_parallel(void) { return 0; }
static inline void omp_set_num_threads(int n) { (void)n; }
static inline int omp_get_level(void) { return 0; }
static inline int omp_get_active_level(void) { return 0; }
static inline int omp_get_max_active_levels(void) { return 0; }
static inline void omp_set_max_active_levels(int n) { (void)n; }
static inline int omp_get_thread_limit(void) { return 1; }
static inline int omp_get_dynamic(void) { return 0; }
static inline void omp_set_dynamic(int d) { (void)d; }
#endif

/* The simplifier shares work out by thread number and meets its team at
 * barriers, so each of its teams must have the threads it asked for:
 * mr_thread_count asks for one where no team could have more (see there),
 * and these two turn off the runtime's right to give a team fewer threads
 * (OMP_DYNAMIC=true) for the length of a call, then restore the caller's
 * setting. */
static inline int mr_omp_fixed_teams(void)
{
    const int dynamic = omp_get_dynamic();
    if (dynamic)
        omp_set_dynamic(0);
    return dynamic;
}

static inline void mr_omp_restore_teams(int dynamic)
{
    if (dynamic)
        omp_set_dynamic(dynamic);
}

#endif /* MR_OMP_COMPAT_H */
