/*
 * High-valence benchmark: a single polygon of N corners (100k by default) as
 * the OBJ reader triangulates a face `f 1 2 ... N` (a fan: one vertex in all
 * N - 2 triangles, long slivers), against a generated scan-like mesh of
 * about as many triangles. For each: mr_mesh_simplify to 10 % of the
 * vertices (full and half-edge collapse, the default batched strategy),
 * mr_render (1024x768, default options),
 * the same with the wireframe, the heat values of `render --error-to`
 * (mr_surface_distances against a copy lifted by 1e-3 of the box diagonal),
 * and mr_compare with itself and with that copy (1M samples). Median, min
 * and max of several runs, at all threads. The bar: each fan figure about
 * a second or less on 2 cores, and of the order of the scan's.
 *
 *   bench_fan [--corners N] [--runs R] [--samples S] [--threads T]
 *   bench_fan [--corners N] --write FILE.obj [--lift D]
 *
 * The second form only writes the polygon (z moved by D) as the one OBJ
 * face `f 1 2 ... N`, to reproduce with the CLI: `meshreduce render
 * FILE.obj`, `meshreduce compare FILE.obj FILE.obj`, ...
 */
#include "benchutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* The polygon on the ellipse (cos t, 0.6 sin t, 0), fan-triangulated. */
static void make_fan(size_t n, mr_mesh *m)
{
    mr_mesh_init(m);
    m->vertex_count = n;
    m->triangle_count = n - 2;
    m->positions = malloc(3 * n * sizeof *m->positions);
    m->indices = malloc(3 * (n - 2) * sizeof *m->indices);
    if (!m->positions || !m->indices) {
        fprintf(stderr, "bench_fan: out of memory\n");
        exit(1);
    }
    for (size_t i = 0; i < n; i++) {
        const double t = 2 * PI * (double)i / (double)n;
        m->positions[3 * i] = (float)cos(t);
        m->positions[3 * i + 1] = (float)(0.6 * sin(t));
        m->positions[3 * i + 2] = 0;
    }
    for (size_t i = 0; i + 2 < n; i++) {
        m->indices[3 * i] = 0;
        m->indices[3 * i + 1] = (uint32_t)(i + 1);
        m->indices[3 * i + 2] = (uint32_t)(i + 2);
    }
}

/* A copy moved by `d` along z (the fan's normal; any direction for the
 * scan), sharing nothing with the original. */
static void lifted_copy(const mr_mesh *m, float d, mr_mesh *out)
{
    mr_mesh_init(out);
    out->vertex_count = m->vertex_count;
    out->triangle_count = m->triangle_count;
    out->positions = malloc(3 * m->vertex_count * sizeof *out->positions);
    out->indices = malloc(3 * m->triangle_count * sizeof *out->indices);
    if (!out->positions || !out->indices) {
        fprintf(stderr, "bench_fan: out of memory\n");
        exit(1);
    }
    memcpy(out->indices, m->indices, 3 * m->triangle_count * sizeof *out->indices);
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        out->positions[i] = m->positions[i] + (i % 3 == 2 ? d : 0.0f);
}

/* The polygon as one OBJ face (which the reader fan-triangulates). */
static int write_obj(const char *path, const mr_mesh *m, double lift)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        perror(path);
        return 1;
    }
    for (size_t i = 0; i < m->vertex_count; i++)
        fprintf(f, "v %.9g %.9g %.9g\n", m->positions[3 * i], m->positions[3 * i + 1],
                (double)m->positions[3 * i + 2] + lift);
    fputc('f', f);
    for (size_t i = 0; i < m->vertex_count; i++)
        fprintf(f, " %zu", i + 1);
    fputc('\n', f);
    if (fclose(f) != 0) {
        perror(path);
        return 1;
    }
    printf("wrote %s: one face of %zu corners\n", path, m->vertex_count);
    return 0;
}

static double diagonal(const mr_mesh *m)
{
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < m->vertex_count; i++)
        for (int k = 0; k < 3; k++) {
            const float v = m->positions[3 * i + k];
            lo[k] = v < lo[k] ? v : lo[k];
            hi[k] = v > hi[k] ? v : hi[k];
        }
    double d = 0;
    for (int k = 0; k < 3; k++)
        d += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    return sqrt(d);
}

enum { SIMPLIFY, SIMPLIFY_HALF, RENDER, WIRE, HEAT, SELF, LIFTED, OPS };
static const char *const op_names[OPS] = {
    "simplify 10 %", "simplify 10 % half", "render 1024x768", "render --wire",
    "heat (--error-to)", "compare self", "compare lifted"};

typedef struct result {
    bench_summary s[OPS];
    double hausdorff_self, hausdorff_lifted, lift;
} result;

