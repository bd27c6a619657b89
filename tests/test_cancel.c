/* Cancelling a simplification from its progress callback: every strategy
 * (greedy and batched, full and half collapse; the concurrent queues on
 * several threads; --quality best's surface fit), through mr_simplify and
 * mr_mesh_simplify, stops soon
 * after the callback asks, fails with MR_ERR_CANCELLED and a message, and
 * leaves its output empty (ASan: nothing leaks). A callback that never asks
 * changes nothing. */
#include "testutil.h"

#include <stdbool.h>
#include <string.h>

typedef struct cancel_at {
    size_t calls, stop_after; /* ask to stop on call stop_after (0: never) */
    double last;
} cancel_at;

static int on_progress(double fraction, void *user)
{
    cancel_at *c = user;
    c->calls++;
    c->last = fraction;
    return c->stop_after && c->calls >= c->stop_after;
}

typedef struct variant {
    mr_strategy strategy;
    mr_collapse_kind collapse;
    int threads;
} variant;

static const variant variants[] = {
    {MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, 2},   {MR_STRATEGY_BATCHED, MR_COLLAPSE_HALF, 1},
    {MR_STRATEGY_GREEDY, MR_COLLAPSE_FULL, 1},    {MR_STRATEGY_GREEDY, MR_COLLAPSE_HALF, 1},
    {MR_STRATEGY_PPQ, MR_COLLAPSE_HALF, 3},       {MR_STRATEGY_FPPQ, MR_COLLAPSE_HALF, 3},
    {MR_STRATEGY_MULTIQUEUE, MR_COLLAPSE_HALF, 2}, {MR_STRATEGY_RPPQ, MR_COLLAPSE_HALF, 2},
    {MR_STRATEGY_PARTITIONED, MR_COLLAPSE_FULL, 2}, {MR_STRATEGY_PARTITIONED, MR_COLLAPSE_HALF, 1},
    {MR_STRATEGY_PARTITIONED_BOUNDARY, MR_COLLAPSE_FULL, 2},
};

/* The concurrent queues report from the calling thread every 256 of its
 * own turns: how many reports a run makes depends on how many turns that
 * thread gets (a loaded machine gave fewer than 5), so only the first
 * report -- the last one at the latest -- is sure to come. The other
 * strategies report at fixed counts. */
static bool reports_vary(const variant *v)
{
    return v->strategy == MR_STRATEGY_PPQ || v->strategy == MR_STRATEGY_RPPQ ||
           v->strategy == MR_STRATEGY_FPPQ || v->strategy == MR_STRATEGY_MULTIQUEUE;
}

static void options(mr_simplify_options *o, const variant *v, cancel_at *c)
{
    mr_simplify_options_default(o);
    o->strategy = v->strategy;
    o->collapse = v->collapse;
    o->threads = v->threads;
    o->target_ratio = 0.05;
    o->progress = on_progress;
    o->progress_user = c;
}

static void test_cancel_flat_arrays(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SCAN, 60000, 1, &m, &err), MR_OK);
    for (size_t i = 0; i < sizeof variants / sizeof variants[0]; i++) {
        const size_t stop_after = reports_vary(&variants[i]) ? 1 : 3;
        cancel_at c = {0, stop_after, 0};
        mr_simplify_options o;
        options(&o, &variants[i], &c);
        mr_simplified r;
        mr_status st = mr_simplify(m.positions, 0, m.vertex_count, m.indices, m.triangle_count,
                                   &o, &r, &err);
        assert_int_equal(st, MR_ERR_CANCELLED);
        assert_int_equal(err.status, MR_ERR_CANCELLED);
        tu_assert_contains(err.message, "cancelled by the progress callback");
        assert_int_equal(c.calls, stop_after); /* not called again after asking */
        assert_true(c.last < 1.0);
        assert_null(r.positions);
        assert_null(r.indices);
        assert_int_equal(r.vertex_count, 0);
        /* never asking: the run completes */
        cancel_at go = {0, 0, 0};
        options(&o, &variants[i], &go);
        assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices,
                                     m.triangle_count, &o, &r, &err),
                         MR_OK);
        assert_true(go.calls >= 1);
        if (!reports_vary(&variants[i]))
            assert_true(go.calls > 3);
        assert_true(go.last == 1.0);
        assert_true(r.triangle_count > 0 && r.triangle_count < m.triangle_count / 10);
        mr_simplified_free(&r);
    }
    assert_string_equal(mr_status_string(MR_ERR_CANCELLED), "cancelled");
    mr_mesh_free(&m);
}

