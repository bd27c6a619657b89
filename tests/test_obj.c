/* The Wavefront OBJ reader and writer. */
#include "testutil.h"
#include "io/io_internal.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* Helpers                                                                  */
/* ------------------------------------------------------------------------ */

/* Read `text` as "x.obj"; fail the test (printing the message) on error. */
static void read_ok(const char *text, mr_mesh *m)
{
    mr_error err;
    mr_status st = tu_read_string(text, "x.obj", m, &err);
    if (st != MR_OK) {
        print_error("unexpected error: %s\n", err.message);
        fail();
    }
}

/* Read `size` bytes with an explicit thread count through the reader. */
static mr_status read_threads(const char *data, size_t size, int threads, mr_mesh *m,
                              mr_error *err)
{
    mr_mesh_init(m);
    mr_error_clear(err);
    mr_status st = mr_read_obj(data, size, "gen.obj", threads, m, err);
    if (st != MR_OK)
        mr_mesh_free(m);
    return st;
}

/* Read `text` as "x.obj", expecting `status` and a message containing
 * `message` (which includes the "x.obj:LINE:" prefix) on line `line`. */
static void expect_error(const char *text, mr_status status, uint64_t line, const char *message)
{
    mr_mesh m;
    mr_error err;
    mr_status st = tu_read_string(text, "x.obj", &m, &err);
    if (st != status) {
        print_error("input:\n%s\nexpected status %d, got %d (%s)\n", text, (int)status,
                    (int)st, err.message);
        fail();
    }
    tu_assert_contains(err.message, message);
    assert_int_equal(err.status, status);
    assert_int_equal(err.line, line);
    /* the dispatcher leaves the mesh empty on failure */
    assert_int_equal(m.vertex_count, 0);
    assert_null(m.positions);
}

static void assert_tri(const mr_mesh *m, size_t t, uint32_t a, uint32_t b, uint32_t c)
{
    assert_true(t < m->triangle_count);
    if (m->indices[3 * t] != a || m->indices[3 * t + 1] != b || m->indices[3 * t + 2] != c) {
        print_error("triangle %zu is (%u %u %u), expected (%u %u %u)\n", t, m->indices[3 * t],
                    m->indices[3 * t + 1], m->indices[3 * t + 2], a, b, c);
        fail();
    }
}

static void assert_vec(const float *got, const float *want, int n)
{
    for (int i = 0; i < n; i++)
        if (got[i] != want[i]) {
            print_error("component %d is %.9g, expected %.9g\n", i, (double)got[i],
                        (double)want[i]);
            fail();
        }
}

/* A growable text buffer for generated files. */
typedef struct textbuf {
    char *s;
    size_t len, cap;
} textbuf;

static void add(textbuf *t, const char *fmt, ...)
{
    va_list ap;
    for (;;) {
        va_start(ap, fmt);
        int n = vsnprintf(t->s ? t->s + t->len : NULL, t->s ? t->cap - t->len : 0, fmt, ap);
        va_end(ap);
        assert_true(n >= 0);
        if (t->s && t->len + (size_t)n < t->cap) {
            t->len += (size_t)n;
            return;
        }
        t->cap = (t->cap + (size_t)n + 1) * 2;
        t->s = realloc(t->s, t->cap);
        assert_non_null(t->s);
    }
}

static uint32_t rng_next(uint32_t *x)
{
    *x ^= *x << 13;
    *x ^= *x >> 17;
    *x ^= *x << 5;
    return *x;
}

/* A random finite float from random bits (any magnitude, subnormals, -0). */
static float random_float(uint32_t *x)
{
    for (;;) {
        uint32_t b = rng_next(x);
        float f;
        memcpy(&f, &b, sizeof f);
        if (isfinite(f))
            return f;
    }
}

/* A random float in [0, 1]. */
static float random_unit(uint32_t *x) { return (float)(rng_next(x) >> 8) / (float)(1u << 24); }

/* ------------------------------------------------------------------------ */
/* Index forms                                                              */
/* ------------------------------------------------------------------------ */

static const char *const tri_v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

static void test_form_v(void **state)
{
    (void)state;
    mr_mesh m;
    read_ok("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", &m);
    assert_int_equal(m.vertex_count, 3);
    assert_int_equal(m.triangle_count, 1);
    assert_tri(&m, 0, 0, 1, 2);
    const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    assert_vec(m.positions, p, 9);
    assert_null(m.normals);
    assert_null(m.texcoords);
    assert_null(m.colors);
    mr_mesh_free(&m);
}

static void test_form_v_vt(void **state)
{
    (void)state;
    char buf[256];
    snprintf(buf, sizeof buf, "%svt 0 0\nvt 1 0\nvt 0 1 0.5\nf 1/1 2/2 3/3\n", tri_v);
    mr_mesh m;
    read_ok(buf, &m);
    assert_int_equal(m.vertex_count, 3);
    assert_tri(&m, 0, 0, 1, 2);
    assert_non_null(m.texcoords);
    assert_null(m.normals);
    const float uv[6] = {0, 0, 1, 0, 0, 1};
    assert_vec(m.texcoords, uv, 6);
    mr_mesh_free(&m);
}

static void test_form_v_vn(void **state)
{
    (void)state;
    char buf[256];
    snprintf(buf, sizeof buf, "%svn 0 0 1\nvn 0 1 0\nf 1//1 2//1 3//2\n", tri_v);
    mr_mesh m;
    read_ok(buf, &m);
    assert_int_equal(m.vertex_count, 3);
    assert_null(m.texcoords);
    assert_non_null(m.normals);
    const float n[9] = {0, 0, 1, 0, 0, 1, 0, 1, 0};
    assert_vec(m.normals, n, 9);
    mr_mesh_free(&m);
}

static void test_form_v_vt_vn(void **state)
{
    (void)state;
    char buf[256];
    snprintf(buf, sizeof buf, "%svt 0.25 0.75\nvn 1 0 0\nf 1/1/1 2/1/1 3/1/1\n", tri_v);
    mr_mesh m;
    read_ok(buf, &m);
    assert_int_equal(m.vertex_count, 3);
    assert_non_null(m.texcoords);
    assert_non_null(m.normals);
    for (int i = 0; i < 3; i++) {
        const float uv[2] = {0.25f, 0.75f}, n[3] = {1, 0, 0};
        assert_vec(m.texcoords + 2 * i, uv, 2);
        assert_vec(m.normals + 3 * i, n, 3);
    }
    mr_mesh_free(&m);
}

