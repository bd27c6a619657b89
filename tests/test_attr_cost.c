/*
 * The attributes' part in the collapse cost (mr_mesh_simplify with
 * normal_weight, uv_weight, color_weight; src/qem/attr_quadric.c): a
 * colour step across a grid kept where interpolation alone smears it, at
 * every strategy, both collapse kinds and both qualities; texture
 * coordinates placed on their (known) function of the position on a
 * UV-seamed curved grid; normals unit, colours in range; the same bytes at
 * 1, 2, 3 and 8 threads; the weights checked.
 */
#include "testutil.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* A grid of 3 x 8 vertices, unit spacing, a little height noise, and a
 * colour step between rows 3 and 4: a bright yellow gradient below, a
 * blue one above (per vertex: rows are whole colours). */
static void step_grid(mr_mesh *m)
{
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, 24, 28, MR_ATTR_COLORS, NULL), MR_OK);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 3; x++) {
            const int v = 3 * y + x;
            float *p = m->positions + 3 * v, *c = m->colors + 4 * v;
            p[0] = (float)x;
            p[1] = (float)y;
            p[2] = 0.03f * (float)x + 0.03f * (float)(y % 2) + (x == 2 && y == 7 ? 0.03f : 0);
            const bool low = y < 4;
            c[0] = low ? 0.8f + 0.05f * (float)y : 0;
            c[1] = c[0];
            c[2] = low ? 0 : 0.8f + 0.05f * (float)(7 - y);
            c[3] = 1;
        }
    uint32_t *t = m->indices;
    for (int y = 0; y < 7; y++)
        for (int x = 0; x < 2; x++) {
            const uint32_t a = (uint32_t)(3 * y + x), b = a + 1, c = a + 3, d = a + 4;
            const uint32_t q[6] = {a, b, c, c, b, d};
            memcpy(t, q, sizeof q);
            t += 6;
        }
}

/* The colour's RMS deviation at matched surface points (compare's). */
static double step_error(const mr_mesh *out)
{
    mr_mesh m;
    step_grid(&m);
    mr_compare_options o;
    mr_compare_options_default(&o);
    o.samples = 20000;
    o.threads = 1;
    mr_attribute_error e;
    mr_error err;
    assert_int_equal(mr_compare_attributes(&m, out, &o, &e, &err), MR_OK);
    assert_true(e.attributes & MR_ATTR_COLORS);
    mr_mesh_free(&m);
    return e.color_rms;
}

static void simplify_step(const mr_simplify_options *o, mr_mesh *out, mr_simplify_stats *st)
{
    mr_mesh m;
    step_grid(&m);
    mr_mesh_init(out);
    mr_error err;
    const mr_status s = mr_mesh_simplify(&m, o, out, NULL, st, &err);
    if (s != MR_OK)
        fail_msg("%s", err.message);
    mr_mesh_free(&m);
}

/* The step is kept with the colour in the cost, smeared without it. */
static void test_colour_step(void **state)
{
    (void)state;
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_triangles = 6;
    mr_mesh out;
    mr_simplify_stats st;
    simplify_step(&o, &out, &st);
    assert_int_equal(out.triangle_count, 6);
    const double with = step_error(&out);
    /* rows 0, 3, 4 and 7 kept at both sides: the step's two rows stay */
    size_t at3 = 0, at4 = 0;
    for (size_t v = 0; v < out.vertex_count; v++) {
        at3 += fabs(out.positions[3 * v + 1] - 3) < 0.01;
        at4 += fabs(out.positions[3 * v + 1] - 4) < 0.01;
    }
    assert_true(at3 >= 2 && at4 >= 2);
    mr_mesh_free(&out);
    o.normal_weight = o.uv_weight = o.color_weight = 0;
    simplify_step(&o, &out, &st);
    const double without = step_error(&out);
    mr_mesh_free(&out);
    print_message("colour RMS %.3g with the cost, %.3g without\n", with, without);
    assert_true(with < 0.02);
    assert_true(without > 0.2);
}

/* Every strategy, both collapse kinds and the best quality keep the step
 * better with the colour in the cost than without. */