static void run(const mr_mesh *m, int runs, size_t samples, int threads, result *res)
{
    mr_error err;
    mr_mesh lifted;
    const double lift = 1e-3 * diagonal(m);
    lifted_copy(m, (float)lift, &lifted);
    res->lift = (double)(float)lift;
    mr_render_options ro;
    mr_render_options_default(&ro);
    ro.threads = threads;
    uint8_t *img = malloc((size_t)ro.width * (size_t)ro.height * 4);
    float *heat = malloc(m->triangle_count * sizeof *heat);
    double *t = malloc(sizeof(double) * (size_t)runs);
    if (!img || !heat || !t) {
        fprintf(stderr, "bench_fan: out of memory\n");
        exit(1);
    }
    mr_compare_options co;
    mr_compare_options_default(&co);
    co.samples = samples;
    co.threads = threads;
    for (int op = 0; op < OPS; op++) {
        for (int r = 0; r < runs; r++) {
            mr_compare_result cr;
            double mx;
            const double t0 = bench_now();
            switch (op) {
            case SIMPLIFY:
            case SIMPLIFY_HALF: {
                mr_simplify_options so;
                mr_simplify_options_default(&so);
                so.target_ratio = 0.1;
                so.threads = threads;
                so.collapse = op == SIMPLIFY ? MR_COLLAPSE_FULL : MR_COLLAPSE_HALF;
                mr_mesh out;
                bench_check(mr_mesh_simplify(m, &so, &out, NULL, NULL, &err), &err);
                mr_mesh_free(&out);
                break;
            }
            case RENDER:
            case WIRE:
                ro.wire = op == WIRE;
                bench_check(mr_render(m->positions, m->vertex_count, m->indices,
                                      m->triangle_count, &ro, img, 0, &err),
                            &err);
                break;
            case HEAT:
                bench_check(mr_surface_distances(lifted.positions, lifted.vertex_count,
                                                 lifted.indices, lifted.triangle_count,
                                                 m->positions, m->vertex_count, m->indices,
                                                 m->triangle_count, threads, heat, &mx, &err),
                            &err);
                break;
            default:
                bench_check(mr_compare(m->positions, m->vertex_count, m->indices,
                                       m->triangle_count,
                                       op == SELF ? m->positions : lifted.positions,
                                       m->vertex_count, m->indices, m->triangle_count, &co,
                                       &cr, &err),
                            &err);
                if (op == SELF)
                    res->hausdorff_self = cr.hausdorff;
                else
                    res->hausdorff_lifted = cr.hausdorff;
                break;
            }
            t[r] = bench_now() - t0;
        }
        res->s[op] = bench_summarize(t, runs);
    }
    free(t);
    free(heat);
    free(img);
    mr_mesh_free(&lifted);
}

int main(int argc, char **argv)
{
    size_t corners = 100000, samples = 1000000;
    int runs = 5, threads = 0;
    const char *write = NULL;
    double lift = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--corners") && i + 1 < argc)
            corners = (size_t)strtod(argv[++i], NULL);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--samples") && i + 1 < argc)
            samples = (size_t)strtod(argv[++i], NULL);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--write") && i + 1 < argc)
            write = argv[++i];
        else if (!strcmp(argv[i], "--lift") && i + 1 < argc)
            lift = strtod(argv[++i], NULL);
        else {
            fprintf(stderr, "usage: bench_fan [--corners N] [--runs R] [--samples S] "
                            "[--threads T]\n"
                            "       bench_fan [--corners N] --write FILE.obj [--lift D]\n");
            return 2;
        }
    }
    if (corners < 3 || corners > UINT32_MAX) {
        fprintf(stderr, "bench_fan: --corners must be 3 to 2^32 - 1\n");
        return 2;
    }
    if (runs < 1)
        runs = 1;
    mr_mesh fan, scan;
    mr_error err;
    make_fan(corners, &fan);
    if (write) {
        const int rc = write_obj(write, &fan, lift);
        mr_mesh_free(&fan);
        return rc;
    }
    bench_print_machine(stdout);
    bench_check(mr_generate(MR_GEN_SCAN, fan.triangle_count, 1, &scan, &err), &err);
    printf("fan: one %zu-corner polygon, %zu triangles around vertex 0\n", corners,
           fan.triangle_count);
    printf("scan: mr_generate scan, seed 1: %zu vertices, %zu triangles\n", scan.vertex_count,
           scan.triangle_count);
    printf("%d runs each, %s threads, compare with %zu samples; lifted copy: moved by 1e-3 "
           "of the diagonal\n\n",
           runs, threads ? "given" : "all", samples);
    result rf, rs;
    run(&fan, runs, samples, threads, &rf);
    run(&scan, runs, samples, threads, &rs);
    printf("%-20s %28s %28s\n", "", "fan: median (min, max) s", "scan: median (min, max) s");
    int pass = 1;
    for (int op = 0; op < OPS; op++) {
        printf("%-20s %10.4f (%.4f, %.4f) %10.4f (%.4f, %.4f)\n", op_names[op], rf.s[op].median,
               rf.s[op].min, rf.s[op].max, rs.s[op].median, rs.s[op].min, rs.s[op].max);
        pass &= rf.s[op].median < 1.5;
    }
    printf("\nhausdorff: fan self %.3g, lifted %.9g (lift %.9g); scan self %.3g, lifted %.9g "
           "(lift %.9g)\n",
           rf.hausdorff_self, rf.hausdorff_lifted, rf.lift, rs.hausdorff_self,
           rs.hausdorff_lifted, rs.lift);
    printf("bar: %s  every fan figure under 1.5 s (about a second) for %zu corners\n",
           pass ? "PASS" : "MISS", corners);
    mr_mesh_free(&fan);
    mr_mesh_free(&scan);
    return 0;
}
