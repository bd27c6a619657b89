/*
 * Sequential simplification benchmark: greedy quadric-error edge collapse
 * (mr_simplify, 1 thread, both collapse kinds) on generated scan-like meshes
 * of 1M and 4M triangles and on the shared test meshes (../shared/data, those
 * present; skipped cleanly when the folder is absent), each reduced to 25 %,
 * 10 % and 1 % of its referenced vertices. In the same run, the peers that
 * were found when the benchmark was configured:
 *   meshopt         meshopt_simplify (options 0: nothing locked; target_error
 *                   FLT_MAX: error limit off), asked for the triangle count
 *                   our full-collapse run reached;
 *   meshopt-sloppy  meshopt_simplifySloppy, same target;
 *   openmesh        OpenMesh's DecimaterT + ModQuadricT (no error limit, no
 *                   other module) via the driver openmesh_decimate, asked for
 *                   the vertex count our full-collapse run reached; its
 *                   repeated runs stop after 20 s in all (at least one run;
 *                   the table then names the run count: "openmesh (1)").
 *
 *   bench_simplify [--runs R] [--quick] [--csv FILE] [--samples N]
 *                  [--data DIR] [--dir DIR] [--mesh NAME]... [--keep]
 *
 * --runs R     timed runs per (mesh, target, algorithm), default 3; the table
 *              gives their median, min and max
 * --quick      only scan-1M, bunny and armadillo at 10 % and 1 % (the meshes
 *              and targets the bars below use), 1 run unless --runs is given
 * --csv FILE   also write one row per (mesh, target, algorithm)
 * --samples N  surface samples per mesh for mr_compare (default 200,000)
 * --data DIR   the test meshes (default: ../shared/data beside the checkout)
 * --dir DIR    temporary files for the OpenMesh driver (default out/bench)
 * --mesh NAME  only this mesh (repeatable): scan-1M, scan-4M, bunny, ...
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
 *   options.threads = 1 and omp_set_num_threads(1); the peers are
 *   single-threaded.
 *   Memory: one more simplification per configuration in a forked child (so
 *   peaks do not accumulate), after malloc_trim: the child resets its peak
 *   resident set through /proc/self/clear_refs ("5"), notes VmRSS (the loaded
 *   mesh and the rest of the process: the baseline), runs, and reports VmHWM
 *   minus that baseline; without clear_refs, the child's own ru_maxrss
 *   (getrusage, which starts at its resident set at the fork) minus the
 *   parent's VmRSS at the fork. The OpenMesh driver does the same
 *   in its own process around the first decimation of a copy of the loaded
 *   mesh. Reported as bytes per input triangle; it includes the output.
 *   Quality: mr_compare of the input (reference) and the output, with
 *   options.samples = N (200,000 by default) area-uniform samples per mesh
 *   besides the vertices; symmetric Hausdorff distance and RMS relative to
 *   the input's bounding-box diagonal. Outputs are compacted first (meshopt's
 *   index buffer refers to the input vertex array; mr_compare samples every
 *   vertex it is given).
 *
 * CSV format (stable: later sweeps and reports read it). Header line, then
 * one row per (mesh, target, algorithm):
 *   mesh,algorithm,threads,target,input_triangles,output_triangles,
 *   time_median,time_min,time_max,triangles_per_second,
 *   peak_bytes_per_triangle,hausdorff_rel,rms_rel
 * mesh: scan-1M, scan-4M, bunny, armadillo, ...; algorithm: meshreduce-full,
 * meshreduce-half, meshopt, meshopt-sloppy, openmesh; target: the fraction of
 * referenced input vertices asked for (0.25, 0.1, 0.01); times in seconds;
 * time_min, time_max: over the runs made (--runs; openmesh's may be fewer,
 * see above); triangles_per_second: input triangles / time_median;
 * peak_bytes_per_triangle: see Memory above; hausdorff_rel and
 * rms_rel: fractions of the input's bounding-box diagonal. A value that was
 * not measured is an empty field.
 */
#include "benchpeers.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Ours first: ALG_FULL (the default options) is the row the others are
 * compared with; ALG_FULL..ALG_GREEDY_HALF are all meshreduce's. */
