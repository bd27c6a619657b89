/*
 * The simplifier's vector kernels (src/qem/kernels.h), each path alone and
 * end to end.
 *
 * Alone: each kernel on inputs that stay in cache (so the figure is the
 * kernel's own work, not memory's), on the default path and on each vector
 * path the CPU has, in alternating rounds; median time per element and the
 * speedup over the default path, after checking that both give the same
 * bits on those inputs. End to end: mr_simplify of the generated scan
 * (default 1M triangles, to 10 % of its vertices) on the default path and
 * on the best one, alternating, at each thread count; median seconds, and
 * whether the outputs are the same bytes.
 *
 *   bench_kernels [--runs R] [--triangles N] [--ratio F] [--threads 1,2,...] [--quick]
 */
#include "benchutil.h"
#include "qem/kernels.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng_state = 0x2545F4914F6CDD1Dull;
static double rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0 - 0.5;
}

static void random_quadric(mr_quadricf *q)
{
    mr_quadric a;
    mr_quadric_zero(&a);
    for (int p = 0; p < 6; p++) {
        double n[3] = {rnd(), rnd(), rnd()};
        const double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int i = 0; i < 3; i++)
            n[i] /= l;
        mr_quadric_add_plane(&a, n, rnd() * 1e-3, (rnd() + 0.5) * 1e-5);
    }
    mr_quadric_store(q, &a);
}

/* The inputs of every kernel: a few hundred KB, in cache. */
enum { NB = 32, NPLANE = 2048, NFAN = 1024, NMERGE = 4096 };
typedef struct inputs {
    float cost_in[NB][FREE_INPUTS * MR_COST_BATCH];
    double plane_in[NPLANE / 8][6 * MR_PLANE_ROW];
    double fan_in[16][9 * MR_FAN_ROW];
    double fan_t[NFAN][3];
    mr_quadricf q[NMERGE + 1];
    double d[NMERGE][3];
    /* outputs */
    double cost[MR_COST_BATCH], x[3 * MR_COST_BATCH], plane_out[7 * MR_PLANE_ROW];
} inputs;

static void fill(inputs *in)
{
    const double box[3] = {0.5, 0.5, 0.5};
    (void)box;
    for (int b = 0; b < NB; b++)
        for (int l = 0; l < MR_COST_BATCH; l++) {
            mr_quadricf qu, qw;
            random_quadric(&qu);
            random_quadric(&qw);
            for (int k = 0; k < 11; k++) {
                in->cost_in[b][(FREE_QU + k) * MR_COST_BATCH + l] = (&qu.a00)[k];
                in->cost_in[b][(FREE_QW + k) * MR_COST_BATCH + l] = (&qw.a00)[k];
            }
            for (int k = 0; k < 3; k++) {
                const float pw = (float)(rnd() * 0.6);
                in->cost_in[b][(FREE_PW + k) * MR_COST_BATCH + l] = pw;
                in->cost_in[b][(FREE_PU + k) * MR_COST_BATCH + l] = pw + (float)(rnd() * 1e-2);
            }
        }
    /* a vertex of valence 6 (plane terms: 8 lanes, 2 padding) */
    for (int c = 0; c < NPLANE / 8; c++)
        for (int i = 0; i < 8; i++)
            for (int k = 0; k < 6; k++)
                in->plane_in[c][k * MR_PLANE_ROW + i] = i < 6 ? (float)(rnd() * 1e-2) : 0;
    /* two fans of valence 6 (the normal test: 12 triangles) */
    for (int c = 0; c < 16; c++)
        for (int i = 0; i < 12; i++) {
            const double a0 = 6.283185307179586 * (i % 6) / 6.0,
                         a1 = 6.283185307179586 * (i % 6 + 1) / 6.0;
            const double p[9] = {0, 0, 0, cos(a0), sin(a0), rnd() * 0.1,
                                 cos(a1), sin(a1), rnd() * 0.1};
            for (int k = 0; k < 9; k++)
                in->fan_in[c][k * MR_FAN_ROW + i] = (float)p[k];
        }
    for (int i = 0; i < NFAN; i++)
        for (int k = 0; k < 3; k++)
            in->fan_t[i][k] = rnd() * 0.1;
    for (int i = 0; i <= NMERGE; i++)
        random_quadric(&in->q[i]);
    for (int i = 0; i < NMERGE; i++)
        for (int k = 0; k < 3; k++)
            in->d[i][k] = rnd() * 1e-2;
}

