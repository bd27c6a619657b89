/* The default simplifier gives the same bytes at every thread count: each
 * case runs at 1, 2, 3 and 8 threads (options.threads, and the OpenMP
 * default for the parts that use it) and every run must equal the
 * one-thread run -- counts, positions, attributes, indices, origins, and
 * the statistics (collapses and the largest error bitwise). A closed
 * manifold input must stay closed and manifold at every thread count.
 *
 * Cases: every mesh of ../shared/data (when present: its OBJ, PLY and STL
 * files up to 32 MB), and generated ones:
 * a 300k-triangle scan (above the 65,536 vertices and triangles where the
 * parallel loops start), a torus with open boundaries (lock_border, an
 * error-bounded run with prune), a sphere with attribute seams (normals,
 * texture coordinates and colours through mr_mesh_simplify) and a scan
 * with locked vertices; the greedy, batched and partitioned strategies
 * (the last on the generated cases), both collapse kinds, ratios 0.25,
 * 0.1 and 0.01. With MR_TEST_QUICK set (the ThreadSanitizer stage) the
 * cases shrink, staying above the parallel thresholds. */
#include "testutil.h"
#include "core/omp_compat.h"
#include "qem/core/collapse.h"

#include <dirent.h>
#include <inttypes.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>

static const int thread_counts[] = {1, 2, 3, 8};
#define NTHREADS (sizeof thread_counts / sizeof thread_counts[0])

/* One simplification to run at every thread count. */
typedef struct variant {
    mr_strategy strategy;
    mr_collapse_kind collapse;
    double ratio;
} variant;

#define BATCHED_FULL(r) {MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, (r)}
#define BATCHED_HALF(r) {MR_STRATEGY_BATCHED, MR_COLLAPSE_HALF, (r)}
#define GREEDY_FULL(r) {MR_STRATEGY_GREEDY, MR_COLLAPSE_FULL, (r)}
#define GREEDY_HALF(r) {MR_STRATEGY_GREEDY, MR_COLLAPSE_HALF, (r)}
#define PART_FULL(r) {MR_STRATEGY_PARTITIONED, MR_COLLAPSE_FULL, (r)}
#define PART_HALF(r) {MR_STRATEGY_PARTITIONED, MR_COLLAPSE_HALF, (r)}
#define PB_FULL(r) {MR_STRATEGY_PARTITIONED_BOUNDARY, MR_COLLAPSE_FULL, (r)}
#define PB_HALF(r) {MR_STRATEGY_PARTITIONED_BOUNDARY, MR_COLLAPSE_HALF, (r)}

/* An input and how to simplify it. */
typedef struct sim_case {
    char name[96];
    const mr_mesh *mesh;
    bool attributes;      /* through mr_mesh_simplify, else mr_simplify */
    bool closed_manifold; /* the input is closed and manifold: so must the outputs be */
} sim_case;

/* What one run produced: the output as a mesh (mr_simplify's arrays moved
 * into it), its origins and its statistics. */
typedef struct run_result {
    mr_mesh out;
    uint32_t *origin;
    mr_simplify_stats stats;
} run_result;

static size_t runs_done;

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static bool quick(void)
{
    const char *q = getenv("MR_TEST_QUICK");
    return q && *q && strcmp(q, "0") != 0;
}

static const char *strategy_name(mr_strategy s)
{
    return s == MR_STRATEGY_GREEDY                 ? "greedy"
           : s == MR_STRATEGY_PARTITIONED          ? "partitioned"
           : s == MR_STRATEGY_PARTITIONED_BOUNDARY ? "partitioned-boundary"
                                                   : "batched";
}

static const char *collapse_name(mr_collapse_kind k)
{
    return k == MR_COLLAPSE_HALF ? "half" : "full";
}

