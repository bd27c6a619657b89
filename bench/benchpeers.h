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

/* Peak memory of our simplifier at any thread count, in a fresh process.
 * A forked child cannot start an OpenMP thread team (see above), so the
 * benchmark runs itself again: bench_exec_peak forks and execs `self` (the
 * benchmark's own executable, /proc/self/exe) as
 *   self --peak-child RAW THREADS RATIO COLLAPSE STRATEGY
 * and the benchmark's main hands such a command line to
 * bench_peak_child_main. That process reads the mesh from RAW (written by
 * bench_raw_write: the flat arrays as loaded, nothing else), trims malloc,
 * resets its peak resident set (/proc/self/clear_refs "5"), notes VmRSS
 * (the mesh and the process: the baseline), runs mr_simplify once with the
 * default options but those five (threads also given to
 * omp_set_num_threads), and prints "peak_bytes N": VmHWM minus the
 * baseline, output included; without clear_refs, ru_maxrss minus the
 * baseline (loading needs less than simplifying). Thread stacks and
 * per-thread malloc arenas count: they are the cost of the threads.
 * bench_exec_peak returns N, or -1 on any failure. */
int bench_raw_write(const mr_mesh *m, const char *path);
double bench_exec_peak(const char *self, const char *raw_path, const mr_simplify_options *opt);
int bench_peak_child_main(int argc, char **argv);

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

/* The pieces of bench_run_meshopt, for benchmarks that interleave peer
 * runs with their own: one timed call (dst: 3 * in->triangle_count + 3
 * indices; *index_count receives the output's index count, *seconds the
 * call's wall clock; returns 0 when meshopt is not built in); its peak
 * memory in a forked child (-1: unknown or not built in); and an index
 * buffer that refers to in's vertices made compact. */
int bench_meshopt_call(const mr_mesh *in, size_t target_triangles, int sloppy, uint32_t *dst,
                       size_t *index_count, double *seconds);
double bench_meshopt_peak(const mr_mesh *in, size_t target_triangles, int sloppy);
void bench_compact(const mr_mesh *in, const uint32_t *idx, size_t index_count,
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

/* CGAL's Surface_mesh_simplification through the driver cgal_decimate
 * (built by `make bench` where libcgal-dev is installed): policy "lt"
 * (Lindstrom-Turk, CGAL's default) or "gh" (Garland-Heckbert plane
 * policies), down to target_edges edges; otherwise as bench_run_openmesh. */
int bench_have_cgal(void);
int bench_run_cgal(const char *policy, const mr_mesh *in, const char *in_path,
                   const char *out_path, size_t target_edges, int runs, double budget,
                   int keep_output, bench_summary *timing, int *runs_done, double *peak_bytes,
                   bench_output *out);

/* Distinct edges of a triangle list (the CGAL driver's target). */
size_t bench_edge_count(const uint32_t *indices, size_t triangle_count);

#endif
