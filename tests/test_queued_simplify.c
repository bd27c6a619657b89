/* The concurrent-queue strategies (MR_STRATEGY_PPQ, _RPPQ, _FPPQ,
 * _MULTIQUEUE):
 *   - on one thread PPQ gives greedy's half-edge output byte for byte
 *     (positions, indices, origins, collapses, largest error, stop) on
 *     generated meshes and the meshes of ../shared/data when present, with
 *     attributes (mr_mesh_simplify), vertex_lock, lock_border, max_error
 *     and boundary_weight;
 *   - every strategy at 1, 2, 3 and 8 threads keeps a closed manifold mesh
 *     closed and manifold and hits a vertex target exactly (a triangle
 *     target within the one triangle a collapse may overshoot);
 *   - runs whose target cannot be reached (a locked border, an error
 *     bound) end, with the stop reason greedy's run gives, and locked
 *     vertices stay;
 *   - the filter levels and heaps per thread apply, the CLI takes the
 *     strategies and their options, and progress comes from the calling
 *     thread only;
 *   - full collapses are refused.
 * With MR_TEST_QUICK set (the ThreadSanitizer stage) the meshes shrink. */
#include "testutil.h"

#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const int thread_counts[] = {1, 2, 3, 8};
#define NTHREADS (sizeof thread_counts / sizeof thread_counts[0])
static const mr_strategy queued[] = {MR_STRATEGY_PPQ, MR_STRATEGY_RPPQ, MR_STRATEGY_FPPQ,
                                     MR_STRATEGY_MULTIQUEUE};
#define NQUEUED (sizeof queued / sizeof queued[0])

static bool quick(void)
{
    const char *q = getenv("MR_TEST_QUICK");
    return q && *q && strcmp(q, "0") != 0;
}

static size_t size_for(size_t full) { return quick() ? full / 8 : full; }

static void generate(mr_generator kind, size_t triangles, mr_mesh *m)
{
    mr_mesh_init(m);
    assert_int_equal(mr_generate(kind, size_for(triangles), 1, m, NULL), MR_OK);
}

static void half_options(mr_simplify_options *o, mr_strategy strategy, int threads)
{
    mr_simplify_options_default(o);
    o->collapse = MR_COLLAPSE_HALF;
    o->strategy = strategy;
    o->threads = threads;
}

static void run(const mr_mesh *m, const mr_simplify_options *o, mr_simplified *out)
{
    mr_error err;
    mr_status st = mr_simplify(m->positions, 0, m->vertex_count, m->indices, m->triangle_count,
                               o, out, &err);
    if (st != MR_OK)
        fail_msg("simplify: %s", err.message);
}

static void assert_same(const mr_simplified *a, const mr_simplified *b, const char *what)
{
    if (a->vertex_count != b->vertex_count || a->triangle_count != b->triangle_count)
        fail_msg("%s: %zu/%zu vertices, %zu/%zu triangles", what, a->vertex_count,
                 b->vertex_count, a->triangle_count, b->triangle_count);
    assert_memory_equal(a->positions, b->positions, 3 * a->vertex_count * sizeof(float));
    assert_memory_equal(a->indices, b->indices, 3 * a->triangle_count * sizeof(uint32_t));
    assert_memory_equal(a->origin, b->origin, a->vertex_count * sizeof(uint32_t));
    assert_int_equal(a->stats.collapses, b->stats.collapses);
    assert_memory_equal(&a->stats.max_error, &b->stats.max_error, sizeof(double));
    assert_int_equal(a->stats.stop, b->stats.stop);
}

/* PPQ on one thread against greedy half, with the options o (strategy and
 * threads set here). */
static void check_equal(const mr_mesh *m, const mr_simplify_options *base, const char *what)
{
    mr_simplify_options o = *base;
    o.collapse = MR_COLLAPSE_HALF;
    o.threads = 1;
    o.strategy = MR_STRATEGY_GREEDY;
    mr_simplified ref, got;
    run(m, &o, &ref);
    o.strategy = MR_STRATEGY_PPQ;
    run(m, &o, &got);
    assert_same(&ref, &got, what);
    assert_true(got.stats.queue_pops >= got.stats.collapses);
    assert_int_equal(got.stats.lock_failures, 0);
    mr_simplified_free(&ref);
    mr_simplified_free(&got);
}

