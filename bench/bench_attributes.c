/*
 * bench_attributes: the attributes' part in the collapse cost
 * (--attribute-weights, src/qem/attr_quadric.c) against interpolation
 * alone (--attribute-weights none), on the same inputs and targets:
 * whole-process time and peak RSS (child processes, median of alternating
 * runs), and each output's distance and attribute deviation from its input
 * (meshreduce compare --json; "tex dev": the texture deviation's RMS, % of
 * the diagonal).
 *
 *   bench_attributes [--runs N] [--threads T] [--dir DIR] [--triangles N]
 *
 * Inputs: a generated scan of --triangles (default 400k) split into four
 * UV islands with normals, texture coordinates and colours
 * (tests/make_seamed.py --normals, run by /usr/bin/python3); a colour step
 * across a 3 x 8 grid (meshoptimizer's simplifyWithAttributes case, written
 * here), to 6 triangles; and where ../shared/data is present, spot.obj and
 * beast.obj (texture coordinates) and the Duck (glTF: normals, UVs).
 */
#include "benchutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifndef MR_CLI_PATH
#define MR_CLI_PATH "meshreduce"
#endif
#ifndef MR_SOURCE_DIR
#define MR_SOURCE_DIR "."
#endif
#ifndef MR_SHARED_DATA
#define MR_SHARED_DATA "../shared/data"
#endif

static void must(char *const av[], const char *what)
{
    bench_run_result r = bench_run(av);
    free(r.out);
    if (r.status != 0) {
        fprintf(stderr, "%s failed (%d)\n", what, r.status);
        exit(1);
    }
}

/* The colour step grid as PLY (rows 0-3 a yellow gradient, 4-7 blue). */
static void write_step(const char *path)
{
    mr_mesh m;
    mr_mesh_init(&m);
    if (mr_mesh_alloc(&m, 24, 28, MR_ATTR_COLORS, NULL) != MR_OK)
        exit(1);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 3; x++) {
            float *p = m.positions + 3 * (3 * y + x), *c = m.colors + 4 * (3 * y + x);
            p[0] = (float)x;
            p[1] = (float)y;
            p[2] = 0.03f * (float)x + 0.03f * (float)(y % 2) + (x == 2 && y == 7 ? 0.03f : 0);
            c[0] = c[1] = y < 4 ? 0.8f + 0.05f * (float)y : 0;
            c[2] = y < 4 ? 0 : 0.8f + 0.05f * (float)(7 - y);
            c[3] = 1;
        }
    uint32_t *t = m.indices;
    for (int y = 0; y < 7; y++)
        for (int x = 0; x < 2; x++) {
            const uint32_t a = (uint32_t)(3 * y + x), q[6] = {a, a + 1, a + 3, a + 3, a + 1, a + 4};
            memcpy(t, q, sizeof q);
            t += 6;
        }
    mr_error err;
    if (mr_mesh_write(path, &m, NULL, &err) != MR_OK) {
        fprintf(stderr, "%s\n", err.message);
        exit(1);
    }
    mr_mesh_free(&m);
}