static void test_vt_lines_unused(void **state)
{
    (void)state;
    /* vt and vn lines that no face uses leave the attributes out */
    char buf[256];
    snprintf(buf, sizeof buf, "%svt 0 0\nvn 0 0 1\nf 1 2 3\n", tri_v);
    mr_mesh m;
    read_ok(buf, &m);
    assert_null(m.texcoords);
    assert_null(m.normals);
    mr_mesh_free(&m);
}

static void test_negative_indices(void **state)
{
    (void)state;
    mr_mesh m;
    /* relative to the vertices defined so far, not to the whole file */
    read_ok("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 1 1 0\nf -3 -1 -2\n"
            "vt 0 0\nvt 1 1\nvn 0 0 1\nf -4/-2/-1 -3/-1/-1 -1/-2/-1\n",
            &m);
    assert_int_equal(m.triangle_count, 3);
    assert_tri(&m, 0, 0, 1, 2);
    assert_tri(&m, 1, 1, 3, 2);
    /* vertex 0 was first used without vt/vn: the corner with them is a
     * new vertex; 1 likewise; 3 likewise */
    assert_int_equal(m.vertex_count, 7);
    assert_tri(&m, 2, 4, 5, 6);
    const float uv[6] = {0, 0, 1, 1, 0, 0};
    assert_vec(m.texcoords + 8, uv, 6);
    mr_mesh_free(&m);
}

static void test_forward_reference(void **state)
{
    (void)state;
    /* positive indices may refer to v lines further down */
    mr_mesh m;
    read_ok("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", &m);
    assert_int_equal(m.vertex_count, 3);
    assert_tri(&m, 0, 0, 1, 2);
    mr_mesh_free(&m);
}

/* ------------------------------------------------------------------------ */
/* Polygons, syntax variants                                                */
/* ------------------------------------------------------------------------ */

static void test_polygons(void **state)
{
    (void)state;
    mr_mesh m;
    read_ok("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 1 0\nv -1 0 0\n"
            "f 1 2 3 4\n"
            "f 1 2 3 4 5 6\n",
            &m);
    assert_int_equal(m.triangle_count, 2 + 4);
    assert_tri(&m, 0, 0, 1, 2);
    assert_tri(&m, 1, 0, 2, 3);
    assert_tri(&m, 2, 0, 1, 2);
    assert_tri(&m, 3, 0, 2, 3);
    assert_tri(&m, 4, 0, 3, 4);
    assert_tri(&m, 5, 0, 4, 5);
    mr_mesh_free(&m);
}

static void test_comments_crlf_keywords(void **state)
{
    (void)state;
    const char *text = "# a comment\r\n"
                       "mtllib scene.mtl\r\n"
                       "o thing\r\n"
                       "\r\n"
                       "   \t \r\n"
                       "g group_1\r\n"
                       "usemtl red\r\n"
                       "s off\r\n"
                       "v 0 0 0 # trailing comment\r\n"
                       "  v\t1 0 0\r\n"
                       "v 0 1 0#tight comment\r\n"
                       "vp 0.5 0.5\r\n"
                       "cstype bspline\r\n"
                       "l 1 2\r\n"
                       "p 1\r\n"
                       "f 1 2 3 # trailing\r\n"
                       "f 3 2 1#x"; /* no final newline */
    mr_mesh m;
    read_ok(text, &m);
    assert_int_equal(m.vertex_count, 3);
    assert_int_equal(m.triangle_count, 2);
    assert_tri(&m, 1, 2, 1, 0);
    const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    assert_vec(m.positions, p, 9);
    mr_mesh_free(&m);
}

static void test_byte_order_mark(void **state)
{
    (void)state;
    mr_mesh m;
    read_ok("\xEF\xBB\xBFv 1 2 3\nv 4 5 6\nv 7 8 9\nf 1 2 3\n", &m);
    assert_int_equal(m.vertex_count, 3);
    assert_true(m.positions[0] == 1.0f);
    mr_mesh_free(&m);
}

static void test_vertex_w_and_numbers(void **state)
{
    (void)state;
    mr_mesh m;
    /* "v x y z w": the weight is accepted and dropped */
    read_ok("v 1.5e1 -2.25 +3 1\nv .5 5. -0\nv 1E-3 2e+2 0.000001\n", &m);
    const float p[9] = {15, -2.25f, 3, 0.5f, 5, -0.0f, 1e-3f, 200, 1e-6f};
    assert_vec(m.positions, p, 9);
    assert_true(signbit(m.positions[5]));
    mr_mesh_free(&m);
}

static void test_point_cloud(void **state)
{
    (void)state;
    mr_mesh m;
    read_ok("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n", &m);
    assert_int_equal(m.vertex_count, 4);
    assert_int_equal(m.triangle_count, 0);
    assert_null(m.normals);
    mr_mesh_free(&m);

    /* vn lines matching the v lines one to one are the points' normals */
    read_ok("v 0 0 0\nv 1 0 0\nvn 0 0 1\nvn 0 1 0\n", &m);
    assert_int_equal(m.triangle_count, 0);
    assert_non_null(m.normals);
    const float n[6] = {0, 0, 1, 0, 1, 0};
    assert_vec(m.normals, n, 6);
    mr_mesh_free(&m);

    /* ... but not when the counts differ */
    read_ok("v 0 0 0\nv 1 0 0\nvn 0 0 1\n", &m);
    assert_null(m.normals);
    mr_mesh_free(&m);
}

static void test_unreferenced_kept(void **state)
{
    (void)state;
    mr_mesh m;
    read_ok("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 8 8 8\nf 2 3 4\n", &m);
    assert_int_equal(m.vertex_count, 5);
    assert_tri(&m, 0, 1, 2, 3);
    assert_true(m.positions[0] == 9.0f && m.positions[12] == 8.0f);
    mr_mesh_free(&m);
}

/* ------------------------------------------------------------------------ */
/* Seams and colors                                                         */
/* ------------------------------------------------------------------------ */

