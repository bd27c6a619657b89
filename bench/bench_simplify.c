/*
 * Simplification benchmark: the default simplifier (mr_simplify with the
 * default options: batched strategy, full collapse) at 1 and 2 threads, or
 * at the thread counts of --threads, on generated scan-like meshes of 1M and
 * 4M triangles and on the shared test meshes (../shared/data, those present;
 * skipped cleanly when the folder is absent), each reduced to 25 %, 10 % and
 * 1 % of its referenced vertices. In the same run, the peers that were found
 * when the benchmark was configured:
 *   meshopt         meshopt_simplify (options 0: nothing locked; target_error
 *                   FLT_MAX: error limit off), asked for the triangle count
 *                   our 1-thread run reached;
 *   meshopt-sloppy  meshopt_simplifySloppy, same target;
 *   openmesh        OpenMesh's DecimaterT + ModQuadricT (no error limit, no
 *                   other module) via the driver openmesh_decimate, asked for
 *                   the vertex count our 1-thread run reached; its repeated
 *                   runs stop after 20 s in all (at least one run; the table
 *                   then names the run count: "openmesh (1)").
 *   cgal-lt, cgal-gh CGAL's Surface_mesh_simplification edge collapse with
 *                   the Lindstrom-Turk policy (its default) and the
 *                   Garland-Heckbert plane policies, via the driver
 *                   cgal_decimate (built by make bench where libcgal-dev
 *                   and libeigen3-dev are installed), asked for the edge
 *                   count of our 1-thread output (the same triangle count
 *                   on a closed mesh); the same 20 s budget as OpenMesh.
 * Without --quick (or with --others), also our other simplifiers on one
 * thread: meshreduce-half (batched, half collapse), mr-greedy-full and
 * mr-greedy-half (the sequential greedy reference), and meshreduce-best
 * (the default with --quality best) at every --threads count, its speedup
 * and sameness against its own 1-thread run.
 *
 *   bench_simplify [--runs R] [--quick] [--threads 1,2,...] [--csv FILE]
 *                  [--md FILE] [--samples N] [--data DIR] [--dir DIR]
 *                  [--mesh NAME]... [--others | --no-others] [--keep]
 *                  [--save DIR]
 *
 * --runs R       timed runs per (mesh, target, algorithm, threads), default
 *                3; the table gives their median, min and max
 * --quick        only scan-1M to 10 % and scan-4M to 1 % (the speed bars)
 *                and bunny and armadillo to 10 % and 1 % (the quality
 *                lines); 1 run unless --runs is given; no other simplifiers
 *                unless --others
 * --threads L    the default simplifier's thread counts (default 1,2; e.g.
 *                1,2,4,8,16 on a bigger machine; 1 is always run, first:
 *                the speedups are over it); counts above the CPUs this
 *                process may use are run but flagged as oversubscribed
 * --csv FILE     also write one row per (mesh, target, algorithm, threads)
 * --md FILE      also write the tables and the bars as Markdown
 * --samples N    surface samples per mesh for mr_compare (default 200,000)
 * --data DIR     the test meshes (default: ../shared/data beside the checkout)
 * --dir DIR      temporary files: the input for the memory measurement and
 *                the OpenMesh driver (default out/bench)
 * --mesh NAME    only this mesh (repeatable): scan-1M, scan-4M,
 *                scan-1M-shuffled (its triangles in a fixed random order:
 *                an input without spatial order), bunny, ...
 * --others       our other simplifiers too (the default without --quick);
 *                --no-others: only the default simplifier and the peers
 * --keep         keep the temporary files
 * --save DIR     also write every algorithm's output (the first run's) as
 *                DIR/MESH-PCT-ALGORITHM.ply (e.g. bunny-10-cgal-lt.ply), for
 *                `meshreduce render` sheets side by side
 *
 * Exit status 3 when an N-thread output differed from the 1-thread output
 * (or a 1-thread run from the first one): a bug, also printed loudly.
 *
 * Method.
 *   Input: each mesh is loaded (mr_mesh_read) or generated (mr_generate
 *   MR_GEN_SCAN, seed 1), attributes are dropped, degenerate triangles and
 *   unreferenced vertices are removed; every algorithm gets the same flat
 *   arrays (packed float positions, uint32 indices).
 *   Time: wall clock of the simplification call alone (ours: mr_simplify,
 *   including its output compaction; meshopt: the simplify call, its output
 *   index buffer preallocated; OpenMesh: decimater setup, decimate_to and
 *   garbage_collection, measured inside the driver). Ours runs with
 *   options.threads = N and omp_set_num_threads(N); the peers are
 *   single-threaded. The runs alternate so that the machine's drifts hit
 *   every configuration alike: for each of the R rounds, the default
 *   simplifier at each thread count in the list's order, then
 *   meshopt_simplify, then meshopt_simplifySloppy (1, 2, meshopt, sloppy,
 *   1, 2, meshopt, sloppy, ...). The other simplifiers and OpenMesh run
 *   after that, their runs back to back. Before the rounds, one untimed
 *   1-thread run of the default simplifier (a warm-up: the first run after
 *   loading or after other work faults its heap in).
 *   Speedup: the median 1-thread time over the median N-thread time of the
 *   same run; meshopt/ours: meshopt_simplify's median over our median at
 *   that thread count (> 1: ours is faster).
 *   Same: every run's output (positions, indices and origin, bytewise, and
 *   the counts) is compared with the first 1-thread output; "yes" when all
 *   runs at that thread count matched it (for the 1-thread row: its
 *   repeated runs). A "no" is a bug: the simplifier promises the same
 *   output at every thread count. Quality is then measured on the
 *   differing output too.
 *   Memory: ours: one more simplification per (configuration, thread count)
 *   in a fresh process (the benchmark executes itself with --peak-child:
 *   benchpeers.h, bench_exec_peak; a forked child cannot start OpenMP
 *   threads), which reads the input, trims malloc, resets its peak resident
 *   set through /proc/self/clear_refs ("5"), notes VmRSS (the input and the
 *   process: the baseline), runs, and reports VmHWM minus that baseline;
 *   thread stacks and per-thread malloc arenas count. meshopt: the same in a
 *   forked child of this process (bench_child_peak; without clear_refs, the
 *   child's ru_maxrss minus the parent's VmRSS at the fork). The OpenMesh
 *   driver does the same in its own process around the first decimation of
 *   a copy of the loaded mesh. Reported as bytes per input triangle; it
 *   includes the output.
 *   Quality: mr_compare of the input (reference) and the output, with
 *   options.samples = N (200,000 by default) area-uniform samples per mesh
 *   besides the vertices; symmetric Hausdorff distance and RMS relative to
 *   the input's bounding-box diagonal. Outputs are compacted first (meshopt's
 *   index buffer refers to the input vertex array; mr_compare samples every
 *   vertex it is given).
 *
 * CSV format (stable: columns are only ever added at the end). Header line,
 * then one row per (mesh, target, algorithm, threads):
 *   mesh,algorithm,threads,target,input_triangles,output_triangles,
 *   time_median,time_min,time_max,triangles_per_second,
 *   peak_bytes_per_triangle,hausdorff_rel,rms_rel,
 *   runs,speedup_vs_1_thread,meshopt_over_ours,same_as_1_thread,
 *   cpu_model,physical_cores,nproc
 * mesh: scan-1M, scan-4M, bunny, armadillo, ...; algorithm: meshreduce-full
 * (the default simplifier: one row per thread count), meshreduce-half,
 * mr-greedy-full, mr-greedy-half, meshopt, meshopt-sloppy, openmesh, cgal-lt,
 * cgal-gh (those at threads 1); target: the fraction of referenced input vertices asked
 * for (0.25, 0.1, 0.01); times in seconds; time_min, time_max: over the
 * runs made (runs; openmesh's may be fewer, see above);
 * triangles_per_second: input triangles / time_median;
 * peak_bytes_per_triangle: see Memory above; hausdorff_rel and rms_rel:
 * fractions of the input's bounding-box diagonal; speedup_vs_1_thread,
 * meshopt_over_ours, same_as_1_thread (yes/no): meshreduce-full rows only,
 * see above; cpu_model (commas replaced by spaces), physical_cores (distinct
 * physical/core id pairs of /proc/cpuinfo; empty when it lists none), nproc
 * (the CPUs this process may use, as nproc counts them): the machine, on
 * every row. A value that was not measured is an empty field.
 */