static void run_once(const sim_case *c, const mr_simplify_options *options, int threads,
                     run_result *r)
{
    mr_simplify_options o = *options;
    o.threads = threads;
    const int saved = omp_get_max_threads();
    omp_set_num_threads(threads);
    mr_error err;
    mr_status st;
    mr_mesh_init(&r->out);
    r->origin = NULL;
    if (c->attributes) {
        st = mr_mesh_simplify(c->mesh, &o, &r->out, &r->origin, &r->stats, &err);
    } else {
        mr_simplified s;
        st = mr_simplify(c->mesh->positions, 0, c->mesh->vertex_count, c->mesh->indices,
                         c->mesh->triangle_count, &o, &s, &err);
        if (st == MR_OK) {
            r->out.vertex_count = s.vertex_count;
            r->out.triangle_count = s.triangle_count;
            r->out.positions = s.positions;
            r->out.indices = s.indices;
            r->origin = s.origin;
            r->stats = s.stats;
        }
    }
    omp_set_num_threads(saved);
    if (st != MR_OK) {
        print_error("%s at %d threads: %s\n", c->name, threads, err.message);
        fail();
    }
    runs_done++;
}

static void run_free(run_result *r)
{
    mr_mesh_free(&r->out);
    free(r->origin);
    r->origin = NULL;
}

/* Fail naming the case, the variant and the thread count. */
#define EXPECT(cond, what)                                                                    \
    do {                                                                                      \
        if (!(cond)) {                                                                        \
            print_error("%s, %s: %s at %d threads not as at 1 thread\n", c->name, desc,        \
                        (what), threads);                                                     \
            fail();                                                                           \
        }                                                                                     \
    } while (0)

static bool same_bytes(const void *a, const void *b, size_t n)
{
    return n == 0 || (a && b && memcmp(a, b, n) == 0);
}

static void expect_same(const sim_case *c, const char *desc, int threads, const run_result *a,
                        const run_result *b)
{
    const mr_mesh *x = &a->out, *y = &b->out;
    EXPECT(x->vertex_count == y->vertex_count, "the vertex count");
    EXPECT(x->triangle_count == y->triangle_count, "the triangle count");
    const size_t nv = x->vertex_count, nt = x->triangle_count;
    EXPECT(same_bytes(x->positions, y->positions, nv * 3 * sizeof(float)), "positions");
    EXPECT(same_bytes(x->indices, y->indices, nt * 3 * sizeof(uint32_t)), "indices");
    EXPECT(same_bytes(a->origin, b->origin, nv * sizeof(uint32_t)), "origin");
    EXPECT((x->normals != NULL) == (y->normals != NULL), "having normals");
    EXPECT((x->texcoords != NULL) == (y->texcoords != NULL), "having texture coordinates");
    EXPECT((x->colors != NULL) == (y->colors != NULL), "having colors");
    if (x->normals)
        EXPECT(same_bytes(x->normals, y->normals, nv * 3 * sizeof(float)), "normals");
    if (x->texcoords)
        EXPECT(same_bytes(x->texcoords, y->texcoords, nv * 2 * sizeof(float)),
               "texture coordinates");
    if (x->colors)
        EXPECT(same_bytes(x->colors, y->colors, nv * 4 * sizeof(float)), "colors");

    const mr_simplify_stats *s = &a->stats, *t = &b->stats;
    EXPECT(s->collapses == t->collapses, "stats.collapses");
    EXPECT(memcmp(&s->max_error, &t->max_error, sizeof s->max_error) == 0,
           "stats.max_error (bitwise)");
    EXPECT(s->input_vertices == t->input_vertices, "stats.input_vertices");
    EXPECT(s->input_triangles == t->input_triangles, "stats.input_triangles");
    EXPECT(s->locked_vertices == t->locked_vertices, "stats.locked_vertices");
    EXPECT(s->output_vertices == t->output_vertices, "stats.output_vertices");
    EXPECT(s->output_points == t->output_points, "stats.output_points");
    EXPECT(s->output_triangles == t->output_triangles, "stats.output_triangles");
    EXPECT(s->pruned_parts == t->pruned_parts, "stats.pruned_parts");
    EXPECT(s->target_reached == t->target_reached, "stats.target_reached");
    EXPECT(s->stop == t->stop, "stats.stop");
}

