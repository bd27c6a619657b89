/* Helpers shared by the benchmarks: clocks, medians, machine facts, peers. */
#ifndef MR_BENCHUTIL_H
#define MR_BENCHUTIL_H

#include "meshreduce.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

double bench_now(void);

/* Median, min and max of n samples (sorts the array in place). */
typedef struct bench_summary {
    double median, min, max;
} bench_summary;
bench_summary bench_summarize(double *samples, int n);

/* Print one line naming the machine: CPU model, cores, memory, date. */
void bench_print_machine(FILE *f);

/* The CPU as /proc/cpuinfo and nproc see it: the model name ("unknown CPU"
 * when absent), the logical processors listed, the physical cores (distinct
 * physical id / core id pairs; 0 when not listed) and the processors this
 * process may run on (sched_getaffinity, as nproc counts them; else the
 * online count). */
typedef struct bench_cpu {
    char model[256];
    int logical, physical, nproc;
} bench_cpu;
void bench_cpu_info(bench_cpu *cpu);

/* Peak resident set size of this process so far, in bytes. */
size_t bench_peak_rss(void);

/* The Python that has Debian's python3-open3d: $MR_PYTHON, else
 * /usr/bin/python3 when present, else python3 from PATH. */
const char *bench_python(void);

/* True when that Python can import open3d. */
bool bench_have_open3d(void);

/* Run a command and return its stdout (malloc'd), or NULL on failure. */
char *bench_capture(const char *cmd);

/* A benchmark input: the generated scan of about `triangles` triangles
 * (seed 1) when file is NULL, else data_dir/file read with `threads`
 * threads (0: all cores); attributes dropped, degenerate triangles and
 * unreferenced vertices removed (their counts in *degenerate and
 * *unreferenced, which may be NULL). Returns 0 when the file is absent;
 * exits with a message when loading fails. */
int bench_load_mesh(const char *data_dir, const char *file, size_t triangles, int threads,
                    mr_mesh *mesh, size_t *degenerate, size_t *unreferenced);

/* Exit with a message when a library call failed. */
void bench_check(mr_status st, const mr_error *err);

#endif