#include "benchpeers.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ALG_FULL (the default options) is the row the others are compared with
 * and the only one run at every thread count; ALG_FULL..ALG_BEST are
 * all meshreduce's. The order is the tables' row order. */
enum {
    ALG_FULL,
    ALG_MESHOPT,
    ALG_SLOPPY,
    ALG_HALF,
    ALG_GREEDY_FULL,
    ALG_GREEDY_HALF,
    ALG_BEST,
    ALG_OPENMESH,
    ALG_CGAL_LT,
    ALG_CGAL_GH,
    ALG_COUNT
};
static const char *const alg_name[ALG_COUNT] = {
    "meshreduce-full", "meshopt",        "meshopt-sloppy", "meshreduce-half",
    "mr-greedy-full",  "mr-greedy-half", "meshreduce-best", "openmesh",
    "cgal-lt",         "cgal-gh"};

#define TARGET_COUNT 3
static const double target_ratio[TARGET_COUNT] = {0.25, 0.10, 0.01};

#define MAX_THREADS 16 /* entries of --threads */

/* One measured (mesh, target, algorithm, threads). Negative values: not
 * measured. */
typedef struct row {
    int done;
    int runs;           /* timed runs behind time */
    int threads;
    bench_summary time;
    size_t out_vertices, out_triangles;
    double peak_bytes;
    double hausdorff_rel, rms_rel;
    int same;           /* meshreduce-full: 1 yes, 0 no; else -1 */
} row;

typedef struct mesh_result {
    char name[32];
    char desc[160];     /* "501762 vertices, 1003520 triangles (...)" */
    size_t input_triangles;
    size_t out_edges[TARGET_COUNT]; /* of our 1-thread output: CGAL's target */
    /* [target][algorithm][thread index]; only ALG_FULL uses index > 0 */
    row rows[TARGET_COUNT][ALG_COUNT][MAX_THREADS];
} mesh_result;

typedef struct config {
    int runs;
    int quick;
    size_t samples;
    int all_threads;
    const char *data;
    const char *dir;
    int keep;
    int others;
    const char *save;         /* --save DIR, or NULL */
    int threads[MAX_THREADS]; /* threads[0] == 1 */
    int n_threads;
    char self[4096];          /* this executable, for --peak-child */
    bench_cpu cpu;
} config;

/* Configurations whose output differed from the 1-thread output. */
static int mismatches;

/* ------------------------------------------------------------------------ */
/* Quality                                                                  */
/* ------------------------------------------------------------------------ */

/* --save: DIR/MESH-PCT- of the (mesh, target) being measured. */
static char save_prefix[4400];

/* The surface distance of an output to the input, into r; with --save, the
 * output written as save_prefix + alg + ".ply" too. */
static void measure_quality(const config *cfg, const mr_mesh *in, const float *positions,
                            size_t vertex_count, const uint32_t *indices, size_t triangle_count,
                            row *r, const char *alg)
{
    if (cfg->save && alg) {
        mr_mesh out;
        mr_mesh_init(&out);
        out.positions = (float *)positions;
        out.vertex_count = vertex_count;
        out.indices = (uint32_t *)indices;
        out.triangle_count = triangle_count;
        mr_write_options wo;
        mr_write_options_default(&wo);
        wo.format = MR_FORMAT_PLY;
        wo.encoding = MR_ENCODING_BINARY_LE;
        char path[4500];
        snprintf(path, sizeof path, "%s%s.ply", save_prefix, alg);
        mr_error err;
        bench_check(mr_mesh_write(path, &out, &wo, &err), &err);
    }
    mr_compare_options opt;
    mr_compare_options_default(&opt);
    opt.samples = cfg->samples;
    opt.threads = cfg->all_threads;
    mr_compare_result res;
    mr_error err;
    omp_set_num_threads(cfg->all_threads);
    mr_status st = mr_compare(in->positions, in->vertex_count, in->indices, in->triangle_count,
                              positions, vertex_count, indices, triangle_count, &opt, &res, &err);
    omp_set_num_threads(1);
    if (st != MR_OK) {
        fprintf(stderr, "bench: mr_compare: %s\n", err.message);
        r->hausdorff_rel = r->rms_rel = -1;
        return;
    }
    r->hausdorff_rel = res.hausdorff_rel;
    r->rms_rel = res.rms_rel;
}

/* ------------------------------------------------------------------------ */
/* meshreduce                                                               */
/* ------------------------------------------------------------------------ */

static void options_for(int alg, double ratio, int threads, mr_simplify_options *opt)
{
    mr_simplify_options_default(opt);
    opt->target_ratio = ratio;
    if (alg == ALG_HALF || alg == ALG_GREEDY_HALF)
        opt->collapse = MR_COLLAPSE_HALF;
    if (alg == ALG_GREEDY_FULL || alg == ALG_GREEDY_HALF)
        opt->strategy = MR_STRATEGY_GREEDY;
    if (alg == ALG_BEST)
        opt->quality = MR_QUALITY_BEST;
    opt->threads = threads;
}

/* One timed mr_simplify at opt->threads threads. */
static double simplify_once(const mr_mesh *in, const mr_simplify_options *opt,
                            mr_simplified *out)
{
    mr_error err;
    omp_set_num_threads(opt->threads);
    double t0 = bench_now();
    bench_check(mr_simplify(in->positions, 0, in->vertex_count, in->indices, in->triangle_count,
                            opt, out, &err),
                &err);
    double t = bench_now() - t0;
    omp_set_num_threads(1);
    return t;
}

/* NULL when a and b are byte-identical, else where they first differ. */
static const char *difference(const mr_simplified *a, const mr_simplified *b, char *buf,
                              size_t size)
{
    if (a->vertex_count != b->vertex_count || a->triangle_count != b->triangle_count) {
        snprintf(buf, size, "%zu vertices, %zu triangles against %zu, %zu", b->vertex_count,
                 b->triangle_count, a->vertex_count, a->triangle_count);
        return buf;
    }
    for (size_t v = 0; v < a->vertex_count; v++)
        if (memcmp(a->positions + 3 * v, b->positions + 3 * v, 3 * sizeof(float)) != 0) {
            snprintf(buf, size, "position of output vertex %zu", v);
            return buf;
        }
    for (size_t t = 0; t < a->triangle_count; t++)
        if (memcmp(a->indices + 3 * t, b->indices + 3 * t, 3 * sizeof(uint32_t)) != 0) {
            snprintf(buf, size, "indices of output triangle %zu", t);
            return buf;
        }
    if ((a->origin == NULL) != (b->origin == NULL)) {
        snprintf(buf, size, "one has no origin array");
        return buf;
    }
    if (a->origin)
        for (size_t v = 0; v < a->vertex_count; v++)
            if (a->origin[v] != b->origin[v]) {
                snprintf(buf, size, "origin of output vertex %zu", v);
                return buf;
            }
    return NULL;
}

