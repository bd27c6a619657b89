/* Features a user sees at once: the corners of open borders and of seams
 * stay where they are (unless the target needs them to move), in both
 * collapse modes and every strategy; --prune keeps the largest piece
 * whatever the order of the pieces. */
#include "testutil.h"

#include "qem/entry.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const int thread_counts[] = {1, 2, 3, 8};

/* ---- meshes --------------------------------------------------------------- */

/*
 * A grid of nx x ny lattice points (x = i, y = j), its cells split along
 * one diagonal, counter-clockwise seen from +z. z: a gentle wave when
 * `wavy` (so that a full collapse has a reason to move a corner off its
 * place), else 0. seam >= 0: a UV seam down column i = seam (its points
 * twice, the copy to the left of the seam and the one to the right with
 * u shifted by 0.5). notch: the cells with i >= nx / 2 and j >= ny / 2
 * are left out (an L: five convex corners and one concave).
 */
static void grid(int nx, int ny, int seam, bool wavy, bool notch, mr_mesh *m)
{
    const int extra = seam >= 0 ? ny : 0;
    const size_t vc = (size_t)(nx * ny + extra), cells = (size_t)((nx - 1) * (ny - 1));
    mr_mesh_init(m);
    mr_error err;
    assert_int_equal(mr_mesh_alloc(m, vc, 2 * cells, seam >= 0 ? MR_ATTR_TEXCOORDS : 0, &err),
                     MR_OK);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            float *p = m->positions + 3 * (size_t)(j * nx + i);
            p[0] = (float)i;
            p[1] = (float)j;
            p[2] = wavy ? (float)(0.15 * sin(1.3 * i + 0.4) * cos(0.9 * j + 0.2)) : 0.0f;
            if (seam >= 0) {
                m->texcoords[2 * (size_t)(j * nx + i)] = (float)i / (float)nx;
                m->texcoords[2 * (size_t)(j * nx + i) + 1] = (float)j / (float)ny;
            }
        }
    for (int j = 0; j < extra; j++) { /* the seam's right-hand copies */
        const size_t v = (size_t)(nx * ny + j), src = (size_t)(j * nx + seam);
        memcpy(m->positions + 3 * v, m->positions + 3 * src, 3 * sizeof(float));
        m->texcoords[2 * v] = m->texcoords[2 * src] + 0.5f;
        m->texcoords[2 * v + 1] = m->texcoords[2 * src + 1];
    }
    size_t t = 0;
    for (int j = 0; j + 1 < ny; j++)
        for (int i = 0; i + 1 < nx; i++) {
            if (notch && i >= nx / 2 && j >= ny / 2)
                continue;
            uint32_t c[4][2] = {{(uint32_t)i, (uint32_t)j},
                                {(uint32_t)i + 1, (uint32_t)j},
                                {(uint32_t)i + 1, (uint32_t)j + 1},
                                {(uint32_t)i, (uint32_t)j + 1}};
            uint32_t id[4];
            for (int k = 0; k < 4; k++) {
                const uint32_t ci = c[k][0], cj = c[k][1];
                /* a cell right of the seam takes the right-hand copies */
                id[k] = seam >= 0 && (int)ci == seam && i >= seam ? (uint32_t)(nx * ny) + cj
                                                                  : cj * (uint32_t)nx + ci;
            }
            uint32_t *tri = m->indices + 3 * t;
            tri[0] = id[0], tri[1] = id[1], tri[2] = id[2];
            tri[3] = id[0], tri[4] = id[2], tri[5] = id[3];
            t += 2;
        }
    m->triangle_count = t;
}

/* meshoptimizer's simplifySeam case, rebuilt by hand as an OBJ: a grid of
 * 4 x 4 points with a UV seam along y = 1 and two raised points. */
static const char seam_case_obj[] = "v 0 0 0\nv 0 1 0\nv 0 2 0\n"
                                    "v 1 0 0\nv 1 1 0.3\nv 1 2 0\n"
                                    "v 2 0 0\nv 2 1 0.1\nv 2 2 0\n"
                                    "v 3 0 0\nv 3 1 0\nv 3 2 0\n"
                                    "vt 0 0\nvt 1 0\n"
                                    "f 1/1 2/1 4/1\nf 4/1 2/1 5/1\n"
                                    "f 2/2 3/2 5/2\nf 5/2 3/2 6/2\n"
                                    "f 4/1 5/1 7/1\nf 7/1 5/1 8/1\n"
                                    "f 5/2 6/2 8/2\nf 8/2 6/2 9/2\n"
                                    "f 7/1 8/1 10/1\nf 10/1 8/1 11/1\n"
                                    "f 8/2 9/2 11/2\nf 11/2 9/2 12/2\n";

