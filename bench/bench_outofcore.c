/*
 * Out-of-core simplification against the in-memory default (bench_outofcore):
 *
 *   bench_outofcore [--sizes 4M,20M] [--large 100M,300M] [--runs N]
 *                   [--ratio R] [--dir DIR] [--csv FILE] [--mpi MPIEXEC]
 *                   [--cluster | --cluster-only] [--attributes | --attributes-only]
 *
 * For each generated scan (written once into DIR as binary PLY, streamed:
 * mr_generate_file), the whole process, as a user runs it: `meshreduce
 * simplify` in memory (the default budget) and out of core (--memory: 256M
 * for inputs up to 8M triangles, else 1G), at 1 and 2 threads, and
 * meshreduce-mpi on 1 and 2 ranks of one thread (--mpi, when built): wall
 * time (median of N alternating runs), input triangles a second, peak RSS
 * (the child's ru_maxrss), the chunks, the levels' times and the temporary
 * disk (--json). Then the quality of the outputs against the input (RMS and
 * Hausdorff, Metro-style, 1M samples) and the error near the chunk
 * planes: the mean distance from the output's triangle centroids to the
 * input surface near the tree's first cuts (within two mean edge lengths
 * of a plane, on its axis) over the mean elsewhere, for each axis the cuts
 * use (1.0: no seam).
 * --large sizes run out of core only (--memory 4G and 2G, 2 threads): their
 * in-memory run would need about 120 bytes a triangle. Their error is
 * measured on a sample of the input: the centroid of every k-th input
 * triangle (k = T / 2M, read in passes) to the output surface, one-sided
 * (input to output: RMS and largest), the same measure given for the
 * smaller sizes beside it.
 * --csv writes the rows for bench/plots.py (time and peak memory against
 * the input's size).
 * --cluster: then grid clustering of each --sizes scan, the file read in
 * passes (mr_cluster_file) against read whole, clustered in memory and
 * written (mr_mesh_read, mr_mesh_cluster, mr_mesh_write: the bytes are the
 * same), both in a child process of this program (its peak RSS), at 1 and 2
 * threads, to a fixed cell (1/500 of the diagonal) and to a target count
 * (the ratio of the vertices), median of N alternating runs;
 * --cluster-only: that alone.
 * --attributes: a seamed copy of each --sizes scan (texture coordinates and
 * colours by tests/make_seamed.py, run by /usr/bin/python3) as binary PLY
 * and OBJ, in memory against out of core (64M up to 8M triangles, else 1G),
 * 2 threads, time and peak RSS, median of N alternating runs;
 * --attributes-only: that alone (with --cluster-only: both).
 */
#define _GNU_SOURCE
#include "benchutil.h"
#include "geometry/distance.h"
#include "io/io_internal.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#ifndef MR_CLI_PATH
#define MR_CLI_PATH "meshreduce"
#endif
#ifndef MR_MPI_CLI_PATH
#define MR_MPI_CLI_PATH ""
#endif

/* The levels' seconds from --json ("levels": [{... "seconds": x}, ...]). */
static int json_levels(const char *json, double *sec, int max)
{
    const char *p = json ? strstr(json, "\"levels\": [") : NULL;
    int n = 0;
    while (p && n < max) {
        const char *q = strstr(p, "\"seconds\": ");
        const char *end = strchr(p, ']');
        if (!q || (end && q > end))
            break;
        sec[n++] = strtod(q + 11, NULL);
        p = q + 11;
    }
    return n;
}

/* The cuts from --json ("splits": [[axis, at], ...]). */
static int json_splits(const char *json, int *axis, double *at, int max)
{
    const char *p = json ? strstr(json, "\"splits\": [") : NULL;
    if (!p)
        return 0;
    p += 11;
    int n = 0;
    while (n < max && (p = strchr(p, '[')) != NULL) {
        char *e;
        axis[n] = (int)strtol(p + 1, &e, 10);
        at[n] = strtod(e + 1, &e);
        n++;
        p = e;
        if (*p == ']' && p[1] == ']')
            break;
    }
    return n;
}

static size_t parse_count(const char *s)
{
    char *e;
    double v = strtod(s, &e);
    if (*e == 'k' || *e == 'K')
        v *= 1e3;
    else if (*e == 'm' || *e == 'M')
        v *= 1e6;
    else if (*e == 'g' || *e == 'G')
        v *= 1e9;
    return (size_t)v;
}

