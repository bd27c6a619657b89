/*
 * The queue-driven parallel simplifiers against the sequential reference:
 * the filter-level priority queue paper's Tables 3-5 and the shape of its
 * Fig. 9b, on generated scan-like meshes of 1M and 4M triangles and on the
 * shared test meshes (../shared/data, those present), each reduced to 25,
 * 5, 1 and 0.1 % of its vertices.
 *
 *   bench_queued [--runs R] [--threads 1,2,4,8] [--quality-threads T]
 *                [--filter-levels L] [--quick] [--mesh NAME]... [--md FILE]
 *                [--samples N] [--data DIR]
 *
 * Per mesh and target, in one run:
 *   greedy-half   the sequential reference (MR_STRATEGY_GREEDY, half-edge
 *                 collapse, 1 thread): what vertex similarity is taken
 *                 against;
 *   ppq, rppq, fppq, multiqueue
 *                 the four queue strategies (half-edge collapse) at every
 *                 thread count of --threads (default 1,2,4,8: on a 2-core
 *                 machine 4 and 8 are oversubscribed, which exercises the
 *                 relaxation); FPPQ with --filter-levels (default 4, the
 *                 paper's);
 *   default       the default strategy (batched, full collapse) at the
 *                 largest thread count of the list that the machine has
 *                 cores for;
 *   meshopt       meshopt_simplify (when found at configure time), asked
 *                 for the triangle count greedy-half reached.
 * Time: median of R runs (default 3), the runs of each configuration back
 * to back. Vertex similarity (mr_vertex_similarity: the share of the
 * output's vertices that the reference has too, same input vertex at the
 * same position, the paper's Table 4): median over the runs. Quality
 * (mr_compare against the input, --samples points per mesh besides the
 * vertices, default 200,000): the modified Hausdorff distance (the paper's
 * formula (3), its Table 3), the symmetric Hausdorff distance and the RMS
 * surface distance, % of the bounding-box diagonal, of the median-
 * similarity run at --quality-threads (default: the largest of --threads).
 * --quick: scan-1M to 1 % and the bunny and armadillo to 1 % only.
 *
 * The queue strategies are relaxed: their output may differ between runs
 * and thread counts; every figure is what these runs gave.
 */
#include "benchpeers.h"
#include "benchutil.h"

#include "../src/core/omp_compat.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef MR_SHARED_DATA
#define MR_SHARED_DATA "../shared/data"
#endif

enum { Q_PPQ, Q_RPPQ, Q_FPPQ, Q_MQ, Q_COUNT };
static const char *const q_name[Q_COUNT] = {"ppq", "rppq", "fppq", "multiqueue"};
static const mr_strategy q_strategy[Q_COUNT] = {MR_STRATEGY_PPQ, MR_STRATEGY_RPPQ,
                                                MR_STRATEGY_FPPQ, MR_STRATEGY_MULTIQUEUE};

#define MAX_THREADS 16
#define MAX_RUNS 15

static const double targets[] = {0.25, 0.05, 0.01, 0.001};
#define TARGET_COUNT (sizeof targets / sizeof targets[0])

typedef struct config {
    int runs;
    int threads[MAX_THREADS], nthreads;
    int quality_threads;
    unsigned filter_levels;
    int quick;
    size_t samples;
    const char *data;
    const char *md;
    char *only[16];
    int n_only;
    int cores;
} config;

/* One configuration's figures. */
typedef struct figures {
    int done;
    double seconds;     /* median */
    double similarity;  /* median, fraction */
    double mhd, hd, rms; /* % of the diagonal; < 0: not measured */
    size_t vertices;
    mr_simplify_stats stats; /* of the median-similarity run */
} figures;

typedef struct target_result {
    figures ref, dflt, mopt;
    figures q[Q_COUNT][MAX_THREADS];
} target_result;

typedef struct mesh_result {
    char name[32];
    char desc[160];
    target_result t[TARGET_COUNT];
} mesh_result;

