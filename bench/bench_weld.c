/*
 * Epsilon-welding benchmark, the shape of the P-Weld paper's experiments:
 * for each mesh, the radii that remove 0.1 %, 1 %, 10 % and 50 % of the
 * vertices (found by the epsilon finder, strict comparison as Open3D), the
 * time of each phase of S-Weld, P-Weld and P-Weld-Async at 1 and 2 threads
 * (and 16 when the machine has them), checked bitwise equal to S-Weld; and
 * Open3D's merge_close_vertices on the same mesh and radii in the same run
 * when python3-open3d is installed, as a ratio to our whole weld.
 *
 *   bench_weld [--quick] [--runs R] [--csv FILE] [--dir DIR] [--no-open3d] [--no-large]
 *
 * Meshes: generated scans of 1M and 10M triangles (200k with --quick) and
 * the ../shared/data meshes when present (the bunny only with --quick);
 * --no-large leaves out the 10M-triangle scan.
 */
#include "benchutil.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct row {
    const char *mesh;
    double share, eps;
    const char *algorithm;
    int threads;
    double graph, mapping, reduction, retri, total;
    size_t out_vertices;
    unsigned rounds;
    double bytes_per_vertex;
} row;

static const char *alg_name(mr_weld_algorithm a)
{
    return a == MR_WELD_SERIAL ? "serial" : a == MR_WELD_PWELD ? "pweld" : "pweld-async";
}

static FILE *csv;

static void print_row(const row *r, double open3d)
{
    char ratio[32] = "";
    if (open3d > 0)
        snprintf(ratio, sizeof ratio, "%.1fx", open3d / r->total);
    printf("  %-11s %2d  %8.4f %8.4f %8.4f %8.4f %8.4f %6u %8zu %6.1f %8s\n", r->algorithm,
           r->threads, r->graph, r->mapping, r->reduction, r->retri, r->total, r->rounds,
           r->out_vertices, r->bytes_per_vertex, ratio);
    if (csv)
        fprintf(csv, "%s,%g,%.9g,%s,%d,%.6f,%.6f,%.6f,%.6f,%.6f,%u,%zu,%.2f,%.6f\n", r->mesh,
                r->share, r->eps, r->algorithm, r->threads, r->graph, r->mapping, r->reduction,
                r->retri, r->total, r->rounds, r->out_vertices, r->bytes_per_vertex, open3d);
}

/* Open3D's medians for the radii, by running the helper once per mesh. */
static void open3d_times(const char *path, int runs, const double *eps, int n, double *out)
{
    char cmd[8192];
    int len = snprintf(cmd, sizeof cmd, "%s '%s/open3d_weld.py' time '%s' %d", bench_python(),
                       MR_BENCH_DIR, path, runs);
    for (int i = 0; i < n; i++)
        len += snprintf(cmd + len, sizeof cmd - (size_t)len, " %.17g", eps[i]);
    char *text = bench_capture(cmd);
    for (int i = 0; i < n; i++)
        out[i] = 0;
    if (!text)
        return;
    char *line = strtok(text, "\n");
    for (int i = 0; i < n && line; i++, line = strtok(NULL, "\n")) {
        double e, s;
        if (sscanf(line, "%lf %lf", &e, &s) == 2)
            out[i] = s;
    }
    free(text);
}