static int parse_list(const char *s, size_t *out, int max)
{
    int n = 0;
    char buf[256];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *tok = strtok(buf, ","); tok && n < max; tok = strtok(NULL, ","))
        out[n++] = parse_count(tok);
    return n;
}

/* Distance of the output's triangle centroids to the input (bvh): mean
 * near the cuts over mean elsewhere, on one axis (-1: no cut on it, or
 * every triangle near one). */
static double seam_ratio(const mr_tri_bvh *bvh, const mr_mesh *o, const int *axis,
                         const double *at, int ns, int ax)
{
    double el = 0;
    for (size_t t = 0; t < o->triangle_count; t++)
        for (int j = 0; j < 3; j++) {
            const float *a = o->positions + 3 * (size_t)o->indices[3 * t + (size_t)j],
                        *b = o->positions + 3 * (size_t)o->indices[3 * t + (size_t)(j + 1) % 3];
            el += sqrt(((double)a[0] - b[0]) * ((double)a[0] - b[0]) +
                       ((double)a[1] - b[1]) * ((double)a[1] - b[1]) +
                       ((double)a[2] - b[2]) * ((double)a[2] - b[2]));
        }
    el /= 3.0 * (double)(o->triangle_count ? o->triangle_count : 1);
    int any = 0;
    for (int k = 0; k < ns; k++)
        any |= axis[k] == ax;
    if (!any)
        return -1;
    double sum[2] = {0, 0};
    size_t n[2] = {0, 0};
    for (size_t t = 0; t < o->triangle_count; t++) {
        double p[3];
        for (int k = 0; k < 3; k++)
            p[k] = ((double)o->positions[3 * (size_t)o->indices[3 * t] + (size_t)k] +
                    o->positions[3 * (size_t)o->indices[3 * t + 1] + (size_t)k] +
                    o->positions[3 * (size_t)o->indices[3 * t + 2] + (size_t)k]) /
                   3;
        const double d = sqrt(mr_tri_bvh_nearest(bvh, p, MR_NO_HINT, NULL, NULL));
        int near = 0;
        for (int k = 0; k < ns; k++)
            near |= axis[k] == ax && fabs(p[ax] - at[k]) <= 2 * el;
        sum[near] += d;
        n[near]++;
    }
    if (!n[0] || !n[1] || !(sum[0] > 0))
        return -1;
    return (sum[1] / (double)n[1]) / (sum[0] / (double)n[0]);
}

/* The sampled error of out against the input file (every k-th input
 * triangle's centroid to the output surface): RMS and largest, relative
 * to the input's bounding-box diagonal. */
static void sampled_error(const char *in, const mr_mesh *out, double *rms, double *worst)
{
    mr_error err;
    mr_ply_source *s;
    bench_check(mr_ply_source_open(in, 0, &s, &err), &err);
    const size_t nt = mr_ply_source_triangle_count(s), nv = mr_ply_source_vertex_count(s);
    const size_t k = nt / 2000000 > 1 ? nt / 2000000 : 1;
    mr_tri_bvh bvh;
    bench_check(mr_tri_bvh_build(&bvh, out->positions, out->indices, out->triangle_count, 0,
                                 &err),
                &err);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < nv; v += 1 + nv / 4000000) { /* the box from a sample too */
        float p[3];
        mr_ply_source_position(s, (uint32_t)v, p);
        for (int c = 0; c < 3; c++) {
            lo[c] = p[c] < lo[c] ? p[c] : lo[c];
            hi[c] = p[c] > hi[c] ? p[c] : hi[c];
        }
    }
    const double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                             (hi[2] - lo[2]) * (hi[2] - lo[2]));
    uint32_t *idx = malloc(12 * (mr_ply_source_max_faces(s) + 1));
    double sum = 0, most = 0;
    size_t n = 0, t = 0;
    for (;;) {
        size_t got;
        bench_check(mr_ply_source_next_faces(s, idx, &got, &err), &err);
        if (!got)
            break;
        for (size_t f = 0; f < got; f++, t++) {
            if (t % k)
                continue;
            float a[3], b[3], c[3];
            mr_ply_source_position(s, idx[3 * f], a);
            mr_ply_source_position(s, idx[3 * f + 1], b);
            mr_ply_source_position(s, idx[3 * f + 2], c);
            const double p[3] = {((double)a[0] + b[0] + c[0]) / 3, ((double)a[1] + b[1] + c[1]) / 3,
                                 ((double)a[2] + b[2] + c[2]) / 3};
            const double d2 = mr_tri_bvh_nearest(&bvh, p, MR_NO_HINT, NULL, NULL);
            sum += d2;
            most = d2 > most ? d2 : most;
            n++;
        }
        mr_ply_source_release(s);
    }
    free(idx);
    mr_tri_bvh_free(&bvh);
    mr_ply_source_close(s);
    *rms = sqrt(sum / (double)(n ? n : 1)) / diag;
    *worst = sqrt(most) / diag;
}

