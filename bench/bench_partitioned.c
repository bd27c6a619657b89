/*
 * The partitioned-batch strategy and its boundary-aware variant against
 * the default one and meshopt_simplify, in one run: per mesh and target
 * (25/10/1/0.5 % of the vertices), the time of the default (batched), the
 * partitioned and the partitioned-boundary strategies at each thread count
 * and of meshopt_simplify (one thread), in alternating runs; the speedup
 * over the strategy's own 1-thread run, over the default at the same
 * thread count, and meshopt's time over the strategy's; the surface distance to
 * the input (mr_compare: Hausdorff and RMS, % of the diagonal); whether the
 * output is the same bytes at every thread count; and the seam measure:
 * the mean distance to the input of the output triangles whose centroid
 * lies within two mean edge lengths of a slab plane, over the mean of the
 * others (the planes of the first partition: the vertex-count quantiles
 * along the longest axis; later rebalances move them; "-" when every
 * triangle lies that near a plane). The bars of the issue follow.
 *
 *   bench_partitioned [--runs R] [--threads 1,2,...] [--partitions P] [--samples N]
 *                     [--data DIR] [--mesh NAME]... [--quick]
 *
 * --quick: the 1M scan to 10 % and 1 %, the bunny and the armadillo to 10 %
 * and 1 %, 3 runs.
 */
#include "benchpeers.h"
#include "geometry/distance.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_THREADS 16
#define NT 4
/* The strategies measured, in this order. */
#define NS 3
static const mr_strategy strategies[NS] = {MR_STRATEGY_BATCHED, MR_STRATEGY_PARTITIONED,
                                           MR_STRATEGY_PARTITIONED_BOUNDARY};
static const char *const strategy_names[NS] = {"default", "partitioned", "part-boundary"};
static const double targets[NT] = {0.25, 0.10, 0.01, 0.005};

typedef struct spec {
    const char *name, *file;
    size_t triangles;
} spec;

static const spec specs[] = {
    {"scan-1M", NULL, 1000000},
    {"bunny", "stanford-bunny.obj", 0},
    {"armadillo", "armadillo.obj", 0},
};

static uint64_t hash_output(const mr_simplified *o)
{
    uint64_t h = 0xCBF29CE484222325ull;
    const unsigned char *p = (const unsigned char *)o->positions;
    for (size_t i = 0; i < 3 * o->vertex_count * sizeof *o->positions; i++)
        h = (h ^ p[i]) * 0x100000001B3ull;
    p = (const unsigned char *)o->indices;
    for (size_t i = 0; i < 3 * o->triangle_count * sizeof *o->indices; i++)
        h = (h ^ p[i]) * 0x100000001B3ull;
    return h;
}

static double run_ours(const mr_mesh *in, double ratio, mr_strategy st, unsigned parts,
                       int threads, mr_simplified *out)
{
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = ratio;
    o.strategy = st;
    o.partitions = parts;
    o.threads = threads;
    omp_set_num_threads(threads);
    mr_error err;
    const double t0 = bench_now();
    bench_check(mr_simplify(in->positions, 0, in->vertex_count, in->indices, in->triangle_count,
                            &o, out, &err),
                &err);
    return bench_now() - t0;
}

static int cmp_float(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

/* The first partition's planes: `parts` - 1 vertex-count quantiles of
 * in's vertices along the longest axis of their box (*axis). */
static double *slab_planes(const mr_mesh *in, unsigned parts, int *axis)
{
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < in->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            const float p = in->positions[3 * v + (size_t)k];
            lo[k] = p < lo[k] ? p : lo[k];
            hi[k] = p > hi[k] ? p : hi[k];
        }
    int ax = 0;
    for (int k = 1; k < 3; k++)
        ax = hi[k] - lo[k] > hi[ax] - lo[ax] ? k : ax;
    float *c = malloc(sizeof *c * in->vertex_count);
    double *plane = malloc(sizeof *plane * parts);
    if (!c || !plane) {
        fprintf(stderr, "bench_partitioned: out of memory\n");
        exit(1);
    }
    for (size_t v = 0; v < in->vertex_count; v++)
        c[v] = in->positions[3 * v + (size_t)ax];
    qsort(c, in->vertex_count, sizeof *c, cmp_float);
    for (unsigned k = 1; k < parts; k++)
        plane[k - 1] = c[(size_t)((double)k / parts * (double)in->vertex_count)];
    free(c);
    *axis = ax;
    return plane;
}

/* The seam measure of output o (see the top): the parts - 1 planes along
 * axis ax; -1 when every triangle (or none) lies near one. */