/* A closed manifold input gives a closed manifold output. */
static void expect_closed_manifold(const sim_case *c, const char *desc, int threads,
                                   const run_result *r)
{
    const mr_mesh *m = &r->out;
    mr_stats s;
    mr_error err;
    if (mr_stats_compute(m->positions, 0, m->vertex_count, m->indices, m->triangle_count, &s,
                         &err) != MR_OK) {
        print_error("%s, %s: stats at %d threads: %s\n", c->name, desc, threads, err.message);
        fail();
    }
    if (s.boundary_edges || s.nonmanifold_edges || s.nonmanifold_vertices || !s.closed ||
        !s.manifold) {
        print_error("%s, %s at %d threads: a closed manifold input gave %zu boundary edges, "
                    "%zu non-manifold edges, %zu non-manifold vertices\n",
                    c->name, desc, threads, s.boundary_edges, s.nonmanifold_edges,
                    s.nonmanifold_vertices);
        fail();
    }
}

/* Run each variant (on top of `base`) at every thread count. */
static void check_variants(const sim_case *c, const mr_simplify_options *base,
                           const variant *v, size_t nvariants)
{
    for (size_t i = 0; i < nvariants; i++) {
        mr_simplify_options o = *base;
        o.strategy = v[i].strategy;
        o.collapse = v[i].collapse;
        o.target_ratio = v[i].ratio;
        char desc[96];
        snprintf(desc, sizeof desc, "%s %s ratio %g", strategy_name(o.strategy),
                 collapse_name(o.collapse), o.target_ratio);
        run_result ref;
        run_once(c, &o, thread_counts[0], &ref);
        if (c->closed_manifold)
            expect_closed_manifold(c, desc, thread_counts[0], &ref);
        for (size_t k = 1; k < NTHREADS; k++) {
            const int threads = thread_counts[k];
            run_result r;
            run_once(c, &o, threads, &r);
            expect_same(c, desc, threads, &ref, &r);
            if (c->closed_manifold)
                expect_closed_manifold(c, desc, threads, &r);
            run_free(&r);
        }
        run_free(&ref);
    }
}

static void describe(sim_case *c, const char *name, const mr_mesh *m)
{
    snprintf(c->name, sizeof c->name, "%s", name);
    c->mesh = m;
    c->attributes = mr_mesh_attributes(m) != 0;
    mr_stats s;
    assert_int_equal(
        mr_stats_compute(m->positions, 0, m->vertex_count, m->indices, m->triangle_count, &s, NULL),
        MR_OK);
    c->closed_manifold = s.closed && s.manifold && s.boundary_edges == 0 &&
                         s.nonmanifold_edges == 0 && s.nonmanifold_vertices == 0;
}

static void generate(mr_generator kind, size_t triangles, mr_mesh *m)
{
    mr_mesh_init(m);
    assert_int_equal(mr_generate(kind, triangles, 7, m, NULL), MR_OK);
}

static void report(const char *what, size_t runs, double t0)
{
    print_message("%s: %zu runs in %.2f s\n", what, runs, now_seconds() - t0);
}

/* ---- the shared data meshes ------------------------------------------------ */

/* Files of at most this size count as loadable in reasonable time (today's
 * largest, armadillo.obj, has 4 MB). */
#define DATA_MAX_BYTES (32u << 20)

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static bool mesh_file(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot && (strcasecmp(dot, ".obj") == 0 || strcasecmp(dot, ".ply") == 0 ||
                   strcasecmp(dot, ".stl") == 0);
}

/* The mesh files of ../shared/data (OBJ, PLY, STL), sorted by name; NULL
 * when the folder is absent. */
static char **data_files(size_t *count)
{
    *count = 0;
    DIR *d = opendir(MR_SHARED_DATA);
    if (!d)
        return NULL;
    size_t cap = 16;
    char **names = malloc(cap * sizeof *names);
    assert_non_null(names);
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        if (!mesh_file(e->d_name))
            continue;
        if (*count == cap) {
            names = realloc(names, (cap *= 2) * sizeof *names);
            assert_non_null(names);
        }
        names[(*count)++] = strdup(e->d_name);
    }
    closedir(d);
    qsort(names, *count, sizeof *names, by_name);
    return names;
}