enum {
    ALG_FULL,
    ALG_HALF,
    ALG_GREEDY_FULL,
    ALG_GREEDY_HALF,
    ALG_MESHOPT,
    ALG_SLOPPY,
    ALG_OPENMESH,
    ALG_COUNT
};
static const char *const alg_name[ALG_COUNT] = {
    "meshreduce-full",  "meshreduce-half", "mr-greedy-full", "mr-greedy-half",
    "meshopt",          "meshopt-sloppy",  "openmesh"};

#define TARGET_COUNT 3
static const double target_ratio[TARGET_COUNT] = {0.25, 0.10, 0.01};

/* One measured (mesh, target, algorithm). Negative values: not measured. */
typedef struct row {
    int done;
    int runs;           /* timed runs behind time */
    bench_summary time;
    size_t out_vertices, out_triangles;
    double peak_bytes;
    double hausdorff_rel, rms_rel;
} row;

typedef struct mesh_result {
    char name[32];
    size_t input_triangles;
    row rows[TARGET_COUNT][ALG_COUNT];
} mesh_result;

typedef struct config {
    int runs;
    int quick;
    size_t samples;
    int all_threads;
    const char *data;
    const char *dir;
    int keep;
} config;

/* ------------------------------------------------------------------------ */
/* Quality                                                                  */
/* ------------------------------------------------------------------------ */