static void quality(const config *cfg, const mr_mesh *in, const float *pos, size_t nv,
                    const uint32_t *idx, size_t nt, figures *f)
{
    mr_compare_options opt;
    mr_compare_options_default(&opt);
    opt.samples = cfg->samples;
    opt.threads = cfg->cores;
    mr_compare_result res;
    mr_error err;
    omp_set_num_threads(cfg->cores);
    bench_check(mr_compare(in->positions, in->vertex_count, in->indices, in->triangle_count, pos,
                           nv, idx, nt, &opt, &res, &err),
                &err);
    f->mhd = 100 * res.modified_hausdorff_rel;
    f->hd = 100 * res.hausdorff_rel;
    f->rms = 100 * res.rms_rel;
}

static void options(mr_simplify_options *o, mr_strategy s, mr_collapse_kind c, double ratio,
                    int threads, unsigned levels)
{
    mr_simplify_options_default(o);
    o->strategy = s;
    o->collapse = c;
    o->target_ratio = ratio;
    o->threads = threads;
    o->filter_levels = levels;
}

static double run_once(const mr_mesh *in, const mr_simplify_options *o, mr_simplified *out)
{
    mr_error err;
    omp_set_num_threads(o->threads);
    const double t0 = bench_now();
    bench_check(mr_simplify(in->positions, 0, in->vertex_count, in->indices, in->triangle_count,
                            o, out, &err),
                &err);
    return bench_now() - t0;
}

/* R runs of one configuration; similarity to ref (when given) per run;
 * quality of the median-similarity run when asked. */
static void measure(const config *cfg, const mr_mesh *in, const mr_simplify_options *o,
                    const mr_simplified *ref, int want_quality, figures *f,
                    mr_simplified *keep)
{
    double secs[MAX_RUNS], sims[MAX_RUNS];
    mr_simplified outs[MAX_RUNS];
    for (int r = 0; r < cfg->runs; r++) {
        secs[r] = run_once(in, o, &outs[r]);
        sims[r] = ref ? mr_vertex_similarity(outs[r].positions, outs[r].origin,
                                             outs[r].vertex_count, ref->positions, ref->origin,
                                             ref->vertex_count)
                      : 1.0;
    }
    double sorted[MAX_RUNS];
    memcpy(sorted, sims, sizeof(double) * (size_t)cfg->runs);
    f->similarity = bench_summarize(sorted, cfg->runs).median;
    int pick = 0; /* the run whose similarity is the median (the first such) */
    for (int r = 0; r < cfg->runs; r++)
        if (fabs(sims[r] - f->similarity) < fabs(sims[pick] - f->similarity))
            pick = r;
    f->seconds = bench_summarize(secs, cfg->runs).median;
    f->vertices = outs[pick].vertex_count;
    f->stats = outs[pick].stats;
    f->mhd = f->hd = f->rms = -1;
    if (want_quality)
        quality(cfg, in, outs[pick].positions, outs[pick].vertex_count, outs[pick].indices,
                outs[pick].triangle_count, f);
    for (int r = 0; r < cfg->runs; r++) {
        if (keep && r == pick)
            *keep = outs[r];
        else
            mr_simplified_free(&outs[r]);
    }
    f->done = 1;
}

typedef struct mesh_spec {
    const char *name, *file;
    size_t triangles;
} mesh_spec;

static const mesh_spec specs[] = {
    {"scan-1M", NULL, 1000000},
    {"scan-4M", NULL, 4000000},
    {"bunny", "stanford-bunny.obj", 0},
    {"armadillo", "armadillo.obj", 0},
    {"nefertiti", "nefertiti.obj", 0},
    {"ogre", "ogre.obj", 0},
    {"igea", "igea.ply", 0},
    {"fandisk", "fandisk.obj", 0},
    {"homer", "homer.obj", 0},
};
#define SPEC_COUNT (sizeof specs / sizeof specs[0])