static void report_mismatch(const char *alg, const char *mesh, double ratio, int threads,
                            int run, const char *what)
{
    char msg[512];
    if (threads == 1)
        snprintf(msg, sizeof msg,
                 "*** BUG: %s on 1 thread, %s to %g %%: run %d differs from run 1 "
                 "(%s): not deterministic ***",
                 alg, mesh, 100 * ratio, run + 1, what);
    else
        snprintf(msg, sizeof msg,
                 "*** BUG: %s on %d threads, %s to %g %%: run %d is not "
                 "byte-identical to the 1-thread output (first difference: %s) ***",
                 alg, threads, mesh, 100 * ratio, run + 1, what);
    fprintf(stderr, "%s\n", msg);
    printf("%s\n", msg);
    fflush(stdout);
}

/* Our peak memory for (alg, ratio, threads) in a fresh process. */
static double peak_of(const config *cfg, const char *raw, int alg, double ratio, int threads)
{
    mr_simplify_options opt;
    options_for(alg, ratio, threads, &opt);
    double p = bench_exec_peak(cfg->self, raw, &opt);
    if (p < 0)
        fprintf(stderr, "bench: the peak-memory child failed (%s --peak-child %s ...)\n",
                cfg->self, raw);
    return p;
}

/* The default simplifier at every thread count and the meshopt peers, their
 * runs alternating (see Method). */
static void run_block(const config *cfg, const mr_mesh *in, const char *raw, mesh_result *m,
                      int ti)
{
    const double ratio = target_ratio[ti];
    const int nt = cfg->n_threads, runs = cfg->runs;
    row *ours = m->rows[ti][ALG_FULL];
    row *mo = &m->rows[ti][ALG_MESHOPT][0], *sl = &m->rows[ti][ALG_SLOPPY][0];
    double *times = malloc(sizeof(double) * (size_t)runs * (size_t)(nt + 2));
    double *mo_t = times + (size_t)runs * (size_t)nt, *sl_t = mo_t + runs;
    mr_simplified ref, diff[MAX_THREADS];
    int have_diff[MAX_THREADS] = {0};
    memset(&ref, 0, sizeof ref);
    const int have_mo = bench_have_meshopt();
    uint32_t *mo_dst = NULL, *sl_dst = NULL;
    size_t mo_n = 0, sl_n = 0;
    if (have_mo) {
        mo_dst = malloc(sizeof(uint32_t) * 3 * (in->triangle_count + 1));
        sl_dst = malloc(sizeof(uint32_t) * 3 * (in->triangle_count + 1));
    }
    for (int j = 0; j < nt; j++) {
        ours[j].threads = cfg->threads[j];
        ours[j].same = 1;
    }
    {
        /* Untimed warm-up: the first run after loading (or after the other
         * algorithms and mr_compare) faults its heap in and would
         * otherwise be charged to the 1-thread figure alone. */
        mr_simplify_options opt;
        options_for(ALG_FULL, ratio, cfg->threads[0], &opt);
        mr_simplified out;
        simplify_once(in, &opt, &out);
        mr_simplified_free(&out);
    }
    for (int k = 0; k < runs; k++) {
        for (int j = 0; j < nt; j++) {
            mr_simplify_options opt;
            options_for(ALG_FULL, ratio, cfg->threads[j], &opt);
            mr_simplified out;
            times[(size_t)j * (size_t)runs + (size_t)k] = simplify_once(in, &opt, &out);
            if (k == 0 && j == 0) {
                ref = out;
                m->out_edges[ti] = bench_edge_count(ref.indices, ref.triangle_count);
                continue;
            }
            char buf[160];
            const char *what = difference(&ref, &out, buf, sizeof buf);
            if (what) {
                if (ours[j].same)
                    mismatches++;
                report_mismatch(alg_name[ALG_FULL], m->name, ratio, cfg->threads[j], k, what);
                ours[j].same = 0;
                if (!have_diff[j]) {
                    diff[j] = out;
                    have_diff[j] = 1;
                    continue;
                }
            }
            mr_simplified_free(&out);
        }
        if (have_mo) {
            bench_meshopt_call(in, ref.triangle_count, 0, mo_dst, &mo_n, &mo_t[k]);
            bench_meshopt_call(in, ref.triangle_count, 1, sl_dst, &sl_n, &sl_t[k]);
        }
    }
    for (int j = 0; j < nt; j++) {
        row *r = &ours[j];
        const mr_simplified *o = have_diff[j] ? &diff[j] : &ref;
        r->runs = runs;
        r->time = bench_summarize(times + (size_t)j * (size_t)runs, runs);
        r->out_vertices = o->vertex_count;
        r->out_triangles = o->triangle_count;
        r->peak_bytes = peak_of(cfg, raw, ALG_FULL, ratio, cfg->threads[j]);
        if (j == 0 || have_diff[j]) {
            measure_quality(cfg, in, o->positions, o->vertex_count, o->indices,
                            o->triangle_count, r, j == 0 ? alg_name[ALG_FULL] : NULL);
        } else {
            r->hausdorff_rel = ours[0].hausdorff_rel;
            r->rms_rel = ours[0].rms_rel;
        }
        r->done = 1;
        if (have_diff[j])
            mr_simplified_free(&diff[j]);
    }
    if (have_mo) {
        row *pr[2] = {mo, sl};
        const double *pt[2] = {mo_t, sl_t};
        const uint32_t *pd[2] = {mo_dst, sl_dst};
        const size_t pn[2] = {mo_n, sl_n};
        for (int p = 0; p < 2; p++) {
            pr[p]->runs = runs;
            pr[p]->threads = 1;
            pr[p]->time = bench_summarize((double *)pt[p], runs);
            pr[p]->peak_bytes = bench_meshopt_peak(in, ref.triangle_count, p);
            bench_output out = {0};
            bench_compact(in, pd[p], pn[p], &out);
            pr[p]->out_vertices = out.vertex_count;
            pr[p]->out_triangles = out.triangle_count;
            measure_quality(cfg, in, out.positions, out.vertex_count, out.indices,
                            out.triangle_count, pr[p], alg_name[p ? ALG_SLOPPY : ALG_MESHOPT]);
            bench_output_free(&out);
            pr[p]->done = 1;
        }
    }
    mr_simplified_free(&ref);
    free(mo_dst);
    free(sl_dst);
    free(times);
}

/* One of our other simplifiers on `threads` threads, its runs back to
 * back; the last output kept in *keep, or compared with *ref (r->same). */
static void run_other(const config *cfg, const mr_mesh *in, const char *raw, const char *name,
                      double ratio, int alg, size_t triangles, int threads, mr_simplified *keep,
                      const mr_simplified *ref, row *r)
{
    mr_simplify_options opt;
    options_for(alg, ratio, threads, &opt);
    if (triangles) { /* asked for this many triangles instead */
        opt.target_ratio = 0;
        opt.target_triangles = triangles;
    }
    double *times = malloc(sizeof(double) * (size_t)cfg->runs);
    mr_simplified out;
    memset(&out, 0, sizeof out);
    for (int k = 0; k < cfg->runs; k++) {
        if (k > 0)
            mr_simplified_free(&out);
        times[k] = simplify_once(in, &opt, &out);
    }
    r->runs = cfg->runs;
    r->threads = threads;
    r->time = bench_summarize(times, cfg->runs);
    free(times);
    r->out_vertices = out.vertex_count;
    r->out_triangles = out.triangle_count;
    r->peak_bytes = peak_of(cfg, raw, alg, ratio, threads);
    measure_quality(cfg, in, out.positions, out.vertex_count, out.indices, out.triangle_count, r,
                    alg_name[alg]);
    if (ref) { /* the last run's output against the 1-thread one */
        char buf[160];
        const char *what = difference(ref, &out, buf, sizeof buf);
        r->same = what == NULL;
        if (what) {
            mismatches++;
            report_mismatch(alg_name[alg], name, ratio, threads, cfg->runs - 1, what);
        }
    }
    if (keep)
        *keep = out;
    else
        mr_simplified_free(&out);
    r->done = 1;
}