/* Every data mesh at the default strategy (batched, full collapses) at
 * the three ratios, and at one ratio (a different one per mesh) with the
 * other three strategy and collapse pairs. */
static void test_data_meshes(void **state)
{
    (void)state;
    const double t0 = now_seconds();
    const size_t runs0 = runs_done;
    size_t nfiles, done = 0;
    char **files = data_files(&nfiles);
    for (size_t f = 0; f < nfiles; f++) {
        const char *path = tu_shared_data(files[f]);
        struct stat sb;
        if (!path || stat(path, &sb) != 0 || !S_ISREG(sb.st_mode))
            continue;
        if ((uintmax_t)sb.st_size > DATA_MAX_BYTES) {
            print_message("%s: %jd bytes, left out (over %u)\n", files[f],
                          (intmax_t)sb.st_size, DATA_MAX_BYTES);
            continue;
        }
        mr_mesh m;
        mr_mesh_init(&m);
        mr_error err;
        if (mr_mesh_read(path, NULL, &m, &err) != MR_OK) {
            print_error("%s\n", err.message);
            fail();
        }
        if (m.triangle_count == 0) { /* a point cloud: nothing to simplify */
            mr_mesh_free(&m);
            continue;
        }
        sim_case c;
        describe(&c, files[f], &m);
        const double r = done % 3 == 0 ? 0.25 : done % 3 == 1 ? 0.1 : 0.01;
        const variant all[] = {
            BATCHED_FULL(0.25), BATCHED_FULL(0.1), BATCHED_FULL(0.01),
            BATCHED_HALF(r),    GREEDY_FULL(r),    GREEDY_HALF(r),
            PART_FULL(r),       PB_FULL(r), /* (the partitioned ones: not quick) */
        };
        /* Under MR_TEST_QUICK: the default at one ratio, and every pair
         * only on the meshes above 65,536 vertices, where the per-vertex
         * loops go parallel (today igea.ply). */
        const variant one[] = {BATCHED_FULL(r)};
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        if (!quick())
            check_variants(&c, &o, all, sizeof all / sizeof all[0]);
        else if (m.vertex_count > 65536)
            check_variants(&c, &o, all, sizeof all / sizeof all[0] - 2);
        else
            check_variants(&c, &o, one, 1);
        mr_mesh_free(&m);
        done++;
    }
    for (size_t f = 0; f < nfiles; f++)
        free(files[f]);
    free(files);
    if (!done)
        skip();
    print_message("%zu data meshes\n", done);
    report("data meshes", runs_done - runs0, t0);
}

/* ---- generated meshes --------------------------------------------------------- */

/* A closed genus-0 scan of ~300k triangles (~150k vertices): the parallel
 * loops run. Every strategy and collapse pair at 0.1; the default also at
 * 0.25 and 0.01. */