static void test_colour_step_everywhere(void **state)
{
    (void)state;
    const struct {
        mr_strategy strategy;
        mr_collapse_kind collapse;
        mr_simplify_quality quality;
    } runs[] = {
        {MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_BATCHED, MR_COLLAPSE_HALF, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, MR_QUALITY_BEST},
        {MR_STRATEGY_GREEDY, MR_COLLAPSE_FULL, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_GREEDY, MR_COLLAPSE_HALF, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_GREEDY, MR_COLLAPSE_FULL, MR_QUALITY_BEST},
        {MR_STRATEGY_PARTITIONED, MR_COLLAPSE_FULL, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_PARTITIONED_BOUNDARY, MR_COLLAPSE_FULL, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_PPQ, MR_COLLAPSE_HALF, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_FPPQ, MR_COLLAPSE_HALF, MR_QUALITY_DEFAULT},
        {MR_STRATEGY_MULTIQUEUE, MR_COLLAPSE_HALF, MR_QUALITY_DEFAULT},
    };
    for (size_t i = 0; i < sizeof runs / sizeof runs[0]; i++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_triangles = 8;
        o.strategy = runs[i].strategy;
        o.collapse = runs[i].collapse;
        o.quality = runs[i].quality;
        o.threads = 1;
        mr_mesh out;
        mr_simplify_stats st;
        simplify_step(&o, &out, &st);
        const double with = step_error(&out);
        mr_mesh_free(&out);
        o.normal_weight = o.uv_weight = o.color_weight = 0;
        simplify_step(&o, &out, &st);
        const double without = step_error(&out);
        mr_mesh_free(&out);
        print_message("run %zu: colour RMS %.3g with the cost, %.3g without\n", i, with, without);
        if (!(with < 0.05 && with < without))
            fail_msg("run %zu: colour error %g with the cost, %g without", i, with, without);
    }
}

/* A curved grid of n x n vertices over [0, 1]^2 (height a smooth bump)
 * in two UV islands split at x = 0.5, each with u = x^2 + (island's 0 or
 * 2), v = y (1 + x) / 2: texture coordinates a known nonlinear function of
 * the position, a seam down the middle. Normals and colours too (the
 * colour a smooth function of the position). */
static float bump(double x, double y)
{
    return (float)(0.15 * sin(3.0 * x) * cos(2.0 * y));
}

static void seamed_grid(int n, mr_mesh *m)
{
    const int half = (n - 1) / 2; /* the seam's column */
    const int cols = n + 1;       /* the seam column twice */
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, (size_t)cols * n, 2 * (size_t)(n - 1) * (n - 1),
                                   MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS, NULL),
                     MR_OK);
    for (int y = 0; y < n; y++)
        for (int c = 0; c < cols; c++) {
            const int x = c <= half ? c : c - 1; /* column c's grid x */
            const double fx = (double)x / (n - 1), fy = (double)y / (n - 1);
            const size_t v = (size_t)y * cols + c;
            float *p = m->positions + 3 * v;
            p[0] = (float)fx;
            p[1] = (float)fy;
            p[2] = bump(fx, fy);
            /* the bump's normal */
            const double dx = 0.45 * cos(3.0 * fx) * cos(2.0 * fy),
                         dy = -0.3 * sin(3.0 * fx) * sin(2.0 * fy);
            const double len = sqrt(dx * dx + dy * dy + 1);
            m->normals[3 * v] = (float)(-dx / len);
            m->normals[3 * v + 1] = (float)(-dy / len);
            m->normals[3 * v + 2] = (float)(1 / len);
            const bool right = c > half;
            m->texcoords[2 * v] = (float)(fx * fx + (right ? 2 : 0));
            m->texcoords[2 * v + 1] = (float)(fy * (1 + fx) / 2);
            float *col = m->colors + 4 * v;
            col[0] = (float)(0.5 + 0.4 * sin(4 * fx));
            col[1] = (float)(0.5 + 0.4 * cos(3 * fy));
            col[2] = 0.25f;
            col[3] = 1;
        }
    uint32_t *t = m->indices;
    for (int y = 0; y + 1 < n; y++)
        for (int x = 0; x + 1 < n; x++) {
            /* the quad's columns: left of the seam the left copy, right of
             * it the right copy */
            const int c0 = x < half ? x : x + 1, c1 = x < half ? x + 1 : x + 2;
            const uint32_t a = (uint32_t)(y * cols + c0), b = (uint32_t)(y * cols + c1),
                           c = a + (uint32_t)cols, d = b + (uint32_t)cols;
            const uint32_t q[6] = {a, b, d, a, d, c};
            memcpy(t, q, sizeof q);
            t += 6;
        }
}

