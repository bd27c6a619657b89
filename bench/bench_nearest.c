/*
 * Nearest-triangle queries in the triangle hierarchy (geometry/distance.h):
 * what `meshreduce compare` and the first sweep of --quality best's surface
 * fit spend most of their time in.
 *
 * For each mesh: the hierarchy over its triangles (one thread), then one
 * query per triangle at its centroid moved by up to `--jitter` of the
 * bounding-box diagonal along each axis (a fixed sequence: points near the
 * surface, in the mesh's triangle order, as the fit's samples are), on one
 * thread. Median, min and max nanoseconds a query over --runs passes, and a
 * checksum of the squared distances (the same on every build that finds
 * the same nearest points).
 *
 *   bench_nearest [--runs R] [--jitter F] [--data DIR] [--mesh NAME]...
 *
 * Meshes: armadillo and homer from the data folder when present, and the
 * generated 1M-triangle scan.
 */
#include "benchutil.h"
#include "geometry/distance.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef MR_SHARED_DATA
#define MR_SHARED_DATA "../shared/data"
#endif

typedef struct spec {
    const char *name, *file; /* file NULL: the generated scan */
    size_t triangles;
} spec;

static const spec specs[] = {
    {"armadillo", "armadillo.obj", 0},
    {"homer", "homer.obj", 0},
    {"scan-1M", NULL, 1000000},
};

/* A fixed sequence in [-0.5, 0.5). */
static double jitter_next(uint64_t *state)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*state >> 11) / 9007199254740992.0 - 0.5;
}

static void run_mesh(const spec *sp, const char *data, int runs, double jitter)
{
    mr_mesh m;
    mr_mesh_init(&m);
    if (!bench_load_mesh(data, sp->file, sp->triangles, 0, &m, NULL, NULL)) {
        printf("%-10s absent (%s/%s)\n", sp->name, data, sp->file);
        return;
    }
    mr_error err;
    mr_tri_bvh t;
    bench_check(mr_tri_bvh_build(&t, m.positions, m.indices, m.triangle_count, 1, &err), &err);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < m.vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            const double x = m.positions[3 * v + (size_t)k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    const double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                             (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const size_t nq = m.triangle_count;
    double *q = malloc(3 * nq * sizeof *q), *times = malloc((size_t)runs * sizeof *times);
    if (!q || !times) {
        fprintf(stderr, "bench_nearest: out of memory\n");
        exit(1);
    }
    uint64_t state = 1;
    for (size_t i = 0; i < nq; i++) {
        const uint32_t *tv = m.indices + 3 * i;
        for (int k = 0; k < 3; k++)
            q[3 * i + (size_t)k] = ((double)m.positions[3 * (size_t)tv[0] + (size_t)k] +
                                    m.positions[3 * (size_t)tv[1] + (size_t)k] +
                                    m.positions[3 * (size_t)tv[2] + (size_t)k]) /
                                       3 +
                                   jitter * diag * jitter_next(&state);
    }
    double sum = 0;
    for (int r = 0; r < runs; r++) {
        double s = 0;
        const double t0 = bench_now();
        for (size_t i = 0; i < nq; i++) {
            uint32_t tri;
            double c[3];
            s += mr_tri_bvh_nearest(&t, q + 3 * i, MR_NO_HINT, &tri, c);
        }
        times[r] = (bench_now() - t0) / (double)nq * 1e9;
        sum = s;
    }
    const bench_summary bs = bench_summarize(times, runs);
    printf("%-10s %10zu %10zu %9.1f %9.1f %9.1f  %.9g\n", sp->name, m.triangle_count, nq, bs.median,
           bs.min, bs.max, sum);
    free(q);
    free(times);
    mr_tri_bvh_free(&t);
    mr_mesh_free(&m);
}

int main(int argc, char **argv)
{
    int runs = 5;
    double jitter = 1e-3;
    const char *data = MR_SHARED_DATA;
    const char *only[8];
    int n_only = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--jitter") && i + 1 < argc)
            jitter = atof(argv[++i]);
        else if (!strcmp(argv[i], "--data") && i + 1 < argc)
            data = argv[++i];
        else if (!strcmp(argv[i], "--mesh") && i + 1 < argc && n_only < 8)
            only[n_only++] = argv[++i];
        else {
            fprintf(stderr, "usage: bench_nearest [--runs R] [--jitter F] [--data DIR] "
                            "[--mesh NAME]...\n");
            return 2;
        }
    }
    if (runs < 1 || !(jitter >= 0)) {
        fprintf(stderr, "bench_nearest: --runs must be at least 1 and --jitter at least 0\n");
        return 2;
    }
    bench_print_machine(stdout);
    printf("nearest-triangle queries at triangle centroids moved by up to %g of the diagonal "
           "per axis, one thread, %d runs\n",
           jitter, runs);
    printf("%-10s %10s %10s %9s %9s %9s  %s\n", "mesh", "triangles", "queries", "median ns",
           "min ns", "max ns", "checksum");
    for (size_t k = 0; k < sizeof specs / sizeof *specs; k++) {
        bool wanted = n_only == 0;
        for (int j = 0; j < n_only; j++)
            wanted |= !strcmp(only[j], specs[k].name);
        if (wanted)
            run_mesh(&specs[k], data, runs, jitter);
    }
    return 0;
}