/* ------------------------------------------------------------------------ */
/* OpenMesh (benchpeers.h)                                                  */
/* ------------------------------------------------------------------------ */

/* OpenMesh is an order of magnitude slower: its repeated runs stop once they
 * add up to this many seconds (at least one run). */
#define OPENMESH_BUDGET 20.0

static void run_openmesh(const config *cfg, const mr_mesh *in, const char *in_path,
                         const char *out_path, size_t target_vertices, row *r)
{
    bench_output out = {0};
    r->threads = 1;
    int ok = bench_run_openmesh(in, in_path, out_path, target_vertices, cfg->runs,
                                OPENMESH_BUDGET, cfg->keep, &r->time, &r->runs, &r->peak_bytes,
                                &out);
    if (ok) {
        r->out_vertices = out.vertex_count;
        r->out_triangles = out.triangle_count;
        measure_quality(cfg, in, out.positions, out.vertex_count, out.indices,
                        out.triangle_count, r, alg_name[ALG_OPENMESH]);
        r->done = 1;
    }
    bench_output_free(&out);
}

/* CGAL's Lindstrom-Turk (policy "lt") or Garland-Heckbert (policy "gh")
 * edge collapse to the edge count of our output, with OpenMesh's budget. */
static void run_cgal(const config *cfg, const mr_mesh *in, const char *in_path,
                     const char *out_path, const char *policy, size_t target_edges, row *r)
{
    bench_output out = {0};
    r->threads = 1;
    int ok = bench_run_cgal(policy, in, in_path, out_path, target_edges, cfg->runs,
                            OPENMESH_BUDGET, cfg->keep, &r->time, &r->runs, &r->peak_bytes, &out);
    if (ok) {
        r->out_vertices = out.vertex_count;
        r->out_triangles = out.triangle_count;
        measure_quality(cfg, in, out.positions, out.vertex_count, out.indices,
                        out.triangle_count, r, !strcmp(policy, "lt") ? "cgal-lt" : "cgal-gh");
        r->done = 1;
    }
    bench_output_free(&out);
}

/* ------------------------------------------------------------------------ */
/* Output                                                                   */
/* ------------------------------------------------------------------------ */

/* The rows of one (mesh, target) in table order: (algorithm, thread index). */
static int row_order(const config *cfg, int *alg, int *ti)
{
    int n = 0;
    for (int a = 0; a < ALG_COUNT; a++)
        for (int j = 0; j < (a == ALG_FULL || a == ALG_BEST ? cfg->n_threads : 1); j++) {
            alg[n] = a;
            ti[n] = j;
            n++;
        }
    return n;
}

static void fmt_ratio(char *buf, size_t size, double num, double den)
{
    if (num >= 0 && den > 0)
        snprintf(buf, size, "%.2f", num / den);
    else
        snprintf(buf, size, "-");
}

/* The derived figures of a row, as text ("" when they do not apply). */
typedef struct row_text {
    char name[32], peak[16], h[16], rms[16];
    char speedup[16], mo[16], same[8];
    char rt[16], rh[16], rr[16];
} row_text;

/* Rows timed over fewer runs than asked name their run count. */
static int runs_asked = 1;

static void row_texts(const mesh_result *m, int ti, int a, int j, row_text *t)
{
    const row *r = &m->rows[ti][a][j];
    const row *ours = &m->rows[ti][ALG_FULL][0];
    const row *mo = &m->rows[ti][ALG_MESHOPT][0];
    memset(t, 0, sizeof *t);
    if (r->peak_bytes >= 0)
        snprintf(t->peak, sizeof t->peak, "%.0f", r->peak_bytes / (double)m->input_triangles);
    else
        snprintf(t->peak, sizeof t->peak, "-");
    if (r->hausdorff_rel >= 0) {
        snprintf(t->h, sizeof t->h, "%.5f%%", 100 * r->hausdorff_rel);
        snprintf(t->rms, sizeof t->rms, "%.5f%%", 100 * r->rms_rel);
    } else {
        snprintf(t->h, sizeof t->h, "-");
        snprintf(t->rms, sizeof t->rms, "-");
    }
    if (a == ALG_FULL) {
        if (ours->done)
            fmt_ratio(t->speedup, sizeof t->speedup, ours->time.median, r->time.median);
        if (mo->done)
            fmt_ratio(t->mo, sizeof t->mo, mo->time.median, r->time.median);
        snprintf(t->same, sizeof t->same, "%s", r->same ? "yes" : "no");
    } else if (a == ALG_BEST && j > 0) { /* against its own 1-thread run */
        const row *one = &m->rows[ti][ALG_BEST][0];
        if (one->done)
            fmt_ratio(t->speedup, sizeof t->speedup, one->time.median, r->time.median);
        snprintf(t->same, sizeof t->same, "%s", r->same ? "yes" : "no");
    }
    if (a != ALG_FULL && ours->done) {
        fmt_ratio(t->rt, sizeof t->rt, r->time.median, ours->time.median);
        fmt_ratio(t->rh, sizeof t->rh, r->hausdorff_rel, ours->hausdorff_rel);
        fmt_ratio(t->rr, sizeof t->rr, r->rms_rel, ours->rms_rel);
    }
    if (r->runs < runs_asked)
        snprintf(t->name, sizeof t->name, "%s (%d)", alg_name[a], r->runs);
    else
        snprintf(t->name, sizeof t->name, "%s", alg_name[a]);
}

static void print_header(void)
{
    printf("%-6s %-19s %3s %10s %9s %9s %9s %9s %7s %6s %10s %10s %7s %7s %4s %6s %6s %6s\n",
           "target", "algorithm", "thr", "out tris", "out verts", "median s", "min s", "max s",
           "Mtri/s", "B/tri", "Hausdorff", "RMS", "speedup", "mopt/us", "same", "t/ours",
           "H/ours", "R/ours");
}

static void print_row(const mesh_result *m, int ti, int a, int j)
{
    const row *r = &m->rows[ti][a][j];
    if (!r->done)
        return;
    row_text t;
    row_texts(m, ti, a, j, &t);
    char target[16];
    snprintf(target, sizeof target, "%g%%", 100 * target_ratio[ti]);
    printf("%-6s %-19s %3d %10zu %9zu %9.4f %9.4f %9.4f %7.2f %6s %10s %10s %7s %7s %4s %6s %6s "
           "%6s\n",
           target, t.name, r->threads, r->out_triangles, r->out_vertices, r->time.median,
           r->time.min, r->time.max,
           r->time.median > 0 ? (double)m->input_triangles / r->time.median / 1e6 : 0, t.peak,
           t.h, t.rms, t.speedup, t.mo, t.same, t.rt, t.rh, t.rr);
}

static void csv_num(FILE *f, double v, int measured)
{
    if (measured)
        fprintf(f, ",%.9g", v);
    else
        fputc(',', f);
}

/* The CPU model with the characters a CSV field cannot hold replaced. */
static void csv_model(const config *cfg, char *buf, size_t size)
{
    snprintf(buf, size, "%s", cfg->cpu.model);
    for (char *p = buf; *p; p++)
        if (*p == ',' || *p == '"' || *p == '\n' || *p == '\r')
            *p = ' ';
}

