/*
 * The benchmark sweep: meshes x targets x algorithms x thread counts,
 * several timed runs each, one CSV row per configuration. bench/report
 * turns the CSV into plots and bench/REPORT.md.
 *
 *   sweep [--quick] [--runs R] [--csv FILE] [--threads 1,2,...] [--samples N]
 *         [--data DIR] [--dir DIR] [--mesh NAME]...
 *
 * --quick      a generated 20k-triangle scan only, targets 10 % and 1 %,
 *              threads 1 and 2, 1 run, 10k samples: seconds, for tests
 * --runs R     timed runs per configuration (default 3)
 * --threads L  thread counts (default: 1, 2 and the machine's cores)
 * --samples N  surface samples per mesh for the distances (default 200k)
 *
 * Algorithms are rows of the `algorithms` table below: a name, a runner,
 * whether it runs at every thread count (else once, single-threaded) and
 * its parameters. A later parallel simplifier or a weld algorithm is one
 * more row (and, for a new kind of call, one more runner).
 *
 * Method: as bench_simplify. Each mesh is loaded or generated, attributes
 * dropped, degenerate triangles and unreferenced vertices removed. Time is
 * the wall clock of the call alone; ours runs with options.threads and
 * omp_set_num_threads set to the row's thread count. Peak memory: one more
 * run in a forked child (benchpeers.h) on one thread (libgomp cannot start
 * threads in a forked child), bytes per input triangle. Quality:
 * mr_compare of input and output (symmetric Hausdorff and RMS, fractions
 * of the input's bounding-box diagonal). Vertex similarity (ours only):
 * mr_vertex_similarity of the output against the sequential greedy
 * reference of the same collapse kind at the same target (the filter-queue
 * paper's measure); empty for the references themselves and the peers.
 * Peers (single-threaded) are asked for the triangle count (meshopt),
 * vertex count (OpenMesh) or edge count (CGAL's Lindstrom-Turk and
 * Garland-Heckbert policies, cgal-lt and cgal-gh, when make bench or make
 * report built their driver) the greedy full-collapse reference reached.
 *
 * CSV: comment lines first ("# machine: ...", "# date: ...", "# mesh NAME
 * SOURCE" where SOURCE is "generate:scan:TRIANGLES:SEED" or "file:PATH"),
 * then the header and one row per (mesh, target, algorithm, threads):
 *   mesh,algorithm,threads,target,input_triangles,output_triangles,runs,
 *   time_median,time_min,time_max,triangles_per_second,
 *   peak_bytes_per_triangle,hausdorff_rel,rms_rel,vertex_similarity
 * An unmeasured value is an empty field.
 */
#include "benchpeers.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define MAX_THREADS_LIST 8
#define MAX_TARGETS 3

typedef struct config {
    int quick, runs;
    int threads[MAX_THREADS_LIST];
    int n_threads;
    size_t samples;
    const char *data, *dir;
    int all_threads;
} config;

/* What one configuration produced. */
typedef struct result {
    int ok, runs;
    bench_summary time;
    double peak_bytes;          /* -1: unknown */
    double hausdorff_rel, rms_rel;
    double similarity;          /* -1: not defined */
    bench_output out;
    uint32_t *origin;           /* ours: output vertex -> input vertex */
} result;

/* Per (mesh, target): the references later rows compare with. */
typedef struct target_state {
    const mr_mesh *in;
    double ratio;
    result ref[2];              /* greedy full, greedy half at 1 thread */
    int have_ref[2];
    const config *cfg;
    const char *ply_path;       /* the input as PLY for the OpenMesh driver */
} target_state;

typedef struct algorithm algorithm;
typedef int (*run_fn)(const algorithm *alg, target_state *ts, int threads, result *r);

struct algorithm {
    const char *name;
    run_fn run;
    int threaded;               /* runs at every thread count */
    mr_collapse_kind collapse;
    mr_strategy strategy;
    int reference;              /* 1: the greedy reference of its collapse kind */
    int sloppy;                 /* meshopt_simplifySloppy */
    mr_simplify_quality quality; /* ours: MR_QUALITY_BEST for meshreduce-best */
};

/* ---- ours ------------------------------------------------------------------ */

