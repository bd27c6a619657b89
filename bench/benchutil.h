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

/* A child process (argv[0] searched in PATH): its wall time, peak RSS
 * (bytes), exit status (128 + signal when killed; -1 when it could not be
 * started) and stdout (malloc'ed, NUL-terminated; the caller frees it). */
typedef struct bench_run_result {
    double seconds;
    size_t rss;
    int status;
    char *out;
} bench_run_result;
bench_run_result bench_run(char *const argv[]);

/* n runs (at most 64) of two commands, alternating which goes first (so
 * that a drift of the machine's speed falls on both): sec[k][r] the
 * seconds of command k's run r, rss[k] its largest peak RSS. Exits with a
 * message naming `what` when a run fails. */
void bench_alternate(char *const *av[2], int n, const char *what, double sec[2][64],
                     size_t rss[2]);

/* The number after "key": in a JSON text (the first one), or NAN. */
double bench_json_number(const char *json, const char *key);

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