/* ---- checks --------------------------------------------------------------- */

/* The output holds a vertex exactly at p. */
static bool has_point(const mr_mesh *m, const float p[3])
{
    for (size_t v = 0; v < m->vertex_count; v++)
        if (!memcmp(m->positions + 3 * v, p, 3 * sizeof(float)))
            return true;
    return false;
}

static void assert_points_kept(const mr_mesh *out, const float (*pts)[3], int n,
                               const char *what)
{
    for (int i = 0; i < n; i++)
        if (!has_point(out, pts[i]))
            fail_msg("%s: the corner (%g, %g, %g) moved", what, pts[i][0], pts[i][1], pts[i][2]);
}

typedef struct strategy_case {
    mr_strategy strategy;
    mr_collapse_kind collapse;
    bool deterministic;
    const char *name;
} strategy_case;

static const strategy_case cases[] = {
    {MR_STRATEGY_BATCHED, MR_COLLAPSE_FULL, true, "batched full"},
    {MR_STRATEGY_BATCHED, MR_COLLAPSE_HALF, true, "batched half"},
    {MR_STRATEGY_GREEDY, MR_COLLAPSE_FULL, true, "greedy full"},
    {MR_STRATEGY_GREEDY, MR_COLLAPSE_HALF, true, "greedy half"},
    {MR_STRATEGY_PARTITIONED, MR_COLLAPSE_FULL, true, "partitioned full"},
    {MR_STRATEGY_PARTITIONED_BOUNDARY, MR_COLLAPSE_HALF, true, "partitioned-boundary half"},
    {MR_STRATEGY_PPQ, MR_COLLAPSE_HALF, false, "ppq"},
    {MR_STRATEGY_FPPQ, MR_COLLAPSE_HALF, false, "fppq"},
    {MR_STRATEGY_MULTIQUEUE, MR_COLLAPSE_HALF, false, "multiqueue"},
};
#define NCASES (sizeof cases / sizeof *cases)

static void simplify_mesh(const mr_mesh *in, const mr_simplify_options *o, mr_mesh *out,
                          mr_simplify_stats *stats)
{
    mr_error err;
    if (mr_mesh_simplify(in, o, out, NULL, stats, &err) != MR_OK)
        fail_msg("simplify: %s", err.message);
}

/*
 * Every strategy, both collapse modes, 1/2/3/8 threads: to `triangles`
 * under a generous error bound, every one of pts stays exactly where it
 * was, and the deterministic strategies give the same mesh at every
 * thread count.
 */
static void check_corners_kept(const mr_mesh *in, size_t triangles, double bound,
                               const float (*pts)[3], int n, const char *what)
{
    for (size_t c = 0; c < NCASES; c++) {
        mr_mesh first;
        mr_mesh_init(&first);
        for (size_t ti = 0; ti < sizeof thread_counts / sizeof *thread_counts; ti++) {
            mr_simplify_options o;
            mr_simplify_options_default(&o);
            o.target_triangles = triangles;
            o.max_error = bound;
            o.error_absolute = 1;
            o.strategy = cases[c].strategy;
            o.collapse = cases[c].collapse;
            o.threads = thread_counts[ti];
            mr_mesh out;
            mr_simplify_stats st;
            simplify_mesh(in, &o, &out, &st);
            char label[160];
            snprintf(label, sizeof label, "%s, %s, %d threads", what, cases[c].name,
                     thread_counts[ti]);
            if (out.triangle_count != triangles)
                fail_msg("%s: %zu triangles, not %zu", label, out.triangle_count, triangles);
            assert_points_kept(&out, pts, n, label);
            if (!cases[c].deterministic || ti == 0) {
                if (ti == 0)
                    first = out;
                else
                    mr_mesh_free(&out);
                continue;
            }
            tu_assert_mesh_equal(&first, &out);
            mr_mesh_free(&out);
        }
        mr_mesh_free(&first);
    }
}

/* ---- corners -------------------------------------------------------------- */

/* meshoptimizer's seam case to 4 triangles, within 3 units: the grid's four
 * corners stay (the full collapse slid two of them along the border, to
 * x = 0.076 and x = 0.029). */
static void test_seam_case_keeps_corners(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(seam_case_obj, "seam.obj", &m, &err), MR_OK);
    static const float corners[4][3] = {{0, 0, 0}, {0, 2, 0}, {3, 0, 0}, {3, 2, 0}};
    check_corners_kept(&m, 4, 3.0, corners, 4, "seam case");
    mr_mesh_free(&m);
}