static void write_csv_rows(FILE *f, const config *cfg, const mesh_result *m)
{
    int alg[ALG_COUNT + MAX_THREADS], thr[ALG_COUNT + MAX_THREADS];
    int n = row_order(cfg, alg, thr);
    char model[256];
    csv_model(cfg, model, sizeof model);
    for (int ti = 0; ti < TARGET_COUNT; ti++)
        for (int i = 0; i < n; i++) {
            const int a = alg[i], j = thr[i];
            const row *r = &m->rows[ti][a][j];
            if (!r->done)
                continue;
            const row *ours = &m->rows[ti][ALG_FULL][0];
            const row *mo = &m->rows[ti][ALG_MESHOPT][0];
            fprintf(f, "%s,%s,%d,%g,%zu,%zu", m->name, alg_name[a], r->threads,
                    target_ratio[ti], m->input_triangles, r->out_triangles);
            csv_num(f, r->time.median, 1);
            csv_num(f, r->time.min, 1);
            csv_num(f, r->time.max, 1);
            csv_num(f, r->time.median > 0 ? (double)m->input_triangles / r->time.median : 0,
                    r->time.median > 0);
            csv_num(f, r->peak_bytes / (double)m->input_triangles, r->peak_bytes >= 0);
            csv_num(f, r->hausdorff_rel, r->hausdorff_rel >= 0);
            csv_num(f, r->rms_rel, r->rms_rel >= 0);
            /* added columns */
            fprintf(f, ",%d", r->runs);
            const int full = a == ALG_FULL, best_n = a == ALG_BEST && j > 0;
            /* speedup: against the same simplifier's 1-thread run */
            const row *one = full ? ours : best_n ? &m->rows[ti][ALG_BEST][0] : NULL;
            csv_num(f, one && r->time.median > 0 ? one->time.median / r->time.median : 0,
                    one && one->done && r->time.median > 0);
            csv_num(f, r->time.median > 0 ? mo->time.median / r->time.median : 0,
                    full && mo->done && r->time.median > 0);
            fprintf(f, ",%s", full || best_n ? (r->same ? "yes" : "no") : "");
            fprintf(f, ",%s,", model);
            if (cfg->cpu.physical > 0)
                fprintf(f, "%d", cfg->cpu.physical);
            fprintf(f, ",%d\n", cfg->cpu.nproc);
        }
    fflush(f);
}

static void md_rows(FILE *f, const config *cfg, const mesh_result *m)
{
    int alg[ALG_COUNT + MAX_THREADS], thr[ALG_COUNT + MAX_THREADS];
    int n = row_order(cfg, alg, thr);
    fprintf(f, "\n### %s: %s\n\n", m->name, m->desc);
    fprintf(f, "| target | algorithm | threads | out tris | median s | min s | max s | Mtri/s | "
               "B/tri | Hausdorff | RMS | speedup vs 1 thread | meshopt / ours | same | "
               "t / ours 1 thread |\n");
    fprintf(f, "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | "
               "---: | ---: | --- | ---: |\n");
    for (int ti = 0; ti < TARGET_COUNT; ti++)
        for (int i = 0; i < n; i++) {
            const row *r = &m->rows[ti][alg[i]][thr[i]];
            if (!r->done)
                continue;
            row_text t;
            row_texts(m, ti, alg[i], thr[i], &t);
            fprintf(f,
                    "| %g %% | %s | %d | %zu | %.4f | %.4f | %.4f | %.2f | %s | %s | %s | %s | "
                    "%s | %s | %s |\n",
                    100 * target_ratio[ti], t.name, r->threads, r->out_triangles, r->time.median,
                    r->time.min, r->time.max,
                    r->time.median > 0 ? (double)m->input_triangles / r->time.median / 1e6 : 0,
                    t.peak, t.h, t.rms, t.speedup, t.mo, t.same, t.rt);
        }
}

/* ------------------------------------------------------------------------ */
/* Meshes                                                                   */
/* ------------------------------------------------------------------------ */

typedef struct mesh_spec {
    const char *name;
    const char *file;       /* in the data folder, or NULL: generated */
    size_t triangles;       /* generated */
    unsigned quick;         /* the targets (bit ti) of --quick */
    int shuffled;           /* triangles in a random order (seeded): an
                               input whose order is not spatially coherent */
} mesh_spec;

#define Q10 (1u << 1)
#define Q1 (1u << 2)
static const mesh_spec specs[] = {
    {"scan-1M", NULL, 1000000, Q10, 0},
    {"scan-4M", NULL, 4000000, Q1, 0},
    {"scan-1M-shuffled", NULL, 1000000, 0, 1},
    {"bunny", "stanford-bunny.obj", 0, Q10 | Q1, 0},
    {"armadillo", "armadillo.obj", 0, Q10 | Q1, 0},
    {"nefertiti", "nefertiti.obj", 0, 0, 0},
    {"ogre", "ogre.obj", 0, 0, 0},
    {"fandisk", "fandisk.obj", 0, 0, 0},
    {"homer", "homer.obj", 0, 0, 0},
    {"igea", "igea.ply", 0, 0, 0},
    {"beast", "beast.obj", 0, 0, 0},
    {"spot", "spot.obj", 0, 0, 0},
};

/* Triangles in a random order, the same every run (Fisher-Yates with a
 * fixed xorshift seed): as a file exported without spatial order. */
static void shuffle_triangles(mr_mesh *mesh)
{
    uint64_t x = 0x853C49E6748FEA9Bull;
    for (size_t i = mesh->triangle_count; i > 1; i--) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        const size_t j = (size_t)(x % i);
        uint32_t t[3];
        memcpy(t, mesh->indices + 3 * (i - 1), sizeof t);
        memcpy(mesh->indices + 3 * (i - 1), mesh->indices + 3 * j, sizeof t);
        memcpy(mesh->indices + 3 * j, t, sizeof t);
    }
}

/* Load or generate, then keep positions and non-degenerate triangles over
 * referenced vertices only. Returns 0 when a file is absent. */
static int load_mesh(const config *cfg, const mesh_spec *s, mr_mesh *mesh, mesh_result *m)
{
    size_t degenerate = 0, unreferenced = 0;
    omp_set_num_threads(cfg->all_threads);
    const int found = bench_load_mesh(cfg->data, s->file, s->triangles, cfg->all_threads, mesh,
                                      &degenerate, &unreferenced);
    omp_set_num_threads(1);
    if (!found)
        return 0;
    if (s->shuffled)
        shuffle_triangles(mesh);
    int len = snprintf(m->desc, sizeof m->desc, "%zu vertices, %zu triangles", mesh->vertex_count,
                       mesh->triangle_count);
    if (!s->file)
        snprintf(m->desc + len, sizeof m->desc - (size_t)len, " (mr_generate scan, seed 1%s)",
                 s->shuffled ? ", triangles shuffled" : "");
    else if (degenerate || unreferenced)
        snprintf(m->desc + len, sizeof m->desc - (size_t)len,
                 " (%s; removed %zu degenerate triangles, %zu unreferenced vertices)", s->file,
                 degenerate, unreferenced);
    else
        snprintf(m->desc + len, sizeof m->desc - (size_t)len, " (%s)", s->file);
    printf("\nmesh %s: %s\n", s->name, m->desc);
    return 1;
}

static int wanted(const char *name, char **only, int n_only)
{
    for (int i = 0; i < n_only; i++)
        if (!strcmp(only[i], name))
            return 1;
    return n_only == 0;
}

/* ------------------------------------------------------------------------ */
/* Bars                                                                     */
/* ------------------------------------------------------------------------ */

typedef struct bar {
    char name[128];
    char measured[160];
    int met;            /* 1 yes, 0 no, -1 not measured */
} bar;

#define MAX_BARS 24

static const mesh_result *find_mesh(const mesh_result *res, int n, const char *name)
{
    for (int i = 0; i < n; i++)
        if (!strcmp(res[i].name, name))
            return &res[i];
    return NULL;
}