static int run_simplify(const algorithm *alg, target_state *ts, int threads, result *r)
{
    mr_simplify_options opt;
    mr_simplify_options_default(&opt);
    opt.target_ratio = ts->ratio;
    opt.collapse = alg->collapse;
    opt.strategy = alg->strategy;
    opt.quality = alg->quality;
    opt.threads = threads;
    omp_set_num_threads(threads);
    mr_simplified out;
    r->runs = ts->cfg->runs;
    bench_run_ours(ts->in, &opt, r->runs, &r->time, &r->peak_bytes, &out);
    r->out.vertex_count = out.vertex_count;
    r->out.triangle_count = out.triangle_count;
    r->out.positions = out.positions;
    r->out.indices = out.indices;
    r->origin = out.origin;
    int kind = alg->collapse == MR_COLLAPSE_HALF;
    if (!alg->reference && ts->have_ref[kind]) {
        const result *ref = &ts->ref[kind];
        r->similarity = mr_vertex_similarity(r->out.positions, r->origin, r->out.vertex_count,
                                             ref->out.positions, ref->origin,
                                             ref->out.vertex_count);
    }
    return 1;
}

/* ---- peers ----------------------------------------------------------------- */

static size_t peer_target_triangles(const target_state *ts)
{
    if (ts->have_ref[0])
        return ts->ref[0].out.triangle_count;
    return (size_t)(ts->ratio * (double)ts->in->triangle_count);
}

static int run_meshopt(const algorithm *alg, target_state *ts, int threads, result *r)
{
    (void)threads;
    if (!bench_have_meshopt())
        return 0;
    return bench_run_meshopt(ts->in, peer_target_triangles(ts), alg->sloppy, ts->cfg->runs,
                             &r->time, &r->runs, &r->peak_bytes, &r->out);
}

/* OpenMesh is an order of magnitude slower: its repeated runs stop once
 * they add up to this many seconds (at least one run). */
#define OPENMESH_BUDGET 20.0

static int run_openmesh(const algorithm *alg, target_state *ts, int threads, result *r)
{
    (void)alg, (void)threads;
    if (!bench_have_openmesh() || !ts->ply_path)
        return 0;
    size_t target_vertices = ts->have_ref[0]
                                 ? ts->ref[0].out.vertex_count
                                 : (size_t)(ts->ratio * (double)ts->in->vertex_count);
    char out_path[4200];
    snprintf(out_path, sizeof out_path, "%s/sweep-openmesh-out.ply", ts->cfg->dir);
    return bench_run_openmesh(ts->in, ts->ply_path, out_path, target_vertices, ts->cfg->runs,
                              ts->cfg->quick ? 2.0 : OPENMESH_BUDGET, 0, &r->time, &r->runs,
                              &r->peak_bytes, &r->out);
}

/* CGAL's edge collapse (policy in the algorithm's name: cgal-lt,
 * cgal-gh) to the edge count of the greedy full reference's output. */
static int run_cgal(const algorithm *alg, target_state *ts, int threads, result *r)
{
    (void)threads;
    if (!bench_have_cgal() || !ts->ply_path)
        return 0;
    size_t edges = ts->have_ref[0] ? bench_edge_count(ts->ref[0].out.indices,
                                                      ts->ref[0].out.triangle_count)
                                   : (size_t)(ts->ratio * 1.5 * (double)ts->in->triangle_count);
    char out_path[4200];
    snprintf(out_path, sizeof out_path, "%s/sweep-cgal-out.ply", ts->cfg->dir);
    return bench_run_cgal(alg->name + 5, ts->in, ts->ply_path, out_path, edges, ts->cfg->runs,
                          ts->cfg->quick ? 2.0 : OPENMESH_BUDGET, 0, &r->time, &r->runs,
                          &r->peak_bytes, &r->out);
}

/* The algorithms, in run order: the greedy references first (the others
 * compare with them). */