static void test_cancel_mesh(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_TORUS, 60000, 2, &m, &err), MR_OK);
    for (size_t i = 0; i < sizeof variants / sizeof variants[0]; i++) {
        const size_t last_stop = reports_vary(&variants[i]) ? 1 : 5;
        for (size_t stop_after = 1; stop_after <= last_stop; stop_after += 4) {
            cancel_at c = {0, stop_after, 0};
            mr_simplify_options o;
            options(&o, &variants[i], &c);
            mr_mesh out;
            mr_mesh_init(&out);
            uint32_t *origin = (uint32_t *)&c; /* set to NULL: nothing to free */
            mr_simplify_stats s;
            assert_int_equal(mr_mesh_simplify(&m, &o, &out, &origin, &s, &err),
                             MR_ERR_CANCELLED);
            tu_assert_contains(err.message, "cancelled by the progress callback");
            assert_int_equal(c.calls, stop_after);
            assert_null(origin);
            assert_null(out.positions);
            assert_int_equal(out.triangle_count, 0);
        }
    }
    mr_mesh_free(&m);
}

/* --quality best: the collapses report up to 0.5, the surface fit the rest;
 * asking to stop during the fit stops it. */
typedef struct fit_watch {
    size_t calls, above_half, after_stop;
    double last, stop_above; /* ask to stop on the first report above
                                stop_above (>= 1: never) */
    bool increasing, stopped;
} fit_watch;

static int on_fit_progress(double fraction, void *user)
{
    fit_watch *w = user;
    w->calls++;
    w->after_stop += w->stopped;
    w->increasing &= w->calls == 1 || fraction >= w->last;
    w->above_half += fraction > 0.5 && fraction < 1;
    w->last = fraction;
    if (fraction > w->stop_above)
        w->stopped = true;
    return w->stopped;
}

static void test_cancel_best(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SCAN, 60000, 1, &m, &err), MR_OK);
    const int threads[2] = {1, 2};
    for (int t = 0; t < 2; t++) {
        const variant v = {MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, threads[t]};
        mr_simplify_options o;
        options(&o, &v, NULL);
        o.quality = MR_QUALITY_BEST;
        o.progress = on_fit_progress;
        /* never asking: the reports climb to 1, six of them in the fit */
        fit_watch go = {0, 0, 0, 0, 2, true, false};
        o.progress_user = &go;
        mr_simplified r;
        assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices, m.triangle_count,
                                     &o, &r, &err),
                         MR_OK);
        assert_true(go.increasing);
        assert_true(go.last == 1.0);
        assert_true(go.above_half >= 6);
        assert_true(go.calls > go.above_half + 3); /* the collapses' reports */
        mr_simplified_free(&r);
        /* asking during the fit: it stops there */
        fit_watch stop = {0, 0, 0, 0, 0.6, true, false};
        o.progress_user = &stop;
        assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices, m.triangle_count,
                                     &o, &r, &err),
                         MR_ERR_CANCELLED);
        tu_assert_contains(err.message, "cancelled by the progress callback");
        assert_true(stop.stopped);
        assert_int_equal(stop.after_stop, 0); /* not called again */
        assert_true(stop.last > 0.6 && stop.last < 1.0);
        assert_null(r.positions);
        assert_int_equal(r.triangle_count, 0);
    }
    mr_mesh_free(&m);

    /* the same through mr_mesh_simplify */
    assert_int_equal(mr_generate(MR_GEN_TORUS, 60000, 2, &m, &err), MR_OK);
    const variant v = {MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, 0};
    mr_simplify_options o;
    options(&o, &v, NULL);
    o.quality = MR_QUALITY_BEST;
    o.progress = on_fit_progress;
    fit_watch stop = {0, 0, 0, 0, 0.6, true, false};
    o.progress_user = &stop;
    mr_mesh out;
    mr_mesh_init(&out);
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, NULL, &err), MR_ERR_CANCELLED);
    assert_true(stop.stopped && stop.after_stop == 0 && stop.last < 1.0);
    assert_null(out.positions);
    fit_watch go = {0, 0, 0, 0, 2, true, false};
    o.progress_user = &go;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, NULL, &err), MR_OK);
    assert_true(go.increasing && go.last == 1.0 && go.above_half >= 6);
    mr_mesh_free(&out);
    mr_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cancel_flat_arrays),
        cmocka_unit_test(test_cancel_mesh),
        cmocka_unit_test(test_cancel_best),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