static void test_large_scan(void **state)
{
    (void)state;
    const double t0 = now_seconds();
    const size_t runs0 = runs_done;
    mr_mesh m;
    /* Quick: still above 65,536 vertices. */
    generate(MR_GEN_SCAN, quick() ? 140000 : 300000, &m);
    assert_true(m.vertex_count > 65536 && m.triangle_count > 65536);
    sim_case c;
    describe(&c, "generated scan", &m);
    assert_true(c.closed_manifold);
    const variant all[] = {
        BATCHED_FULL(0.25), BATCHED_FULL(0.1), BATCHED_FULL(0.01),
        BATCHED_HALF(0.1),  GREEDY_FULL(0.1),  GREEDY_HALF(0.1),
    };
    const variant few[] = {BATCHED_FULL(0.1), BATCHED_HALF(0.01), GREEDY_FULL(0.25)};
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    if (quick())
        check_variants(&c, &o, few, sizeof few / sizeof few[0]);
    else
        check_variants(&c, &o, all, sizeof all / sizeof all[0]);

    /* The same triangles shuffled (the batched strategy then works them
     * in its own spatial order): still the same bytes at every thread
     * count, still closed and manifold. */
    uint64_t seed = 0x9E3779B97F4A7C15ull;
    for (size_t t = m.triangle_count; t > 1; t--) {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        const size_t j = (size_t)(seed % t);
        uint32_t tmp[3];
        memcpy(tmp, m.indices + 3 * (t - 1), sizeof tmp);
        memcpy(m.indices + 3 * (t - 1), m.indices + 3 * j, sizeof tmp);
        memcpy(m.indices + 3 * j, tmp, sizeof tmp);
    }
    describe(&c, "generated scan, triangles shuffled", &m);
    const variant shuffled[] = {BATCHED_FULL(0.1), BATCHED_HALF(0.01)};
    check_variants(&c, &o, shuffled, sizeof shuffled / sizeof shuffled[0]);
    mr_mesh_free(&m);
    report("generated scan", runs_done - runs0, t0);
}

/* ---- the collapse mesh's compaction -------------------------------------- */

/* Both meshes' lists, counts and refs are the same (the layout, not only
 * the lists' contents), and every list entry is a live corner of its
 * vertex. */
static void assert_same_lists(const mr_collapse_mesh *a, const mr_collapse_mesh *b)
{
    assert_int_equal(a->refs_size, b->refs_size);
    assert_memory_equal(a->start, b->start, a->vertex_count * sizeof *a->start);
    assert_memory_equal(a->count, b->count, a->vertex_count * sizeof *a->count);
    assert_memory_equal(a->dead, b->dead, a->vertex_count * sizeof *a->dead);
    assert_memory_equal(a->refs, b->refs, a->refs_size * sizeof *a->refs);
    for (size_t v = 0; v < a->vertex_count; v++) {
        const uint32_t *l = mr_collapse_vertex_tris(a, (uint32_t)v);
        for (uint32_t i = 0; i < a->count[v]; i++)
            assert_true(a->tris[l[i]] == v || (a->dead[v] && a->tris[l[i]] == MR_COLLAPSE_NONE));
    }
}

/* The same collapses on meshes whose compaction runs on 1, 2, 3 and 8
 * threads: concurrent-style collapses (opposite vertices' lists left dirty,
 * room handed out as the batched strategy does), compactions forced every
 * few thousand collapses and whenever refs runs full; after each, every
 * mesh has the layout of the 1-thread one. */