/* Each kernel over all its inputs once; returns elements done. */
typedef size_t (*kernel_run)(const mr_kernels *k, inputs *in, uint64_t *sig);

static uint64_t mix(uint64_t h, const void *p, size_t n)
{
    const unsigned char *c = p;
    for (size_t i = 0; i < n; i++)
        h = (h ^ c[i]) * 0x100000001B3ull;
    return h;
}

static size_t run_costs(const mr_kernels *k, inputs *in, uint64_t *sig)
{
    const double box[3] = {0.5, 0.5, 0.5};
    for (int b = 0; b < NB; b++) {
        k->free_costs(in->cost_in[b], MR_COST_BATCH, in->cost, in->x, box);
        if (sig)
            *sig = mix(mix(*sig, in->cost, sizeof in->cost), in->x, sizeof in->x);
    }
    return (size_t)NB * MR_COST_BATCH;
}

static size_t run_plane(const mr_kernels *k, inputs *in, uint64_t *sig)
{
    for (int c = 0; c < NPLANE / 8; c++) {
        k->plane_terms(in->plane_in[c], 8, in->plane_out);
        if (sig)
            for (int r = 0; r < 7; r++)
                *sig = mix(*sig, in->plane_out + r * MR_PLANE_ROW, 8 * sizeof(double));
    }
    return NPLANE / 8;
}

static size_t run_fan(const mr_kernels *k, inputs *in, uint64_t *sig)
{
    unsigned ok = 0;
    for (int i = 0; i < NFAN; i++) {
        const bool r = k->fan_ok(in->fan_in[i % 16], 12, in->fan_t[i], 0.5);
        ok += r;
        if (sig)
            *sig = mix(*sig, &r, sizeof r);
    }
    if (ok == 0xFFFFFFFFu)
        puts(""); /* keeps the calls */
    return NFAN;
}

static size_t run_merge(const mr_kernels *k, inputs *in, uint64_t *sig)
{
    /* independent merges, as a collapse's are (the first half's records
     * take in the second half's) */
    enum { H = NMERGE / 2 };
    for (int i = 0; i < H; i++)
        k->merge(&in->q[i], &in->q[H + i], in->d[i], in->d[H + i]);
    if (sig)
        *sig = mix(*sig, in->q, sizeof in->q);
    return H;
}

typedef struct kernel_case {
    const char *name, *unit;
    kernel_run run;
} kernel_case;

static void parse_threads(const char *s, int *t, int *n)
{
    *n = 0;
    while (*s && *n < 16) {
        t[(*n)++] = atoi(s);
        const char *c = strchr(s, ',');
        if (!c)
            break;
        s = c + 1;
    }
}

static uint64_t output_hash(const mr_simplified *o)
{
    uint64_t h = 0xCBF29CE484222325ull;
    h = mix(h, o->positions, 3 * o->vertex_count * sizeof *o->positions);
    return mix(h, o->indices, 3 * o->triangle_count * sizeof *o->indices);
}