static void test_seams(void **state)
{
    (void)state;
    const char *text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\n"
                       "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\n"
                       "f 1/1 2/2 3/3\n"
                       "f 1/5 3/3 4/4\n" /* v1 with another vt: a new vertex */
                       "f 2 3/3 4/4\n"   /* v2 without vt: new, at (0, 0) */
                       "f 1/5 2/2 4/4\n"; /* reuses the duplicate of v1 */
    mr_mesh m;
    read_ok(text, &m);
    assert_int_equal(m.vertex_count, 7);
    assert_int_equal(m.triangle_count, 4);
    assert_tri(&m, 0, 0, 1, 2);
    assert_tri(&m, 1, 5, 2, 3);
    assert_tri(&m, 2, 6, 2, 3);
    assert_tri(&m, 3, 5, 1, 3);
    const float pos[21] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 5, 5, 5, 0, 0, 0, 1, 0, 0};
    assert_vec(m.positions, pos, 21);
    /* the unreferenced v (index 4) keeps its slot with texcoord 0 0 */
    const float uv[14] = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 0.5f, 0.5f, 0, 0};
    assert_vec(m.texcoords, uv, 14);
    assert_null(m.normals);
    mr_mesh_free(&m);
}

static void test_seams_normals(void **state)
{
    (void)state;
    /* a hard edge: one position, two normals */
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                       "vn 0 0 1\nvn 1 0 0\n"
                       "f 1//1 2//1 3//1\n"
                       "f 1//2 3//2 4//2\n";
    mr_mesh m;
    read_ok(text, &m);
    assert_int_equal(m.vertex_count, 6);
    assert_tri(&m, 0, 0, 1, 2);
    assert_tri(&m, 1, 4, 5, 3);
    const float n[18] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 1, 0, 0};
    assert_vec(m.normals, n, 18);
    mr_mesh_free(&m);
}

static void test_colors(void **state)
{
    (void)state;
    mr_mesh m;
    read_ok("v 0 0 0 1 0 0\nv 1 0 0 0 0.5 0\nv 0 1 0 0 0 1\nf 1 2 3\n", &m);
    assert_non_null(m.colors);
    const float c[12] = {1, 0, 0, 1, 0, 0.5f, 0, 1, 0, 0, 1, 1};
    assert_vec(m.colors, c, 12);
    mr_mesh_free(&m);

    /* the first v has no color: the colors show up later (a second parse);
     * a vertex without a color among colored ones is white */
    read_ok("v 0 0 0\nv 1 0 0 0.25 0.5 0.75\nv 0 1 0\n", &m);
    assert_non_null(m.colors);
    const float c2[12] = {1, 1, 1, 1, 0.25f, 0.5f, 0.75f, 1, 1, 1, 1, 1};
    assert_vec(m.colors, c2, 12);
    mr_mesh_free(&m);

    /* colors and seams: the duplicate keeps the color */
    read_ok("v 0 0 0 0 1 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 1\n"
            "f 1/1 2/1 3/1\nf 1/2 3/1 2/1\n",
            &m);
    assert_int_equal(m.vertex_count, 4);
    const float c3[4] = {0, 1, 0, 1};
    assert_vec(m.colors + 12, c3, 4);
    mr_mesh_free(&m);
}

/* ------------------------------------------------------------------------ */
/* Errors                                                                   */
/* ------------------------------------------------------------------------ */