static int target_index(double ratio)
{
    for (int i = 0; i < TARGET_COUNT; i++)
        if (fabs(target_ratio[i] - ratio) < 1e-12)
            return i;
    return 0;
}

static int thread_index(const config *cfg, int threads)
{
    for (int j = 0; j < cfg->n_threads; j++)
        if (cfg->threads[j] == threads)
            return j;
    return -1;
}

/* The row of the default simplifier at `threads` on mesh to ratio, or NULL
 * when not measured. */
static const row *full_row(const config *cfg, const mesh_result *res, int n, const char *mesh,
                           double ratio, int threads)
{
    const mesh_result *m = find_mesh(res, n, mesh);
    int j = thread_index(cfg, threads);
    if (!m || j < 0)
        return NULL;
    const row *r = &m->rows[target_index(ratio)][ALG_FULL][j];
    return r->done ? r : NULL;
}

static const row *peer_row(const mesh_result *res, int n, const char *mesh, double ratio,
                           int alg)
{
    const mesh_result *m = find_mesh(res, n, mesh);
    if (!m)
        return NULL;
    const row *r = &m->rows[target_index(ratio)][alg][0];
    return r->done ? r : NULL;
}

static int collect_bars(const config *cfg, const mesh_result *res, int n, bar *bars)
{
    int nb = 0;
    struct {
        const char *mesh;
        double ratio;
    } speed[2] = {{"scan-1M", 0.10}, {"scan-4M", 0.01}};

    /* 2 threads against 1 */
    for (int i = 0; i < 2; i++) {
        bar *b = &bars[nb++];
        snprintf(b->name, sizeof b->name, "2 threads >= 1.7x faster than 1 thread, %s to %g %%",
                 speed[i].mesh, 100 * speed[i].ratio);
        const row *r1 = full_row(cfg, res, n, speed[i].mesh, speed[i].ratio, 1);
        const row *r2 = full_row(cfg, res, n, speed[i].mesh, speed[i].ratio, 2);
        if (r1 && r2 && r2->time.median > 0) {
            double s = r1->time.median / r2->time.median;
            snprintf(b->measured, sizeof b->measured, "%.2fx (%.4f s / %.4f s)", s,
                     r1->time.median, r2->time.median);
            b->met = s >= 1.7;
        } else {
            snprintf(b->measured, sizeof b->measured, "not measured");
            b->met = -1;
        }
    }
    /* 2 threads against meshopt_simplify */
    for (int i = 0; i < 2; i++) {
        bar *b = &bars[nb++];
        snprintf(b->name, sizeof b->name,
                 "2 threads >= 2x faster than meshopt_simplify, %s to %g %%", speed[i].mesh,
                 100 * speed[i].ratio);
        const row *r2 = full_row(cfg, res, n, speed[i].mesh, speed[i].ratio, 2);
        const row *p = peer_row(res, n, speed[i].mesh, speed[i].ratio, ALG_MESHOPT);
        if (r2 && p && r2->time.median > 0) {
            double s = p->time.median / r2->time.median;
            snprintf(b->measured, sizeof b->measured, "%.2fx (%.4f s / %.4f s)", s,
                     p->time.median, r2->time.median);
            b->met = s >= 2.0;
        } else {
            snprintf(b->measured, sizeof b->measured, "not measured");
            b->met = -1;
        }
    }
    /* 16 threads against 1, when asked for */
    if (thread_index(cfg, 16) >= 0) {
        bar *b = &bars[nb++];
        snprintf(b->name, sizeof b->name, "16 threads >= 10x faster than 1 thread, scan-4M to "
                                          "1 %%");
        const row *r1 = full_row(cfg, res, n, "scan-4M", 0.01, 1);
        const row *r16 = full_row(cfg, res, n, "scan-4M", 0.01, 16);
        if (r1 && r16 && r16->time.median > 0) {
            double s = r1->time.median / r16->time.median;
            snprintf(b->measured, sizeof b->measured, "%.2fx (%.4f s / %.4f s)%s", s,
                     r1->time.median, r16->time.median,
                     cfg->cpu.nproc < 16 ? "; oversubscribed" : "");
            b->met = s >= 10.0;
        } else {
            snprintf(b->measured, sizeof b->measured, "not measured");
            b->met = -1;
        }
    }
    /* Memory: the worst default-simplifier row of the generated meshes (large
     * enough for per-triangle figures to mean something), any thread count. */
    {
        bar *b = &bars[nb++];
        snprintf(b->name, sizeof b->name,
                 "peak <= 100 B per input triangle (default, every thread count, scans)");
        double worst = -1;
        char where[96] = "";
        for (int i = 0; i < n; i++) {
            if (strncmp(res[i].name, "scan-", 5) != 0)
                continue;
            for (int ti = 0; ti < TARGET_COUNT; ti++)
                for (int j = 0; j < cfg->n_threads; j++) {
                    const row *r = &res[i].rows[ti][ALG_FULL][j];
                    if (!r->done || r->peak_bytes < 0)
                        continue;
                    double v = r->peak_bytes / (double)res[i].input_triangles;
                    if (v > worst) {
                        worst = v;
                        snprintf(where, sizeof where, "%s to %g %%, %d thread%s", res[i].name,
                                 100 * target_ratio[ti], r->threads, r->threads == 1 ? "" : "s");
                    }
                }
        }
        if (worst >= 0) {
            snprintf(b->measured, sizeof b->measured, "worst %.0f (%s)", worst, where);
            b->met = worst <= 100;
        } else {
            snprintf(b->measured, sizeof b->measured, "not measured");
            b->met = -1;
        }
    }
    /* Same output at every thread count: every configuration measured. */
    {
        bar *b = &bars[nb++];
        snprintf(b->name, sizeof b->name,
                 "output byte-identical at every thread count (all meshes and targets; "
                 "default and best)");
        int total = 0, same = 0;
        for (int i = 0; i < n; i++)
            for (int ti = 0; ti < TARGET_COUNT; ti++)
                for (int j = 0; j < cfg->n_threads; j++)
                    for (int a = 0; a < 2; a++) { /* the default, and best past 1 thread */
                        const row *r = &res[i].rows[ti][a ? ALG_BEST : ALG_FULL][j];
                        if (!r->done || (a && j == 0))
                            continue;
                        total++;
                        same += r->same == 1;
                    }
        if (total) {
            snprintf(b->measured, sizeof b->measured, "%d of %d rows yes", same, total);
            b->met = same == total;
        } else {
            snprintf(b->measured, sizeof b->measured, "not measured");
            b->met = -1;
        }
    }
    /* Quality against meshopt_simplify on the data meshes (1 thread; the
     * other thread counts give the same output). */
    const char *qm[2] = {"bunny", "armadillo"};
    const double qt[2] = {0.10, 0.01};
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 2; k++) {
            bar *b = &bars[nb++];
            snprintf(b->name, sizeof b->name,
                     "quality: Hausdorff and RMS <= meshopt_simplify's, %s to %g %%", qm[i],
                     100 * qt[k]);
            const row *o = full_row(cfg, res, n, qm[i], qt[k], 1);
            const row *p = peer_row(res, n, qm[i], qt[k], ALG_MESHOPT);
            if (!o || !p || o->hausdorff_rel < 0 || p->hausdorff_rel < 0) {
                snprintf(b->measured, sizeof b->measured, "not measured");
                b->met = -1;
                continue;
            }
            snprintf(b->measured, sizeof b->measured, "H %.5f%% vs %.5f%%, RMS %.5f%% vs %.5f%%",
                     100 * o->hausdorff_rel, 100 * p->hausdorff_rel, 100 * o->rms_rel,
                     100 * p->rms_rel);
            b->met = o->hausdorff_rel <= p->hausdorff_rel && o->rms_rel <= p->rms_rel;
        }
    return nb;
}