static void test_compaction_layout(void **state)
{
    (void)state;
    mr_mesh in;
    generate(MR_GEN_SCAN, quick() ? 140000 : 300000, &in);
    const double centre[3] = {0, 0, 0};
    mr_collapse_mesh cm[NTHREADS];
    for (size_t t = 0; t < NTHREADS; t++) {
        assert_int_equal(mr_collapse_mesh_init(&cm[t], in.positions, 0, in.vertex_count,
                                               in.indices, in.triangle_count, NULL, centre, 1.0,
                                               thread_counts[t], NULL),
                         MR_OK);
        cm[t].lazy = true;
        mr_collapse_prepare(&cm[t]);
        assert_non_null(cm[t].dead);
    }
    for (size_t t = 1; t < NTHREADS; t++) /* the lists as init fills them */
        assert_same_lists(&cm[0], &cm[t]);
    const mr_collapse_limits lim = {0.5, 0, mr_kernels_get()};
    size_t done = 0, compactions = 0;
    for (size_t step = 0; step < 4 * in.vertex_count && done < in.vertex_count / 2; step++) {
        const uint32_t u = (uint32_t)((step * 7919u) % in.vertex_count);
        mr_collapse_mesh *m0 = &cm[0];
        if (m0->flags[u] & MR_VF_REMOVED || !m0->count[u])
            continue;
        /* u's first live triangle: the vertex after u there (the
         * cleaning, as every reader's, on every mesh alike) */
        for (size_t t = 0; t < NTHREADS; t++)
            mr_collapse_clean(&cm[t], u);
        const uint32_t c0 = mr_collapse_vertex_tris(m0, u)[0];
        const uint32_t v = m0->tris[c0 - c0 % 3 + (c0 % 3 == 2 ? 0 : c0 % 3 + 1)];
        for (size_t t = 0; t < NTHREADS; t++)
            mr_collapse_clean(&cm[t], v);
        double at[3];
        mr_collapse_load(m0, v, at);
        if (!mr_collapse_valid(m0, u, v, at, &lim))
            continue;
        for (size_t t = 0; t < NTHREADS; t++) {
            mr_collapse_mesh *m = &cm[t];
            const uint32_t room = m->count[u] + m->count[v] - 1;
            if (m->refs_size + room > m->refs_capacity) {
                mr_collapse_compact(m);
                compactions += t == 0;
            }
            size_t gone;
            uint32_t *out = m->refs + m->refs_size;
            const unsigned deleted = mr_collapse_apply_at(m, u, v, at, out, &gone, true);
            for (uint32_t j = m->count[v]; j < room; j++)
                out[j] = 0;
            m->refs_size += room;
            m->live_vertices -= gone;
            m->live_triangles -= deleted;
        }
        done++;
        if (done % 4096 == 0) {
            for (size_t t = 0; t < NTHREADS; t++)
                mr_collapse_compact(&cm[t]);
            compactions++;
        }
        if (done % 4096 == 0 || done % 4096 == 2048)
            for (size_t t = 1; t < NTHREADS; t++)
                assert_same_lists(&cm[0], &cm[t]);
    }
    assert_true(done > in.vertex_count / 8);
    assert_true(compactions > 4);
    for (size_t t = 0; t < NTHREADS; t++)
        mr_collapse_compact(&cm[t]);
    for (size_t t = 1; t < NTHREADS; t++)
        assert_same_lists(&cm[0], &cm[t]);
    print_message("compaction: %zu collapses, %zu compactions\n", done, compactions);
    for (size_t t = 0; t < NTHREADS; t++)
        mr_collapse_mesh_free(&cm[t]);
    mr_mesh_free(&in);
}

/* A torus with round holes (open boundaries): plain, with lock_border, and
 * an error-bounded run (until_error, max_error) with prune. */
static void test_open_boundaries(void **state)
{
    (void)state;
    const double t0 = now_seconds();
    const size_t runs0 = runs_done;
    mr_mesh m;
    generate(MR_GEN_TORUS, 140000, &m);
    assert_true(m.vertex_count > 65536);
    sim_case c;
    describe(&c, "generated torus with holes", &m);
    assert_false(c.closed_manifold);
    mr_stats s;
    assert_int_equal(
        mr_stats_compute(m.positions, 0, m.vertex_count, m.indices, m.triangle_count, &s, NULL),
        MR_OK);
    assert_true(s.boundary_edges > 0 && s.boundary_loops >= 3);

    mr_simplify_options o;
    mr_simplify_options_default(&o);
    const variant plain[] = {
        BATCHED_FULL(0.25), BATCHED_FULL(0.1), BATCHED_FULL(0.01),
        BATCHED_HALF(0.1),  GREEDY_FULL(0.01), GREEDY_HALF(0.25),
        PART_FULL(0.1),     PART_HALF(0.01),
    };
    const variant plain_quick[] = {BATCHED_FULL(0.1), GREEDY_HALF(0.25), PART_FULL(0.1)};
    if (quick())
        check_variants(&c, &o, plain_quick, 3);
    else
        check_variants(&c, &o, plain, sizeof plain / sizeof plain[0]);

    snprintf(c.name, sizeof c.name, "generated torus, lock_border");
    o.lock_border = 1;
    const variant border[] = {BATCHED_FULL(0.1), PART_FULL(0.1), PB_HALF(0.1),
                              BATCHED_HALF(0.01), GREEDY_FULL(0.25)};
    check_variants(&c, &o, border, quick() ? 2 : sizeof border / sizeof border[0]);

    snprintf(c.name, sizeof c.name, "generated torus, until_error max_error 0.002, prune");
    mr_simplify_options_default(&o);
    o.until_error = 1;
    o.max_error = 0.002;
    o.prune = 1;
    const variant bounded[] = {BATCHED_FULL(0), PART_FULL(0), GREEDY_HALF(0)};
    check_variants(&c, &o, bounded, quick() ? 2 : 3);
    mr_mesh_free(&m);
    report("open boundaries", runs_done - runs0, t0);
}