int main(int argc, char **argv)
{
    int runs = 5, nthreads = 2, threads[16] = {1, 2};
    size_t triangles = 1000000;
    double ratio = 0.1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--triangles") && i + 1 < argc)
        {
            char *end;
            double v = strtod(argv[++i], &end);
            v *= *end == 'k' ? 1e3 : *end == 'M' ? 1e6 : 1;
            triangles = v >= 1000 ? (size_t)v : 1000;
        }
        else if (!strcmp(argv[i], "--ratio") && i + 1 < argc)
            ratio = atof(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            parse_threads(argv[++i], threads, &nthreads);
        else if (!strcmp(argv[i], "--quick"))
            runs = 3;
        else {
            fprintf(stderr,
                    "usage: bench_kernels [--runs R] [--triangles N] [--ratio F] "
                    "[--threads 1,2,...] [--quick]\n");
            return 2;
        }
    }
    if (runs < 1 || runs > 64 || nthreads < 1) {
        fprintf(stderr, "bench_kernels: --runs 1..64, --threads a list\n");
        return 2;
    }
    bench_print_machine(stdout);
    const mr_kernels *paths[MR_PATHS];
    for (int p = 0; p < MR_PATHS; p++) {
        paths[p] = mr_kernels_path(p);
        printf("path %-8s %s\n", p == MR_PATH_DEFAULT ? "default" : "avx2",
               paths[p] ? "available" : "not on this CPU or build");
    }

    inputs *in = malloc(sizeof *in);
    if (!in) {
        fprintf(stderr, "bench_kernels: out of memory\n");
        return 1;
    }
    const kernel_case cases[] = {
        {"free_costs (solve + cost)", "edge", run_costs},
        {"plane_terms (construction)", "vertex", run_plane},
        {"fan_ok (normal test)", "collapse", run_fan},
        {"merge (addition)", "collapse", run_merge},
    };
    printf("\nkernels alone (in cache; median of %d alternating rounds of ~20 ms)\n", runs);
    printf("%-28s %-8s %12s %12s %8s %5s\n", "kernel", "path", "ns/element", "min", "speedup",
           "same");
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        double t[MR_PATHS][64];
        uint64_t sig[MR_PATHS];
        /* the same bits: the signature of one pass over fresh inputs */
        for (int p = 0; p < MR_PATHS; p++) {
            if (!paths[p])
                continue;
            rng_state = 0x2545F4914F6CDD1Dull;
            fill(in);
            sig[p] = 0xCBF29CE484222325ull;
            cases[c].run(paths[p], in, &sig[p]);
        }
        rng_state = 0x2545F4914F6CDD1Dull;
        fill(in);
        for (int r = 0; r < runs; r++)
            for (int p = 0; p < MR_PATHS; p++) {
                if (!paths[p])
                    continue;
                size_t done = 0;
                const double t0 = bench_now();
                double t1 = t0;
                while (t1 - t0 < 0.02) {
                    done += cases[c].run(paths[p], in, NULL);
                    t1 = bench_now();
                }
                t[p][r] = (t1 - t0) / (double)done * 1e9;
            }
        bench_summary base = {0, 0, 0};
        for (int p = 0; p < MR_PATHS; p++) {
            if (!paths[p])
                continue;
            const bench_summary s = bench_summarize(t[p], runs);
            if (p == MR_PATH_DEFAULT)
                base = s;
            printf("%-28s %-8s %12.2f %12.2f %7.2fx %5s\n", cases[c].name, paths[p]->name,
                   s.median, s.min, base.median / s.median,
                   sig[p] == sig[MR_PATH_DEFAULT] ? "yes" : "NO");
        }
    }
    free(in);

    /* end to end */
    mr_mesh mesh;
    bench_load_mesh(NULL, NULL, triangles, 0, &mesh, NULL, NULL);
    printf("\nend to end: mr_simplify, generated scan (%zu vertices, %zu triangles) to %g of "
           "its vertices; median (min) of %d alternating runs\n",
           mesh.vertex_count, mesh.triangle_count, ratio, runs);
    printf("%-8s %-8s %10s %10s %8s %5s\n", "threads", "path", "median s", "min s", "speedup",
           "same");
    for (int ti = 0; ti < nthreads; ti++) {
        double t[MR_PATHS][64];
        uint64_t h[MR_PATHS] = {0};
        bool same = true;
        for (int r = 0; r < runs; r++)
            for (int p = 0; p < MR_PATHS; p++) {
                if (!paths[p])
                    continue;
                mr_kernels_use(paths[p]);
                mr_simplify_options o;
                mr_simplify_options_default(&o);
                o.target_ratio = ratio;
                o.threads = threads[ti];
                mr_simplified out;
                mr_error err;
                const double t0 = bench_now();
                bench_check(mr_simplify(mesh.positions, 0, mesh.vertex_count, mesh.indices,
                                        mesh.triangle_count, &o, &out, &err),
                            &err);
                t[p][r] = bench_now() - t0;
                const uint64_t hh = output_hash(&out);
                if (r == 0 && p == MR_PATH_DEFAULT)
                    h[0] = hh;
                same = same && hh == h[0];
                h[p] = hh;
                mr_simplified_free(&out);
            }
        bench_summary base = {0, 0, 0};
        for (int p = 0; p < MR_PATHS; p++) {
            if (!paths[p])
                continue;
            const bench_summary s = bench_summarize(t[p], runs);
            if (p == MR_PATH_DEFAULT)
                base = s;
            printf("%-8d %-8s %10.4f %10.4f %7.2fx %5s\n", threads[ti], paths[p]->name,
                   s.median, s.min, base.median / s.median, same ? "yes" : "NO");
        }
    }
    mr_kernels_use(NULL);
    mr_mesh_free(&mesh);
    return 0;
}