static double seam_ratio(const mr_tri_bvh *bvh, const mr_simplified *o, const double *plane,
                         unsigned parts, int ax)
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
        for (unsigned k = 0; k + 1 < parts; k++)
            near |= fabs(p[ax] - plane[k]) <= 2 * el;
        sum[near] += d;
        n[near]++;
    }
    if (!n[0] || !n[1] || !(sum[0] > 0))
        return -1;
    return (sum[1] / (double)n[1]) / (sum[0] / (double)n[0]);
}

static void distances(const mr_mesh *in, const mr_simplified *o, size_t samples, double *h,
                      double *rms)
{
    mr_compare_options co;
    mr_compare_options_default(&co);
    co.samples = samples;
    mr_compare_result r;
    mr_error err;
    bench_check(mr_compare(in->positions, in->vertex_count, in->indices, in->triangle_count,
                           o->positions, o->vertex_count, o->indices, o->triangle_count, &co, &r,
                           &err),
                &err);
    *h = 100 * r.hausdorff_rel;
    *rms = 100 * r.rms_rel;
}

int main(int argc, char **argv)
{
    int runs = 5, nthreads = 2, threads[MAX_THREADS] = {1, 2}, quick = 0;
    unsigned parts = MR_PARTITIONS_DEFAULT;
    size_t samples = 200000;
    const char *data = MR_SHARED_DATA;
    const char *only[8];
    int n_only = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--partitions") && i + 1 < argc)
            parts = (unsigned)atoi(argv[++i]);
        else if (!strcmp(argv[i], "--samples") && i + 1 < argc)
            samples = (size_t)atof(argv[++i]);
        else if (!strcmp(argv[i], "--data") && i + 1 < argc)
            data = argv[++i];
        else if (!strcmp(argv[i], "--mesh") && i + 1 < argc && n_only < 8)
            only[n_only++] = argv[++i];
        else if (!strcmp(argv[i], "--quick"))
            quick = 1;
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) {
            nthreads = 0;
            for (char *s = argv[++i]; *s && nthreads < MAX_THREADS;) {
                threads[nthreads++] = atoi(s);
                char *c = strchr(s, ',');
                if (!c)
                    break;
                s = c + 1;
            }
        } else {
            fprintf(stderr, "usage: bench_partitioned [--runs R] [--threads 1,2,...] "
                            "[--partitions P] [--samples N] [--data DIR] [--mesh NAME]... "
                            "[--quick]\n");
            return 2;
        }
    }
    if (quick && runs == 5)
        runs = 3;
    if (runs < 1 || runs > 64 || nthreads < 1 || threads[0] != 1 || parts < 1 ||
        parts > MR_PARTITIONS_MAX) {
        fprintf(stderr, "bench_partitioned: --runs 1..64, --threads starting at 1, "
                        "--partitions 1..%d\n",
                MR_PARTITIONS_MAX);
        return 2;
    }
    bench_print_machine(stdout);
    printf("partitioned, part(itioned)-boundary: %u slabs; times: median of %d alternating "
           "runs (each strategy at each thread count, then meshopt_simplify); H, RMS: mr_compare, %zu "
           "samples, %% of the diagonal; seam: mean distance near the slab planes / elsewhere\n",
           parts, runs, samples);
    if (!bench_have_meshopt())
        printf("meshopt_simplify not built in: its column is empty\n");
    double bar_speedup = -1, bar_mo = -1, bar_seam = -1, worst_rms = 0, worst_brms = 0;
    double b_speedup = -1;
    for (size_t si = 0; si < sizeof specs / sizeof *specs; si++) {
        const spec *sp = &specs[si];
        int wanted = n_only == 0;
        for (int k = 0; k < n_only; k++)
            wanted |= !strcmp(only[k], sp->name);
        mr_mesh in;
        if (!wanted || !bench_load_mesh(data, sp->file, sp->triangles, 0, &in, NULL, NULL))
            continue;
        mr_tri_bvh bvh;
        mr_error err;
        bench_check(mr_tri_bvh_build(&bvh, in.positions, in.indices, in.triangle_count,
                                     omp_get_num_procs(), &err),
                    &err);
        int axis;
        double *plane = slab_planes(&in, parts, &axis);
        printf("\nmesh %s: %zu vertices, %zu triangles\n", sp->name, in.vertex_count,
               in.triangle_count);
        printf("%-7s %-13s %3s %9s %8s %8s %9s %9s %9s %6s %5s\n", "target", "strategy", "thr",
               "median s", "speedup", "vs def", "mopt/us", "H %", "RMS %", "seam", "same");
        uint32_t *mo = malloc(sizeof *mo * 3 * (in.triangle_count + 1));
        for (int ti = 0; ti < NT; ti++) {
            if (quick && (ti == 0 || ti == 3))
                continue;
            double t[NS][MAX_THREADS][64], tm[64];
            uint64_t h0[NS] = {0, 0, 0};
            int same[NS] = {1, 1, 1};
            mr_simplified keep[NS];
            for (int r = 0; r < runs; r++) {
                for (int s = 0; s < NS; s++)
                    for (int j = 0; j < nthreads; j++) {
                        mr_simplified o;
                        t[s][j][r] =
                            run_ours(&in, targets[ti], strategies[s], parts, threads[j], &o);
                        const uint64_t h = hash_output(&o);
                        if (r == 0 && j == 0) {
                            h0[s] = h;
                            keep[s] = o;
                            continue;
                        }
                        same[s] &= h == h0[s];
                        mr_simplified_free(&o);
                    }
                size_t nidx = 0;
                tm[r] = -1;
                if (mo && bench_have_meshopt())
                    bench_meshopt_call(&in, keep[0].triangle_count, 0, mo, &nidx, &tm[r]);
            }
            const double mo_med = tm[0] >= 0 ? bench_summarize(tm, runs).median : -1;
            double base[NS] = {0, 0, 0}, rms[NS], hd[NS];
            for (int s = 0; s < NS; s++) {
                distances(&in, &keep[s], samples, &hd[s], &rms[s]);
                const double seam = seam_ratio(&bvh, &keep[s], plane, parts, axis);
                for (int j = 0; j < nthreads; j++) {
                    const bench_summary sm = bench_summarize(t[s][j], runs);
                    if (j == 0)
                        base[s] = sm.median;
                    const double def_j = bench_summarize(t[0][j], runs).median;
                    char mos[16] = "", vs[16] = "", seams[16] = "-";
                    if (seam >= 0) /* else every triangle lies near a plane */
                        snprintf(seams, sizeof seams, "%.3f", seam);
                    if (mo_med > 0)
                        snprintf(mos, sizeof mos, "%.2f", mo_med / sm.median);
                    if (s)
                        snprintf(vs, sizeof vs, "%.2f", def_j / sm.median);
                    printf("%5g%%  %-13s %3d %9.4f %7.2fx %8s %9s %9.4f %9.5f %6s %5s\n",
                           100 * targets[ti], strategy_names[s], threads[j],
                           sm.median, base[s] / sm.median, vs, mos, hd[s], rms[s], seams,
                           same[s] ? "yes" : "NO");
                    if (s == 1 && j == 1 && !strcmp(sp->name, "scan-1M") && ti == 1) {
                        bar_speedup = base[1] / sm.median;
                        bar_mo = mo_med > 0 ? mo_med / sm.median : -1;
                        bar_seam = seam;
                    }
                    if (s == 2 && j == 1 && !strcmp(sp->name, "scan-1M") && ti == 1)
                        b_speedup = base[2] / sm.median;
                }
            }
            if (ti == 1 || ti == 2) {
                const double d = fabs(rms[1] / rms[0] - 1), e = rms[2] / rms[1] - 1;
                worst_rms = d > worst_rms ? d : worst_rms;
                worst_brms = e > worst_brms ? e : worst_brms;
            }
            for (int s = 0; s < NS; s++)
                mr_simplified_free(&keep[s]);
        }
        free(mo);
        free(plane);
        mr_tri_bvh_free(&bvh);
        mr_mesh_free(&in);
    }
    printf("\nbars (issue 16):\n");
    printf("  partitioned, 2 threads >= 1.8x its 1 thread, scan-1M to 10 %%:   %s\n",
           bar_speedup < 0 ? "not measured" : bar_speedup >= 1.8 ? "met" : "NOT met");
    if (bar_speedup >= 0)
        printf("    measured %.2fx\n", bar_speedup);
    printf("  partitioned, 2 threads faster than meshopt_simplify, scan-1M to 10 %%: %s\n",
           bar_mo < 0 ? "not measured" : bar_mo > 1 ? "met" : "NOT met");
    if (bar_mo >= 0)
        printf("    measured meshopt / partitioned %.2f\n", bar_mo);
    printf("  RMS within 5 %% of the default at 10 %% and 1 %%: worst %.1f %% (%s)\n",
           100 * worst_rms, worst_rms <= 0.05 ? "met" : "NOT met");
    printf("  seam: near-plane mean error <= 1.2x elsewhere, scan-1M to 10 %%: %s\n",
           bar_seam < 0 ? "not measured" : bar_seam <= 1.2 ? "met" : "NOT met");
    if (bar_seam >= 0)
        printf("    measured %.3f\n", bar_seam);
    printf("  partitioned-boundary: RMS within 2 %% of partitioned at 10 %% and 1 %% (the "
           "aim): worst %+.1f %% (%s)\n",
           100 * worst_brms, worst_brms <= 0.02 ? "met" : "NOT met");
    if (b_speedup >= 0)
        printf("  partitioned-boundary, 2 threads over its 1 thread, scan-1M to 10 %%: %.2fx\n",
               b_speedup);
    return 0;
}