static const algorithm algorithms[] = {
    {"mr-greedy-full", run_simplify, 0, MR_COLLAPSE_FULL, MR_STRATEGY_GREEDY, 1, 0,
     MR_QUALITY_DEFAULT},
    {"mr-greedy-half", run_simplify, 0, MR_COLLAPSE_HALF, MR_STRATEGY_GREEDY, 1, 0,
     MR_QUALITY_DEFAULT},
    {"meshreduce-full", run_simplify, 1, MR_COLLAPSE_FULL, MR_STRATEGY_BATCHED, 0, 0,
     MR_QUALITY_DEFAULT},
    {"meshreduce-half", run_simplify, 1, MR_COLLAPSE_HALF, MR_STRATEGY_BATCHED, 0, 0,
     MR_QUALITY_DEFAULT},
    {"meshreduce-best", run_simplify, 0, MR_COLLAPSE_FULL, MR_STRATEGY_BATCHED, 0, 0,
     MR_QUALITY_BEST},
    {"meshreduce-partitioned", run_simplify, 1, MR_COLLAPSE_FULL, MR_STRATEGY_PARTITIONED, 0, 0,
     MR_QUALITY_DEFAULT},
    {"meshreduce-part-boundary", run_simplify, 1, MR_COLLAPSE_FULL,
     MR_STRATEGY_PARTITIONED_BOUNDARY, 0, 0, MR_QUALITY_DEFAULT},
    {"meshopt", run_meshopt, 0, 0, 0, 0, 0, MR_QUALITY_DEFAULT},
    {"meshopt-sloppy", run_meshopt, 0, 0, 0, 0, 1, MR_QUALITY_DEFAULT},
    {"openmesh", run_openmesh, 0, 0, 0, 0, 0, MR_QUALITY_DEFAULT},
    {"cgal-lt", run_cgal, 0, 0, 0, 0, 0, MR_QUALITY_DEFAULT},
    {"cgal-gh", run_cgal, 0, 0, 0, 0, 0, MR_QUALITY_DEFAULT},
};
enum { N_ALGORITHMS = sizeof algorithms / sizeof *algorithms };

/* ---- meshes ------------------------------------------------------------------ */

typedef struct mesh_spec {
    const char *name;
    const char *file;       /* in the data folder, or NULL: generated */
    size_t triangles;       /* generated */
    int quick;              /* the --quick set */
} mesh_spec;

static const mesh_spec specs[] = {
    {"scan-20k", NULL, 20000, 1},
    {"scan-1M", NULL, 1000000, 0},
    {"bunny", "stanford-bunny.obj", 0, 0},
    {"armadillo", "armadillo.obj", 0, 0},
};

static int load_mesh(const config *cfg, const mesh_spec *s, mr_mesh *mesh, char *source,
                     size_t source_size)
{
    if (!bench_load_mesh(cfg->data, s->file, s->triangles, 0, mesh, NULL, NULL))
        return 0;
    if (!s->file)
        snprintf(source, source_size, "generate:scan:%zu:1", s->triangles);
    else
        snprintf(source, source_size, "file:%s/%s", cfg->data, s->file);
    return 1;
}

/* ---- output ------------------------------------------------------------------- */

static void csv_num(FILE *f, double v, int measured)
{
    if (measured)
        fprintf(f, ",%.9g", v);
    else
        fputc(',', f);
}

static void quality(const config *cfg, const mr_mesh *in, result *r)
{
    mr_compare_options opt;
    mr_compare_options_default(&opt);
    opt.samples = cfg->samples;
    opt.threads = cfg->all_threads;
    omp_set_num_threads(cfg->all_threads);
    mr_compare_result res;
    mr_error err;
    r->hausdorff_rel = r->rms_rel = -1;
    if (r->out.triangle_count == 0)
        return;
    if (mr_compare(in->positions, in->vertex_count, in->indices, in->triangle_count,
                   r->out.positions, r->out.vertex_count, r->out.indices, r->out.triangle_count,
                   &opt, &res, &err) != MR_OK) {
        fprintf(stderr, "sweep: mr_compare: %s\n", err.message);
        return;
    }
    r->hausdorff_rel = res.hausdorff_rel;
    r->rms_rel = res.rms_rel;
}

static void write_row(FILE *f, const char *mesh, const algorithm *alg, int threads,
                      double ratio, const mr_mesh *in, const result *r)
{
    double tps = r->time.median > 0 ? (double)in->triangle_count / r->time.median : 0;
    fprintf(f, "%s,%s,%d,%g,%zu,%zu,%d", mesh, alg->name, threads, ratio, in->triangle_count,
            r->out.triangle_count, r->runs);
    csv_num(f, r->time.median, 1);
    csv_num(f, r->time.min, 1);
    csv_num(f, r->time.max, 1);
    csv_num(f, tps, r->time.median > 0);
    csv_num(f, r->peak_bytes / (double)in->triangle_count, r->peak_bytes >= 0);
    csv_num(f, r->hausdorff_rel, r->hausdorff_rel >= 0);
    csv_num(f, r->rms_rel, r->rms_rel >= 0);
    csv_num(f, r->similarity, r->similarity >= 0);
    fputc('\n', f);
    fflush(f);
}