static int load(const config *cfg, const mesh_spec *s, mr_mesh *mesh, mesh_result *m)
{
    omp_set_num_threads(cfg->cores);
    if (!bench_load_mesh(cfg->data, s->file, s->triangles, 0, mesh, NULL, NULL))
        return 0;
    snprintf(m->name, sizeof m->name, "%s", s->name);
    snprintf(m->desc, sizeof m->desc, "%zu vertices, %zu triangles%s%s", mesh->vertex_count,
             mesh->triangle_count, s->file ? ", " : " (mr_generate scan, seed 1)",
             s->file ? s->file : "");
    return 1;
}

static int quick_target(const mesh_spec *s, double ratio)
{
    return ratio == 0.01 &&
           (!strcmp(s->name, "scan-1M") || !strcmp(s->name, "bunny") ||
            !strcmp(s->name, "armadillo"));
}

static void run_mesh(const config *cfg, const mesh_spec *spec, mesh_result *m)
{
    mr_mesh in;
    if (!load(cfg, spec, &in, m))
        return;
    printf("\nmesh %s: %s\n", m->name, m->desc);
    fflush(stdout);
    for (size_t ti = 0; ti < TARGET_COUNT; ti++) {
        if (cfg->quick && !quick_target(spec, targets[ti]))
            continue;
        target_result *t = &m->t[ti];
        const double ratio = targets[ti];
        mr_simplify_options o;
        mr_simplified ref;
        options(&o, MR_STRATEGY_GREEDY, MR_COLLAPSE_HALF, ratio, 1, 0);
        measure(cfg, &in, &o, NULL, 1, &t->ref, &ref);
        int dthreads = 1;
        for (int i = 0; i < cfg->nthreads; i++)
            if (cfg->threads[i] <= cfg->cores && cfg->threads[i] > dthreads)
                dthreads = cfg->threads[i];
        options(&o, MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, ratio, dthreads, 0);
        measure(cfg, &in, &o, NULL, 1, &t->dflt, NULL);
        t->dflt.similarity = -1;
        for (int q = 0; q < Q_COUNT; q++)
            for (int i = 0; i < cfg->nthreads; i++) {
                const int th = cfg->threads[i];
                options(&o, q_strategy[q], MR_COLLAPSE_HALF, ratio, th,
                        q == Q_FPPQ ? cfg->filter_levels : 0);
                measure(cfg, &in, &o, &ref, th == cfg->quality_threads, &t->q[q][i], NULL);
            }
        if (bench_have_meshopt()) {
            bench_summary timing;
            int made;
            double peak;
            bench_output out;
            if (bench_run_meshopt(&in, ref.triangle_count, 0, cfg->runs, &timing, &made, &peak,
                                  &out)) {
                t->mopt.done = 1;
                t->mopt.seconds = timing.median;
                t->mopt.similarity = -1;
                t->mopt.vertices = out.vertex_count;
                quality(cfg, &in, out.positions, out.vertex_count, out.indices,
                        out.triangle_count, &t->mopt);
                bench_output_free(&out);
            }
        }
        mr_simplified_free(&ref);
        printf("  %g %%: greedy-half %.3f s", 100 * ratio, t->ref.seconds);
        for (int q = 0; q < Q_COUNT; q++)
            printf(", %s %.1f %%", q_name[q],
                   100 * t->q[q][cfg->nthreads - 1].similarity);
        printf("\n");
        fflush(stdout);
    }
    mr_mesh_free(&in);
}

/* ---- tables ---------------------------------------------------------------- */

static void cell(FILE *f, double v, const char *fmt)
{
    if (v < 0)
        fprintf(f, " | n/a");
    else
        fprintf(f, fmt, v);
}

static int qt_index(const config *cfg)
{
    for (int i = 0; i < cfg->nthreads; i++)
        if (cfg->threads[i] == cfg->quality_threads)
            return i;
    return cfg->nthreads - 1;
}