/* A wavy 9 x 6 grid with a UV seam down column 4, to 4 triangles: its four
 * corners stay, and so do the seam's two ends on the border. */
static void test_seamed_grid_keeps_corners(void **state)
{
    (void)state;
    mr_mesh m;
    grid(9, 6, 4, true, false, &m);
    float pts[6][3];
    const int at[6] = {0, 8, 5 * 9, 5 * 9 + 8, 4, 5 * 9 + 4};
    for (int i = 0; i < 6; i++)
        memcpy(pts[i], m.positions + 3 * (size_t)at[i], sizeof pts[i]);
    check_corners_kept(&m, 4, 10.0, pts, 6, "seamed 9 x 6 grid");
    mr_mesh_free(&m);
}

/* A wavy grid without seams, through the flat-array call: to 2 triangles,
 * the four corners. */
static void test_open_grid_keeps_corners(void **state)
{
    (void)state;
    mr_mesh m;
    grid(7, 5, -1, true, false, &m);
    float pts[4][3];
    const int at[4] = {0, 6, 4 * 7, 4 * 7 + 6};
    for (int i = 0; i < 4; i++)
        memcpy(pts[i], m.positions + 3 * (size_t)at[i], sizeof pts[i]);
    for (int half = 0; half < 2; half++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_triangles = 2;
        o.collapse = half ? MR_COLLAPSE_HALF : MR_COLLAPSE_FULL;
        mr_simplified r;
        mr_error err;
        assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices,
                                     m.triangle_count, &o, &r, &err),
                         MR_OK);
        assert_int_equal(r.triangle_count, 2);
        mr_mesh out = {.vertex_count = r.vertex_count, .triangle_count = r.triangle_count,
                       .positions = r.positions, .indices = r.indices};
        assert_points_kept(&out, pts, 4, half ? "open grid, half" : "open grid, full");
        mr_simplified_free(&r);
    }
    mr_mesh_free(&m);
}

/* A seam that turns inside the surface: on a wavy 9 x 9 grid the wedges
 * left of column 4 below row 4, and those below row 4 left of column 4,
 * differ from the rest -- an L of seam from the bottom border up to
 * (4, 4) and across to the left border. Reduced to 12 vertices, the turn
 * at (4, 4) stays. */
static void test_seam_turn_is_kept(void **state)
{
    (void)state;
    mr_mesh base;
    grid(9, 9, -1, true, false, &base);
    /* split the lower left block's wedges off: each cell with i < 4 and
     * j < 4 gets its own copies of its corners on the block's edge */
    const size_t nv = base.vertex_count, nt = base.triangle_count;
    mr_mesh m;
    mr_mesh_init(&m);
    mr_error err;
    assert_int_equal(mr_mesh_alloc(&m, 2 * nv, nt, MR_ATTR_TEXCOORDS, &err), MR_OK);
    memcpy(m.positions, base.positions, nv * 12);
    memcpy(m.positions + 3 * nv, base.positions, nv * 12);
    for (size_t v = 0; v < nv; v++) {
        m.texcoords[2 * v] = base.positions[3 * v] / 8;
        m.texcoords[2 * v + 1] = base.positions[3 * v + 1] / 8;
        m.texcoords[2 * (nv + v)] = base.positions[3 * v] / 8 + 0.5f;
        m.texcoords[2 * (nv + v) + 1] = base.positions[3 * v + 1] / 8;
    }
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *tri = base.indices + 3 * t;
        float cx = 0, cy = 0;
        for (int k = 0; k < 3; k++) {
            cx += base.positions[3 * tri[k]] / 3;
            cy += base.positions[3 * tri[k] + 1] / 3;
        }
        const bool inside = cx < 4 && cy < 4;
        for (int k = 0; k < 3; k++)
            m.indices[3 * t + k] = tri[k] + (inside ? (uint32_t)nv : 0);
    }
    m.triangle_count = nt;
    float turn[1][3];
    memcpy(turn[0], base.positions + 3 * (4 * 9 + 4), sizeof turn[0]);
    for (int half = 0; half < 2; half++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_vertices = 12; /* the grid's 4 corners, the seam's 2 ends and its turn: 7 */
        o.collapse = half ? MR_COLLAPSE_HALF : MR_COLLAPSE_FULL;
        mr_mesh out;
        simplify_mesh(&m, &o, &out, NULL);
        assert_points_kept(&out, turn, 1, half ? "seam turn, half" : "seam turn, full");
        mr_mesh_free(&out);
    }
    mr_mesh_free(&m);
    mr_mesh_free(&base);
}