static void row(const char *name, const char *in, const char *target, const char *value,
                const char *dir, const char *threads, int runs)
{
    const char *ext = strrchr(in, '.');
    char out[2][1200];
    snprintf(out[0], sizeof out[0], "%s/attr-cost%s", dir, ext);
    snprintf(out[1], sizeof out[1], "%s/attr-none%s", dir, ext);
    char *with[] = {MR_CLI_PATH, "--threads", (char *)threads, "simplify", (char *)in, "-o",
                    out[0], (char *)target, (char *)value, "-q", NULL};
    char *none[] = {MR_CLI_PATH, "--threads", (char *)threads, "simplify", (char *)in, "-o",
                    out[1], (char *)target, (char *)value, "--attribute-weights", "none",
                    "-q", NULL};
    char *const *av[2] = {with, none};
    double sec[2][64];
    size_t rss[2];
    const int n = runs < 64 ? runs : 64;
    bench_alternate(av, n, name, sec, rss);
    const double a = bench_summarize(sec[0], n).median, b = bench_summarize(sec[1], n).median;
    for (int k = 0; k < 2; k++) {
        char *cmp[] = {MR_CLI_PATH, "compare", (char *)in, out[k], "--json", NULL};
        bench_run_result r = bench_run(cmp);
        if (r.status != 0) {
            fprintf(stderr, "compare %s failed\n", out[k]);
            exit(1);
        }
        printf("%-10s %-6s %-14s %7.3f %6.0fMB %9.4f %9.4f %8.3f %10.3g %10.4f %10.3g\n", name,
               k ? "none" : "cost", value, k ? b : a, rss[k] / 1e6,
               100 * bench_json_number(r.out, "rms_rel"),
               100 * bench_json_number(r.out, "hausdorff_rel"),
               bench_json_number(r.out, "normal_rms_degrees"),
               bench_json_number(r.out, "texcoord_rms"),
               100 * bench_json_number(r.out, "texture_rms_rel"),
               bench_json_number(r.out, "color_rms"));
        free(r.out);
    }
    printf("%-10s time %.2fx, peak RSS %.2fx the interpolated run's\n", name, a / b,
           (double)rss[0] / (double)rss[1]);
}

int main(int argc, char **argv)
{
    int runs = 5;
    const char *dir = "bench/work", *threads = "1", *tri = "400k";
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = argv[++i];
        else if (!strcmp(argv[i], "--dir") && i + 1 < argc)
            dir = argv[++i];
        else if (!strcmp(argv[i], "--triangles") && i + 1 < argc)
            tri = argv[++i];
        else {
            fprintf(stderr, "usage: bench_attributes [--runs N] [--threads T] [--dir DIR] "
                            "[--triangles N]\n");
            return 2;
        }
    }
    if (runs < 1)
        runs = 1;
    mkdir(dir, 0777);
    bench_print_machine(stdout);
    printf("attribute cost (default weights) against interpolation (--attribute-weights none); "
           "%s thread(s), median of %d alternating runs, whole process\n\n",
           threads, runs);
    printf("%-10s %-6s %-14s %7s %8s %9s %9s %8s %10s %10s %10s\n", "input", "run", "target",
           "s", "RSS", "RMS %", "Haus %", "nrm deg", "uv RMS", "tex dev %", "col RMS");
    char scan[1024], seamed[1100], step[1024];
    snprintf(scan, sizeof scan, "%s/attr-scan-%s.ply", dir, tri);
    snprintf(seamed, sizeof seamed, "%s/attr-seamed-%s.ply", dir, tri);
    snprintf(step, sizeof step, "%s/attr-step.ply", dir);
    struct stat sb;
    if (stat(seamed, &sb) != 0) {
        char *gen[] = {MR_CLI_PATH, "generate", "scan", "--triangles", (char *)tri, "-o", scan,
                       "-q", NULL};
        must(gen, "generate");
        char *seam[] = {"/usr/bin/python3", MR_SOURCE_DIR "/tests/make_seamed.py", "--normals",
                        scan, seamed, NULL};
        must(seam, "make_seamed.py");
    }
    write_step(step);
    row("step", step, "--triangles", "6", dir, threads, runs);
    row("seamed", seamed, "--ratio", "10%", dir, threads, runs);
    row("seamed", seamed, "--ratio", "2%", dir, threads, runs);
    const char *shared[][2] = {{"spot.obj", "spot"},
                               {"beast.obj", "beast"},
                               {"gltf/Duck/glTF-Binary/Duck.glb", "duck"}};
    for (size_t i = 0; i < sizeof shared / sizeof shared[0]; i++) {
        char path[2048];
        const char *root = getenv("MR_SHARED_DATA") ? getenv("MR_SHARED_DATA") : MR_SHARED_DATA;
        snprintf(path, sizeof path, "%s/%s", root, shared[i][0]);
        if (stat(path, &sb) != 0) {
            printf("%-10s absent (%s)\n", shared[i][1], path);
            continue;
        }
        row(shared[i][1], path, "--ratio", "10%", dir, threads, runs);
    }
    return 0;
}