static void result_free(result *r)
{
    bench_output_free(&r->out);
    free(r->origin);
    memset(r, 0, sizeof *r);
}

static int parse_threads(const char *s, config *cfg)
{
    cfg->n_threads = 0;
    while (*s && cfg->n_threads < MAX_THREADS_LIST) {
        char *end;
        long v = strtol(s, &end, 10);
        if (end == s || v < 1 || v > 4096)
            return -1;
        cfg->threads[cfg->n_threads++] = (int)v;
        s = *end == ',' ? end + 1 : end;
        if (*end && *end != ',')
            return -1;
    }
    return cfg->n_threads ? 0 : -1;
}

static void add_thread_count(config *cfg, int t)
{
    for (int i = 0; i < cfg->n_threads; i++)
        if (cfg->threads[i] == t)
            return;
    if (cfg->n_threads < MAX_THREADS_LIST)
        cfg->threads[cfg->n_threads++] = t;
}

static void usage(void)
{
    fprintf(stderr, "usage: sweep [--quick] [--runs R] [--csv FILE] [--threads 1,2,...] "
                    "[--samples N] [--data DIR] [--dir DIR] [--mesh NAME]...\n");
    exit(2);
}

int main(int argc, char **argv)
{
    config cfg = {0, 3, {0}, 0, 200000, MR_SHARED_DATA, "out/bench", 1};
    const char *csv_path = "bench/report/sweep.csv";
    const char *only[16];
    int n_only = 0, runs_given = 0, threads_given = 0, samples_given = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--quick"))
            cfg.quick = 1;
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            cfg.runs = atoi(argv[++i]), runs_given = 1;
        else if (!strcmp(argv[i], "--csv") && i + 1 < argc)
            csv_path = argv[++i];
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) {
            if (parse_threads(argv[++i], &cfg) != 0)
                usage();
            threads_given = 1;
        } else if (!strcmp(argv[i], "--samples") && i + 1 < argc)
            cfg.samples = (size_t)strtod(argv[++i], NULL), samples_given = 1;
        else if (!strcmp(argv[i], "--data") && i + 1 < argc)
            cfg.data = argv[++i];
        else if (!strcmp(argv[i], "--dir") && i + 1 < argc)
            cfg.dir = argv[++i];
        else if (!strcmp(argv[i], "--mesh") && i + 1 < argc && n_only < 16)
            only[n_only++] = argv[++i];
        else
            usage();
    }
    cfg.all_threads = omp_get_max_threads();
    if (!threads_given) {
        add_thread_count(&cfg, 1);
        add_thread_count(&cfg, 2);
        if (!cfg.quick)
            add_thread_count(&cfg, cfg.all_threads);
    }
    if (cfg.quick && !runs_given)
        cfg.runs = 1;
    if (cfg.quick && !samples_given)
        cfg.samples = 10000;
    if (cfg.runs < 1)
        cfg.runs = 1;
    const double full_targets[] = {0.25, 0.10, 0.01}, quick_targets[] = {0.10, 0.01};
    const double *targets = cfg.quick ? quick_targets : full_targets;
    const int n_targets = cfg.quick ? 2 : 3;

    char cmd[8500], csv_dir[4200];
    snprintf(csv_dir, sizeof csv_dir, "%s", csv_path);
    char *slash = strrchr(csv_dir, '/');
    if (slash)
        *slash = '\0';
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' '%s'", cfg.dir, slash ? csv_dir : ".");
    if (system(cmd) != 0) {
        fprintf(stderr, "sweep: cannot create %s\n", cfg.dir);
        return 1;
    }
    /* Written beside the destination and renamed at the end: a failed
     * sweep leaves the last complete CSV in place. */
    char tmp_path[4200];
    snprintf(tmp_path, sizeof tmp_path, "%s.partial", csv_path);
    FILE *csv = fopen(tmp_path, "w");
    if (!csv) {
        fprintf(stderr, "sweep: cannot write %s\n", tmp_path);
        return 1;
    }
    bench_print_machine(stdout);
    fputs("# ", csv);
    bench_print_machine(csv);
    time_t now = time(NULL);
    char date[32];
    strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", gmtime(&now));
    fprintf(csv, "# date: %s\n", date);
    fprintf(csv, "# runs: %d; samples: %zu; peers: meshopt %s, openmesh %s, cgal %s\n",
            cfg.runs, cfg.samples, bench_have_meshopt() ? "yes" : "no",
            bench_have_openmesh() ? "yes" : "no", bench_have_cgal() ? "yes" : "no");

    /* The mesh lines first, so the report knows every source. */
    mr_mesh meshes[sizeof specs / sizeof *specs];
    int loaded[sizeof specs / sizeof *specs] = {0};
    for (size_t si = 0; si < sizeof specs / sizeof *specs; si++) {
        const mesh_spec *s = &specs[si];
        int wanted = n_only == 0 ? s->quick == cfg.quick : 0;
        for (int k = 0; k < n_only; k++)
            wanted |= !strcmp(only[k], s->name);
        char source[4200];
        if (!wanted || !load_mesh(&cfg, s, &meshes[si], source, sizeof source))
            continue;
        loaded[si] = 1;
        fprintf(csv, "# mesh %s %s\n", s->name, source);
    }
    fprintf(csv, "mesh,algorithm,threads,target,input_triangles,output_triangles,runs,"
                 "time_median,time_min,time_max,triangles_per_second,"
                 "peak_bytes_per_triangle,hausdorff_rel,rms_rel,vertex_similarity\n");

    printf("%-10s %-22s %3s %6s %10s %9s %9s %7s %9s %9s %6s\n", "mesh", "algorithm", "thr",
           "target", "out tris", "median s", "Mtri/s", "B/tri", "Hausdorff", "RMS", "simil");
    for (size_t si = 0; si < sizeof specs / sizeof *specs; si++) {
        if (!loaded[si])
            continue;
        const mesh_spec *s = &specs[si];
        mr_mesh *in = &meshes[si];
        char ply[4200];
        const char *ply_path = NULL;
        if (bench_have_openmesh() || bench_have_cgal()) {
            snprintf(ply, sizeof ply, "%s/sweep-%s.ply", cfg.dir, s->name);
            mr_write_options wo;
            mr_write_options_default(&wo);
            wo.format = MR_FORMAT_PLY;
            mr_error err;
            bench_check(mr_mesh_write(ply, in, &wo, &err), &err);
            ply_path = ply;
        }
        for (int ti = 0; ti < n_targets; ti++) {
            target_state ts;
            memset(&ts, 0, sizeof ts);
            ts.in = in;
            ts.ratio = targets[ti];
            ts.cfg = &cfg;
            ts.ply_path = ply_path;
            for (int a = 0; a < N_ALGORITHMS; a++) {
                const algorithm *alg = &algorithms[a];
                for (int k = 0; k < (alg->threaded ? cfg.n_threads : 1); k++) {
                    int threads = alg->threaded ? cfg.threads[k] : 1;
                    result r;
                    memset(&r, 0, sizeof r);
                    r.peak_bytes = r.similarity = -1;
                    if (!alg->run(alg, &ts, threads, &r)) {
                        result_free(&r);
                        break;
                    }
                    quality(&cfg, in, &r);
                    write_row(csv, s->name, alg, threads, ts.ratio, in, &r);
                    char simil[16] = "-";
                    if (r.similarity >= 0)
                        snprintf(simil, sizeof simil, "%.3f", r.similarity);
                    printf("%-10s %-22s %3d %5g%% %10zu %9.4f %9.2f %7.0f %8.4f%% %8.4f%% %6s\n",
                           s->name, alg->name, threads, 100 * ts.ratio, r.out.triangle_count,
                           r.time.median,
                           r.time.median > 0 ? in->triangle_count / r.time.median / 1e6 : 0,
                           r.peak_bytes >= 0 ? r.peak_bytes / (double)in->triangle_count : -1,
                           100 * r.hausdorff_rel, 100 * r.rms_rel, simil);
                    fflush(stdout);
                    if (alg->reference) {
                        int kind = alg->collapse == MR_COLLAPSE_HALF;
                        ts.ref[kind] = r;
                        ts.have_ref[kind] = 1;
                    } else {
                        result_free(&r);
                    }
                }
            }
            for (int kind = 0; kind < 2; kind++)
                if (ts.have_ref[kind])
                    result_free(&ts.ref[kind]);
        }
        if (ply_path)
            unlink(ply_path);
        mr_mesh_free(in);
    }
    int ok = fclose(csv) == 0;
    if (!ok || rename(tmp_path, csv_path) != 0) {
        fprintf(stderr, "sweep: cannot write %s\n", csv_path);
        unlink(tmp_path);
        return 1;
    }
    printf("csv: %s\n", csv_path);
    return 0;
}
