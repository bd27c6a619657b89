/*
 * Running our simplifier and the peer simplifiers and measuring peak
 * memory, for bench_simplify and the sweep (and any benchmark that wants
 * them): meshoptimizer linked in when found at configure time
 * (MR_HAVE_MESHOPT), OpenMesh's Decimater through the openmesh_decimate
 * driver (MR_OPENMESH_DRIVER). A benchmark that uses these compiles
 * benchpeers.c itself with those definitions.
 */
#ifndef MR_BENCHPEERS_H
#define MR_BENCHPEERS_H

#include "benchutil.h"

#include <stdint.h>

/* Peak memory growth in bytes of job(ctx), run once in a forked child with
 * `threads` OpenMP threads, or -1. Use 1: libgomp hangs when a forked child
 * of a process that already ran a thread team starts another. The child
 * resets its peak resident set (/proc/self/clear_refs "5") and reports
 * VmHWM minus its VmRSS before the job; without clear_refs, its ru_maxrss
 * minus the parent's VmRSS. */
typedef void (*bench_job_fn)(void *ctx);
double bench_child_peak(bench_job_fn job, void *ctx, int threads);

/* Timed runs of our simplifier: mr_simplify of in with *opt, runs times
 * (the caller sets omp_set_num_threads to match opt->threads). *timing
 * receives the median, min and max seconds of the runs; *out the last
 * run's output (the caller frees it with mr_simplified_free); *peak_bytes
 * the peak memory of one more run in a forked child (bench_child_peak)
 * with opt->threads = 1: libgomp cannot start a thread team there, and the
 * data structures, which dominate, are the same. Exits with a message when
 * mr_simplify fails. */
void bench_run_ours(const mr_mesh *in, const mr_simplify_options *opt, int runs,
                    bench_summary *timing, double *peak_bytes, mr_simplified *out);

/* A simplification's output as compact arrays (malloc'd). */
typedef struct bench_output {
    size_t vertex_count, triangle_count;
    float *positions;
    uint32_t *indices;
} bench_output;
void bench_output_free(bench_output *o);

/* Timed runs of one peer. *timing receives the median, min and max seconds
 * of the runs made; *runs_done how many were made (OpenMesh stops after
 * budget seconds, at least one run; meshopt makes all of them);
 * *peak_bytes the peak memory (-1: unknown); *out the last output,
 * compacted (the caller frees it with bench_output_free). Return 0 when
 * the peer is not built in or failed. */
int bench_have_meshopt(void);
int bench_run_meshopt(const mr_mesh *in, size_t target_triangles, int sloppy, int runs,
                      bench_summary *timing, int *runs_done, double *peak_bytes,
                      bench_output *out);

int bench_have_openmesh(void);
/* in_path: the input as a PLY file the driver reads (written by the
 * caller); out_path: where the driver writes its result, removed after it
 * is read unless keep_output. A note goes to stderr when the driver read
 * other vertex or face counts than in's. */
int bench_run_openmesh(const mr_mesh *in, const char *in_path, const char *out_path,
                       size_t target_vertices, int runs, double budget, int keep_output,
                       bench_summary *timing, int *runs_done, double *peak_bytes,
                       bench_output *out);

#endif
