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
#endif

#endif /* MR_OMP_COMPAT_H */
