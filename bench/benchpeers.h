/*
 * Running the peer simplifiers and measuring peak memory, for the sweep
 * (and any benchmark that wants them): meshoptimizer linked in when found
 * at configure time (MR_HAVE_MESHOPT), OpenMesh's Decimater through the
 * openmesh_decimate driver (MR_OPENMESH_DRIVER). A benchmark that uses
 * these compiles benchpeers.c itself with those definitions.
 */
#ifndef MR_BENCHPEERS_H
#define MR_BENCHPEERS_H

#include "benchutil.h"

#include <stdint.h>

/* Peak memory growth in bytes of job(ctx), run once in a forked child with
 * `threads` OpenMP threads, or -1. Use 1: libgomp hangs when a forked child
 * of a process that already ran a thread team starts another. The child resets its peak resident set
 * (/proc/self/clear_refs "5") and reports VmHWM minus its VmRSS before the
 * job; without clear_refs, its ru_maxrss minus the parent's VmRSS. */
typedef void (*bench_job_fn)(void *ctx);
double bench_child_peak(bench_job_fn job, void *ctx, int threads);

/* A simplification's output as compact arrays (malloc'd). */
typedef struct bench_output {
    size_t vertex_count, triangle_count;
    float *positions;
    uint32_t *indices;
} bench_output;
void bench_output_free(bench_output *o);

/* Timed runs of one peer. times[runs] receives the seconds of each run;
 * *runs_done how many were made (OpenMesh stops after budget seconds, at
 * least one run); *peak_bytes the peak memory (-1: unknown); *out the last
 * output, compacted. Return 0 when the peer is not built in or failed. */
int bench_have_meshopt(void);
int bench_run_meshopt(const mr_mesh *in, size_t target_triangles, int sloppy, int runs,
                      double *times, double *peak_bytes, bench_output *out);

int bench_have_openmesh(void);
/* in_path: the input as a PLY file the driver reads (written by the
 * caller); out_path: where the driver writes its result. */
int bench_run_openmesh(const mr_mesh *in, const char *in_path, const char *out_path,
                       size_t target_vertices, int runs, double budget, double *times,
                       int *runs_done, double *peak_bytes, bench_output *out);

#endif
