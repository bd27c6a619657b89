/* No silent failures: outputs that meshreduce can read back whatever the
 * input's range, a clear error for a mesh with no surface, and a word when
 * a simplification target cannot be reached. */
#include "testutil.h"

#include <sys/stat.h>

#include <float.h>
#include <stdbool.h>
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static void all_finite(const mr_mesh *m)
{
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        if (!isfinite(m->positions[i]))
            fail_msg("coordinate %zu of vertex %zu is %g", i % 3, i / 3,
                     (double)m->positions[i]);
}

/* A sphere blown up to the edge of the float range: quadric optima and
 * grid cells beyond the input's bounding box would overflow to inf. */
static void test_float_max_scale(void **state)
{
    (void)state;
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 5000, 1, &m, NULL), MR_OK);
    for (size_t i = 0; i < 3 * m.vertex_count; i++)
        m.positions[i] *= 3.4e38f;
    all_finite(&m);
    for (int kind = 0; kind < 2; kind++)
        for (int strategy = 0; strategy < 2; strategy++) {
            mr_simplify_options o;
            mr_simplify_options_default(&o);
            o.target_ratio = 0.05;
            o.collapse = (mr_collapse_kind)kind;
            o.strategy = (mr_strategy)strategy;
            mr_mesh out;
            mr_error err;
            assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, NULL, &err), MR_OK);
            all_finite(&out);
            mr_mesh_free(&out);
        }
    mr_cluster_options co;
    mr_cluster_options_default(&co);
    co.target_vertices = 100;
    mr_mesh out;
    mr_error err;
    assert_int_equal(mr_mesh_cluster(&m, &co, &out, NULL, &err), MR_OK);
    all_finite(&out);
    mr_mesh_free(&out);

    /* and through the tool: every output reads back */
    const char *in = tu_tmp_path("huge.ply"), *s = tu_tmp_path("huge-s.obj"),
               *c = tu_tmp_path("huge-c.ply");
    assert_int_equal(mr_mesh_write(in, &m, NULL, &err), MR_OK);
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 5%% -q", in, s), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", s), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt("cluster '%s' -o '%s' --target-vertices 100 -q", in, c),
                                NULL),
                     0);
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", c), NULL), 0);
    mr_mesh_free(&m);
}

/* Every triangle uses a vertex twice: no surface, a clear error and no
 * file. */
static void test_all_degenerate(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("degenerate.obj"), *out = tu_tmp_path("degenerate-s.obj");
    const char text[] = "v 1 1 1\nv 1 1 2\nv 0 0 0\nf 1 1 2\nf 2 2 1\nf 3 1 3\n";
    tu_write_file(in, text, sizeof text - 1);
    remove(out);
    char *msg;
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.5", in, out), &msg), 1);
    tu_assert_contains(msg, "degenerate.obj");
    tu_assert_contains(msg, "uses a vertex twice");
    free(msg);
    assert_false(tu_file_exists(out));

    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read(in, NULL, &m, &err), MR_OK);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 0.5;
    mr_mesh res;
    assert_int_equal(mr_mesh_simplify(&m, &o, &res, NULL, NULL, &err), MR_ERR_EMPTY);
    tu_assert_contains(err.message, "no surface to simplify");
    mr_simplified flat;
    assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices, m.triangle_count,
                                 &o, &flat, &err),
                     MR_ERR_EMPTY);
    mr_mesh_free(&m);
}

static mr_simplify_stats simplify_stats(const char *text, double ratio, int lock_border)
{
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(text, "t.obj", &m, &err), MR_OK);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = ratio;
    o.lock_border = lock_border;
    mr_mesh out;
    mr_simplify_stats st;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, &err), MR_OK);
    mr_mesh_free(&out);
    mr_mesh_free(&m);
    return st;
}

/* A closed tetrahedron whose vertices all lie on one line: every collapse
 * would leave triangles without a normal; and an open square with locked
 * borders: nothing may move. */
static const char collinear[] = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\n"
                                "f 1 2 3\nf 1 3 4\nf 2 4 3\nf 1 4 2\n";