/* Where the target needs a corner to move, it moves: an L of cells (six
 * corners, one of them concave) reaches 2 triangles (a quad), in every
 * strategy; under a tight error bound the corners stay instead. */
static void test_corners_move_when_needed(void **state)
{
    (void)state;
    mr_mesh m;
    grid(9, 9, -1, false, true, &m);
    for (size_t c = 0; c < NCASES; c++)
        for (int ti = 0; ti < 2; ti++) {
            mr_simplify_options o;
            mr_simplify_options_default(&o);
            o.target_triangles = 2;
            o.strategy = cases[c].strategy;
            o.collapse = cases[c].collapse;
            o.threads = thread_counts[ti];
            mr_mesh out;
            mr_simplify_stats st;
            simplify_mesh(&m, &o, &out, &st);
            if (out.triangle_count != 2 || !st.target_reached)
                fail_msg("L, %s: %zu triangles (target 2)", cases[c].name, out.triangle_count);
            mr_mesh_free(&out);
        }
    /* a bound no corner's move fits: the six corners stay */
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_triangles = 2;
    o.max_error = 0.01;
    o.error_absolute = 1;
    mr_mesh out;
    mr_simplify_stats st;
    simplify_mesh(&m, &o, &out, &st);
    static const float six[6][3] = {{0, 0, 0}, {8, 0, 0}, {8, 4, 0},
                                    {4, 4, 0}, {4, 8, 0}, {0, 8, 0}};
    assert_points_kept(&out, six, 6, "L under a tight bound");
    assert_int_equal(out.triangle_count, 4);
    mr_mesh_free(&out);
    mr_mesh_free(&m);
}

/* Corners of the input, as mr_simplifier_init finds them. */
static size_t corners_of(const mr_mesh *m)
{
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 0.5;
    mr_simplifier s;
    mr_error err;
    assert_int_equal(mr_simplify_setup(&s, m->positions, 0, m->vertex_count, m->indices,
                                        m->triangle_count, &o, NULL, &err),
                     MR_OK);
    const size_t n = s.corners;
    mr_simplifier_free(&s);
    return n;
}

/* A disk: a fan of n triangles around its centre, the rim at radius
 * 1 + jag * (-1)^i (a ragged rim when jag > 0). */
static void disk(int n, double jag, mr_mesh *m)
{
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, (size_t)n + 1, (size_t)n, 0, NULL), MR_OK);
    m->positions[0] = m->positions[1] = m->positions[2] = 0;
    for (int i = 0; i < n; i++) {
        const double a = 2 * 3.14159265358979323846 * i / n, r = 1 + jag * (i % 2 ? 1 : -1);
        float *p = m->positions + 3 * (size_t)(i + 1);
        p[0] = (float)(r * cos(a));
        p[1] = (float)(r * sin(a));
        p[2] = 0;
        uint32_t *tri = m->indices + 3 * (size_t)i;
        tri[0] = 0;
        tri[1] = (uint32_t)i + 1;
        tri[2] = (uint32_t)((i + 1) % n) + 1;
    }
}

/* What is a corner: a grid's four, an L's six, a strip one cell wide its
 * four (two pairs of corners one edge apart); a round rim, a ragged rim
 * and a staircase none. */
static void test_corner_detection(void **state)
{
    (void)state;
    mr_mesh m;
    grid(6, 5, -1, false, false, &m);
    assert_int_equal(corners_of(&m), 4);
    mr_mesh_free(&m);
    grid(9, 9, -1, false, true, &m);
    assert_int_equal(corners_of(&m), 6);
    mr_mesh_free(&m);
    grid(12, 2, -1, false, false, &m);
    assert_int_equal(corners_of(&m), 4);
    mr_mesh_free(&m);
    disk(48, 0, &m);
    assert_int_equal(corners_of(&m), 0);
    mr_mesh_free(&m);
    disk(64, 0.08, &m);
    assert_int_equal(corners_of(&m), 0);
    mr_mesh_free(&m);
    /* a staircase: the cells (i, j) with i + j < 10 of a 10 x 10 grid; its
     * long edge turns at every vertex, back and forth */
    grid(11, 11, -1, false, false, &m);
    size_t t = 0;
    for (size_t k = 0; k < m.triangle_count; k++) {
        const uint32_t a = m.indices[3 * k];
        const uint32_t i = a % 11, j = a / 11;
        if (i + j < 9) {
            memmove(m.indices + 3 * t, m.indices + 3 * k, 12);
            t++;
        }
    }
    m.triangle_count = t;
    /* the right angle at the origin alone: the stairs turn back and forth
     * at every vertex, up to their ends where they meet the straight sides */
    assert_int_equal(corners_of(&m), 1);
    mr_mesh_free(&m);
}