static void check_ratios(const mr_mesh *m, const char *what)
{
    static const double ratios[] = {0.25, 0.1, 0.01};
    for (size_t i = 0; i < sizeof ratios / sizeof ratios[0]; i++) {
        mr_simplify_options o;
        half_options(&o, MR_STRATEGY_PPQ, 1);
        o.target_ratio = ratios[i];
        check_equal(m, &o, what);
    }
}

static void test_one_thread_equals_greedy(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_SCAN, 200000, &m);
    check_ratios(&m, "scan");
    mr_mesh_free(&m);
    generate(MR_GEN_TORUS, 60000, &m);
    check_ratios(&m, "torus");
    mr_simplify_options o;
    half_options(&o, MR_STRATEGY_PPQ, 1);
    o.target_ratio = 0.05;
    o.lock_border = 1;
    check_equal(&m, &o, "torus, lock_border");
    o.lock_border = 0;
    o.boundary_weight = 0;
    check_equal(&m, &o, "torus, boundary_weight 0");
    o.boundary_weight = 4;
    check_equal(&m, &o, "torus, boundary_weight 4");
    half_options(&o, MR_STRATEGY_PPQ, 1);
    o.until_error = 1;
    o.max_error = 0.002;
    check_equal(&m, &o, "torus, max_error");
    uint8_t *lock = malloc(m.vertex_count);
    assert_non_null(lock);
    for (size_t v = 0; v < m.vertex_count; v++)
        lock[v] = v % 37 == 0;
    half_options(&o, MR_STRATEGY_PPQ, 1);
    o.target_ratio = 0.02;
    o.vertex_lock = lock;
    check_equal(&m, &o, "torus, vertex_lock");
    free(lock);
    mr_mesh_free(&m);
}

static void test_one_thread_equals_greedy_shared_data(void **state)
{
    (void)state;
    static const char *const names[] = {"stanford-bunny.obj", "armadillo.obj", "fandisk.obj",
                                        "homer.obj", "igea.ply"};
    size_t found = 0;
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        if (quick() && i > 2)
            break;
        const char *path = tu_shared_data(names[i]);
        if (!path)
            continue;
        mr_mesh m;
        mr_mesh_init(&m);
        assert_int_equal(mr_mesh_read(path, NULL, &m, NULL), MR_OK);
        check_ratios(&m, names[i]);
        mr_mesh_free(&m);
        found++;
    }
    if (!found)
        skip();
}

/* Attributes (seams) through mr_mesh_simplify: the same at one thread, and
 * valid at every thread count. */
static void test_attributes(void **state)
{
    (void)state;
    const char *path = tu_shared_data("spot.obj");
    if (!path)
        skip();
    mr_mesh m, ref, got;
    mr_mesh_init(&m);
    assert_int_equal(mr_mesh_read(path, NULL, &m, NULL), MR_OK);
    assert_non_null(m.texcoords);
    mr_simplify_options o;
    half_options(&o, MR_STRATEGY_GREEDY, 1);
    o.target_ratio = 0.1;
    mr_mesh_init(&ref);
    mr_simplify_stats rs, gs;
    assert_int_equal(mr_mesh_simplify(&m, &o, &ref, NULL, &rs, NULL), MR_OK);
    o.strategy = MR_STRATEGY_PPQ;
    mr_mesh_init(&got);
    assert_int_equal(mr_mesh_simplify(&m, &o, &got, NULL, &gs, NULL), MR_OK);
    tu_assert_mesh_equal(&ref, &got);
    assert_int_equal(rs.collapses, gs.collapses);
    mr_mesh_free(&got);
    for (size_t s = 0; s < NQUEUED; s++)
        for (size_t i = 0; i < NTHREADS; i++) {
            half_options(&o, queued[s], thread_counts[i]);
            o.target_ratio = 0.1;
            mr_mesh_init(&got);
            assert_int_equal(mr_mesh_simplify(&m, &o, &got, NULL, &gs, NULL), MR_OK);
            assert_int_equal(gs.output_points, rs.output_points);
            assert_non_null(got.texcoords);
            mr_mesh_free(&got);
        }
    mr_mesh_free(&ref);
    mr_mesh_free(&m);
}