static const char *met_text(int met)
{
    return met > 0 ? "yes" : met == 0 ? "NO" : "n/a";
}

static void print_bars(const config *cfg, const bar *bars, int nb)
{
    printf("\nbars:\n");
    printf("  %-72s  %-44s  %s\n", "bar", "measured", "met?");
    for (int i = 0; i < nb; i++)
        printf("  %-72s  %-44s  %s\n", bars[i].name, bars[i].measured, met_text(bars[i].met));
    if (thread_index(cfg, 16) < 0)
        printf("  (16 threads >= 10x over 1 thread on scan-4M: checked only with 16 in "
               "--threads)\n");
}

/* ------------------------------------------------------------------------ */

static void usage(void)
{
    fprintf(stderr, "usage: bench_simplify [--runs R] [--quick] [--threads 1,2,...] [--csv FILE] "
                    "[--md FILE] [--samples N] [--data DIR] [--dir DIR] [--mesh NAME]... "
                    "[--others | --no-others] [--keep] [--save DIR]\n");
    exit(2);
}

/* "1,2,4": the list, 1 first, without repeats; -1 on a bad list. */
static int parse_threads(const char *s, config *cfg)
{
    cfg->threads[0] = 1;
    cfg->n_threads = 1;
    while (*s) {
        char *end;
        long v = strtol(s, &end, 10);
        if (end == s || v < 1 || v > 4096 || (*end && *end != ','))
            return -1;
        int seen = 0;
        for (int j = 0; j < cfg->n_threads; j++)
            seen |= cfg->threads[j] == (int)v;
        if (!seen) {
            if (cfg->n_threads == MAX_THREADS)
                return -1;
            cfg->threads[cfg->n_threads++] = (int)v;
        }
        s = *end ? end + 1 : end;
    }
    return 0;
}