static const char square[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
                             "f 1 2 3\nf 1 3 4\nf 2 5 6\nf 2 6 3\n";

static void test_missed_target(void **state)
{
    (void)state;
    mr_simplify_stats st = simplify_stats(collinear, 0.1, 0);
    assert_false(st.target_reached);
    assert_int_equal(st.stop, MR_STOP_REFUSED);
    assert_int_equal(st.collapses, 0);
    st = simplify_stats(square, 0.1, 1);
    assert_false(st.target_reached);
    assert_int_equal(st.stop, MR_STOP_LOCKED);
    /* the sphere reaches its target */
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 2000, 1, &m, NULL), MR_OK);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 0.1;
    mr_mesh out;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, NULL), MR_OK);
    assert_true(st.target_reached);
    assert_int_equal(st.stop, MR_STOP_TARGET);
    mr_mesh_free(&out);
    /* an error bound that stops first is a target reached */
    o.max_error = 1e-6;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, NULL), MR_OK);
    assert_true(st.target_reached);
    assert_int_equal(st.stop, MR_STOP_MAX_ERROR);
    mr_mesh_free(&out);
    mr_mesh_free(&m);

    /* the tool says so, on stderr and in JSON, and exits 0 */
    const char *in = tu_tmp_path("collinear.obj"), *res = tu_tmp_path("collinear-s.obj");
    tu_write_file(in, collinear, sizeof collinear - 1);
    char *msg;
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.1 -q", in, res), &msg),
                     0);
    tu_assert_contains(msg, "warning: ");
    tu_assert_contains(msg, "collinear.obj: target not reached");
    tu_assert_contains(msg, "refused");
    free(msg);
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.1 --json", in, res),
                                &msg),
                     0);
    tu_assert_contains(msg, "\"target_reached\": false");
    tu_assert_contains(msg, "\"stop_reason\": \"refused\"");
    free(msg);
}

/* a strip of two quads split along its middle column by a UV seam */
static const char strip[] = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n"
                                "vt 0 0\nvt 0.4 0\nvt 0.6 0\nvt 1 0\nvt 0 1\nvt 0.4 1\n"
                                "vt 0.6 1\nvt 1 1\n"
                                "f 1/1 2/2 5/6\nf 1/1 5/6 4/5\nf 2/3 3/4 6/8\nf 2/3 6/8 5/7\n";

/* A triangle that repeats a vertex has no edges: it does not undo the
 * join of a seam's copies it touches. */
static void test_degenerate_triangle_keeps_seam(void **state)
{
    (void)state;
    static const char extra[] = "f 2/2 2/2 5/6\n";
    char text[sizeof strip + sizeof extra];
    memcpy(text, strip, sizeof strip - 1);
    memcpy(text + sizeof strip - 1, extra, sizeof extra);
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(text, "strip.obj", &m, &err), MR_OK);
    uint32_t point[16];
    size_t split = 0;
    assert_true(m.vertex_count <= 16);
    assert_int_equal(mr_surface_points(m.positions, m.vertex_count, m.indices,
                                       m.triangle_count, point, &split, NULL),
                     MR_OK);
    assert_int_equal(split, 2);
    mr_mesh_free(&m);
}

/* Vertices are counted as surface points on both sides of the report: a
 * seam's copies count once in the input and in the output. */
static void test_report_counts_points(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(strip, "strip.obj", &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 8);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 1;
    mr_mesh out;
    mr_simplify_stats st;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, &err), MR_OK);
    assert_int_equal(st.input_vertices, 6);
    assert_int_equal(st.output_points, 6);
    assert_int_equal(st.output_vertices, 8);
    mr_mesh_free(&out);
    mr_mesh_free(&m);
}

/* info describes the surface: the seam is no cut; convert --no-texcoords
 * merges the copies that only the texture coordinates kept apart. */