static void assert_closed_manifold(const mr_simplified *r)
{
    mr_stats st;
    assert_int_equal(mr_stats_compute(r->positions, 0, r->vertex_count, r->indices,
                                      r->triangle_count, &st, NULL),
                     MR_OK);
    assert_true(st.closed);
    assert_true(st.manifold);
}

/* A closed manifold m simplified to vt vertices with o: exactly vt, closed
 * and manifold, greedy's stop. */
static void check_vertex_target(const mr_mesh *m, mr_simplify_options *o, size_t vt)
{
    o->target_vertices = vt;
    mr_simplified r;
    run(m, o, &r);
    assert_int_equal(r.vertex_count, vt);
    assert_int_equal(r.stats.stop, MR_STOP_TARGET);
    assert_int_equal(r.stats.collapses, m->vertex_count - vt);
    assert_closed_manifold(&r);
    mr_simplified_free(&r);
}

/* Every strategy, every thread count: closed and manifold, targets hit. */
static void test_targets_exact(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_SCAN, 200000, &m);
    mr_stats in;
    assert_int_equal(mr_stats_compute(m.positions, 0, m.vertex_count, m.indices,
                                      m.triangle_count, &in, NULL),
                     MR_OK);
    assert_true(in.closed && in.manifold);
    const size_t vt = m.vertex_count / 50, tt = m.triangle_count / 7;
    for (size_t s = 0; s < NQUEUED; s++)
        for (size_t i = 0; i < NTHREADS; i++) {
            mr_simplify_options o;
            half_options(&o, queued[s], thread_counts[i]);
            check_vertex_target(&m, &o, vt);
            half_options(&o, queued[s], thread_counts[i]);
            mr_simplified r;
            o.target_triangles = tt;
            run(&m, &o, &r);
            assert_true(r.triangle_count <= tt && r.triangle_count + 2 > tt);
            assert_int_equal(r.stats.stop, MR_STOP_TARGET);
            assert_closed_manifold(&r);
            mr_simplified_free(&r);
        }
    mr_mesh_free(&m);
}

/* Progress: from the calling thread only, rising, ending at 1. */
typedef struct progress_log {
    pthread_t caller;
    size_t calls, foreign;
    double last;
    bool falling;
} progress_log;

static int on_progress(double f, void *user)
{
    progress_log *p = user;
    p->calls++;
    p->foreign += !pthread_equal(pthread_self(), p->caller);
    p->falling |= f < p->last;
    p->last = f;
    return 0;
}

static void test_progress(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_SCAN, 200000, &m);
    for (size_t s = 0; s < NQUEUED; s++) {
        progress_log log = {pthread_self(), 0, 0, 0, false};
        mr_simplify_options o;
        half_options(&o, queued[s], 8);
        o.target_ratio = 0.1;
        o.progress = on_progress;
        o.progress_user = &log;
        mr_simplified r;
        run(&m, &o, &r);
        assert_true(log.calls >= 1);
        assert_int_equal(log.foreign, 0);
        assert_false(log.falling);
        assert_true(log.last == 1.0);
        mr_simplified_free(&r);
    }
    mr_mesh_free(&m);
}

/* The queues' own options: filter levels (FPPQ, RPPQ) and heaps per
 * thread (MultiQueue), at 3 threads. */
static void test_queue_options(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_SCAN, 100000, &m);
    const size_t vt = m.vertex_count / 20;
    for (unsigned c = 1; c <= 4; c++) {
        const mr_strategy st[] = {MR_STRATEGY_FPPQ, MR_STRATEGY_RPPQ, MR_STRATEGY_MULTIQUEUE};
        for (size_t i = 0; i < sizeof st / sizeof st[0]; i++) {
            mr_simplify_options o;
            half_options(&o, st[i], 3);
            o.filter_levels = c;
            o.multiqueue_factor = c;
            check_vertex_target(&m, &o, vt);
        }
    }
    mr_mesh_free(&m);
}