static void tables(FILE *f, const config *cfg, const mesh_result *res, int n)
{
    const int qi = qt_index(cfg);
    fprintf(f, "\n### Vertex similarity to greedy-half, %d threads (the paper's Table 4)\n\n",
            cfg->quality_threads);
    fprintf(f, "| mesh | target | ppq | rppq | fppq (l_f %u) | multiqueue |\n", cfg->filter_levels);
    fprintf(f, "| --- | ---: | ---: | ---: | ---: | ---: |\n");
    for (int k = 0; k < n; k++)
        for (size_t ti = 0; ti < TARGET_COUNT; ti++) {
            const target_result *t = &res[k].t[ti];
            if (!t->ref.done)
                continue;
            fprintf(f, "| %s | %g %%", res[k].name, 100 * targets[ti]);
            for (int q = 0; q < Q_COUNT; q++)
                cell(f, 100 * t->q[q][qi].similarity, " | %.1f %%");
            fprintf(f, " |\n");
        }
    fprintf(f, "\n### Modified Hausdorff / Hausdorff / RMS, %% of the diagonal, %d threads "
               "(the paper's Table 3 and more)\n\n",
            cfg->quality_threads);
    fprintf(f, "| mesh | target | greedy-half | ppq | rppq | fppq | multiqueue | default | "
               "meshopt |\n");
    fprintf(f, "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    for (int k = 0; k < n; k++)
        for (size_t ti = 0; ti < TARGET_COUNT; ti++) {
            const target_result *t = &res[k].t[ti];
            if (!t->ref.done)
                continue;
            fprintf(f, "| %s | %g %%", res[k].name, 100 * targets[ti]);
            const figures *row[7] = {&t->ref,         &t->q[Q_PPQ][qi], &t->q[Q_RPPQ][qi],
                                     &t->q[Q_FPPQ][qi], &t->q[Q_MQ][qi],  &t->dflt,
                                     &t->mopt};
            for (int c = 0; c < 7; c++) {
                if (!row[c]->done || row[c]->mhd < 0)
                    fprintf(f, " | n/a");
                else
                    fprintf(f, " | %.4f / %.4f / %.5f", row[c]->mhd, row[c]->hd, row[c]->rms);
            }
            fprintf(f, " |\n");
        }
    fprintf(f, "\n### Seconds, median of %d runs (the paper's Table 5; Fig. 9b: along a row)\n\n",
            cfg->runs);
    fprintf(f, "| mesh | target | greedy-half (1) | default | meshopt");
    for (int q = 0; q < Q_COUNT; q++)
        for (int i = 0; i < cfg->nthreads; i++)
            fprintf(f, " | %s %d", q_name[q], cfg->threads[i]);
    fprintf(f, " |\n| --- | ---: | ---: | ---: | ---:");
    for (int q = 0; q < Q_COUNT * cfg->nthreads; q++)
        fprintf(f, " | ---:");
    fprintf(f, " |\n");
    for (int k = 0; k < n; k++)
        for (size_t ti = 0; ti < TARGET_COUNT; ti++) {
            const target_result *t = &res[k].t[ti];
            if (!t->ref.done)
                continue;
            fprintf(f, "| %s | %g %%", res[k].name, 100 * targets[ti]);
            cell(f, t->ref.seconds, " | %.3f");
            cell(f, t->dflt.seconds, " | %.3f");
            cell(f, t->mopt.done ? t->mopt.seconds : -1, " | %.3f");
            for (int q = 0; q < Q_COUNT; q++)
                for (int i = 0; i < cfg->nthreads; i++)
                    cell(f, t->q[q][i].done ? t->q[q][i].seconds : -1, " | %.3f");
            fprintf(f, " |\n");
        }
}

/* The paper's Fig. 9a, as counts: what the threads did, per strategy. */
static void profile(FILE *f, const config *cfg, const mesh_result *res, int n)
{
    const int qi = qt_index(cfg);
    fprintf(f, "\n### Profile at %d threads: counts summed over the threads (the paper's "
               "Fig. 9a)\n\n",
            cfg->quality_threads);
    fprintf(f, "| mesh | target | strategy | pops | lock acquisitions | lock failures | "
               "topology checks | collapses | priority updates | compactions |\n");
    fprintf(f, "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    for (int k = 0; k < n; k++)
        for (size_t ti = 0; ti < TARGET_COUNT; ti++) {
            const target_result *t = &res[k].t[ti];
            if (!t->ref.done)
                continue;
            for (int q = 0; q < Q_COUNT; q++) {
                const mr_simplify_stats *st = &t->q[q][qi].stats;
                fprintf(f, "| %s | %g %% | %s | %zu | %zu | %zu | %zu | %zu | %zu | %zu |\n",
                        res[k].name, 100 * targets[ti], q_name[q], st->queue_pops,
                        st->lock_acquisitions, st->lock_failures, st->topology_checks,
                        st->collapses, st->priority_updates, st->compactions);
            }
        }
}

static const target_result *find(const mesh_result *res, int n, const char *mesh, double ratio)
{
    for (int k = 0; k < n; k++)
        if (!strcmp(res[k].name, mesh))
            for (size_t ti = 0; ti < TARGET_COUNT; ti++)
                if (targets[ti] == ratio && res[k].t[ti].ref.done)
                    return &res[k].t[ti];
    return NULL;
}

static int tindex(const config *cfg, int threads)
{
    for (int i = 0; i < cfg->nthreads; i++)
        if (cfg->threads[i] == threads)
            return i;
    return -1;
}

static void bars(FILE *f, const config *cfg, const mesh_result *res, int n)
{
    const int qi = qt_index(cfg);
    fprintf(f, "\nbars (quality at %d threads, scans at 1 %%):\n", cfg->quality_threads);
    static const double need[Q_COUNT] = {99.5, -1, 96, 79};
    const char *scans[2] = {"scan-1M", "scan-4M"};
    for (int s = 0; s < 2; s++) {
        const target_result *t = find(res, n, scans[s], 0.01);
        for (int q = 0; q < Q_COUNT; q++) {
            char what[96];
            snprintf(what, sizeof what, "%s vertex similarity%s, %s to 1 %%", q_name[q],
                     q == Q_FPPQ ? " (l_f given)" : "", scans[s]);
            if (!t) {
                fprintf(f, "  %-58s not measured\n", what);
                continue;
            }
            const double v = 100 * t->q[q][qi].similarity;
            if (need[q] < 0)
                fprintf(f, "  %-58s %.1f %% (reported)\n", what, v);
            else
                fprintf(f, "  %-58s %.1f %% >= %.1f %%: %s\n", what, v, need[q],
                        v >= need[q] ? "yes" : "NO");
        }
    }
    const target_result *t = find(res, n, "scan-1M", 0.01);
    const int i1 = tindex(cfg, 1), i2 = tindex(cfg, 2);
    if (t && i1 >= 0 && i2 >= 0) {
        const double s1 = t->q[Q_FPPQ][i1].seconds, s2 = t->q[Q_FPPQ][i2].seconds;
        fprintf(f, "  %-58s %.2fx (%.3f / %.3f s): %s\n",
                "fppq 2 threads >= 1.5x its 1 thread, scan-1M to 1 %", s1 / s2, s1, s2,
                s1 / s2 >= 1.5 ? "yes" : "NO");
        fprintf(f, "  %-58s %.3f vs %.3f s: %s\n",
                "fppq 2 threads at least as fast as greedy-half, scan-1M 1 %", s2,
                t->ref.seconds, s2 <= t->ref.seconds ? "yes" : "NO");
    } else {
        fprintf(f, "  fppq speed bars: need scan-1M to 1 %% and 1 and 2 in --threads\n");
    }
}

static void usage(void)
{
    fprintf(stderr, "usage: bench_queued [--runs R] [--threads 1,2,4,8] [--quality-threads T] "
                    "[--filter-levels L] [--quick] [--mesh NAME]... [--md FILE] [--samples N] "
                    "[--data DIR]\n");
    exit(2);
}

int main(int argc, char **argv)
{
    config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.runs = 3;
    cfg.threads[0] = 1;
    cfg.threads[1] = 2;
    cfg.threads[2] = 4;
    cfg.threads[3] = 8;
    cfg.nthreads = 4;
    cfg.filter_levels = 4;
    cfg.samples = 200000;
    cfg.data = MR_SHARED_DATA;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--runs") && v) {
            cfg.runs = atoi(v);
            i++;
        } else if (!strcmp(a, "--threads") && v) {
            cfg.nthreads = 0;
            for (char *p = (char *)v; *p && cfg.nthreads < MAX_THREADS;) {
                const long t = strtol(p, &p, 10);
                if (t < 1)
                    usage();
                cfg.threads[cfg.nthreads++] = (int)t;
                if (*p == ',')
                    p++;
                else if (*p)
                    usage();
            }
            i++;
        } else if (!strcmp(a, "--quality-threads") && v) {
            cfg.quality_threads = atoi(v);
            i++;
        } else if (!strcmp(a, "--filter-levels") && v) {
            cfg.filter_levels = (unsigned)atoi(v);
            i++;
        } else if (!strcmp(a, "--quick")) {
            cfg.quick = 1;
        } else if (!strcmp(a, "--mesh") && v && cfg.n_only < 16) {
            cfg.only[cfg.n_only++] = (char *)v;
            i++;
        } else if (!strcmp(a, "--md") && v) {
            cfg.md = v;
            i++;
        } else if (!strcmp(a, "--samples") && v) {
            cfg.samples = (size_t)atol(v);
            i++;
        } else if (!strcmp(a, "--data") && v) {
            cfg.data = v;
            i++;
        } else {
            usage();
        }
    }
    if (cfg.runs < 1 || cfg.runs > MAX_RUNS || cfg.nthreads == 0)
        usage();
    if (!cfg.quality_threads)
        cfg.quality_threads = cfg.threads[cfg.nthreads - 1];
    if (tindex(&cfg, cfg.quality_threads) < 0)
        usage();
    bench_cpu cpu;
    bench_cpu_info(&cpu);
    cfg.cores = cpu.nproc > 0 ? cpu.nproc : 1;
    bench_print_machine(stdout);
    printf("queue strategies (half-edge collapse) against greedy-half; threads");
    for (int i = 0; i < cfg.nthreads; i++)
        printf(" %d%s", cfg.threads[i], cfg.threads[i] > cfg.cores ? " (oversubscribed)" : "");
    printf("; fppq with %u filter levels; median of %d runs\n", cfg.filter_levels, cfg.runs);
    mesh_result *res = calloc(SPEC_COUNT, sizeof *res);
    if (!res)
        return 1;
    int n = 0;
    for (size_t s = 0; s < SPEC_COUNT; s++) {
        int want = cfg.n_only == 0;
        for (int k = 0; k < cfg.n_only; k++)
            want |= !strcmp(cfg.only[k], specs[s].name);
        if (cfg.quick && cfg.n_only == 0)
            want = !strcmp(specs[s].name, "scan-1M") || !strcmp(specs[s].name, "bunny") ||
                   !strcmp(specs[s].name, "armadillo");
        if (!want)
            continue;
        run_mesh(&cfg, &specs[s], &res[n]);
        if (res[n].name[0])
            n++;
    }
    tables(stdout, &cfg, res, n);
    profile(stdout, &cfg, res, n);
    bars(stdout, &cfg, res, n);
    if (cfg.md) {
        FILE *f = fopen(cfg.md, "w");
        if (f) {
            fprintf(f, "```\n");
            bench_print_machine(f);
            fprintf(f, "```\n");
            tables(f, &cfg, res, n);
            profile(f, &cfg, res, n);
            fprintf(f, "\n```");
            bars(f, &cfg, res, n);
            fprintf(f, "```\n");
            fclose(f);
            printf("markdown: %s\n", cfg.md);
        }
    }
    free(res);
    return 0;
}
