/*
 * Rendering benchmark: mr_render of a generated scan-like mesh (about 1M
 * triangles by default) at 1024x768 with the default options (3x3
 * supersampling, iso view), at 1 thread and at all threads; the median,
 * min and max of several runs. The bar: well under a second on 2 cores.
 *
 *   bench_render [--triangles N] [--runs R] [--size WxH] [--wire] [--png FILE]
 */
#include "benchutil.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

int main(int argc, char **argv)
{
    size_t triangles = 1000000;
    int runs = 7, wire = 0, w = 1024, h = 768;
    const char *png = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--triangles") && i + 1 < argc)
            triangles = (size_t)strtod(argv[++i], NULL);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--size") && i + 1 < argc) {
            if (sscanf(argv[++i], "%dx%d", &w, &h) != 2 || w < 1 || h < 1) {
                fprintf(stderr, "bench_render: --size needs WxH\n");
                return 2;
            }
        } else if (!strcmp(argv[i], "--wire"))
            wire = 1;
        else if (!strcmp(argv[i], "--png") && i + 1 < argc)
            png = argv[++i];
        else {
            fprintf(stderr, "usage: bench_render [--triangles N] [--runs R] [--size WxH] "
                            "[--wire] [--png FILE]\n");
            return 2;
        }
    }
    if (runs < 1)
        runs = 1;
    bench_print_machine(stdout);
    mr_mesh m;
    mr_error err;
    bench_check(mr_generate(MR_GEN_SCAN, triangles, 1, &m, &err), &err);
    printf("mesh: mr_generate scan, seed 1: %zu vertices, %zu triangles\n", m.vertex_count,
           m.triangle_count);
    mr_render_options o;
    mr_render_options_default(&o);
    o.width = w;
    o.height = h;
    o.wire = wire;
    printf("render %dx%d, supersample %d (%dx%d samples), %s view%s; %d runs each\n", w, h,
           o.supersample, w * o.supersample, h * o.supersample, "iso", wire ? ", wireframe" : "",
           runs);
    uint8_t *img = malloc((size_t)w * (size_t)h * 4);
    uint8_t *first = malloc((size_t)w * (size_t)h * 4);
    double *t = malloc(sizeof(double) * (size_t)runs);
    int all = omp_get_max_threads();
    int counts[2] = {1, all};
    double median_all = 0;
    for (int k = 0; k < (all > 1 ? 2 : 1); k++) {
        o.threads = counts[k];
        for (int r = 0; r < runs; r++) {
            double t0 = bench_now();
            bench_check(mr_render(m.positions, m.vertex_count, m.indices, m.triangle_count, &o,
                                  img, 0, &err),
                        &err);
            t[r] = bench_now() - t0;
        }
        if (k == 0)
            memcpy(first, img, (size_t)w * (size_t)h * 4);
        bench_summary s = bench_summarize(t, runs);
        printf("  %2d thread%s  median %.4f s  (min %.4f, max %.4f)  %.1f M triangles/s\n",
               counts[k], counts[k] == 1 ? " " : "s", s.median, s.min, s.max,
               (double)m.triangle_count / s.median / 1e6);
        median_all = s.median;
    }
    int same = !memcmp(first, img, (size_t)w * (size_t)h * 4);
    printf("  image identical at 1 and %d threads: %s\n", all, same ? "yes" : "NO");
    printf("bar: %s  %.4f s < 1 s for %zu triangles at %dx%d on %d threads\n",
           median_all < 1.0 ? "PASS" : "MISS", median_all, m.triangle_count, w, h, all);
    if (png) {
        bench_check(mr_png_write(png, img, w, h, &err), &err);
        printf("image: %s\n", png);
    }
    free(t);
    free(img);
    free(first);
    mr_mesh_free(&m);
    return same ? 0 : 1;
}