static void test_info_and_convert_seams(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("strip.obj"), *out = tu_tmp_path("strip-nouv.obj");
    tu_write_file(in, strip, sizeof strip - 1);
    char *msg;
    assert_int_equal(tu_run_cli(tu_fmt("info --json '%s'", in), &msg), 0);
    tu_assert_contains(msg, "\"vertices\": 8");
    tu_assert_contains(msg, "\"surface_vertices\": 6, \"split_vertices\": 2");
    tu_assert_contains(msg, "\"boundary_loops\": 1");
    tu_assert_contains(msg, "\"components\": 1");
    tu_assert_contains(msg, "\"genus\": 0");
    free(msg);
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", in), &msg), 0);
    tu_assert_contains(msg, "6 surface points; 2 vertices repeat one");
    free(msg);
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' '%s' --no-texcoords -q", in, out), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt("info --json '%s'", out), &msg), 0);
    tu_assert_contains(msg, "\"vertices\": 6");
    tu_assert_contains(msg, "\"split_vertices\": 0");
    tu_assert_contains(msg, "\"texcoords\": false");
    free(msg);
    /* kept, the texture coordinates keep the split */
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' '%s' -q", in, out), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt("info --json '%s'", out), &msg), 0);
    tu_assert_contains(msg, "\"vertices\": 8");
    free(msg);
}

/* A unit sphere with five specks (spheres 1/500 its size) beside it. */
static void sphere_and_specks(mr_mesh *m)
{
    mr_mesh one;
    mr_mesh_init(&one);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 500, 1, &one, NULL), MR_OK);
    const size_t vc = one.vertex_count, tc = one.triangle_count;
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, 6 * vc, 6 * tc, 0, NULL), MR_OK);
    for (size_t p = 0; p < 6; p++) {
        const float scale = p ? 0.002f : 1.0f, shift = p ? 1.5f + 0.1f * (float)p : 0;
        for (size_t v = 0; v < vc; v++)
            for (int k = 0; k < 3; k++)
                m->positions[3 * (p * vc + v) + k] =
                    one.positions[3 * v + k] * scale + (k == 0 ? shift : 0);
        for (size_t c = 0; c < 3 * tc; c++)
            m->indices[3 * p * tc + c] = one.indices[c] + (uint32_t)(p * vc);
    }
    mr_mesh_free(&one);
}

static size_t components_of(const mr_mesh *m)
{
    mr_stats s;
    assert_int_equal(mr_stats_compute(m->positions, 0, m->vertex_count, m->indices,
                                      m->triangle_count, &s, NULL),
                     MR_OK);
    return s.components;
}

/* --prune drops the pieces no larger than the error bound; a target of 0
 * triangles goes as far as the bound allows; --lock keeps vertices. */
static void test_prune_zero_target_and_locks(void **state)
{
    (void)state;
    mr_mesh m;
    sphere_and_specks(&m);
    assert_int_equal(components_of(&m), 6);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 0.5;
    o.max_error = 0.01;
    mr_mesh out;
    mr_simplify_stats st;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, NULL), MR_OK);
    assert_int_equal(components_of(&out), 6);
    assert_int_equal(st.pruned_parts, 0);
    mr_mesh_free(&out);
    o.prune = 1;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, NULL), MR_OK);
    assert_int_equal(components_of(&out), 1);
    assert_int_equal(st.pruned_parts, 5);
    mr_mesh_free(&out);
    /* a bound below the specks' size keeps them */
    o.max_error = 1e-4;
    assert_int_equal(mr_mesh_simplify(&m, &o, &out, NULL, &st, NULL), MR_OK);
    assert_int_equal(st.pruned_parts, 0);
    mr_mesh_free(&out);

    /* --triangles 0: no count target, as far as the bound allows */
    const char *in = tu_tmp_path("specks.ply"), *res = tu_tmp_path("specks-s.ply");
    assert_int_equal(mr_mesh_write(in, &m, NULL, NULL), MR_OK);
    char *msg;
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o '%s' --triangles 0 --max-error 0.001 --json -q",
                          in, res),
                   &msg),
        0);
    tu_assert_contains(msg, "\"target_reached\": true");
    tu_assert_contains(msg, "\"stop_reason\": \"max_error\"");
    free(msg);
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o '%s' --triangles 0 --max-error 0.01 --prune --json",
                          in, res),
                   &msg),
        0);
    tu_assert_contains(msg, "\"pruned_parts\": 5");
    free(msg);

    /* --lock FILE: the listed vertices keep their place */
    const char *locks = tu_tmp_path("locks.txt");
    static const char list[] = "# the first three\n0, 1\n2 # and done\n";
    tu_write_file(locks, list, sizeof list - 1);
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.05 --lock '%s' -q", in, res, locks),
                   NULL),
        0);
    mr_mesh r;
    assert_int_equal(mr_mesh_read(res, NULL, &r, NULL), MR_OK);
    for (size_t v = 0; v < 3; v++) {
        bool found = false;
        for (size_t w = 0; w < r.vertex_count && !found; w++)
            found = !memcmp(r.positions + 3 * w, m.positions + 3 * v, 12);
        assert_true(found);
    }
    mr_mesh_free(&r);
    static const char bad[] = "0\n12x\n";
    tu_write_file(locks, bad, sizeof bad - 1);
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.05 --lock '%s'", in, res, locks),
                   &msg),
        1);
    tu_assert_contains(msg, "locks.txt:2: '12x' is no vertex index");
    free(msg);
    static const char big[] = "99999999\n";
    tu_write_file(locks, big, sizeof big - 1);
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.05 --lock '%s'", in, res, locks),
                   &msg),
        1);
    tu_assert_contains(msg, "locks.txt:1: vertex 99999999 does not exist");
    free(msg);
    mr_mesh_free(&m);
}