/* RMS of the output's texture coordinates from the function they sample
 * (the island from the vertex's input vertex). */
static double uv_error(const mr_mesh *out, const uint32_t *origin, const mr_mesh *in)
{
    double sum = 0;
    for (size_t v = 0; v < out->vertex_count; v++) {
        const float *p = out->positions + 3 * v, *t = out->texcoords + 2 * v;
        const double off = in->texcoords[2 * (size_t)origin[v]] >= 2 ? 2 : 0;
        const double du = t[0] - (p[0] * p[0] + off), dv = t[1] - p[1] * (1 + p[0]) / 2;
        sum += du * du + dv * dv;
    }
    return sqrt(sum / (double)out->vertex_count);
}

static void test_uv_seamed_grid(void **state)
{
    (void)state;
    mr_mesh m;
    seamed_grid(41, &m);
    double err[2];
    for (int pass = 0; pass < 2; pass++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_ratio = 0.1;
        if (pass)
            o.normal_weight = o.uv_weight = o.color_weight = 0;
        mr_mesh out;
        uint32_t *origin = NULL;
        mr_error e;
        assert_int_equal(mr_mesh_simplify(&m, &o, &out, &origin, NULL, &e), MR_OK);
        err[pass] = uv_error(&out, origin, &m);
        /* unit normals, colours in range, the seam kept (two UV islands:
         * every triangle's corners on one side of u = 1.5) */
        for (size_t v = 0; v < out.vertex_count; v++) {
            const float *q = out.normals + 3 * v, *c = out.colors + 4 * v;
            assert_true(fabs(sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]) - 1) < 1e-4);
            for (int k = 0; k < 4; k++)
                assert_true(c[k] >= 0 && c[k] <= 1);
        }
        for (size_t t = 0; t < out.triangle_count; t++) {
            const uint32_t *tri = out.indices + 3 * t;
            const bool r0 = out.texcoords[2 * tri[0]] > 1.5f;
            assert_true((out.texcoords[2 * tri[1]] > 1.5f) == r0);
            assert_true((out.texcoords[2 * tri[2]] > 1.5f) == r0);
        }
        free(origin);
        mr_mesh_free(&out);
    }
    /* the quadric's values at the survivors: the function, far more
     * closely than interpolation along the edges */
    print_message("uv RMS from the function: %.3g with the cost, %.3g without\n", err[0],
                  err[1]);
    assert_true(err[0] < 0.5 * err[1]);
    mr_mesh_free(&m);
}

/* A bumpy grid of q x q quads cut into UV tiles of t x t quads, each tile
 * its own island of the atlas (its vertices its own): every tile corner
 * is a vertex of four wedges where four islands meet, which no seam rule
 * can move, and every tile edge a seam. */
static void atlas_grid(int q, int t, mr_mesh *m)
{
    const int tiles = q / t, per = t + 1;
    const size_t nv = (size_t)tiles * tiles * per * per;
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, nv, 2 * (size_t)q * q, MR_ATTR_TEXCOORDS, NULL), MR_OK);
    uint32_t *tri = m->indices;
    for (int ty = 0; ty < tiles; ty++)
        for (int tx = 0; tx < tiles; tx++) {
            const uint32_t base = (uint32_t)((ty * tiles + tx) * per * per);
            for (int y = 0; y < per; y++)
                for (int x = 0; x < per; x++) {
                    const size_t v = base + (size_t)(y * per + x);
                    const double fx = (double)(tx * t + x) / q, fy = (double)(ty * t + y) / q;
                    m->positions[3 * v] = (float)fx;
                    m->positions[3 * v + 1] = (float)fy;
                    m->positions[3 * v + 2] = bump(fx, fy);
                    /* island (tx, ty) at its own place in the atlas */
                    m->texcoords[2 * v] = (float)((tx * per + x) / (double)(tiles * per));
                    m->texcoords[2 * v + 1] = (float)((ty * per + y) / (double)(tiles * per));
                }
            for (int y = 0; y < t; y++)
                for (int x = 0; x < t; x++) {
                    const uint32_t a = base + (uint32_t)(y * per + x), b = a + 1,
                                   c = a + (uint32_t)per, d = c + 1;
                    const uint32_t quad[6] = {a, b, d, a, d, c};
                    memcpy(tri, quad, sizeof quad);
                    tri += 6;
                }
        }
}