static void measure_quality(const config *cfg, const mr_mesh *in, const float *positions,
                            size_t vertex_count, const uint32_t *indices, size_t triangle_count,
                            row *r)
{
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

static void run_ours(const config *cfg, const mr_mesh *in, double ratio, int alg, row *r)
{
    mr_simplify_options opt;
    mr_simplify_options_default(&opt);
    opt.target_ratio = ratio;
    opt.collapse = alg == ALG_HALF || alg == ALG_GREEDY_HALF ? MR_COLLAPSE_HALF
                                                             : MR_COLLAPSE_FULL;
    if (alg == ALG_GREEDY_FULL || alg == ALG_GREEDY_HALF)
        opt.strategy = MR_STRATEGY_GREEDY;
    opt.threads = 1;
    mr_simplified out;
    r->runs = cfg->runs;
    bench_run_ours(in, &opt, r->runs, &r->time, &r->peak_bytes, &out);
    r->out_vertices = out.vertex_count;
    r->out_triangles = out.triangle_count;
    measure_quality(cfg, in, out.positions, out.vertex_count, out.indices, out.triangle_count, r);
    mr_simplified_free(&out);
    r->done = 1;
}

/* ------------------------------------------------------------------------ */
/* Peers (benchpeers.h)                                                     */
/* ------------------------------------------------------------------------ */

/* A peer's output (ok: it ran) into r, with its quality; frees out. */
static void finish_peer(const config *cfg, const mr_mesh *in, int ok, bench_output *out, row *r)
{
    if (ok) {
        r->out_vertices = out->vertex_count;
        r->out_triangles = out->triangle_count;
        measure_quality(cfg, in, out->positions, out->vertex_count, out->indices,
                        out->triangle_count, r);
        r->done = 1;
    }
    bench_output_free(out);
}

static void run_meshopt(const config *cfg, const mr_mesh *in, size_t target_triangles,
                        int sloppy, row *r)
{
    bench_output out = {0};
    int ok = bench_run_meshopt(in, target_triangles, sloppy, cfg->runs, &r->time, &r->runs,
                               &r->peak_bytes, &out);
    finish_peer(cfg, in, ok, &out, r);
}

/* OpenMesh is an order of magnitude slower: its repeated runs stop once they
 * add up to this many seconds (at least one run). */
#define OPENMESH_BUDGET 20.0

static void run_openmesh(const config *cfg, const mr_mesh *in, const char *in_path,
                         const char *out_path, size_t target_vertices, row *r)
{
    bench_output out = {0};
    int ok = bench_run_openmesh(in, in_path, out_path, target_vertices, cfg->runs,
                                OPENMESH_BUDGET, cfg->keep, &r->time, &r->runs, &r->peak_bytes,
                                &out);
    finish_peer(cfg, in, ok, &out, r);
}

/* ------------------------------------------------------------------------ */
/* Output                                                                   */
/* ------------------------------------------------------------------------ */

static void fmt_ratio(char *buf, size_t size, double peer, double ours)
{
    if (peer >= 0 && ours > 0)
        snprintf(buf, size, "%.2f", peer / ours);
    else
        snprintf(buf, size, "-");
}

static void print_header(void)
{
    printf("%-6s %-19s %10s %9s %9s %9s %9s %7s %6s %10s %10s %6s %6s %6s\n", "target",
           "algorithm", "out tris", "out verts", "median s", "min s", "max s", "Mtri/s", "B/tri",
           "Hausdorff", "RMS", "t/ours", "H/ours", "R/ours");
}

/* Rows timed over fewer runs than asked name their run count. */
static int runs_asked = 1;

static void print_row(const mesh_result *m, int ti, int a)
{
    const row *r = &m->rows[ti][a];
    const row *ours = &m->rows[ti][ALG_FULL];
    if (!r->done)
        return;
    char peak[16], h[16], rms[16], rt[16] = "", rh[16] = "", rr[16] = "";
    if (r->peak_bytes >= 0)
        snprintf(peak, sizeof peak, "%.0f", r->peak_bytes / (double)m->input_triangles);
    else
        snprintf(peak, sizeof peak, "-");
    if (r->hausdorff_rel >= 0) {
        snprintf(h, sizeof h, "%.5f%%", 100 * r->hausdorff_rel);
        snprintf(rms, sizeof rms, "%.5f%%", 100 * r->rms_rel);
    } else {
        snprintf(h, sizeof h, "-");
        snprintf(rms, sizeof rms, "-");
    }
    if (a != ALG_FULL && ours->done) {
        fmt_ratio(rt, sizeof rt, r->time.median, ours->time.median);
        fmt_ratio(rh, sizeof rh, r->hausdorff_rel, ours->hausdorff_rel);
        fmt_ratio(rr, sizeof rr, r->rms_rel, ours->rms_rel);
    }
    char target[16], name[32];
    snprintf(target, sizeof target, "%g%%", 100 * target_ratio[ti]);
    if (r->runs < runs_asked)
        snprintf(name, sizeof name, "%s (%d)", alg_name[a], r->runs);
    else
        snprintf(name, sizeof name, "%s", alg_name[a]);
    printf("%-6s %-19s %10zu %9zu %9.4f %9.4f %9.4f %7.2f %6s %10s %10s %6s %6s %6s\n", target,
           name, r->out_triangles, r->out_vertices, r->time.median, r->time.min, r->time.max,
           r->time.median > 0 ? (double)m->input_triangles / r->time.median / 1e6 : 0, peak, h,
           rms, rt, rh, rr);
    fflush(stdout);
}

static void csv_num(FILE *f, double v, int measured)
{
    if (measured)
        fprintf(f, ",%.9g", v);
    else
        fputc(',', f);
}

static void write_csv_rows(FILE *f, const mesh_result *m)
{
    for (int ti = 0; ti < TARGET_COUNT; ti++)
        for (int a = 0; a < ALG_COUNT; a++) {
            const row *r = &m->rows[ti][a];
            if (!r->done)
                continue;
            fprintf(f, "%s,%s,1,%g,%zu,%zu", m->name, alg_name[a], target_ratio[ti],
                    m->input_triangles, r->out_triangles);
            csv_num(f, r->time.median, 1);
            csv_num(f, r->time.min, 1);
            csv_num(f, r->time.max, 1);
            csv_num(f, r->time.median > 0 ? (double)m->input_triangles / r->time.median : 0,
                    r->time.median > 0);
            csv_num(f, r->peak_bytes / (double)m->input_triangles, r->peak_bytes >= 0);
            csv_num(f, r->hausdorff_rel, r->hausdorff_rel >= 0);
            csv_num(f, r->rms_rel, r->rms_rel >= 0);
            fputc('\n', f);
        }
    fflush(f);
}

/* ------------------------------------------------------------------------ */
/* Meshes                                                                   */
/* ------------------------------------------------------------------------ */

typedef struct mesh_spec {
    const char *name;
    const char *file;       /* in the data folder, or NULL: generated */
    size_t triangles;       /* generated */
    int quick;              /* part of --quick */
} mesh_spec;

static const mesh_spec specs[] = {
    {"scan-1M", NULL, 1000000, 1},
    {"scan-4M", NULL, 4000000, 0},
    {"bunny", "stanford-bunny.obj", 0, 1},
    {"armadillo", "armadillo.obj", 0, 1},
    {"nefertiti", "nefertiti.obj", 0, 0},
    {"ogre", "ogre.obj", 0, 0},
    {"fandisk", "fandisk.obj", 0, 0},
    {"homer", "homer.obj", 0, 0},
    {"igea", "igea.ply", 0, 0},
};

/* Load or generate, then keep positions and non-degenerate triangles over
 * referenced vertices only. Returns 0 when a file is absent. */
static int load_mesh(const config *cfg, const mesh_spec *s, mr_mesh *mesh)
{
    mr_error err;
    mr_mesh_init(mesh);
    if (!s->file) {
        bench_check(mr_generate(MR_GEN_SCAN, s->triangles, 1, mesh, &err), &err);
    } else {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", cfg->data, s->file);
        if (access(path, R_OK) != 0)
            return 0;
        mr_read_options ro;
        mr_read_options_default(&ro);
        ro.threads = cfg->all_threads;
        bench_check(mr_mesh_read(path, &ro, mesh, &err), &err);
    }
    free(mesh->normals);
    free(mesh->texcoords);
    free(mesh->colors);
    mesh->normals = mesh->texcoords = NULL;
    mesh->colors = NULL;
    size_t degenerate = 0, unreferenced = 0;
    bench_check(mr_mesh_remove_degenerate(mesh, 0, &degenerate, &err), &err);
    bench_check(mr_mesh_remove_unreferenced(mesh, &unreferenced, &err), &err);
    printf("\nmesh %s: %zu vertices, %zu triangles", s->name, mesh->vertex_count,
           mesh->triangle_count);
    if (!s->file)
        printf(" (mr_generate scan, seed 1)");
    else
        printf(" (%s", s->file);
    if (s->file && (degenerate || unreferenced))
        printf("; removed %zu degenerate triangles, %zu unreferenced vertices", degenerate,
               unreferenced);
    printf("%s\n", s->file ? ")" : "");
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

static void print_bars(const mesh_result *res, int n)
{
    printf("\nbars (information only):\n");
    const mesh_result *m1 = find_mesh(res, n, "scan-1M");
    int t10 = target_index(0.10), t1 = target_index(0.01);
    const row *full = m1 ? &m1->rows[t10][ALG_FULL] : NULL;
    const row *mo = m1 ? &m1->rows[t10][ALG_MESHOPT] : NULL;

    if (full && full->done && mo->done)
        printf("  %-4s speed: meshreduce-full %.4f s <= meshopt_simplify %.4f s on scan-1M to 10 %% "
               "(1 thread)\n",
               full->time.median <= mo->time.median ? "PASS" : "MISS", full->time.median,
               mo->time.median);
    else
        printf("  n/a  speed vs meshopt_simplify on scan-1M to 10 %% (not measured)\n");

    if (full && full->done) {
        double tps = (double)m1->input_triangles / full->time.median;
        printf("  %-4s throughput: %.2f M input triangles/s >= 1.5 on scan-1M to 10 %% "
               "(meshreduce-full, default options, 1 thread)\n",
               tps >= 1.5e6 ? "PASS" : "MISS", tps / 1e6);
    } else {
        printf("  n/a  throughput on scan-1M to 10 %% (not measured)\n");
    }

    /* Memory: the worst meshreduce row of the generated meshes (large
     * enough for per-triangle figures to mean something). */
    double worst = -1;
    char where[96] = "";
    for (int i = 0; i < n; i++) {
        if (strncmp(res[i].name, "scan-", 5) != 0)
            continue;
        for (int ti = 0; ti < TARGET_COUNT; ti++)
            for (int a = ALG_FULL; a <= ALG_GREEDY_HALF; a++) {
                const row *r = &res[i].rows[ti][a];
                if (!r->done || r->peak_bytes < 0)
                    continue;
                double b = r->peak_bytes / (double)res[i].input_triangles;
                if (b > worst) {
                    worst = b;
                    snprintf(where, sizeof where, "%s to %g %%, %s", res[i].name,
                             100 * target_ratio[ti], alg_name[a]);
                }
            }
    }
    if (worst >= 0)
        printf("  %-4s memory: peak %.0f bytes per input triangle <= 100 (worst over the scan "
               "meshes: %s)\n",
               worst <= 100 ? "PASS" : "MISS", worst, where);
    else
        printf("  n/a  memory (not measured)\n");

    const char *qm[2] = {"bunny", "armadillo"};
    int qt[2] = {t10, t1};
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 2; k++) {
            const mesh_result *m = find_mesh(res, n, qm[i]);
            const row *o = m ? &m->rows[qt[k]][ALG_FULL] : NULL;
            const row *p = m ? &m->rows[qt[k]][ALG_MESHOPT] : NULL;
            if (!o || !o->done || !p->done || o->hausdorff_rel < 0 || p->hausdorff_rel < 0) {
                printf("  n/a  quality on %s to %g %% (not measured)\n", qm[i],
                       100 * target_ratio[qt[k]]);
                continue;
            }
            int pass = o->hausdorff_rel <= p->hausdorff_rel && o->rms_rel <= p->rms_rel;
            printf("  %-4s quality on %s to %g %%: Hausdorff %.5f%% vs meshopt %.5f%%, RMS "
                   "%.5f%% vs %.5f%% (of the diagonal)\n",
                   pass ? "PASS" : "MISS", qm[i], 100 * target_ratio[qt[k]],
                   100 * o->hausdorff_rel, 100 * p->hausdorff_rel, 100 * o->rms_rel,
                   100 * p->rms_rel);
        }
}

/* ------------------------------------------------------------------------ */

static void usage(void)
{
    fprintf(stderr, "usage: bench_simplify [--runs R] [--quick] [--csv FILE] [--samples N] "
                    "[--data DIR] [--dir DIR] [--mesh NAME]... [--keep]\n");
    exit(2);
}

int main(int argc, char **argv)
{
    config cfg = {3, 0, 200000, 1, MR_SHARED_DATA, "out/bench", 0};
    const char *csv_path = NULL;
    int runs_given = 0;
    char **only = calloc((size_t)argc, sizeof *only);
    int n_only = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc) {
            cfg.runs = atoi(argv[++i]);
            runs_given = 1;
        } else if (!strcmp(argv[i], "--quick")) {
            cfg.quick = 1;
        } else if (!strcmp(argv[i], "--csv") && i + 1 < argc) {
            csv_path = argv[++i];
        } else if (!strcmp(argv[i], "--samples") && i + 1 < argc) {
            cfg.samples = (size_t)strtod(argv[++i], NULL);
        } else if (!strcmp(argv[i], "--data") && i + 1 < argc) {
            cfg.data = argv[++i];
        } else if (!strcmp(argv[i], "--dir") && i + 1 < argc) {
            cfg.dir = argv[++i];
        } else if (!strcmp(argv[i], "--mesh") && i + 1 < argc) {
            only[n_only++] = argv[++i];
        } else if (!strcmp(argv[i], "--keep")) {
            cfg.keep = 1;
        } else {
            usage();
        }
    }
    if (cfg.quick && !runs_given)
        cfg.runs = 1;
    if (cfg.runs < 1)
        cfg.runs = 1;
    runs_asked = cfg.runs;
    cfg.all_threads = omp_get_max_threads();
    omp_set_num_threads(1);

    FILE *csv = NULL;
    if (csv_path) {
        csv = fopen(csv_path, "w");
        if (!csv) {
            fprintf(stderr, "bench: cannot write %s\n", csv_path);
            return 1;
        }
        fprintf(csv, "mesh,algorithm,threads,target,input_triangles,output_triangles,"
                     "time_median,time_min,time_max,triangles_per_second,"
                     "peak_bytes_per_triangle,hausdorff_rel,rms_rel\n");
    }
    if (bench_have_openmesh()) {
        char cmd[4200];
        snprintf(cmd, sizeof cmd, "mkdir -p '%s'", cfg.dir);
        if (system(cmd) != 0) {
            fprintf(stderr, "bench: cannot create %s\n", cfg.dir);
            return 1;
        }
    }

    bench_print_machine(stdout);
    printf("simplification to 25/10/1 %% of the referenced vertices; 1 thread; time: median "
           "(min, max) of %d run%s; peak memory: growth of the peak resident set in a forked "
           "child, per input triangle; Hausdorff, RMS: mr_compare with %zu samples per mesh, "
           "%% of the input's bounding-box diagonal; ratios: peer / meshreduce-full "
           "(> 1: meshreduce is faster / closer)\n",
           cfg.runs, cfg.runs == 1 ? "" : "s", cfg.samples);
    printf("peers: meshopt %s; OpenMesh %s\n",
           bench_have_meshopt()
               ? "0.18-style C API, meshopt_simplify (options 0, target_error FLT_MAX, same "
                 "triangle count) and meshopt_simplifySloppy"
               : "not built in (meshoptimizer not found at configure time)",
           bench_have_openmesh() ? "Decimater + ModQuadric (same vertex count), subprocess"
                                 : "not built in (OpenMesh or C++ not found at configure time)");
    if (access(cfg.data, R_OK) != 0)
        printf("data folder %s absent: only the generated meshes\n", cfg.data);

    size_t n_specs = sizeof specs / sizeof *specs;
    mesh_result *results = calloc(n_specs, sizeof *results);
    int n_results = 0;
    for (size_t si = 0; si < n_specs; si++) {
        const mesh_spec *s = &specs[si];
        if ((cfg.quick && !s->quick) || !wanted(s->name, only, n_only))
            continue;
        mr_mesh mesh;
        if (!load_mesh(&cfg, s, &mesh))
            continue;
        mesh_result *m = &results[n_results++];
        snprintf(m->name, sizeof m->name, "%s", s->name);
        m->input_triangles = mesh.triangle_count;
        char om_in[4200], om_out[4200];
        snprintf(om_in, sizeof om_in, "%s/simplify-%s.ply", cfg.dir, s->name);
        snprintf(om_out, sizeof om_out, "%s/simplify-%s-openmesh.ply", cfg.dir, s->name);
        int om_ready = 0;
        print_header();
        for (int ti = 0; ti < TARGET_COUNT; ti++) {
            double ratio = target_ratio[ti];
            if (cfg.quick && ratio > 0.2)
                continue;
            row *rows = m->rows[ti];
            for (int a = 0; a < ALG_COUNT; a++)
                rows[a].peak_bytes = rows[a].hausdorff_rel = rows[a].rms_rel = -1;
            for (int a = ALG_FULL; a <= ALG_GREEDY_HALF; a++) {
                run_ours(&cfg, &mesh, ratio, a, &rows[a]);
                print_row(m, ti, a);
            }
            if (bench_have_meshopt()) {
                run_meshopt(&cfg, &mesh, rows[ALG_FULL].out_triangles, 0, &rows[ALG_MESHOPT]);
                print_row(m, ti, ALG_MESHOPT);
                run_meshopt(&cfg, &mesh, rows[ALG_FULL].out_triangles, 1, &rows[ALG_SLOPPY]);
                print_row(m, ti, ALG_SLOPPY);
            }
            if (!bench_have_openmesh())
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
            run_openmesh(&cfg, &mesh, om_in, om_out, rows[ALG_FULL].out_vertices,
                         &rows[ALG_OPENMESH]);
            print_row(m, ti, ALG_OPENMESH);
        }
        if (om_ready && !cfg.keep)
            unlink(om_in);
        if (csv)
            write_csv_rows(csv, m);
        mr_mesh_free(&mesh);
    }

    print_bars(results, n_results);
    if (csv) {
        fclose(csv);
        printf("csv: %s\n", csv_path);
    }
    free(results);
    free(only);
    return 0;
}