/* An n x n grid over the unit square, its middle column a UV seam (the
 * right half's faces use their own texture coordinates there). */
static void seamed_grid(int n, mr_mesh *m)
{
    static char text[1 << 16];
    size_t len = 0;
    const int mid = (n - 1) / 2;
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++)
            len += (size_t)snprintf(text + len, sizeof text - len, "v %g %g 0\n",
                                    (double)x / (n - 1), (double)y / (n - 1));
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++)
            len += (size_t)snprintf(text + len, sizeof text - len, "vt %g %g\n",
                                    0.45 * x / (n - 1), (double)y / (n - 1));
    for (int y = 0; y < n; y++) /* the seam's right-hand copies */
        len += (size_t)snprintf(text + len, sizeof text - len, "vt %g %g\n",
                                0.55 + 0.45 * mid / (n - 1), (double)y / (n - 1));
    for (int y = 0; y + 1 < n; y++)
        for (int x = 0; x + 1 < n; x++) {
            const int right = x >= mid;
            const int cx[4] = {x, x + 1, x + 1, x}, cy[4] = {y, y, y + 1, y + 1};
            const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
            for (int t = 0; t < 2; t++) {
                len += (size_t)snprintf(text + len, sizeof text - len, "f");
                for (int k = 0; k < 3; k++) {
                    const int px = cx[tri[t][k]], py = cy[tri[t][k]], v = py * n + px + 1;
                    const int uv = right && px == mid ? n * n + py + 1 : v;
                    len += (size_t)snprintf(text + len, sizeof text - len, " %d/%d", v, uv);
                }
                len += (size_t)snprintf(text + len, sizeof text - len, "\n");
            }
        }
    mr_error err;
    assert_int_equal(tu_read_string(text, "grid.obj", m, &err), MR_OK);
}

static bool has_position(const mr_mesh *m, float x, float y, float tolerance)
{
    for (size_t v = 0; v < m->vertex_count; v++)
        if (fabsf(m->positions[3 * v] - x) <= tolerance &&
            fabsf(m->positions[3 * v + 1] - y) <= tolerance)
            return true;
    return false;
}

/* The collapse rules: a full collapse keeps boundary and seam vertices on
 * their polylines and may take a seam vertex onto a locked one; it never
 * does worse than the half-edge collapse on these grids. */