static void bench_mesh(const char *name, const mr_mesh *m, int runs, bool use_open3d,
                       const char *dir)
{
    static const double shares[] = {0.001, 0.01, 0.1, 0.5};
    enum { NS = 4 };
    double eps[NS];
    mr_error err;
    mr_weld_options o;
    mr_weld_options_default(&o);
    o.strict = 1;
    double t0 = bench_now();
    for (int i = 0; i < NS; i++)
        bench_check(mr_weld_find_eps(m->positions, 0, m->vertex_count, shares[i], &o, &eps[i],
                                     NULL, &err),
                    &err);
    printf("\n%s: %zu vertices, %zu triangles (radii found in %.1f s)\n", name, m->vertex_count,
           m->triangle_count, bench_now() - t0);

    double o3d[NS] = {0};
    if (use_open3d) {
        char path[4096];
        snprintf(path, sizeof path, "%s/weld-%d.ply", dir, (int)getpid());
        bench_check(mr_mesh_write(path, m, NULL, &err), &err);
        open3d_times(path, runs, eps, NS, o3d);
        unlink(path);
    }
    int cores = omp_get_num_procs();
    int threads[3] = {1, 2, 16};
    int nthreads = cores >= 16 ? 3 : 2;
    for (int i = 0; i < NS; i++) {
        printf(" remove %.1f%%: eps %.6g; Open3D merge_close_vertices %s\n", 100 * shares[i],
               eps[i], o3d[i] > 0 ? "" : "not measured");
        if (o3d[i] > 0)
            printf("  Open3D: %.4f s\n", o3d[i]);
        printf("  %-11s %2s  %8s %8s %8s %8s %8s %6s %8s %6s %8s\n", "algorithm", "t", "graph",
               "mapping", "reduce", "retri", "total", "rounds", "vertices", "B/vert",
               "vs Open3D");
        mr_welded ref;
        o.eps = eps[i];
        o.algorithm = MR_WELD_SERIAL;
        o.threads = 1;
        bench_check(mr_weld(m->positions, 0, m->vertex_count, m->indices, m->triangle_count, &o,
                            &ref, &err),
                    &err);
        for (int a = MR_WELD_SERIAL; a <= MR_WELD_PWELD_ASYNC; a++)
            for (int t = 0; t < nthreads; t++) {
                double *s = calloc((size_t)runs * 5, sizeof *s);
                row r = {name, shares[i], eps[i], alg_name((mr_weld_algorithm)a), threads[t],
                         0, 0, 0, 0, 0, 0, 0, 0};
                for (int k = 0; k < runs; k++) {
                    mr_welded w;
                    o.algorithm = (mr_weld_algorithm)a;
                    o.threads = threads[t];
                    bench_check(mr_weld(m->positions, 0, m->vertex_count, m->indices,
                                        m->triangle_count, &o, &w, &err),
                                &err);
                    if (w.vertex_count != ref.vertex_count ||
                        memcmp(w.positions, ref.positions, w.vertex_count * 12) != 0 ||
                        memcmp(w.indices, ref.indices, w.triangle_count * 12) != 0) {
                        fprintf(stderr, "bench: %s at %d threads differs from S-Weld\n", r.algorithm,
                                threads[t]);
                        exit(1);
                    }
                    s[k] = w.stats.seconds_graph;
                    s[runs + k] = w.stats.seconds_mapping;
                    s[2 * runs + k] = w.stats.seconds_reduction;
                    s[3 * runs + k] = w.stats.seconds_retriangulation;
                    s[4 * runs + k] = w.stats.seconds_total;
                    r.rounds = w.stats.rounds;
                    r.out_vertices = w.vertex_count;
                    r.bytes_per_vertex = (double)w.stats.peak_bytes / (double)m->vertex_count;
                    mr_welded_free(&w);
                }
                r.graph = bench_summarize(s, runs).median;
                r.mapping = bench_summarize(s + runs, runs).median;
                r.reduction = bench_summarize(s + 2 * runs, runs).median;
                r.retri = bench_summarize(s + 3 * runs, runs).median;
                r.total = bench_summarize(s + 4 * runs, runs).median;
                print_row(&r, o3d[i]);
                free(s);
            }
        mr_welded_free(&ref);
    }
}

int main(int argc, char **argv)
{
    int quick = 0, runs = 0, use_open3d = 1, large = 1;
    const char *csv_path = NULL, *dir = "out/bench";
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--quick"))
            quick = 1;
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--csv") && i + 1 < argc)
            csv_path = argv[++i];
        else if (!strcmp(argv[i], "--dir") && i + 1 < argc)
            dir = argv[++i];
        else if (!strcmp(argv[i], "--no-open3d"))
            use_open3d = 0;
        else if (!strcmp(argv[i], "--no-large"))
            large = 0;
        else {
            fprintf(stderr, "usage: bench_weld [--quick] [--runs R] [--csv FILE] [--dir DIR] "
                            "[--no-open3d] [--no-large]\n");
            return 2;
        }
    }
    if (runs < 1)
        runs = quick ? 3 : 5;
    char cmd[4200];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", dir);
    if (system(cmd) != 0)
        return 1;
    if (csv_path) {
        csv = fopen(csv_path, "w");
        if (!csv) {
            fprintf(stderr, "bench: cannot write %s\n", csv_path);
            return 1;
        }
        fprintf(csv, "mesh,share_removed,eps,algorithm,threads,graph_s,mapping_s,reduction_s,"
                     "retriangulation_s,total_s,rounds,out_vertices,bytes_per_vertex,"
                     "open3d_s\n");
    }
    bench_print_machine(stdout);
    if (use_open3d && !bench_have_open3d()) {
        printf("(Open3D not measured: python3-open3d is not installed)\n");
        use_open3d = 0;
    }
    printf("times: median of %d runs (at most 3 on the 10M-triangle scan), seconds; total = "
           "whole weld (graph to output); B/vert = peak working bytes per input vertex\n",
           runs);
    mr_error err;
    const size_t sizes[] = {quick ? (size_t)200000 : (size_t)1000000, 10000000};
    for (int k = 0; k < (quick || !large ? 1 : 2); k++) {
        mr_mesh m;
        bench_check(mr_generate(MR_GEN_SCAN, sizes[k], 1, &m, &err), &err);
        char name[64];
        snprintf(name, sizeof name, "scan-%zuk", sizes[k] / 1000);
        /* Open3D takes about 5 s per call on the 10M mesh: at most 3 runs */
        bench_mesh(name, &m, k == 0 || runs < 3 ? runs : 3, use_open3d, dir);
        mr_mesh_free(&m);
    }
    const char *shared[] = {"stanford-bunny.obj", "armadillo.obj", "nefertiti.obj", "igea.ply"};
    for (int k = 0; k < (quick ? 1 : 4); k++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", MR_SHARED_DATA, shared[k]);
        if (access(path, R_OK) != 0)
            continue;
        mr_mesh m;
        bench_check(mr_mesh_read(path, NULL, &m, &err), &err);
        bench_mesh(shared[k], &m, runs, use_open3d, dir);
        mr_mesh_free(&m);
    }
    printf("\npeak RSS %.1f MB\n", (double)bench_peak_rss() / 1e6);
    if (csv)
        fclose(csv);
    return 0;
}