typedef struct config {
    const char *name;
    int threads, ranks; /* ranks 0: meshreduce, else meshreduce-mpi */
    const char *memory; /* NULL: the default (in memory when it fits) */
} config;

/* The child of --cluster: MODE (file or memory) IN OUT THREADS CELL_REL
 * TARGET; exit 0 on success. */
static int cluster_child(char **argv)
{
    const bool file = !strcmp(argv[0], "file");
    mr_cluster_options o;
    mr_cluster_options_default(&o);
    o.threads = atoi(argv[3]);
    o.cell_rel = atof(argv[4]);
    o.target_vertices = (size_t)atoll(argv[5]);
    mr_error err;
    if (file)
        return mr_cluster_file(argv[1], argv[2], &o, NULL, NULL, NULL, &err) == MR_OK ? 0 : 1;
    mr_mesh in, out;
    if (mr_mesh_read(argv[1], NULL, &in, &err) != MR_OK)
        return 1;
    if (mr_mesh_cluster(&in, &o, &out, NULL, &err) != MR_OK)
        return 1;
    mr_mesh_free(&in);
    const int rc = mr_mesh_write(argv[2], &out, NULL, &err) == MR_OK ? 0 : 1;
    mr_mesh_free(&out);
    return rc;
}

static char *read_all(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    const long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *d = size >= 0 ? malloc((size_t)size + 1) : NULL;
    *n = d ? fread(d, 1, (size_t)size, f) : 0;
    fclose(f);
    return d;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The generated scan of T triangles at path, made once. */
static void ensure_scan(size_t T, const char *in)
{
    struct stat sb;
    if (stat(in, &sb) == 0)
        return;
    mr_error err;
    const double g0 = bench_now();
    bench_check(mr_generate_file(MR_GEN_SCAN, T, 1, in, NULL, NULL, NULL, &err), &err);
    fprintf(stderr, "generated %s in %.1f s\n", in, bench_now() - g0);
}

/* --cluster: in passes against in memory, on each of the sizes. */
/* n runs of each of two commands (av[0], av[1]; n at most 64), alternating
 * which goes first: each one's times in sec[k] (run order) and its
 * largest peak RSS in rss[k]; a failed run ends the benchmark, naming
 * `what`. */
static double cluster_section(const char *self, const char *dir, const size_t *sizes,
                              int nsizes, int runs, double ratio)
{
    printf("\ncluster: the file read in passes (mr_cluster_file) against read whole and "
           "clustered in memory; a child process each, median of %d alternating runs\n\n",
           runs);
    printf("%-9s %-22s %3s %9s %9s %9s %9s %7s\n", "input", "grid", "thr", "passes s",
           "memory s", "passes RSS", "memory RSS", "ratio");
    double worst = -1;
    for (int si = 0; si < nsizes; si++) {
        char in[1024], label[32], out[2][1100], target[32];
        snprintf(label, sizeof label, "%zuM", sizes[si] / 1000000);
        snprintf(in, sizeof in, "%s/scan-%s.ply", dir, label);
        ensure_scan(sizes[si], in);
        snprintf(out[0], sizeof out[0], "%s/cluster-file.ply", dir);
        snprintf(out[1], sizeof out[1], "%s/cluster-memory.ply", dir);
        /* the scan's vertices: about half its triangles */
        snprintf(target, sizeof target, "%zu", (size_t)(ratio * (double)sizes[si] / 2));
        for (int g = 0; g < 2; g++)
            for (int threads = 1; threads <= 2; threads++) {
                char th[8];
                snprintf(th, sizeof th, "%d", threads);
                double sec[2][64];
                size_t rss[2];
                const int n = runs < 64 ? runs : 64;
                char *file[] = {(char *)self, "--cluster-child", "file",   in, out[0], th,
                                g ? "0" : "0.002", g ? target : "0", NULL};
                char *memory[] = {(char *)self, "--cluster-child", "memory", in, out[1], th,
                                  g ? "0" : "0.002", g ? target : "0", NULL};
                char *const *av[2] = {file, memory};
                bench_alternate(av, n, "cluster child", sec, rss);
                size_t na, nb;
                char *a = read_all(out[0], &na), *b = read_all(out[1], &nb);
                const bool same = a && b && na == nb && memcmp(a, b, na) == 0;
                free(a);
                free(b);
                qsort(sec[0], (size_t)n, sizeof(double), cmp_double);
                qsort(sec[1], (size_t)n, sizeof(double), cmp_double);
                const double f = sec[0][n / 2], m = sec[1][n / 2];
                printf("%-9s %-22s %3d %9.3f %9.3f %8.0fMB %8.0fMB %6.2fx%s\n", label,
                       g ? "--target-vertices 1%" : "--cell-rel 0.002", threads, f, m,
                       rss[0] / 1e6, rss[1] / 1e6, m / f, same ? "" : "  OTHER BYTES");
                if (worst < 0 || m / f < worst)
                    worst = m / f;
            }
    }
    return worst;
}

/* --attributes: a seamed copy of each --sizes scan (texture coordinates and
 * colours, split four ways by tests/make_seamed.py), as binary PLY and as
 * OBJ, simplified in memory and out of core, 2 threads: time and peak RSS,
 * medians of alternating runs. */
static void attributes_section(const char *dir, const size_t *sizes, int nsizes, int runs,
                               const char *ratio)
{
    printf("\nattributes: seamed scans (texture coordinates, colours) in memory and out of "
           "core, 2 threads; median of %d alternating runs\n\n",
           runs);
    printf("%-9s %-5s %-8s %9s %9s %9s %9s %7s\n", "input", "fmt", "budget", "memory s",
           "ooc s", "mem RSS", "ooc RSS", "ratio");
    for (int si = 0; si < nsizes; si++) {
        char scan[1024], label[32], in[2][1100], out[1100];
        snprintf(label, sizeof label, "%zuM", sizes[si] / 1000000);
        snprintf(scan, sizeof scan, "%s/scan-%s.ply", dir, label);
        ensure_scan(sizes[si], scan);
        snprintf(in[0], sizeof in[0], "%s/seamed-%s.ply", dir, label);
        snprintf(in[1], sizeof in[1], "%s/seamed-%s.obj", dir, label);
        snprintf(out, sizeof out, "%s/seamed-out.ply", dir);
        struct stat sb;
        if (stat(in[0], &sb) != 0) {
            char *av[] = {"/usr/bin/python3", MR_SOURCE_DIR "/tests/make_seamed.py", scan, in[0],
                          NULL};
            bench_run_result rr = bench_run(av);
            free(rr.out);
            if (rr.status != 0) {
                fprintf(stderr, "make_seamed.py failed (%d)\n", rr.status);
                exit(1);
            }
        }
        if (stat(in[1], &sb) != 0) {
            char *av[] = {MR_CLI_PATH, "convert", in[0], in[1], "-q", NULL};
            bench_run_result rr = bench_run(av);
            free(rr.out);
            if (rr.status != 0) {
                fprintf(stderr, "convert failed (%d)\n", rr.status);
                exit(1);
            }
        }
        const char *budget = sizes[si] <= 8000000 ? "64M" : "1G";
        for (int f = 0; f < 2; f++) {
            double sec[2][64];
            size_t rss[2];
            const int n = runs < 64 ? runs : 64;
            char *memory[] = {MR_CLI_PATH, "--threads", "2", "simplify", in[f], "-o", out,
                              "--ratio", (char *)ratio, "-q", NULL};
            char *chunks[] = {MR_CLI_PATH, "--threads", "2", "simplify", in[f], "-o", out,
                              "--ratio", (char *)ratio, "-q", "--memory", (char *)budget, NULL};
            char *const *av[2] = {memory, chunks};
            char what[2300];
            snprintf(what, sizeof what, "simplify %s", in[f]);
            bench_alternate(av, n, what, sec, rss);
            const double a = bench_summarize(sec[0], n).median,
                         b = bench_summarize(sec[1], n).median;
            printf("%-9s %-5s %-8s %9.3f %9.3f %7.0fMB %7.0fMB %6.2fx\n", label, f ? "OBJ" : "PLY",
                   budget, a, b, rss[0] / 1e6, rss[1] / 1e6, a / b);
        }
    }
}

int main(int argc, char **argv)
{
    if (argc == 8 && !strcmp(argv[1], "--cluster-child"))
        return cluster_child(argv + 2);
    size_t sizes[8], large[8];
    bool cluster = false, attributes = false, skip_main = false;
    int nsizes = parse_list("4M,20M", sizes, 8), nlarge = 0, runs = 3;
    double ratio = 0.01;
    const char *dir = "bench/work", *csv = NULL, *mpiexec = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--sizes") && i + 1 < argc)
            nsizes = parse_list(argv[++i], sizes, 8);
        else if (!strcmp(argv[i], "--large") && i + 1 < argc)
            nlarge = parse_list(argv[++i], large, 8);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--ratio") && i + 1 < argc)
            ratio = atof(argv[++i]);
        else if (!strcmp(argv[i], "--dir") && i + 1 < argc)
            dir = argv[++i];
        else if (!strcmp(argv[i], "--csv") && i + 1 < argc)
            csv = argv[++i];
        else if (!strcmp(argv[i], "--mpi") && i + 1 < argc)
            mpiexec = argv[++i];
        else if (!strcmp(argv[i], "--cluster"))
            cluster = true;
        else if (!strcmp(argv[i], "--cluster-only"))
            cluster = skip_main = true;
        else if (!strcmp(argv[i], "--attributes"))
            attributes = true;
        else if (!strcmp(argv[i], "--attributes-only"))
            attributes = skip_main = true;
        else {
            fprintf(stderr, "usage: bench_outofcore [--sizes 4M,20M] [--large 100M,300M] "
                            "[--runs N] [--ratio R] [--dir DIR] [--csv FILE] [--mpi MPIEXEC] "
                            "[--cluster | --cluster-only] [--attributes | --attributes-only]\n");
            return 2;
        }
    }
    if (runs < 1)
        runs = 1;
    mkdir(dir, 0755);
    const bool mpi = mpiexec && MR_MPI_CLI_PATH[0];
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 0);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 0);
    setenv("GOMP_SPINCOUNT", "10000", 0);
    bench_print_machine(stdout);
    printf("simplify to %g%% of the vertices; the whole process (fork, exec, read, simplify, "
           "write); median of %d alternating runs\n\n",
           100 * ratio, runs);
    FILE *cf = csv ? fopen(csv, "w") : NULL;
    if (cf)
        fprintf(cf, "triangles,config,threads,ranks,memory,seconds,rss_bytes,chunks,levels,"
                    "temp_bytes,rms_rel,hausdorff_rel,sampled_rms_rel,sampled_max_rel\n");
    printf("%-9s %-14s %3s %5s %8s %8s %9s %6s %4s %9s  %s\n", "input", "run", "thr", "ranks",
           "seconds", "Mtri/s", "peak RSS", "chunks", "lvl", "temp disk", "levels' seconds");
    char ratio_s[32];
    snprintf(ratio_s, sizeof ratio_s, "%g", ratio);
    double bar_tp = -1, bar_mpi = -1;
    for (int big = 0; big < 2 && !skip_main; big++) {
        const int count = big ? nlarge : nsizes;
        for (int si = 0; si < count; si++) {
            const size_t T = big ? large[si] : sizes[si];
            char in[1024], label[32];
            snprintf(label, sizeof label, "%zuM", T / 1000000);
            snprintf(in, sizeof in, "%s/scan-%s.ply", dir, label);
            ensure_scan(T, in);
            const char *ooc_mem = T <= 8000000 ? "256M" : "1G";
            config cfgs[8];
            int nc = 0;
            if (!big) {
                cfgs[nc++] = (config){"in memory", 1, 0, NULL};
                cfgs[nc++] = (config){"in memory", 2, 0, NULL};
                cfgs[nc++] = (config){"out of core", 1, 0, ooc_mem};
                cfgs[nc++] = (config){"out of core", 2, 0, ooc_mem};
                if (mpi) {
                    cfgs[nc++] = (config){"mpi", 1, 1, ooc_mem};
                    cfgs[nc++] = (config){"mpi", 1, 2, ooc_mem};
                }
            } else {
                cfgs[nc++] = (config){"out of core", 2, 0, "4G"};
                cfgs[nc++] = (config){"out of core", 2, 0, "2G"};
            }
            double sec[8][16];
            bench_run_result last[8];
            memset(last, 0, sizeof last);
            const int nr = big ? 1 : runs;
            for (int r = 0; r < nr; r++)
                for (int c = 0; c < nc; c++) {
                    char out[1100], th[16], np[16];
                    snprintf(out, sizeof out, "%s/out-%s-%d.ply", dir, label, c);
                    snprintf(th, sizeof th, "%d", cfgs[c].threads);
                    snprintf(np, sizeof np, "%d", cfgs[c].ranks);
                    char *av[32];
                    int a = 0;
                    if (cfgs[c].ranks) {
                        av[a++] = (char *)mpiexec;
                        av[a++] = "--oversubscribe";
                        av[a++] = "--bind-to";
                        av[a++] = "none";
                        av[a++] = "-np";
                        av[a++] = np;
                        av[a++] = MR_MPI_CLI_PATH;
                    } else {
                        av[a++] = MR_CLI_PATH;
                    }
                    av[a++] = "--threads";
                    av[a++] = th;
                    av[a++] = "simplify";
                    av[a++] = in;
                    av[a++] = "-o";
                    av[a++] = out;
                    av[a++] = "--ratio";
                    av[a++] = ratio_s;
                    av[a++] = "--json";
                    av[a++] = "-q";
                    if (cfgs[c].memory) {
                        av[a++] = "--memory";
                        av[a++] = (char *)cfgs[c].memory;
                    }
                    av[a] = NULL;
                    bench_run_result rr = bench_run(av);
                    if (rr.status != 0) {
                        fprintf(stderr, "failed (%d): %s %s\n", rr.status, cfgs[c].name, in);
                        return 1;
                    }
                    sec[c][r] = rr.seconds;
                    if (r + 1 < nr)
                        free(rr.out);
                    else
                        last[c] = rr;
                }
            double med[8];
            for (int c = 0; c < nc; c++) {
                med[c] = bench_summarize(sec[c], nr).median;
                const char *js = last[c].out;
                const double chunks = bench_json_number(js, "chunks"),
                             temp = bench_json_number(js, "temp_bytes_peak");
                double lv[MR_LEVELS_MAX];
                const int nl = json_levels(js, lv, MR_LEVELS_MAX);
                char lvs[256] = "", tmps[32] = "-", chs[16] = "-", ls[8] = "-";
                for (int l = 0; l < nl && strlen(lvs) < 200; l++)
                    snprintf(lvs + strlen(lvs), sizeof lvs - strlen(lvs), "%s%.2f",
                             l ? " " : "", lv[l]);
                if (temp == temp)
                    snprintf(tmps, sizeof tmps, "%.0f MB", temp / 1e6);
                if (chunks == chunks) {
                    snprintf(chs, sizeof chs, "%.0f", chunks);
                    snprintf(ls, sizeof ls, "%d", nl);
                }
                printf("%-9s %-14s %3d %5d %8.2f %8.2f %6.0f MB %6s %4s %9s  %s\n", label,
                       cfgs[c].memory ? (cfgs[c].ranks ? "mpi" : cfgs[c].memory) : "in memory",
                       cfgs[c].threads, cfgs[c].ranks, med[c], (double)T / med[c] / 1e6,
                       (double)last[c].rss / 1e6, chs, ls, tmps, lvs);
            }
            if (!big && T >= 20000000 && nc >= 4)
                bar_tp = med[1] / med[3]; /* 2 threads: in memory over out of core */
            if (!big && T >= 20000000 && mpi && nc >= 6)
                bar_mpi = med[4] / med[5];
            /* quality */
            mr_mesh input;
            mr_mesh_init(&input);
            mr_error err;
            mr_tri_bvh bvh;
            bool have_input = !big;
            if (have_input) {
                bench_check(mr_mesh_read(in, NULL, &input, &err), &err);
                bench_check(mr_tri_bvh_build(&bvh, input.positions, input.indices,
                                             input.triangle_count, 0, &err),
                            &err);
            }
            for (int c = 0; c < nc; c++) {
                /* the small sizes: one run each way (the other threads and
                 * ranks make the same bytes) */
                if (!big && c != 0 && c != 2)
                    continue;
                char out[1100];
                snprintf(out, sizeof out, "%s/out-%s-%d.ply", dir, label, c);
                mr_mesh o;
                bench_check(mr_mesh_read(out, NULL, &o, &err), &err);
                double srms, smax;
                sampled_error(in, &o, &srms, &smax);
                double rms = NAN, haus = NAN, seam[3] = {-1, -1, -1};
                if (have_input) {
                    mr_compare_options co;
                    mr_compare_options_default(&co);
                    mr_compare_result cr;
                    bench_check(mr_compare(input.positions, input.vertex_count, input.indices,
                                           input.triangle_count, o.positions, o.vertex_count,
                                           o.indices, o.triangle_count, &co, &cr, &err),
                                &err);
                    rms = cr.rms_rel;
                    haus = cr.hausdorff_rel;
                    int ax[MR_SPLITS_MAX];
                    double at[MR_SPLITS_MAX];
                    const int ns = json_splits(last[c].out, ax, at, MR_SPLITS_MAX);
                    for (int k = 0; k < 3 && ns; k++)
                        seam[k] = seam_ratio(&bvh, &o, ax, at, ns, k);
                }
                printf("  %-9s %-12s RMS %.5f%%, Hausdorff %.4f%%; sampled input to output "
                       "RMS %.5f%%, max %.4f%%",
                       label, cfgs[c].memory ? cfgs[c].memory : "in memory", 100 * rms,
                       100 * haus, 100 * srms, 100 * smax);
                for (int k = 0; k < 3; k++)
                    if (seam[k] >= 0)
                        printf("; near %c cuts %.3fx", "xyz"[k], seam[k]);
                printf(" (%zu triangles)\n", o.triangle_count);
                /* the rows this quality stands for */
                const int c_end = big ? c + 1 : c == 0 ? 2 : nc;
                if (cf)
                    for (int c2 = c; c2 < c_end; c2++)
                            fprintf(cf, "%zu,%s,%d,%d,%s,%.4f,%zu,%.0f,%d,%.0f,%.6g,%.6g,%.6g,%.6g\n",
                                    T, cfgs[c2].ranks ? "mpi"
                                       : cfgs[c2].memory ? "out of core" : "in memory",
                                    cfgs[c2].threads, cfgs[c2].ranks,
                                    cfgs[c2].memory ? cfgs[c2].memory : "default", med[c2],
                                    last[c2].rss, bench_json_number(last[c2].out, "chunks"),
                                    json_levels(last[c2].out, (double[MR_LEVELS_MAX]){0},
                                                MR_LEVELS_MAX),
                                    bench_json_number(last[c2].out, "temp_bytes_peak"), rms, haus,
                                    srms, smax);
                mr_mesh_free(&o);
            }
            if (have_input) {
                mr_tri_bvh_free(&bvh);
                mr_mesh_free(&input);
            }
            for (int c = 0; c < nc; c++)
                free(last[c].out);
        }
    }
    if (cf)
        fclose(cf);
    printf("\n");
    if (bar_tp > 0)
        printf("bar: out-of-core throughput %.2fx the in-memory default's at 20M, 2 threads "
               "(at least 0.5)\n",
               bar_tp);
    if (bar_mpi > 0)
        printf("bar: 2 ranks of 1 thread %.2fx faster than 1 rank at 20M (at least 1.7)\n",
               bar_mpi);
    if (attributes)
        attributes_section(dir, sizes, nsizes, runs, ratio_s);
    if (cluster) {
        const double w = cluster_section("/proc/self/exe", dir, sizes, nsizes, runs, ratio);
        printf("\nbar: cluster in passes at least as fast as in memory: worst %.2fx (in "
               "memory's time over the passes')\n",
               w);
    }
    return 0;
}
