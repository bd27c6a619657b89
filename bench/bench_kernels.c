/*
 * The simplifier's vector kernels (src/qem/core/kernels.h), each path alone and
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
#include "qem/core/kernels.h"

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
    /* fan sums: an edge (0, 1) with 10 ring vertices, 12 triangles (two on
     * the edge), r's 7 and k's 7 list entries, bumped 16 ways */
    float ring_pos[16][3 * 12 + 1];
    uint32_t ring_tris[3 * 12], ring_lr[7], ring_lk[7];
    /* outputs */
    double cost[MR_COST_BATCH], x[3 * MR_COST_BATCH], plane_out[7 * MR_PLANE_ROW];
} inputs;

static void fill_rings(inputs *in)
{
    enum { N = 10 };
    for (int c = 0; c < 16; c++) {
        float *p = in->ring_pos[c];
        memset(p, 0, sizeof in->ring_pos[c]);
        p[3] = 1;
        for (int i = 0; i < N; i++) {
            const double a = 6.283185307179586 * i / N;
            p[3 * (2 + i)] = (float)(0.5 + 1.2 * cos(a) + rnd() * 0.2);
            p[3 * (2 + i) + 1] = (float)(sin(a) + rnd() * 0.2);
            p[3 * (2 + i) + 2] = (float)(rnd() * 0.6);
        }
    }
    uint32_t nr = 0, nk = 0;
    for (uint32_t i = 0; i < N; i++) {
        const uint32_t at = i >= N / 2, t[3] = {at, 2 + i, 2 + (i + 1) % N};
        memcpy(in->ring_tris + 3 * i, t, sizeof t);
        if (at)
            in->ring_lk[nk++] = 3 * i;
        else
            in->ring_lr[nr++] = 3 * i;
    }
    const uint32_t e[2][3] = {{0, 1, 2}, {1, 0, 2 + N / 2}};
    for (uint32_t j = 0; j < 2; j++) {
        memcpy(in->ring_tris + 3 * (N + j), e[j], sizeof e[j]);
        in->ring_lr[nr++] = 3 * (N + j) + j;
        in->ring_lk[nk++] = 3 * (N + j) + 1 - j;
    }
}