static void test_errors_faces(void **state)
{
    (void)state;
    char buf[512];
#define WITH_TRI(s) (snprintf(buf, sizeof buf, "%s%s", tri_v, s), buf)
    expect_error(WITH_TRI("f 1 2 0\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face index 0 is invalid (OBJ indices start at 1)");
    expect_error(WITH_TRI("f 1 2 4\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face refers to vertex 4, but the file defines only 3 vertices");
    expect_error(WITH_TRI("f -1 -2 -4\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face refers to vertex -4, but only 3 vertices are defined so far");
    expect_error("v 0 0 0\nf -1 -1 -2\nv 1 1 1\n", MR_ERR_PARSE, 2,
                 "x.obj:2: face refers to vertex -2, but only 1 vertices are defined so far");
    expect_error(WITH_TRI("vt 0 0\nf 1/1 2/2 3/1\n"), MR_ERR_PARSE, 5,
                 "x.obj:5: face refers to texture coordinate 2, but the file defines only 1 "
                 "texture coordinates");
    expect_error(WITH_TRI("f 1//1 2//1 3//1\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face refers to normal 1, but the file defines only 0 normals");
    expect_error(WITH_TRI("vn 0 0 1\nf 1/1/-2 2//1 3//1\n"), MR_ERR_PARSE, 5,
                 "x.obj:5: face refers to texture coordinate 1, but the file defines only 0");
    expect_error(WITH_TRI("f 1 2\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face has only 2 corners (at least 3 needed)");
    expect_error(WITH_TRI("f\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face has only 0 corners (at least 3 needed)");
    expect_error(WITH_TRI("f 1 2 3x\n"), MR_ERR_PARSE, 4, "x.obj:4: malformed face corner '3x'");
    expect_error(WITH_TRI("f 1/ 2 3\n"), MR_ERR_PARSE, 4, "x.obj:4: malformed face corner '1/'");
    expect_error(WITH_TRI("f 1 2 a\n"), MR_ERR_PARSE, 4, "x.obj:4: malformed face corner 'a'");
    expect_error(WITH_TRI("f 1 2 1.5\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: malformed face corner '1.5'");
    expect_error(WITH_TRI("f 1 2 99999999999999999999\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face index '99999999999999999999' is out of range");
    expect_error(WITH_TRI("f 1 2 4294967296\n"), MR_ERR_PARSE, 4,
                 "x.obj:4: face refers to vertex 4294967296, but the file defines only 3");
#undef WITH_TRI
}

static void test_errors_vertices(void **state)
{
    (void)state;
    expect_error("v 0 0 0\nv 1 2\n", MR_ERR_PARSE, 2,
                 "x.obj:2: vertex has too few coordinates (expected x y z)");
    expect_error("v 0 0 0\nv\n", MR_ERR_PARSE, 2, "x.obj:2: vertex has too few coordinates");
    expect_error("v 1 2 x\n", MR_ERR_PARSE, 1, "x.obj:1: malformed number 'x'");
    expect_error("v 1 2 1e400\n", MR_ERR_PARSE, 1, "x.obj:1: number '1e400' is out of range");
    expect_error("v 1 2 3.5.6\n", MR_ERR_PARSE, 1, "x.obj:1: malformed number '3.5.6'");
    expect_error("v 1 2 0x10\n", MR_ERR_PARSE, 1, "x.obj:1: malformed number '0x10'");
    expect_error("v 1 2 3\nv nan 0 0\n", MR_ERR_PARSE, 2,
                 "x.obj:2: vertex has a non-finite coordinate");
    expect_error("v 1 -inf 3\n", MR_ERR_PARSE, 1, "x.obj:1: vertex has a non-finite coordinate");
    /* finite as a double, infinite as a float */
    expect_error("v 1 2 1e39\n", MR_ERR_PARSE, 1, "x.obj:1: vertex has a non-finite coordinate");
    expect_error("v 1 2 3 4 5\n", MR_ERR_PARSE, 1,
                 "x.obj:1: vertex has 5 numbers (expected x y z, x y z w or x y z r g b)");
    expect_error("v 1 2 3 4 5 6 7\n", MR_ERR_PARSE, 1, "x.obj:1: vertex has more than 6 numbers");
    expect_error("v 1 2 3 0 2 0\n", MR_ERR_PARSE, 1, "x.obj:1: vertex color 2 is outside [0, 1]");
    expect_error("v 1 2 3\nvt\n", MR_ERR_PARSE, 2,
                 "x.obj:2: texture coordinate has 0 numbers (expected u [v [w]])");
    expect_error("v 1 2 3\nvt 1 2 3 4\n", MR_ERR_PARSE, 2,
                 "x.obj:2: texture coordinate has more than 3 numbers");
    expect_error("v 1 2 3\nvt 1 inf\n", MR_ERR_PARSE, 2, "x.obj:2: texture coordinate is not finite");
    expect_error("v 1 2 3\nvn 1 0\n", MR_ERR_PARSE, 2,
                 "x.obj:2: normal has 2 numbers (expected x y z)");
    expect_error("v 1 2 3\nvn 1 0 nan\n", MR_ERR_PARSE, 2, "x.obj:2: normal is not finite");
}

static void test_errors_not_obj(void **state)
{
    (void)state;
    expect_error("# nothing but comments\n\n", MR_ERR_EMPTY, MR_NO_POSITION,
                 "x.obj: contains no vertices");
    expect_error("o empty\ng nothing\n", MR_ERR_EMPTY, MR_NO_POSITION, "contains no vertices");
    expect_error("v 1 2 3\n123 456\n", MR_ERR_PARSE, 2,
                 "x.obj:2: not an OBJ line (it starts with '123')");
    expect_error("v 1 2 3\nmtllib.x\n", MR_ERR_PARSE, 2, "x.obj:2: not an OBJ line");
    expect_error("\x7f" "ELF\x02\x01\x01\n", MR_ERR_PARSE, 1,
                 "x.obj:1: not an OBJ line (it starts with '?ELF");
    /* NUL bytes inside the buffer */
    const char bin[] = "v 1 2 3\nv 4 5 6\n\0\0\x01garbage\n";
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read_memory(bin, sizeof bin - 1, "b.obj", NULL, &m, &err),
                     MR_ERR_PARSE);
    tu_assert_contains(err.message, "b.obj:3: not an OBJ line");
    const char nul_in_v[] = "v 1 2 3\0\n";
    assert_int_equal(mr_mesh_read_memory(nul_in_v, sizeof nul_in_v - 1, "b.obj", NULL, &m, &err),
                     MR_ERR_PARSE);
    tu_assert_contains(err.message, "b.obj:1: malformed number '3?'");
}

static void test_error_is_the_first(void **state)
{
    (void)state;
    /* the earliest bad line wins, and the offset points into it */
    mr_mesh m;
    mr_error err;
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\nv 1 x 1\n";
    assert_int_equal(tu_read_string(text, "x.obj", &m, &err), MR_ERR_PARSE);
    assert_int_equal(err.line, 5);
    tu_assert_contains(err.message, "x.obj:5: face refers to vertex 9");
    assert_int_equal(err.offset, strlen("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 "));
}

/* ------------------------------------------------------------------------ */
/* Writer and round trips                                                   */
/* ------------------------------------------------------------------------ */

/* A mesh of n vertices with random finite values in every array asked for;
 * every vertex is used by a triangle (the reader takes attributes through
 * the faces). */
static void random_mesh(mr_mesh *m, size_t n, unsigned attrs, uint32_t seed)
{
    mr_error err;
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, n, n, attrs, &err), MR_OK);
    uint32_t x = seed;
    for (size_t i = 0; i < 3 * n; i++)
        m->positions[i] = random_float(&x);
    m->positions[0] = -0.0f;
    m->positions[1] = FLT_MAX;
    m->positions[2] = FLT_MIN / 8; /* subnormal */
    if (m->normals)
        for (size_t i = 0; i < 3 * n; i++)
            m->normals[i] = random_float(&x);
    if (m->texcoords)
        for (size_t i = 0; i < 2 * n; i++)
            m->texcoords[i] = random_float(&x);
    if (m->colors)
        for (size_t i = 0; i < n; i++) {
            for (int k = 0; k < 3; k++)
                m->colors[4 * i + k] = random_unit(&x);
            m->colors[4 * i + 3] = 1.0f; /* OBJ has no alpha */
        }
    for (size_t t = 0; t < n; t++) {
        m->indices[3 * t] = (uint32_t)t;
        m->indices[3 * t + 1] = (uint32_t)((t + 1) % n);
        m->indices[3 * t + 2] = (uint32_t)((t + 2) % n);
    }
}

static void round_trip(unsigned attrs, size_t n, const char *file)
{
    mr_mesh a, b;
    mr_error err;
    random_mesh(&a, n, attrs, 0x9e3779b9u ^ attrs);
    const char *path = tu_tmp_path(file);
    assert_int_equal(mr_mesh_write(path, &a, NULL, &err), MR_OK);
    mr_status st = mr_mesh_read(path, NULL, &b, &err);
    if (st != MR_OK) {
        print_error("%s\n", err.message);
        fail();
    }
    tu_assert_mesh_equal(&a, &b);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
}

static void test_round_trip_positions(void **state)
{
    (void)state;
    round_trip(0, 20000, "rt_pos.obj");
}

static void test_round_trip_normals(void **state)
{
    (void)state;
    round_trip(MR_ATTR_NORMALS, 5000, "rt_n.obj");
}

static void test_round_trip_texcoords(void **state)
{
    (void)state;
    round_trip(MR_ATTR_TEXCOORDS, 5000, "rt_t.obj");
}

static void test_round_trip_colors(void **state)
{
    (void)state;
    round_trip(MR_ATTR_COLORS, 5000, "rt_c.obj");
}

static void test_round_trip_all(void **state)
{
    (void)state;
    round_trip(MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS, 30000, "rt_all.obj");
}

static void test_round_trip_point_cloud(void **state)
{
    (void)state;
    mr_mesh a, b;
    mr_error err;
    random_mesh(&a, 1000, MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS, 7);
    a.triangle_count = 0;
    const char *path = tu_tmp_path("rt_cloud.obj");
    assert_int_equal(mr_mesh_write(path, &a, NULL, &err), MR_OK);
    assert_int_equal(mr_mesh_read(path, NULL, &b, &err), MR_OK);
    tu_assert_mesh_equal(&a, &b);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
}

static void test_writer_text(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    mr_mesh_init(&m);
    assert_int_equal(mr_mesh_alloc(&m, 3, 1, MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS,
                                   &err),
                     MR_OK);
    const float p[9] = {0, 0, 0, 1, 0, 0, 0.1f, -2.5f, 1e-7f};
    const float n[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    const float t[6] = {0, 0, 1, 0, 0.5f, 1};
    const float c[12] = {1, 0, 0, 1, 0, 1, 0, 1, 0, 0, 1, 1};
    memcpy(m.positions, p, sizeof p);
    memcpy(m.normals, n, sizeof n);
    memcpy(m.texcoords, t, sizeof t);
    memcpy(m.colors, c, sizeof c);
    m.indices[0] = 0;
    m.indices[1] = 1;
    m.indices[2] = 2;

    const char *path = tu_tmp_path("w.obj");
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_OK);
    char *s = tu_read_file(path, NULL);
    tu_assert_contains(s, "# meshreduce");
    tu_assert_contains(s, "\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0.1 -2.5 1e-07 0 0 1\n"
                          "vt 0 0\nvt 1 0\nvt 0.5 1\n"
                          "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\n"
                          "f 1/1/1 2/2/2 3/3/3\n");
    free(s);

    mr_write_options opt;
    mr_write_options_default(&opt);
    opt.write_colors = 0;
    opt.write_texcoords = 0;
    assert_int_equal(mr_mesh_write(path, &m, &opt, &err), MR_OK);
    s = tu_read_file(path, NULL);
    tu_assert_contains(s, "\nv 0 0 0\nv 1 0 0\nv 0.1 -2.5 1e-07\nvn 0 0 1\n");
    tu_assert_contains(s, "\nf 1//1 2//2 3//3\n");
    assert_null(strstr(s, "vt "));
    free(s);

    opt.write_normals = 0;
    opt.write_texcoords = 1;
    assert_int_equal(mr_mesh_write(path, &m, &opt, &err), MR_OK);
    s = tu_read_file(path, NULL);
    tu_assert_contains(s, "\nf 1/1 2/2 3/3\n");
    assert_null(strstr(s, "vn "));
    free(s);

    opt.write_texcoords = 0;
    assert_int_equal(mr_mesh_write(path, &m, &opt, &err), MR_OK);
    s = tu_read_file(path, NULL);
    tu_assert_contains(s, "\nf 1 2 3\n");
    free(s);
    mr_mesh_free(&m);
}

/* ------------------------------------------------------------------------ */
/* Thread-count independence                                                */
/* ------------------------------------------------------------------------ */

/* About 50,000 lines exercising every line kind and index form, with
 * relative indices that reach back across chunk boundaries. */
static char *generate_obj(size_t *size, size_t *lines)
{
    textbuf t = {0};
    size_t v = 0, vt = 0, vn = 0, n = 0;
    uint32_t x = 12345;
    const size_t blocks = 6000;
    /* a forward reference to one of the last vertices (not the very last,
     * so that the error test may replace a v line) */
    add(&t, "# generated\nf 1 2 %zu\n", blocks * 4 - 10);
    n += 2;
    for (size_t b = 0; b < blocks; b++) {
        for (int i = 0; i < 4; i++, v++, n++)
            add(&t, "v %.7g %.7g %.7g\n", (double)random_unit(&x) * 100 - 50,
                (double)random_unit(&x), (double)(float)(b * 0.001));
        add(&t, "vt %.6g %.6g\r\nvt %.6g %.6g\n", (double)random_unit(&x),
            (double)random_unit(&x), (double)random_unit(&x), (double)random_unit(&x));
        vt += 2;
        add(&t, "vn 0 0 1\n");
        vn++;
        n += 3;
        switch (b % 5) {
        case 0: add(&t, "f -4/-2/-1 -3/-1/-1 -2/-2/-1 -1/-1/-1\n"); break;
        case 1: add(&t, "f %zu %zu %zu # tri\n", v - 3, v - 1, v); break;
        case 2: add(&t, "o part%zu\nf %zu//%zu %zu//%zu %zu//%zu\n", b, v, vn, v - 1, vn,
                    v - 2, vn); n++; break;
        case 3: add(&t, "f %zu/%zu %zu/%zu %zu/%zu %zu/%zu %zu/%zu\n", v - 3, vt, v - 2, vt,
                    v - 1, vt - 1, v, vt, v > 8 ? v - 8 : 1, vt); break;
        default: add(&t, "\nf -8 -4 -1\r\n"); n++; break;
        }
        n++;
        if (b % 97 == 0) {
            add(&t, "# a comment line\nusemtl m%zu\n", b);
            n += 2;
        }
    }
    *size = t.len;
    *lines = n;
    return t.s;
}

static void test_thread_independence(void **state)
{
    (void)state;
    size_t size, lines;
    char *data = generate_obj(&size, &lines);
    assert_true(lines >= 50000);
    mr_mesh ref;
    mr_error err;
    assert_int_equal(read_threads(data, size, 1, &ref, &err), MR_OK);
    assert_true(ref.vertex_count > 16000); /* seams were split */
    assert_non_null(ref.texcoords);
    assert_non_null(ref.normals);
    const int threads[] = {2, 3, 7, 64};
    for (size_t i = 0; i < sizeof threads / sizeof *threads; i++) {
        mr_mesh m;
        assert_int_equal(read_threads(data, size, threads[i], &m, &err), MR_OK);
        tu_assert_mesh_equal(&ref, &m);
        mr_mesh_free(&m);
    }
    mr_mesh_free(&ref);
    free(data);
}

static void test_thread_independence_cloud_colors(void **state)
{
    (void)state;
    /* colors that only appear deep into the file (past the first chunk's
     * first vertex), and a point cloud */
    textbuf t = {0};
    uint32_t x = 99;
    for (int i = 0; i < 50000; i++) {
        if (i % 1000 == 999)
            add(&t, "v %.6g 1 2 %.6g 0.5 1\n", (double)random_unit(&x),
                (double)random_unit(&x));
        else
            add(&t, "v %.6g %.6g %.6g\n", (double)random_unit(&x), (double)random_unit(&x),
                (double)random_unit(&x));
    }
    mr_mesh ref;
    mr_error err;
    assert_int_equal(read_threads(t.s, t.len, 1, &ref, &err), MR_OK);
    assert_int_equal(ref.vertex_count, 50000);
    assert_int_equal(ref.triangle_count, 0);
    assert_non_null(ref.colors);
    assert_true(ref.colors[4 * 999 + 1] == 0.5f && ref.colors[0] == 1.0f);
    const int threads[] = {2, 3, 7};
    for (size_t i = 0; i < sizeof threads / sizeof *threads; i++) {
        mr_mesh m;
        assert_int_equal(read_threads(t.s, t.len, threads[i], &m, &err), MR_OK);
        tu_assert_mesh_equal(&ref, &m);
        mr_mesh_free(&m);
    }
    mr_mesh_free(&ref);
    free(t.s);
}

/* Replace line `line` (1-based) of the text with `repl`. */
static char *replace_line(const char *s, size_t size, size_t line, const char *repl,
                          size_t *out_size)
{
    const char *b = s, *end = s + size;
    for (size_t l = 1; l < line; l++)
        b = memchr(b, '\n', (size_t)(end - b)) + 1;
    const char *e = memchr(b, '\n', (size_t)(end - b));
    size_t rl = strlen(repl);
    char *out = malloc(size + rl + 1);
    size_t head = (size_t)(b - s);
    memcpy(out, s, head);
    memcpy(out + head, repl, rl);
    memcpy(out + head + rl, e, (size_t)(end - e));
    *out_size = head + rl + (size_t)(end - e);
    return out;
}

static void test_thread_independence_errors(void **state)
{
    (void)state;
    size_t size, lines;
    char *data = generate_obj(&size, &lines);
    size_t s1, s2;
    char *bad1 = replace_line(data, size, 30000, "f 1 2 0", &s1);
    char *bad2 = replace_line(bad1, s1, 45000, "v 1 2", &s2);
    /* the file cut in the middle of a line: whatever the outcome, it is
     * the same for every thread count */
    mr_mesh cut;
    mr_error cut_err;
    mr_status cut_st = read_threads(data, 200003, 1, &cut, &cut_err);
    const int threads[] = {1, 2, 3, 7, 64};
    for (size_t i = 0; i < sizeof threads / sizeof *threads; i++) {
        mr_mesh m;
        mr_error err;
        assert_int_equal(read_threads(bad2, s2, threads[i], &m, &err), MR_ERR_PARSE);
        assert_string_equal(err.message,
                            "gen.obj:30000: face index 0 is invalid (OBJ indices start at 1)");
        assert_int_equal(read_threads(data, 200003, threads[i], &m, &err), cut_st);
        if (cut_st == MR_OK) {
            tu_assert_mesh_equal(&cut, &m);
            mr_mesh_free(&m);
        } else {
            assert_string_equal(err.message, cut_err.message);
        }
    }
    if (cut_st == MR_OK)
        mr_mesh_free(&cut);
    free(bad2);
    free(bad1);
    free(data);
}

/* ------------------------------------------------------------------------ */
/* The reader in windows                                                    */
/* ------------------------------------------------------------------------ */

static size_t size_of_file(const char *path)
{
    size_t n = 0;
    free(tu_read_file(path, &n));
    return n;
}

/* Read path through mr_obj_stream in windows of `window` bytes into one
 * mesh (positions of the v lines, the triangles). */
static mr_status read_windows(const char *path, size_t window, int threads, mr_mesh *m,
                              unsigned *attributes, mr_error *err)
{
    mr_obj_stream *s;
    mr_status st = mr_obj_stream_open(path, threads, window, &s, err);
    if (st != MR_OK)
        return st;
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, mr_obj_stream_vertex_count(s),
                                   mr_obj_stream_triangle_count(s), 0, err),
                     MR_OK);
    size_t nv = 0, nt = 0, windows = 0;
    for (;;) {
        mr_obj_window w;
        if ((st = mr_obj_stream_next(s, &w, err)) != MR_OK)
            break;
        if (!w.positions)
            break;
        windows++;
        assert_int_equal(w.first_vertex, nv);
        assert_int_equal(w.first_triangle, nt);
        memcpy(m->positions + 3 * nv, w.positions, 12 * w.vertex_count);
        memcpy(m->indices + 3 * nt, w.indices, 12 * w.triangle_count);
        nv += w.vertex_count;
        nt += w.triangle_count;
    }
    *attributes = mr_obj_stream_attributes(s);
    mr_obj_stream_close(s);
    if (st != MR_OK) {
        mr_mesh_free(m);
        return st;
    }
    assert_int_equal(nv, m->vertex_count);
    assert_int_equal(nt, m->triangle_count);
    assert_true(window >= size_of_file(path) || windows > 1);
    return MR_OK;
}

/* The windows give mr_read_obj's mesh, for every window size (cuts in
 * every kind of line, relative indices across windows) and thread count,
 * and its errors; on a file with vt / vn, the v lines' positions and the
 * attributes noted. */
static void test_stream_windows(void **state)
{
    (void)state;
    size_t size, lines;
    char *data = generate_obj(&size, &lines);
    /* the same file without its vt / vn: the v lines are its vertices */
    textbuf g = {0};
    for (const char *p = data; p < data + size;) {
        const char *e = memchr(p, '\n', (size_t)(data + size - p));
        e = e ? e + 1 : data + size;
        if (!(p[0] == 'v' && (p[1] == 't' || p[1] == 'n'))) {
            for (const char *c = p; c < e; c++) {
                if (*c == '/') {
                    while (c + 1 < e && c[1] != ' ' && c[1] != '\n' && c[1] != '\r')
                        c++;
                    continue;
                }
                add(&g, "%c", *c);
            }
        }
        p = e;
    }
    char plain[1024], full[1024];
    snprintf(plain, sizeof plain, "%s", tu_tmp_path("stream-plain.obj"));
    snprintf(full, sizeof full, "%s", tu_tmp_path("stream-full.obj"));
    tu_write_file(plain, g.s, g.len);
    tu_write_file(full, data, size);
    mr_mesh ref, withseams, m;
    mr_error err;
    assert_int_equal(read_threads(g.s, g.len, 2, &ref, &err), MR_OK);
    assert_int_equal(read_threads(data, size, 2, &withseams, &err), MR_OK);
    const size_t windows[] = {4096, 5000, 65536, 1u << 20};
    const int threads[] = {1, 3};
    unsigned attrs;
    for (size_t w = 0; w < sizeof windows / sizeof *windows; w++)
        for (size_t t = 0; t < 2; t++) {
            assert_int_equal(read_windows(plain, windows[w], threads[t], &m, &attrs, &err),
                             MR_OK);
            tu_assert_mesh_equal(&ref, &m);
            assert_int_equal(attrs, 0);
            mr_mesh_free(&m);
            assert_int_equal(read_windows(full, windows[w], threads[t], &m, &attrs, &err),
                             MR_OK);
            assert_int_equal(attrs, MR_ATTR_TEXCOORDS | MR_ATTR_NORMALS);
            assert_int_equal(m.triangle_count, withseams.triangle_count);
            assert_memory_equal(m.positions, withseams.positions, 12 * m.vertex_count);
            mr_mesh_free(&m);
        }
    /* errors late in the file: the in-memory reader's message */
    size_t s1, s2;
    char *bad1 = replace_line(g.s, g.len, 30000, "f 1 2 0", &s1);
    char *bad2 = replace_line(g.s, g.len, 29000, "f 1 2 99999999", &s2);
    const char *bads[2] = {bad1, bad2};
    const size_t sizes[2] = {s1, s2};
    for (int b = 0; b < 2; b++) {
        tu_write_file(plain, bads[b], sizes[b]);
        mr_error want;
        assert_int_equal(read_threads(bads[b], sizes[b], 1, &m, &want), MR_ERR_PARSE);
        assert_int_equal(read_windows(plain, 5000, 2, &m, &attrs, &err), MR_ERR_PARSE);
        /* the same words after the file's name */
        tu_assert_contains(err.message, strchr(want.message, ':'));
    }
    free(bad1);
    free(bad2);
    mr_mesh_free(&ref);
    mr_mesh_free(&withseams);
    free(g.s);
    free(data);
}

/* ------------------------------------------------------------------------ */
/* Shared test meshes                                                       */
/* ------------------------------------------------------------------------ */

static void read_shared(const char *path, mr_mesh *m)
{
    mr_error err;
    mr_status st = mr_mesh_read(path, NULL, m, &err);
    if (st != MR_OK) {
        print_error("%s\n", err.message);
        fail();
    }
}

static void test_beast(void **state)
{
    (void)state;
    const char *path = tu_shared_data("beast.obj");
    if (!path)
        skip();
    /* count v lines, polygons and sum(corners - 2) independently */
    size_t size;
    char *s = tu_read_file(path, &size);
    assert_non_null(s);
    size_t v = 0, polys = 0, tris = 0;
    for (char *line = strtok(s, "\n"); line; line = strtok(NULL, "\n")) {
        if (line[0] == 'v' && line[1] == ' ')
            v++;
        if (line[0] != 'f' || line[1] != ' ')
            continue;
        polys++;
        size_t corners = 0;
        for (char *tok = line + 1; *tok;) {
            while (*tok == ' ' || *tok == '\t' || *tok == '\r')
                tok++;
            if (!*tok)
                break;
            corners++;
            while (*tok && *tok != ' ' && *tok != '\t' && *tok != '\r')
                tok++;
        }
        tris += corners - 2;
    }
    free(s);
    assert_int_equal(v, 32311);
    assert_int_equal(polys, 32364);
    assert_true(tris > polys);

    mr_mesh m;
    read_shared(path, &m);
    assert_int_equal(m.triangle_count, tris);
    assert_true(m.vertex_count >= 32311);
    assert_non_null(m.texcoords);
    mr_mesh_free(&m);
}

static void test_spot(void **state)
{
    (void)state;
    const char *path = tu_shared_data("spot.obj");
    if (!path)
        skip();
    mr_mesh m;
    read_shared(path, &m);
    assert_int_equal(m.triangle_count, 5856);
    assert_true(m.vertex_count > 2930); /* UV seams split vertices */
    assert_non_null(m.texcoords);
    assert_null(m.normals);
    mr_mesh_free(&m);
}

static void test_bunny(void **state)
{
    (void)state;
    const char *path = tu_shared_data("stanford-bunny.obj");
    if (!path)
        skip();
    mr_mesh m;
    read_shared(path, &m);
    assert_int_equal(m.vertex_count, 35947);
    assert_int_equal(m.triangle_count, 69451);
    assert_null(m.texcoords);
    assert_null(m.normals);
    /* the same with one thread, bit for bit */
    mr_read_options opt;
    mr_read_options_default(&opt);
    opt.threads = 1;
    mr_mesh one;
    mr_error err;
    assert_int_equal(mr_mesh_read(path, &opt, &one, &err), MR_OK);
    tu_assert_mesh_equal(&m, &one);
    mr_mesh_free(&one);
    mr_mesh_free(&m);
}

/* An OBJ's mtllib and usemtl groups through simplify and convert: a
 * sphere whose upper half is material "top" and lower half "bottom" (the
 * faces interleaved in the file, a few before any usemtl) keeps both
 * groups, one usemtl line each, the material border where it was (every
 * "top" triangle above the equator, every "bottom" one below), and stays
 * closed; convert keeps the groups face for face. */
static void test_materials_kept(void **state)
{
    (void)state;
    mr_mesh g;
    mr_mesh_init(&g);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 5000, 0, &g, NULL), MR_OK);
    const char *in = tu_tmp_path("mat-sphere.obj"), *out = tu_tmp_path("mat-sphere-10.obj"),
               *conv = tu_tmp_path("mat-sphere-conv.obj");
    FILE *f = fopen(in, "w");
    assert_non_null(f);
    fprintf(f, "mtllib mat.mtl\n");
    for (size_t v = 0; v < g.vertex_count; v++)
        fprintf(f, "v %.9g %.9g %.9g\n", g.positions[3 * v], g.positions[3 * v + 1],
                g.positions[3 * v + 2]);
    /* the material of a face: its centroid's side of the equator (y) */
    int last = -1;
    size_t loose = 0;
    for (size_t t = 0; t < g.triangle_count; t++) {
        const uint32_t *tri = g.indices + 3 * t;
        const double y = g.positions[3 * tri[0] + 1] + g.positions[3 * tri[1] + 1] +
                         g.positions[3 * tri[2] + 1];
        const int top = y > 0;
        if (t >= 3 && top != last) {
            fprintf(f, "usemtl %s\n", top ? "top" : "bottom");
            last = top;
        } else if (t < 3) {
            loose++; /* before any usemtl: no material (all on one side?) */
        }
        fprintf(f, "f %u %u %u\n", tri[0] + 1, tri[1] + 1, tri[2] + 1);
    }
    fclose(f);
    (void)loose;
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 10%% -q", in, out), NULL),
                     0);
    mr_obj_materials om;
    mr_error err;
    assert_int_equal(mr_obj_materials_read(out, &om, &err), MR_OK);
    assert_non_null(om.mtllib);
    assert_string_equal(om.mtllib, "mat.mtl");
    assert_int_equal(om.count, 2);
    mr_mesh m;
    assert_int_equal(mr_mesh_read(out, NULL, &m, &err), MR_OK);
    assert_int_equal(om.triangle_count, m.triangle_count);
    /* one run per material (none first), and the border kept */
    char *text = tu_read_file(out, NULL);
    size_t lines = 0;
    for (const char *p = text; (p = strstr(p, "usemtl ")) != NULL; p++)
        lines++;
    free(text);
    assert_int_equal(lines, 2);
    size_t none = 0;
    for (size_t t = 0; t < m.triangle_count; t++) {
        const uint32_t gi = om.face_material[t];
        if (gi == UINT32_MAX) {
            assert_int_equal(none, t); /* the ungrouped ones first */
            none++;
            continue;
        }
        const bool top = !strcmp(om.names[gi], "top");
        for (int k = 0; k < 3; k++) {
            const float y = m.positions[3 * m.indices[3 * t + (size_t)k] + 1];
            assert_true(top ? y > -0.05f : y < 0.05f);
        }
    }
    mr_stats st;
    assert_int_equal(mr_stats_compute(m.positions, 0, m.vertex_count, m.indices,
                                      m.triangle_count, &st, NULL),
                     MR_OK);
    assert_true(st.closed && st.manifold);
    mr_mesh_free(&m);
    mr_obj_materials_free(&om);

    /* convert: face for face */
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' '%s' -q", in, conv), NULL), 0);
    mr_obj_materials a, b;
    assert_int_equal(mr_obj_materials_read(in, &a, &err), MR_OK);
    assert_int_equal(mr_obj_materials_read(conv, &b, &err), MR_OK);
    assert_int_equal(a.count, b.count);
    assert_int_equal(a.triangle_count, b.triangle_count);
    for (size_t t = 0; t < a.triangle_count; t++) {
        const uint32_t x = a.face_material[t], y = b.face_material[t];
        assert_true(x == UINT32_MAX ? y == UINT32_MAX : !strcmp(a.names[x], b.names[y]));
    }
    /* the reader's materials are the usemtl groups */
    mr_mesh r;
    assert_int_equal(mr_mesh_read(in, NULL, &r, &err), MR_OK);
    assert_non_null(r.materials);
    assert_int_equal(r.triangle_count, a.triangle_count);
    assert_memory_equal(r.materials, a.face_material, 4 * a.triangle_count);
    mr_mesh_free(&r);
    mr_obj_materials_free(&a);
    mr_obj_materials_free(&b);
    /* the file path in memory (a memory budget given): the same bytes */
    char out_path[1024], file_path[1024], lods[1024], lod2[1024];
    snprintf(out_path, sizeof out_path, "%s", out);
    snprintf(file_path, sizeof file_path, "%s", tu_tmp_path("mat-sphere-file.obj"));
    snprintf(lods, sizeof lods, "%s", tu_tmp_path("mat-sphere-lods.obj"));
    snprintf(lod2, sizeof lod2, "%s", tu_tmp_path("mat-sphere-lods.lod2.obj"));
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 10%% --memory 1G -q", in,
                                       file_path),
                                NULL),
                     0);
    size_t n1, n2;
    char *t1 = tu_read_file(out_path, &n1), *t2 = tu_read_file(file_path, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(t1, t2, n1);
    free(t1), free(t2);
    /* levels of detail: each keeps both groups */
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --lods 30%%,5%% -q", in, lods),
                                NULL),
                     0);
    assert_int_equal(mr_obj_materials_read(lod2, &a, &err), MR_OK);
    assert_int_equal(a.count, 2);
    assert_string_equal(a.mtllib, "mat.mtl");
    mr_obj_materials_free(&a);
    mr_mesh_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_form_v),
        cmocka_unit_test(test_form_v_vt),
        cmocka_unit_test(test_form_v_vn),
        cmocka_unit_test(test_form_v_vt_vn),
        cmocka_unit_test(test_vt_lines_unused),
        cmocka_unit_test(test_negative_indices),
        cmocka_unit_test(test_forward_reference),
        cmocka_unit_test(test_polygons),
        cmocka_unit_test(test_comments_crlf_keywords),
        cmocka_unit_test(test_byte_order_mark),
        cmocka_unit_test(test_vertex_w_and_numbers),
        cmocka_unit_test(test_point_cloud),
        cmocka_unit_test(test_unreferenced_kept),
        cmocka_unit_test(test_seams),
        cmocka_unit_test(test_seams_normals),
        cmocka_unit_test(test_colors),
        cmocka_unit_test(test_errors_faces),
        cmocka_unit_test(test_errors_vertices),
        cmocka_unit_test(test_errors_not_obj),
        cmocka_unit_test(test_error_is_the_first),
        cmocka_unit_test(test_round_trip_positions),
        cmocka_unit_test(test_round_trip_normals),
        cmocka_unit_test(test_round_trip_texcoords),
        cmocka_unit_test(test_round_trip_colors),
        cmocka_unit_test(test_round_trip_all),
        cmocka_unit_test(test_round_trip_point_cloud),
        cmocka_unit_test(test_writer_text),
        cmocka_unit_test(test_thread_independence),
        cmocka_unit_test(test_thread_independence_cloud_colors),
        cmocka_unit_test(test_thread_independence_errors),
        cmocka_unit_test(test_stream_windows),
        cmocka_unit_test(test_beast),
        cmocka_unit_test(test_spot),
        cmocka_unit_test(test_bunny),
        cmocka_unit_test(test_materials_kept),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