static void print_machine_lines(FILE *f, const config *cfg, const char *prefix)
{
    fprintf(f, "%s", prefix);
    bench_print_machine(f);
    fprintf(f, "%scpu: %s; /proc/cpuinfo: %d logical processors", prefix, cfg->cpu.model,
            cfg->cpu.logical);
    if (cfg->cpu.physical > 0)
        fprintf(f, ", %d physical cores", cfg->cpu.physical);
    fprintf(f, "; nproc: %d; OpenMP max threads: %d\n", cfg->cpu.nproc, cfg->all_threads);
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "--peak-child"))
        return bench_peak_child_main(argc, argv);

    double start = bench_now();
    config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.runs = 3;
    cfg.samples = 200000;
    cfg.all_threads = 1;
    cfg.data = MR_SHARED_DATA;
    cfg.dir = "out/bench";
    cfg.others = -1;
    cfg.threads[0] = 1;
    cfg.threads[1] = 2;
    cfg.n_threads = 2;
    const char *csv_path = NULL, *md_path = NULL;
    int runs_given = 0;
    char **only = calloc((size_t)argc, sizeof *only);
    int n_only = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc) {
            cfg.runs = atoi(argv[++i]);
            runs_given = 1;
        } else if (!strcmp(argv[i], "--quick")) {
            cfg.quick = 1;
        } else if (!strcmp(argv[i], "--threads") && i + 1 < argc) {
            if (parse_threads(argv[++i], &cfg) != 0)
                usage();
        } else if (!strcmp(argv[i], "--csv") && i + 1 < argc) {
            csv_path = argv[++i];
        } else if (!strcmp(argv[i], "--md") && i + 1 < argc) {
            md_path = argv[++i];
        } else if (!strcmp(argv[i], "--samples") && i + 1 < argc) {
            cfg.samples = (size_t)strtod(argv[++i], NULL);
        } else if (!strcmp(argv[i], "--data") && i + 1 < argc) {
            cfg.data = argv[++i];
        } else if (!strcmp(argv[i], "--dir") && i + 1 < argc) {
            cfg.dir = argv[++i];
        } else if (!strcmp(argv[i], "--mesh") && i + 1 < argc) {
            only[n_only++] = argv[++i];
        } else if (!strcmp(argv[i], "--others")) {
            cfg.others = 1;
        } else if (!strcmp(argv[i], "--no-others")) {
            cfg.others = 0;
        } else if (!strcmp(argv[i], "--keep")) {
            cfg.keep = 1;
        } else if (!strcmp(argv[i], "--save") && i + 1 < argc) {
            cfg.save = argv[++i];
        } else {
            usage();
        }
    }
    if (cfg.quick && !runs_given)
        cfg.runs = 1;
    if (cfg.runs < 1)
        cfg.runs = 1;
    if (cfg.others < 0)
        cfg.others = !cfg.quick;
    runs_asked = cfg.runs;
    cfg.all_threads = omp_get_max_threads();
    omp_set_num_threads(1);
    bench_cpu_info(&cfg.cpu);
    ssize_t sl = readlink("/proc/self/exe", cfg.self, sizeof cfg.self - 1);
    if (sl > 0)
        cfg.self[sl] = '\0';
    else
        snprintf(cfg.self, sizeof cfg.self, "%s", argv[0]);

    FILE *csv = NULL;
    if (csv_path) {
        csv = fopen(csv_path, "w");
        if (!csv) {
            fprintf(stderr, "bench: cannot write %s\n", csv_path);
            return 1;
        }
        fprintf(csv, "mesh,algorithm,threads,target,input_triangles,output_triangles,"
                     "time_median,time_min,time_max,triangles_per_second,"
                     "peak_bytes_per_triangle,hausdorff_rel,rms_rel,"
                     "runs,speedup_vs_1_thread,meshopt_over_ours,same_as_1_thread,"
                     "cpu_model,physical_cores,nproc\n");
    }
    {
        char cmd[4200];
        snprintf(cmd, sizeof cmd, "mkdir -p '%s'", cfg.dir);
        if (system(cmd) != 0) {
            fprintf(stderr, "bench: cannot create %s\n", cfg.dir);
            return 1;
        }
    }

    print_machine_lines(stdout, &cfg, "");
    printf("threads:");
    for (int j = 0; j < cfg.n_threads; j++)
        printf("%s%d", j ? "," : " ", cfg.threads[j]);
    printf(" (the default simplifier; its runs alternate with the meshopt peers': ");
    for (int j = 0; j < cfg.n_threads; j++)
        printf("%d, ", cfg.threads[j]);
    printf("meshopt, meshopt-sloppy, then again)\n");
    for (int j = 0; j < cfg.n_threads; j++)
        if (cfg.threads[j] > cfg.cpu.nproc)
            printf("note: %d threads > %d CPUs available: oversubscribed, its times say "
                   "nothing about scaling\n",
                   cfg.threads[j], cfg.cpu.nproc);
    printf("simplification to 25/10/1 %% of the referenced vertices; time: median (min, max) "
           "of %d run%s; speedup: our 1-thread median / this median; mopt/us: meshopt_simplify's "
           "median / this median (> 1: ours is faster); same: output byte-identical to the "
           "1-thread output in every run; peak memory: growth of the peak resident set in a "
           "fresh process (ours) or forked child (peers), per input triangle; Hausdorff, RMS: "
           "mr_compare with %zu samples per mesh, %% of the input's bounding-box diagonal; "
           "t/H/R/ours: this row / meshreduce-full on 1 thread\n",
           cfg.runs, cfg.runs == 1 ? "" : "s", cfg.samples);
    printf("peers: meshopt %s; OpenMesh %s; CGAL %s\n",
           bench_have_meshopt()
               ? "0.18-style C API, meshopt_simplify (options 0, target_error FLT_MAX, same "
                 "triangle count) and meshopt_simplifySloppy"
               : "not built in (meshoptimizer not found at configure time)",
           bench_have_openmesh() ? "Decimater + ModQuadric (same vertex count), subprocess"
                                 : "not built in (OpenMesh or C++ not found at configure time)",
           bench_have_cgal() ? "Surface_mesh_simplification edge_collapse, Lindstrom-Turk "
                               "(cgal-lt) and Garland-Heckbert plane (cgal-gh) policies (same "
                               "edge count), subprocess"
                             : "not built (libcgal-dev and libeigen3-dev absent, or the driver "
                               "not built: make bench builds it)");
    if (access(cfg.data, R_OK) != 0)
        printf("data folder %s absent: only the generated meshes\n", cfg.data);

    size_t n_specs = sizeof specs / sizeof *specs;
    mesh_result *results = calloc(n_specs, sizeof *results);
    int n_results = 0;
    for (size_t si = 0; si < n_specs; si++) {
        const mesh_spec *s = &specs[si];
        if ((cfg.quick && !s->quick) || !wanted(s->name, only, n_only))
            continue;
        mesh_result *m = &results[n_results];
        snprintf(m->name, sizeof m->name, "%s", s->name);
        mr_mesh mesh;
        if (!load_mesh(&cfg, s, &mesh, m))
            continue;
        n_results++;
        m->input_triangles = mesh.triangle_count;
        char raw[4200], om_in[4200], om_out[4200];
        snprintf(raw, sizeof raw, "%s/simplify-%s-%d.raw", cfg.dir, s->name, (int)getpid());
        if (bench_raw_write(&mesh, raw) != 0) {
            fprintf(stderr, "bench: cannot write %s\n", raw);
            return 1;
        }
        snprintf(om_in, sizeof om_in, "%s/simplify-%s.ply", cfg.dir, s->name);
        snprintf(om_out, sizeof om_out, "%s/simplify-%s-openmesh.ply", cfg.dir, s->name);
        int om_ready = 0;
        print_header();
        for (int ti = 0; ti < TARGET_COUNT; ti++) {
            double ratio = target_ratio[ti];
            if (cfg.quick && !(s->quick & (1u << ti)))
                continue;
            if (cfg.save)
                snprintf(save_prefix, sizeof save_prefix, "%s/%s-%g-", cfg.save, s->name,
                         100 * ratio);
            for (int a = 0; a < ALG_COUNT; a++)
                for (int j = 0; j < MAX_THREADS; j++) {
                    row *r = &m->rows[ti][a][j];
                    r->peak_bytes = r->hausdorff_rel = r->rms_rel = -1;
                    r->same = -1;
                }
            run_block(&cfg, &mesh, raw, m, ti);
            for (int j = 0; j < cfg.n_threads; j++)
                print_row(m, ti, ALG_FULL, j);
            print_row(m, ti, ALG_MESHOPT, 0);
            print_row(m, ti, ALG_SLOPPY, 0);
            fflush(stdout);
            if (cfg.others)
                for (int a = ALG_HALF; a <= ALG_BEST; a++) {
                    /* best at the default's triangle count, as the peers
                     * (its collapses keep more boundary vertices, so the
                     * same vertex count has more triangles), and at every
                     * thread count asked, its output against its own at 1
                     * thread (the first) */
                    const int nt = a == ALG_BEST ? cfg.n_threads : 1;
                    mr_simplified one;
                    memset(&one, 0, sizeof one);
                    for (int j = 0; j < nt; j++) {
                        run_other(&cfg, &mesh, raw, m->name, ratio, a,
                                  a == ALG_BEST ? m->rows[ti][ALG_FULL][0].out_triangles : 0,
                                  a == ALG_BEST ? cfg.threads[j] : 1,
                                  j == 0 && nt > 1 ? &one : NULL, j > 0 ? &one : NULL,
                                  &m->rows[ti][a][j]);
                        print_row(m, ti, a, j);
                        fflush(stdout);
                    }
                    mr_simplified_free(&one);
                }
            if (!cfg.others || (!bench_have_openmesh() && !bench_have_cgal()))
                continue;
            if (!om_ready) {
                mr_write_options wo;
                mr_write_options_default(&wo);
                wo.format = MR_FORMAT_PLY;
                wo.encoding = MR_ENCODING_BINARY_LE;
                mr_error err;
                bench_check(mr_mesh_write(om_in, &mesh, &wo, &err), &err);
                om_ready = 1;
            }
            if (bench_have_openmesh()) {
                run_openmesh(&cfg, &mesh, om_in, om_out,
                             m->rows[ti][ALG_FULL][0].out_vertices,
                             &m->rows[ti][ALG_OPENMESH][0]);
                print_row(m, ti, ALG_OPENMESH, 0);
                fflush(stdout);
            }
            for (int a = ALG_CGAL_LT; a <= ALG_CGAL_GH && bench_have_cgal(); a++) {
                run_cgal(&cfg, &mesh, om_in, om_out, a == ALG_CGAL_LT ? "lt" : "gh",
                         m->out_edges[ti], &m->rows[ti][a][0]);
                print_row(m, ti, a, 0);
                fflush(stdout);
            }
        }
        if (om_ready && !cfg.keep)
            unlink(om_in);
        if (!cfg.keep)
            unlink(raw);
        if (csv)
            write_csv_rows(csv, &cfg, m);
        mr_mesh_free(&mesh);
    }

    bar bars[MAX_BARS];
    int nb = collect_bars(&cfg, results, n_results, bars);
    print_bars(&cfg, bars, nb);
    double total = bench_now() - start;
    if (mismatches)
        printf("\n*** BUG: %d configuration%s of the default simplifier gave an output that is "
               "not byte-identical to the 1-thread output (see the lines above) ***\n",
               mismatches, mismatches == 1 ? "" : "s");
    printf("\ntotal time: %.1f s\n", total);
    if (csv) {
        fclose(csv);
        printf("csv: %s\n", csv_path);
    }
    if (md_path) {
        FILE *md = fopen(md_path, "w");
        if (!md) {
            fprintf(stderr, "bench: cannot write %s\n", md_path);
            return 1;
        }
        fprintf(md, "## Simplification: `bench_simplify");
        for (int i = 1; i < argc; i++)
            fprintf(md, " %s", argv[i]);
        fprintf(md, "`\n\n```\n");
        print_machine_lines(md, &cfg, "");
        fprintf(md, "```\n\nThreads:");
        for (int j = 0; j < cfg.n_threads; j++)
            fprintf(md, "%s%d", j ? "," : " ", cfg.threads[j]);
        fprintf(md, "; time: median (min, max) of %d run%s, the thread counts' and meshopt's "
                    "runs alternating; speedup: our 1-thread median / this median; meshopt / "
                    "ours: meshopt_simplify's median / this median; same: byte-identical to the "
                    "1-thread output in every run; B/tri: peak memory growth per input "
                    "triangle; Hausdorff, RMS: mr_compare, %zu samples, %% of the bounding-box "
                    "diagonal; total time %.1f s.\n",
                    cfg.runs, cfg.runs == 1 ? "" : "s", cfg.samples, total);
        for (int i = 0; i < n_results; i++)
            md_rows(md, &cfg, &results[i]);
        fprintf(md, "\n### Bars\n\n| bar | measured | met? |\n| --- | --- | --- |\n");
        for (int i = 0; i < nb; i++)
            fprintf(md, "| %s | %s | %s |\n", bars[i].name, bars[i].measured,
                    met_text(bars[i].met));
        if (mismatches)
            fprintf(md, "\n**BUG: %d configuration%s not byte-identical to the 1-thread "
                        "output.**\n",
                    mismatches, mismatches == 1 ? "" : "s");
        fclose(md);
        printf("markdown: %s\n", md_path);
    }
    free(results);
    free(only);
    return mismatches ? 3 : 0;
}
