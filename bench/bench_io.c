/*
 * I/O benchmark: read throughput (MB/s) of the OBJ and binary PLY readers
 * on a generated mesh of about 200 MB as OBJ, at 1 thread and all threads,
 * and Open3D's reader on the same files in the same run when python3-open3d
 * is installed.
 *
 *   bench_io [--triangles N] [--runs R] [--dir DIR] [--keep]
 */
#include "benchutil.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct result {
    const char *label;
    double seconds;
    double mbps;
} result;

static double time_read(const char *path, int threads, int runs, const mr_mesh *expect)
{
    double *t = malloc(sizeof(double) * (size_t)runs);
    mr_read_options opt;
    mr_read_options_default(&opt);
    opt.threads = threads;
    for (int r = 0; r < runs; r++) {
        mr_mesh m;
        mr_error err;
        double t0 = bench_now();
        bench_check(mr_mesh_read(path, &opt, &m, &err), &err);
        t[r] = bench_now() - t0;
        if (m.vertex_count != expect->vertex_count || m.triangle_count != expect->triangle_count) {
            fprintf(stderr, "bench: %s read back with other counts\n", path);
            exit(1);
        }
        mr_mesh_free(&m);
    }
    bench_summary s = bench_summarize(t, runs);
    free(t);
    return s.median;
}

int main(int argc, char **argv)
{
    size_t triangles = 5000000;
    int runs = 5;
    const char *dir = "out/bench";
    int keep = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--triangles") && i + 1 < argc)
            triangles = (size_t)strtod(argv[++i], NULL);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--dir") && i + 1 < argc)
            dir = argv[++i];
        else if (!strcmp(argv[i], "--keep"))
            keep = 1;
        else {
            fprintf(stderr, "usage: bench_io [--triangles N] [--runs R] [--dir DIR] [--keep]\n");
            return 2;
        }
    }
    if (runs < 1)
        runs = 1;
    char cmd[12800];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", dir);
    if (system(cmd) != 0)
        return 1;

    bench_print_machine(stdout);
    mr_mesh mesh;
    mr_error err;
    bench_check(mr_generate(MR_GEN_SCAN, triangles, 1, &mesh, &err), &err);
    char obj[4096], ply[4096];
    snprintf(obj, sizeof obj, "%s/io-scan.obj", dir);
    snprintf(ply, sizeof ply, "%s/io-scan.ply", dir);
    double t0 = bench_now();
    bench_check(mr_mesh_write(obj, &mesh, NULL, &err), &err);
    double t_wobj = bench_now() - t0;
    t0 = bench_now();
    bench_check(mr_mesh_write(ply, &mesh, NULL, &err), &err);
    double t_wply = bench_now() - t0;

    FILE *f = fopen(obj, "rb");
    fseek(f, 0, SEEK_END);
    double mb_obj = (double)ftell(f) / 1e6;
    fclose(f);
    f = fopen(ply, "rb");
    fseek(f, 0, SEEK_END);
    double mb_ply = (double)ftell(f) / 1e6;
    fclose(f);

    int all = omp_get_max_threads();
    printf("mesh: generated scan, %zu vertices, %zu triangles; OBJ %.0f MB, binary PLY %.0f MB; "
           "median of %d runs (file in page cache)\n",
           mesh.vertex_count, mesh.triangle_count, mb_obj, mb_ply, runs);
    printf("write: OBJ %.0f MB/s, binary PLY %.0f MB/s\n", mb_obj / t_wobj, mb_ply / t_wply);

    /* Warm the page cache so every reader sees the same conditions. */
    time_read(obj, all, 1, &mesh);
    time_read(ply, all, 1, &mesh);
    double obj1 = time_read(obj, 1, runs, &mesh);
    double objn = time_read(obj, all, runs, &mesh);
    double ply1 = time_read(ply, 1, runs, &mesh);
    double plyn = time_read(ply, all, runs, &mesh);

    printf("\n%-34s %10s %10s %10s\n", "reader", "seconds", "MB/s", "vs Open3D");
    double o3d_obj = 0, o3d_ply = 0;
    if (bench_have_open3d()) {
        snprintf(cmd, sizeof cmd, "%s '%s/open3d_read.py' --runs=%d '%s' '%s'",
                 bench_python(), MR_BENCH_DIR, runs < 3 ? runs : 3, obj, ply);
        char *out = bench_capture(cmd);
        if (out) {
            char *line = strtok(out, "\n");
            while (line) {
                char path[4096];
                double s;
                if (sscanf(line, "%4095s %lf", path, &s) == 2) {
                    if (!strcmp(path, obj))
                        o3d_obj = s;
                    if (!strcmp(path, ply))
                        o3d_ply = s;
                }
                line = strtok(NULL, "\n");
            }
            free(out);
        }
    }
    struct {
        const char *label;
        double mb, s, peer;
    } rows[] = {
        {"meshreduce OBJ, 1 thread", mb_obj, obj1, o3d_obj},
        {"meshreduce OBJ, all threads", mb_obj, objn, o3d_obj},
        {"meshreduce binary PLY, 1 thread", mb_ply, ply1, o3d_ply},
        {"meshreduce binary PLY, all threads", mb_ply, plyn, o3d_ply},
        {"Open3D OBJ", mb_obj, o3d_obj, 0},
        {"Open3D binary PLY", mb_ply, o3d_ply, 0},
    };
    for (size_t i = 0; i < sizeof rows / sizeof *rows; i++) {
        if (rows[i].s <= 0)
            continue;
        char ratio[32] = "";
        if (rows[i].peer > 0)
            snprintf(ratio, sizeof ratio, "%.1fx", rows[i].peer / rows[i].s);
        printf("%-34s %10.3f %10.0f %10s\n", rows[i].label, rows[i].s, rows[i].mb / rows[i].s,
               ratio);
    }
    if (o3d_obj <= 0)
        printf("(Open3D not measured: python3-open3d is not installed)\n");
    printf("threads: %d\n", all);
    mr_mesh_free(&mesh);
    if (!keep) {
        unlink(obj);
        unlink(ply);
    }
    return 0;
}