/* mr_mesh_simplify(m, o) gives `expected` at 1, 2, 3 and 8 threads. */
static void same_at_threads(const mr_mesh *m, const mr_simplify_options *o,
                            const mr_mesh *expected)
{
    const int threads[] = {1, 2, 3, 8};
    for (int i = 0; i < 4; i++) {
        mr_simplify_options ot = *o;
        ot.threads = threads[i];
        mr_mesh again;
        assert_int_equal(mr_mesh_simplify(m, &ot, &again, NULL, NULL, NULL), MR_OK);
        tu_assert_mesh_equal(expected, &again);
        mr_mesh_free(&again);
    }
}

/* Where the seams hold the run short of its target, the last stage frees
 * the seam vertices off the open boundary (their wedges priced by the
 * attribute quadrics) and reaches it; without weighted attributes, which
 * would price that, the seams hold. The result is the same at 1, 2, 3 and
 * 8 threads. */
static void test_atlas_release(void **state)
{
    (void)state;
    mr_mesh m;
    atlas_grid(48, 4, &m); /* 144 islands, 121 four-island corners */
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_triangles = 200;
    mr_mesh strict, out;
    mr_simplify_stats st;
    mr_simplify_options none = o;
    none.normal_weight = none.uv_weight = none.color_weight = 0;
    assert_int_equal(mr_mesh_simplify(&m, &none, &strict, NULL, &st, NULL), MR_OK);
    assert_false(st.target_reached);
    assert_true(strict.triangle_count > 250);
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, NULL), MR_OK);
    print_message("atlas grid: %zu triangles with the seams held, %zu freed (target 200)\n",
                  strict.triangle_count, out.triangle_count);
    assert_true(st.target_reached);
    assert_true(out.triangle_count <= 200);
    /* every vertex still on the square (the outline's corners may have
     * moved along it: the stage before frees the corners) */
    for (size_t v = 0; v < out.vertex_count; v++)
        for (int k = 0; k < 2; k++)
            assert_true(out.positions[3 * v + (size_t)k] >= 0 &&
                        out.positions[3 * v + (size_t)k] <= 1);
    same_at_threads(&m, &o, &out);
    /* free from the start (MR_SEAMS_FREE): the target too, the same bytes
     * at 1, 2, 3 and 8 threads, and another path than the stages' */
    mr_simplify_options of = o;
    of.seams = MR_SEAMS_FREE;
    mr_mesh freed;
    assert_int_equal(mr_mesh_simplify(&m, &of, &freed, NULL, &st, NULL), MR_OK);
    assert_true(st.target_reached);
    assert_true(freed.triangle_count <= 200);
    assert_true(freed.vertex_count != out.vertex_count ||
                memcmp(freed.positions, out.positions, 12 * out.vertex_count) != 0);
    same_at_threads(&m, &of, &freed);
    mr_mesh_free(&freed);
    /* kept (MR_SEAMS_KEEP): as without weighted attributes, short of it */
    mr_simplify_options ok = o;
    ok.seams = MR_SEAMS_KEEP;
    mr_mesh kept;
    assert_int_equal(mr_mesh_simplify(&m, &ok, &kept, NULL, &st, NULL), MR_OK);
    assert_false(st.target_reached);
    assert_true(kept.triangle_count > 250);
    mr_mesh_free(&kept);
    mr_mesh_free(&strict);
    mr_mesh_free(&out);
    mr_mesh_free(&m);
}

/* A closed surface cut into a cube-map atlas: each triangle's island is
 * the axis its normal points along most (six islands, planar UVs), its
 * corners the wedges of (vertex, island) -- seams where three islands
 * meet too. */