static void test_seams_borders_locks(void **state)
{
    (void)state;
    mr_mesh g;
    seamed_grid(4, &g);
    size_t kept[2];
    for (int kind = 0; kind < 2; kind++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_triangles = 4;
        o.collapse = (mr_collapse_kind)kind;
        mr_mesh out;
        mr_simplify_stats st;
        assert_int_equal(mr_mesh_simplify(&g, &o, &out, NULL, &st, NULL), MR_OK);
        assert_true(st.target_reached);
        /* the four corners stay, and the surface stays in its plane */
        assert_true(has_position(&out, 0, 0, 1e-6f));
        assert_true(has_position(&out, 1, 0, 1e-6f));
        assert_true(has_position(&out, 0, 1, 1e-6f));
        assert_true(has_position(&out, 1, 1, 1e-6f));
        for (size_t v = 0; v < out.vertex_count; v++)
            assert_true(out.positions[3 * v + 2] == 0);
        mr_compare_result cr;
        assert_int_equal(mr_compare(g.positions, g.vertex_count, g.indices, g.triangle_count,
                                    out.positions, out.vertex_count, out.indices,
                                    out.triangle_count, NULL, &cr, NULL),
                         MR_OK);
        assert_true(cr.hausdorff < 1e-5);
        kept[kind] = out.triangle_count;
        mr_mesh_free(&out);
    }
    mr_mesh_free(&g);

    /* Locked borders: the seam's inner vertices may go onto its locked
     * ends, so full collapses get as far as half ones, and no border
     * vertex moves. */
    seamed_grid(5, &g);
    for (int kind = 0; kind < 2; kind++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_triangles = 1;
        o.lock_border = 1;
        o.collapse = (mr_collapse_kind)kind;
        mr_mesh out;
        assert_int_equal(mr_mesh_simplify(&g, &o, &out, NULL, NULL, NULL), MR_OK);
        kept[kind] = out.triangle_count;
        for (int i = 0; i < 5; i++) {
            const float f = (float)i / 4;
            assert_true(has_position(&out, f, 0, 0));
            assert_true(has_position(&out, f, 1, 0));
            assert_true(has_position(&out, 0, f, 0));
            assert_true(has_position(&out, 1, f, 0));
        }
        mr_mesh_free(&out);
    }
    assert_true(kept[MR_COLLAPSE_FULL] <= kept[MR_COLLAPSE_HALF]);
    mr_mesh_free(&g);
}

/* Outputs without an extension take --format: -o /dev/null, /dev/stdout. */
static void test_format_option(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("fmt-strip.obj");
    tu_write_file(in, strip, sizeof strip - 1);
    char *msg;
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o /dev/null --ratio 1 -q", in), &msg), 2);
    tu_assert_contains(msg, "or --format");
    free(msg);
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o /dev/null --ratio 1 --format ply -q", in), NULL), 0);
    struct stat sb;
    assert_int_equal(stat("/dev/null", &sb), 0);
    assert_true(S_ISCHR(sb.st_mode));
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' /dev/stdout --format obj -q", in), &msg), 0);
    tu_assert_contains(msg, "v 1 1 0");
    tu_assert_contains(msg, "f ");
    free(msg);
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' /dev/stdout --format jpg", in), &msg), 2);
    tu_assert_contains(msg, "--format is obj, ply, stl or xyz, got 'jpg'");
    free(msg);
}

/* A PNG that cannot be written says why, as the mesh writers do. */
static void test_png_write_reason(void **state)
{
    (void)state;
    const size_t w = 1500, h = 1500;
    uint8_t *img = malloc(w * h * 4);
    assert_non_null(img);
    for (size_t i = 0; i < w * h * 4; i++)
        img[i] = (uint8_t)(i * 2654435761u >> 24); /* incompressible */
    mr_error err;
    assert_int_equal(mr_png_write("/dev/full", img, (int)w, (int)h, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "No space left on device");
    free(img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_float_max_scale),
        cmocka_unit_test(test_all_degenerate),
        cmocka_unit_test(test_missed_target),
        cmocka_unit_test(test_report_counts_points),
        cmocka_unit_test(test_degenerate_triangle_keeps_seam),
        cmocka_unit_test(test_info_and_convert_seams),
        cmocka_unit_test(test_prune_zero_target_and_locks),
        cmocka_unit_test(test_seams_borders_locks),
        cmocka_unit_test(test_format_option),
        cmocka_unit_test(test_png_write_reason),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