/* The mesh split into four charts by the signs of x and y at each
 * triangle's centroid: every chart has its own copies of its vertices,
 * with its own texture coordinates (a planar projection shifted per
 * chart), so vertices split along x = 0 and y = 0, four ways where the
 * seams meet. Normals (area-weighted, the same on both sides of a seam)
 * and colours come along. */
static void add_seams(const mr_mesh *m, mr_mesh *out)
{
    const size_t nv = m->vertex_count, nt = m->triangle_count;
    double *vn = calloc(3 * nv, sizeof *vn);
    uint32_t *copy = malloc(4 * nv * sizeof *copy);
    uint32_t *idx = malloc(3 * nt * sizeof *idx);
    uint32_t *from = malloc(4 * nv * sizeof *from);
    uint8_t *chart_of = malloc(4 * nv);
    assert_true(vn && copy && idx && from && chart_of);
    memset(copy, 0xff, 4 * nv * sizeof *copy);
    size_t count = 0;
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *tri = m->indices + 3 * t;
        const float *p[3] = {m->positions + 3 * tri[0], m->positions + 3 * tri[1],
                             m->positions + 3 * tri[2]};
        const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
        const double w[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
        const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                             u[0] * w[1] - u[1] * w[0]};
        const double cx = (double)p[0][0] + p[1][0] + p[2][0];
        const double cy = (double)p[0][1] + p[1][1] + p[2][1];
        const unsigned chart = (cx >= 0) + 2u * (cy >= 0);
        for (int k = 0; k < 3; k++) {
            for (int j = 0; j < 3; j++)
                vn[3 * tri[k] + j] += n[j];
            uint32_t *slot = &copy[4 * (size_t)tri[k] + chart];
            if (*slot == UINT32_MAX) {
                from[count] = tri[k];
                chart_of[count] = (uint8_t)chart;
                *slot = (uint32_t)count++;
            }
            idx[3 * t + k] = *slot;
        }
    }
    mr_mesh_init(out);
    assert_int_equal(mr_mesh_alloc(out, count, nt,
                                   MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS, NULL),
                     MR_OK);
    memcpy(out->indices, idx, 3 * nt * sizeof *idx);
    for (size_t v = 0; v < count; v++) {
        const float *p = m->positions + 3 * (size_t)from[v];
        const double *n = vn + 3 * (size_t)from[v];
        const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        memcpy(out->positions + 3 * v, p, 3 * sizeof(float));
        for (int j = 0; j < 3; j++)
            out->normals[3 * v + j] = (float)(len > 0 ? n[j] / len : 0);
        out->texcoords[2 * v + 0] = 0.25f * p[0] + 0.25f + 0.5f * (float)(chart_of[v] & 1);
        out->texcoords[2 * v + 1] = 0.25f * p[2] + 0.25f + 0.5f * (float)(chart_of[v] >> 1);
        for (int j = 0; j < 3; j++)
            out->colors[4 * v + j] = 0.5f + 0.5f * p[j];
        out->colors[4 * v + 3] = 1.0f;
    }
    free(vn);
    free(copy);
    free(idx);
    free(from);
    free(chart_of);
}

/* Attribute seams through mr_mesh_simplify: the seams stay (the outputs
 * have more vertices than surface points) and the surface stays closed. */