static void cube_atlas(mr_generator kind, size_t triangles, mr_mesh *out)
{
    mr_mesh g;
    mr_mesh_init(&g);
    assert_int_equal(mr_generate(kind, triangles, 7, &g, NULL), MR_OK);
    const size_t nv = g.vertex_count, nt = g.triangle_count;
    uint32_t *wedge = malloc(6 * nv * sizeof *wedge);
    assert_non_null(wedge);
    for (size_t i = 0; i < 6 * nv; i++)
        wedge[i] = UINT32_MAX;
    uint8_t *island = malloc(nt);
    size_t count = 0;
    for (size_t t = 0; t < nt; t++) {
        const float *a = g.positions + 3 * g.indices[3 * t], *b = g.positions + 3 * g.indices[3 * t + 1],
                    *c = g.positions + 3 * g.indices[3 * t + 2];
        double n[3], u[3], w[3];
        for (int k = 0; k < 3; k++) {
            u[k] = b[k] - a[k];
            w[k] = c[k] - a[k];
        }
        n[0] = u[1] * w[2] - u[2] * w[1];
        n[1] = u[2] * w[0] - u[0] * w[2];
        n[2] = u[0] * w[1] - u[1] * w[0];
        int axis = 0;
        for (int k = 1; k < 3; k++)
            if (fabs(n[k]) > fabs(n[axis]))
                axis = k;
        island[t] = (uint8_t)(2 * axis + (n[axis] < 0));
        for (int k = 0; k < 3; k++) {
            uint32_t *x = &wedge[6 * (size_t)g.indices[3 * t + (size_t)k] + island[t]];
            if (*x == UINT32_MAX)
                *x = (uint32_t)count++;
        }
    }
    mr_mesh_init(out);
    assert_int_equal(mr_mesh_alloc(out, count, nt, MR_ATTR_TEXCOORDS, NULL), MR_OK);
    for (size_t v = 0; v < nv; v++)
        for (int i = 0; i < 6; i++) {
            const uint32_t x = wedge[6 * v + (size_t)i];
            if (x == UINT32_MAX)
                continue;
            memcpy(out->positions + 3 * (size_t)x, g.positions + 3 * v, 12);
            /* the island's plane, placed in its cell of a 3 x 2 atlas */
            const int axis = i / 2, s = (axis + 1) % 3, r = (axis + 2) % 3;
            const float *p = g.positions + 3 * v;
            out->texcoords[2 * (size_t)x] = (float)((i % 3) + 0.5 + 0.4 * p[s] / 80.0) / 3.0f;
            out->texcoords[2 * (size_t)x + 1] = (float)((i / 3) + 0.5 + 0.4 * p[r] / 80.0) / 2.0f;
        }
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 3; k++)
            out->indices[3 * t + (size_t)k] = wedge[6 * (size_t)g.indices[3 * t + (size_t)k] + island[t]];
    free(wedge);
    free(island);
    mr_mesh_free(&g);
}

/* A closed genus-0 surface stays closed, manifold and of genus 0 through
 * the attribute path, with the seams held, freed in the last stage, or
 * free from the start. */
static void test_closed_atlas(void **state)
{
    (void)state;
    mr_mesh m;
    cube_atlas(MR_GEN_SCAN, 20000, &m);
    mr_stats in;
    assert_int_equal(mr_stats_compute(m.positions, 0, m.vertex_count, m.indices, m.triangle_count,
                                      &in, NULL),
                     MR_OK);
    assert_true(in.closed && in.manifold);
    assert_true(in.split_vertices > 0);
    const size_t targets[] = {2000, 150};
    for (int free_seams = 0; free_seams < 2; free_seams++)
        for (size_t i = 0; i < 2; i++) {
            mr_simplify_options o;
            mr_simplify_options_default(&o);
            o.target_triangles = targets[i];
            o.seams = free_seams ? MR_SEAMS_FREE : MR_SEAMS_AUTO;
            mr_mesh out;
            mr_simplify_stats st;
            assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, NULL), MR_OK);
            mr_stats s;
            assert_int_equal(mr_stats_compute(out.positions, 0, out.vertex_count, out.indices,
                                              out.triangle_count, &s, NULL),
                             MR_OK);
            print_message("cube atlas to %zu (free seams %d): %zu triangles, closed %d, "
                          "manifold %d, euler %lld\n",
                          targets[i], free_seams, out.triangle_count, s.closed, s.manifold,
                          s.euler_characteristic);
            assert_true(s.closed);
            assert_true(s.manifold);
            assert_int_equal(s.euler_characteristic, in.euler_characteristic);
            assert_true(out.triangle_count <= targets[i] + 2);
            mr_mesh_free(&out);
        }
    mr_mesh_free(&m);
}