static void fill(inputs *in)
{
    fill_rings(in);
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

static size_t run_fan_sums(const mr_kernels *k, inputs *in, uint64_t *sig)
{
    double acc = 0;
    for (int i = 0; i < NFAN; i++) {
        const float *p = in->ring_pos[i % 16];
        const mr_fan_input f = {p, in->ring_tris, in->ring_lr, in->ring_lk, 7, 7, 0, 1};
        const double o[3] = {p[3], p[4], p[5]};
        double sum[MR_FAN_SUMS] = {0};
        k->fan_sums(&f, o, true, sum);
        acc += sum[MR_FAN_C];
        if (sig)
            *sig = mix(*sig, sum, sizeof sum);
    }
    if (acc == -1)
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

/* ---- quadric storage: array of structures against structure of arrays --- */

/*
 * The simplifier keeps a vertex's quadric as one 44-byte record
 * (mr_quadricf, an array of structures). A structure of arrays (11 float
 * arrays) would let a kernel load a coefficient of 8 vertices as one vector
 * when the vertices are consecutive, but a collapse's vertices are not:
 * each edge names two vertices anywhere in the mesh. The two operations
 * that read quadrics by vertex id, timed on both layouts with the same
 * arithmetic, over a generated scan's edges (out of cache):
 *   - gather: the batched cost's inputs of 64 edges (both ends' quadrics
 *     and positions into the batch's rows: the library's gather,
 *     mr_cost_pack_inputs, on records; one row at a time on the arrays),
 *     then the cost kernel;
 *   - merge: a collapse's r += k (mr_merge_body), one edge after another.
 * In mesh order (the set-up's pass: neighbouring edges share vertices) and
 * shuffled (the collapses' order: by cost, scattered over the mesh).
 */
typedef struct soa_quadrics {
    float *c[11];
} soa_quadrics;

static void gather_soa(const soa_quadrics *q, const float *pos, const uint32_t *u,
                       const uint32_t *w, size_t n, float *in)
{
    /* row by row: each row one coefficient of every edge's end */
    for (int k = 0; k < 11; k++) {
        const float *c = q->c[k];
        float *ru = in + (size_t)(FREE_QU + k) * MR_COST_BATCH,
              *rw = in + (size_t)(FREE_QW + k) * MR_COST_BATCH;
        for (size_t l = 0; l < n; l++) {
            ru[l] = c[u[l]];
            rw[l] = c[w[l]];
        }
    }
    for (size_t l = 0; l < n; l++)
        for (int k = 0; k < 3; k++) {
            in[(size_t)(FREE_PU + k) * MR_COST_BATCH + l] = pos[3 * (size_t)u[l] + k];
            in[(size_t)(FREE_PW + k) * MR_COST_BATCH + l] = pos[3 * (size_t)w[l] + k];
        }
}

static void merge_soa(soa_quadrics *q, uint32_t k, uint32_t r, const mr_kernels *kern,
                      const double dk[3], const double dr[3])
{
    mr_quadricf a, b;
    float *fa = &a.a00, *fb = &b.a00;
    for (int i = 0; i < 11; i++) {
        fa[i] = q->c[i][k];
        fb[i] = q->c[i][r];
    }
    kern->merge(&a, &b, dk, dr);
    for (int i = 0; i < 11; i++)
        q->c[i][k] = fa[i];
}

enum { LAYOUT_AOS = 0, LAYOUT_SOA = 1 };

/* One pass of op (0 gather + cost, 1 merge) over the edges on layout L;
 * returns a signature of the results. */
static uint64_t layout_pass(int op, int L, mr_quadricf *aos, soa_quadrics *soa,
                            const float *pos, const uint32_t *u, const uint32_t *w, size_t ne,
                            const mr_kernels *kern, float *in)
{
    static const double box[3] = {0.5, 0.5, 0.5}, dk[3] = {1e-4, -2e-4, 3e-4},
                        dr[3] = {-3e-4, 1e-4, 2e-4};
    double cost[MR_COST_BATCH], x[3 * MR_COST_BATCH], sum = 0;
    if (op == 0) {
        for (size_t e = 0; e < ne; e += MR_COST_BATCH) {
            const size_t n = ne - e < MR_COST_BATCH ? ne - e : MR_COST_BATCH;
            if (L == LAYOUT_AOS)
                mr_cost_pack_inputs(aos, pos, u + e, w + e, n, in);
            else
                gather_soa(soa, pos, u + e, w + e, n, in);
            kern->free_costs(in, n, cost, x, box);
            sum += cost[0] + cost[n - 1];
        }
    } else {
        for (size_t e = 0; e < ne; e++) {
            if (L == LAYOUT_AOS)
                kern->merge(&aos[u[e]], &aos[w[e]], dk, dr);
            else
                merge_soa(soa, u[e], w[e], kern, dk, dr);
        }
    }
    uint64_t h;
    memcpy(&h, &sum, sizeof h);
    return h;
}

static void bench_layout(const mr_mesh *mesh, const mr_kernels *kern, int runs)
{
    const size_t nv = mesh->vertex_count, ne = 3 * mesh->triangle_count;
    /* one record and one float of padding: the library's gather reads 12
     * floats of a quadric and 4 of a position */
    mr_quadricf *aos = malloc((nv + 1) * sizeof *aos);
    soa_quadrics soa;
    float *soa_block = malloc(11 * nv * sizeof(float));
    float *pos = calloc(3 * nv + 1, sizeof(float));
    uint32_t *u = malloc(ne * sizeof *u), *w = malloc(ne * sizeof *w);
    uint32_t *su = malloc(ne * sizeof *su), *sw = malloc(ne * sizeof *sw);
    float *in = malloc(FREE_INPUTS * MR_COST_BATCH * sizeof(float));
    if (!aos || !soa_block || !pos || !u || !w || !su || !sw || !in) {
        fprintf(stderr, "bench_kernels: out of memory\n");
        exit(1);
    }
    for (int k = 0; k < 11; k++)
        soa.c[k] = soa_block + (size_t)k * nv;
    for (size_t v = 0; v < nv; v++) {
        random_quadric(&aos[v]);
        for (int k = 0; k < 3; k++)
            pos[3 * v + k] = (float)rnd();
    }
    /* every triangle's three edges (an inner edge twice: the set-up's pass
     * meets it from both sides), and the same shuffled */
    for (size_t t = 0; t < mesh->triangle_count; t++)
        for (int c = 0; c < 3; c++) {
            u[3 * t + c] = mesh->indices[3 * t + c];
            w[3 * t + c] = mesh->indices[3 * t + (c + 1) % 3];
        }
    memcpy(su, u, ne * sizeof *u);
    memcpy(sw, w, ne * sizeof *w);
    for (size_t i = ne - 1; i > 0; i--) {
        const size_t j = (size_t)((rnd() + 0.5) * (double)(i + 1)) % (i + 1);
        uint32_t t = su[i];
        su[i] = su[j];
        su[j] = t;
        t = sw[i];
        sw[i] = sw[j];
        sw[j] = t;
    }
    printf("\nquadric storage (%zu vertices: %.1f MiB of quadrics; %zu edges; %s path): "
           "ns per edge, median (min) of %d alternating passes\n",
           nv, (double)nv * sizeof *aos / 1048576.0, ne, kern->name, runs);
    printf("%-22s %-12s %10s %10s %10s %10s %9s %5s\n", "operation", "edge order", "AoS ns",
           "min", "SoA ns", "min", "SoA/AoS", "same");
    static const char *opname[2] = {"gather + cost (64)", "merge (one at a time)"};
    for (int op = 0; op < 2; op++)
        for (int order = 0; order < 2; order++) {
            const uint32_t *eu = order ? su : u, *ew = order ? sw : w;
            double t[2][64];
            uint64_t sig[2];
            for (int r = 0; r < runs; r++)
                for (int L = 0; L < 2; L++) {
                    if (op == 1) { /* the same quadrics before every merge pass */
                        rng_state = 0x9E3779B97F4A7C15ull;
                        for (size_t v = 0; v < nv; v++)
                            random_quadric(&aos[v]);
                        for (int k = 0; k < 11; k++)
                            for (size_t v = 0; v < nv; v++)
                                soa.c[k][v] = (&aos[v].a00)[k];
                    } else if (r == 0 && L == 0)
                        for (int k = 0; k < 11; k++)
                            for (size_t v = 0; v < nv; v++)
                                soa.c[k][v] = (&aos[v].a00)[k];
                    const double t0 = bench_now();
                    sig[L] = layout_pass(op, L, aos, &soa, pos, eu, ew, ne, kern, in);
                    t[L][r] = (bench_now() - t0) / (double)ne * 1e9;
                    if (op == 1) { /* the merged quadrics' bits */
                        uint64_t h = 0xCBF29CE484222325ull;
                        for (size_t v = 0; v < nv; v += 97) {
                            mr_quadricf f;
                            for (int k = 0; k < 11; k++)
                                (&f.a00)[k] = L ? soa.c[k][v] : (&aos[v].a00)[k];
                            h = mix(h, &f, sizeof f);
                        }
                        sig[L] = h;
                    }
                }
            const bench_summary a = bench_summarize(t[0], runs), s = bench_summarize(t[1], runs);
            printf("%-22s %-12s %10.2f %10.2f %10.2f %10.2f %8.2fx %5s\n", opname[op],
                   order ? "shuffled" : "mesh", a.median, a.min, s.median, s.min,
                   s.median / a.median, sig[0] == sig[1] ? "yes" : "NO");
        }
    free(aos);
    free(soa_block);
    free(pos);
    free(u);
    free(w);
    free(su);
    free(sw);
    free(in);
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
        {"fan_sums (memoryless plan)", "plan", run_fan_sums},
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
    bench_layout(&mesh, mr_kernels_get(), runs);

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