static void test_attribute_seams(void **state)
{
    (void)state;
    const double t0 = now_seconds();
    const size_t runs0 = runs_done;
    mr_mesh base, m;
    generate(MR_GEN_SPHERE, quick() ? 140000 : 160000, &base);
    add_seams(&base, &m);
    mr_mesh_free(&base);
    assert_true(m.vertex_count > 65536);
    sim_case c;
    describe(&c, "generated sphere with seams", &m);
    assert_true(c.attributes && c.closed_manifold);
    mr_stats s;
    assert_int_equal(
        mr_stats_compute(m.positions, 0, m.vertex_count, m.indices, m.triangle_count, &s, NULL),
        MR_OK);
    assert_true(s.split_vertices > 0);

    const variant all[] = {
        BATCHED_FULL(0.25), BATCHED_FULL(0.1), BATCHED_FULL(0.01),
        BATCHED_HALF(0.1),  GREEDY_FULL(0.1),  GREEDY_HALF(0.01),
        PART_FULL(0.1),     PART_HALF(0.01),   PB_FULL(0.1),
    };
    const variant few[] = {BATCHED_FULL(0.1), GREEDY_HALF(0.01), PART_FULL(0.1), PB_FULL(0.1)};
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    if (quick())
        check_variants(&c, &o, few, 3); /* (partitioned-boundary: not quick) */
    else
        check_variants(&c, &o, all, sizeof all / sizeof all[0]);

    /* The seams survive: an output keeps split vertices. */
    o.target_ratio = 0.1;
    run_result r;
    run_once(&c, &o, 2, &r);
    assert_non_null(r.out.texcoords);
    assert_true(r.stats.output_vertices > r.stats.output_points);
    run_free(&r);
    mr_mesh_free(&m);
    report("attribute seams", runs_done - runs0, t0);
}

/* Locked vertices (options.vertex_lock): a scattered set and a slab; and
 * with lock_border on the torus with holes. */
static void test_locked_vertices(void **state)
{
    (void)state;
    const double t0 = now_seconds();
    const size_t runs0 = runs_done;
    mr_mesh m;
    generate(MR_GEN_SCAN, 140000, &m);
    assert_true(m.vertex_count > 65536);
    uint8_t *lock = malloc(m.vertex_count);
    assert_non_null(lock);
    size_t locked = 0;
    for (size_t v = 0; v < m.vertex_count; v++) {
        const float x = m.positions[3 * v];
        lock[v] = v % 61 == 0 || (x > 5.0f && x < 12.0f);
        locked += lock[v];
    }
    assert_true(locked > m.vertex_count / 60 && locked < m.vertex_count / 2);
    sim_case c;
    describe(&c, "generated scan, vertex_lock", &m);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.vertex_lock = lock;
    const variant all[] = {BATCHED_FULL(0.25), PART_FULL(0.01), PB_FULL(0.01), BATCHED_FULL(0.01),
                           BATCHED_HALF(0.1),  GREEDY_FULL(0.1), GREEDY_HALF(0.01)};
    check_variants(&c, &o, all, quick() ? 2 : sizeof all / sizeof all[0]);
    free(lock);
    mr_mesh_free(&m);

    generate(MR_GEN_TORUS, quick() ? 70000 : 140000, &m);
    lock = malloc(m.vertex_count);
    assert_non_null(lock);
    for (size_t v = 0; v < m.vertex_count; v++)
        lock[v] = v % 37 == 0;
    describe(&c, "generated torus, vertex_lock and lock_border", &m);
    mr_simplify_options_default(&o);
    o.vertex_lock = lock;
    o.lock_border = 1;
    const variant torus[] = {BATCHED_FULL(0.1), PART_HALF(0.1), BATCHED_HALF(0.01),
                             GREEDY_FULL(0.25)};
    check_variants(&c, &o, torus, quick() ? 2 : sizeof torus / sizeof torus[0]);
    free(lock);
    mr_mesh_free(&m);
    report("locked vertices", runs_done - runs0, t0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_compaction_layout),
        cmocka_unit_test(test_large_scan),
        cmocka_unit_test(test_open_boundaries),
        cmocka_unit_test(test_attribute_seams),
        cmocka_unit_test(test_locked_vertices),
        cmocka_unit_test(test_data_meshes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