/* The same bytes at 1, 2, 3 and 8 threads, for each deterministic
 * strategy: a grid above the 65,536 vertices and triangles from which the
 * records' build and the strategies' loops run on several threads (under
 * ThreadSanitizer too: MR_TEST_QUICK's size is above them). */
static void test_threads(void **state)
{
    (void)state;
    mr_mesh m;
    seamed_grid(getenv("MR_TEST_QUICK") ? 261 : 341, &m);
    const mr_strategy strategies[] = {MR_STRATEGY_BATCHED, MR_STRATEGY_PARTITIONED_BOUNDARY,
                                      MR_STRATEGY_PARTITIONED};
    /* the quick runs (the sanitizers') leave out the plain partitioned
     * strategy, whose slabs the boundary variant runs too */
    const size_t ns = getenv("MR_TEST_QUICK") ? 2 : 3;
    for (size_t s = 0; s < ns; s++) {
        mr_mesh first;
        const int threads[] = {1, 2, 3, 8};
        for (int i = 0; i < 4; i++) {
            mr_simplify_options o;
            mr_simplify_options_default(&o);
            o.target_ratio = 0.05;
            o.strategy = strategies[s];
            o.threads = threads[i];
            mr_mesh out;
            assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, NULL, NULL), MR_OK);
            if (i == 0) {
                first = out;
                continue;
            }
            tu_assert_mesh_equal(&first, &out);
            mr_mesh_free(&out);
        }
        mr_mesh_free(&first);
    }
    mr_mesh_free(&m);
}

static void test_bad_weights(void **state)
{
    (void)state;
    mr_mesh m;
    step_grid(&m);
    const double bad[] = {-1, NAN, INFINITY};
    for (int which = 0; which < 3; which++)
        for (int i = 0; i < 3; i++) {
            mr_simplify_options o;
            mr_simplify_options_default(&o);
            o.target_ratio = 0.5;
            double *w[3] = {&o.normal_weight, &o.uv_weight, &o.color_weight};
            *w[which] = bad[i];
            mr_mesh out;
            mr_error err;
            assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, NULL, &err),
                             MR_ERR_INVALID_ARGUMENT);
            tu_assert_contains(err.message, which == 0 ? "normal weight"
                                            : which == 1 ? "uv weight"
                                                         : "color weight");
        }
    mr_mesh_free(&m);
}

/* The CLI's --attribute-weights: parsed, and a bad one refused. */
static void test_cli(void **state)
{
    (void)state;
    mr_mesh m;
    step_grid(&m);
    const char *in = tu_tmp_path("attr-step.ply"), *out = tu_tmp_path("attr-step-out.ply");
    assert_int_equal(mr_mesh_write(in, &m, NULL, NULL), MR_OK);
    mr_mesh_free(&m);
    char *text = NULL;
    assert_int_equal(tu_run_cli(tu_fmt("simplify %s -o %s --triangles 6 --attribute-weights "
                                       "color=2,normal=0 -q",
                                       in, out),
                                &text),
                     0);
    free(text);
    mr_mesh r;
    assert_int_equal(mr_mesh_read(out, NULL, &r, NULL), MR_OK);
    assert_true(step_error(&r) < 0.02);
    mr_mesh_free(&r);
    const char *bad[] = {"color", "color=-1", "tangent=1", "uv=x", ""};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_not_equal(tu_run_cli(tu_fmt("simplify %s -o %s --triangles 6 "
                                               "--attribute-weights '%s'",
                                               in, out, bad[i]),
                                        &text),
                             0);
        tu_assert_contains(text, "--attribute-weights");
        free(text);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_colour_step),
        cmocka_unit_test(test_colour_step_everywhere),
        cmocka_unit_test(test_uv_seamed_grid),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_atlas_release),
        cmocka_unit_test(test_closed_atlas),
        cmocka_unit_test(test_bad_weights),
        cmocka_unit_test(test_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