/* ---- prune ---------------------------------------------------------------- */

/* meshoptimizer's simplifyPruneCleanup case: three single triangles of
 * sizes 1, 2 and 4, pruned within the whole diagonal to 1 triangle. In
 * each of the six orders of the pieces (in the vertex and the triangle
 * lists) the largest stays, and the target counts as reached. */
static void test_prune_keeps_largest_in_any_order(void **state)
{
    (void)state;
    static const float piece[3][9] = {{0, 0, 0, 0, 1, 0, 1, 0, 0},
                                      {0, 0, 1, 0, 2, 1, 2, 0, 1},
                                      {0, 0, 2, 0, 4, 2, 4, 0, 2}};
    static const int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                     {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int k = 0; k < 6; k++)
        for (int ti = 0; ti < 4; ti++) {
            float pos[27];
            uint32_t idx[9];
            for (int i = 0; i < 3; i++) {
                memcpy(pos + 9 * i, piece[orders[k][i]], sizeof piece[0]);
                for (int c = 0; c < 3; c++)
                    idx[3 * i + c] = (uint32_t)(3 * i + c);
            }
            mr_simplify_options o;
            mr_simplify_options_default(&o);
            o.target_triangles = 1;
            o.max_error = 1;
            o.prune = 1;
            o.threads = thread_counts[ti];
            mr_simplified r;
            mr_error err;
            assert_int_equal(mr_simplify(pos, 0, 9, idx, 3, &o, &r, &err), MR_OK);
            assert_int_equal(r.triangle_count, 1);
            assert_int_equal(r.stats.pruned_parts, 2);
            assert_true(r.stats.target_reached);
            assert_int_equal(r.stats.stop, MR_STOP_TARGET);
            mr_mesh out = {.vertex_count = r.vertex_count, .triangle_count = r.triangle_count,
                           .positions = r.positions, .indices = r.indices};
            const float (*big)[3] = (const float (*)[3])piece[2];
            assert_points_kept(&out, big, 3, "pruned pieces");
            mr_simplified_free(&r);
        }
}

/* The same through the CLI: the file's pieces in reverse order too, and no
 * "target not reached" warning. */
static void test_prune_cli(void **state)
{
    (void)state;
    const char *fwd = "v 0 0 0\nv 0 1 0\nv 1 0 0\nv 0 0 1\nv 0 2 1\nv 2 0 1\n"
                      "v 0 0 2\nv 0 4 2\nv 4 0 2\nf 1 2 3\nf 4 5 6\nf 7 8 9\n";
    const char *rev = "v 0 0 2\nv 0 4 2\nv 4 0 2\nv 0 0 1\nv 0 2 1\nv 2 0 1\n"
                      "v 0 0 0\nv 0 1 0\nv 1 0 0\nf 1 2 3\nf 4 5 6\nf 7 8 9\n";
    const char *texts[2] = {fwd, rev};
    for (int k = 0; k < 2; k++) {
        const char *in = tu_tmp_path(k ? "prune_rev.obj" : "prune_fwd.obj");
        tu_write_file(in, texts[k], strlen(texts[k]));
        char out_path[1024];
        snprintf(out_path, sizeof out_path, "%s", tu_tmp_path("prune_out.obj"));
        char *out = NULL;
        const int rc = tu_run_cli(
            tu_fmt("simplify %s -o %s --triangles 1 --prune --max-error 1", in, out_path), &out);
        assert_int_equal(rc, 0);
        if (strstr(out, "not reached"))
            fail_msg("a reached target reported as missed: %s", out);
        free(out);
        mr_mesh m;
        mr_error err;
        assert_int_equal(mr_mesh_read(out_path, NULL, &m, &err), MR_OK);
        assert_int_equal(m.triangle_count, 1);
        static const float big[3][3] = {{0, 0, 2}, {0, 4, 2}, {4, 0, 2}};
        assert_points_kept(&m, big, 3, "pruned file");
        mr_mesh_free(&m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_seam_case_keeps_corners),
        cmocka_unit_test(test_seamed_grid_keeps_corners),
        cmocka_unit_test(test_open_grid_keeps_corners),
        cmocka_unit_test(test_seam_turn_is_kept),
        cmocka_unit_test(test_corners_move_when_needed),
        cmocka_unit_test(test_corner_detection),
        cmocka_unit_test(test_prune_keeps_largest_in_any_order),
        cmocka_unit_test(test_prune_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