/* Targets that cannot be reached: the run ends, with greedy's reason. */
static void test_unreachable(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_TORUS, 60000, &m);
    uint8_t *lock = malloc(m.vertex_count);
    assert_non_null(lock);
    for (size_t v = 0; v < m.vertex_count; v++)
        lock[v] = v % 29 == 0;
    for (int c = 0; c < 3; c++) {
        mr_simplify_options o;
        half_options(&o, MR_STRATEGY_GREEDY, 1);
        o.target_vertices = 10;
        if (c == 0) {
            o.lock_border = 1;
        } else if (c == 1) {
            o.max_error = 0.001;
        } else {
            o.vertex_lock = lock;
        }
        mr_simplified ref;
        run(&m, &o, &ref);
        assert_false(ref.stats.target_reached && c != 1);
        for (size_t s = 0; s < NQUEUED; s++)
            for (size_t i = 0; i < NTHREADS; i++) {
                o.strategy = queued[s];
                o.threads = thread_counts[i];
                mr_simplified r;
                run(&m, &o, &r);
                assert_int_equal(r.stats.stop, ref.stats.stop);
                assert_true(r.vertex_count > 10);
                if (c == 1)
                    assert_true(r.stats.max_error <= 0.001 * (1 + 1e-9));
                if (c == 2) { /* every locked vertex stays */
                    size_t kept = 0;
                    for (size_t v = 0; v < r.vertex_count; v++)
                        kept += lock[r.origin[v]] != 0;
                    size_t locked = 0;
                    for (size_t v = 0; v < m.vertex_count; v++)
                        locked += lock[v];
                    assert_int_equal(kept, locked);
                }
                mr_simplified_free(&r);
            }
        mr_simplified_free(&ref);
    }
    free(lock);
    mr_mesh_free(&m);
}

static void test_full_rejected(void **state)
{
    (void)state;
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 500, 1, &m, NULL), MR_OK);
    for (size_t s = 0; s < NQUEUED; s++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.strategy = queued[s];
        o.target_ratio = 0.5;
        mr_simplified r;
        mr_error err;
        assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices,
                                     m.triangle_count, &o, &r, &err),
                         MR_ERR_INVALID_ARGUMENT);
        tu_assert_contains(err.message, "half-edge collapses only");
        o.collapse = MR_COLLAPSE_HALF;
        o.filter_levels = 13;
        assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices,
                                     m.triangle_count, &o, &r, &err),
                         MR_ERR_INVALID_ARGUMENT);
    }
    mr_mesh_free(&m);
}

/* The command line: the strategies, their options, the profile. */
static void test_cli(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("sphere.ply"), *out = tu_tmp_path("out.ply");
    char *text = NULL;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere -o %s --triangles 5000 -q", in), NULL), 0);
    static const char *const names[] = {"ppq", "rppq", "fppq", "multiqueue"};
    for (size_t i = 0; i < NQUEUED; i++) {
        assert_int_equal(tu_run_cli(tu_fmt("simplify %s -o %s --strategy %s --collapse half "
                                           "--ratio 0.2 --threads 2 --filter-levels 2 "
                                           "--multiqueue-factor 3 --stats",
                                           in, out, names[i]),
                                    &text),
                         0);
        tu_assert_contains(text, "profile    summed over threads:");
        tu_assert_contains(text, "lock failures");
        free(text);
        assert_int_equal(tu_run_cli(tu_fmt("simplify %s -o %s --strategy %s --collapse half "
                                           "--ratio 0.2 --json", in, out, names[i]),
                                    &text),
                         0);
        tu_assert_contains(text, "\"profile\": {\"pops\": ");
        free(text);
        assert_true(tu_run_cli(tu_fmt("simplify %s -o %s --strategy %s --ratio 0.2", in, out,
                                      names[i]),
                               &text) != 0);
        tu_assert_contains(text, "half-edge collapses only");
        free(text);
    }
    assert_true(tu_run_cli(tu_fmt("simplify %s -o %s --strategy fppq --collapse half "
                                  "--ratio 0.2 --filter-levels 0", in, out),
                           &text) != 0);
    tu_assert_contains(text, "--filter-levels");
    free(text);
    assert_int_equal(tu_run_cli("simplify --help", &text), 0);
    tu_assert_contains(text, "Relaxed: the output may vary");
    tu_assert_contains(text, "k = L*2^L + 1");
    free(text);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_full_rejected),
        cmocka_unit_test(test_one_thread_equals_greedy),
        cmocka_unit_test(test_one_thread_equals_greedy_shared_data),
        cmocka_unit_test(test_attributes),
        cmocka_unit_test(test_targets_exact),
        cmocka_unit_test(test_unreachable),
        cmocka_unit_test(test_queue_options),
        cmocka_unit_test(test_progress),
        cmocka_unit_test(test_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
