/* The rasterizer, heat maps, sheets, text and PNG output, and `meshreduce render`. */
#include "testutil.h"

#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers ---------------------------------------------------------------- */

static uint32_t pixel(const uint8_t *img, int w, int x, int y)
{
    const uint8_t *p = img + 4 * ((size_t)y * (size_t)w + (size_t)x);
    return (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
}

static size_t count_not(const uint8_t *img, int w, int h, uint32_t bg)
{
    size_t n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            n += pixel(img, w, x, y) != bg;
    return n;
}

static uint8_t *render(const float *pos, size_t nv, const uint32_t *idx, size_t nt,
                       const mr_render_options *o)
{
    uint8_t *img = malloc((size_t)o->width * (size_t)o->height * 4);
    mr_error err;
    mr_status st = mr_render(pos, nv, idx, nt, o, img, 0, &err);
    if (st != MR_OK)
        fail_msg("mr_render: %s", err.message);
    return img;
}

/* The triangle (0,0,0) (1,0,0) (0,1,0), seen from the front, fills the
 * lower-left half of a square image. */
static const float tri_pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
static const uint32_t tri_idx[3] = {0, 1, 2};

static void front_options(mr_render_options *o, int size)
{
    mr_render_options_default(o);
    o->width = o->height = size;
    o->view = MR_VIEW_FRONT;
    o->margin = 0;
    o->supersample = 1;
}

/* ---- triangles --------------------------------------------------------------- */

static void test_single_triangle(void **state)
{
    (void)state;
    mr_render_options o;
    front_options(&o, 100);
    uint8_t *img = render(tri_pos, 3, tri_idx, 1, &o);
    /* Facing the headlight: the surface colour at full strength. */
    assert_int_equal(pixel(img, 100, 10, 89), o.color);
    assert_int_equal(pixel(img, 100, 5, 50), o.color);
    /* Above the diagonal and in the corners away from it: background. */
    assert_int_equal(pixel(img, 100, 90, 10), 0xffffff);
    assert_int_equal(pixel(img, 100, 99, 0), 0xffffff);
    assert_int_equal(pixel(img, 100, 60, 30), 0xffffff);
    /* Coverage: half the image, give or take the diagonal. */
    size_t n = count_not(img, 100, 100, 0xffffff);
    assert_true(n >= 4900 && n <= 5100);
    /* Every pixel is the surface or the background at 1x sampling, and
     * alpha is opaque. */
    for (int i = 0; i < 100 * 100; i++) {
        uint32_t c = pixel(img, 100, i % 100, i / 100);
        assert_true(c == o.color || c == 0xffffff);
        assert_int_equal(img[4 * i + 3], 255);
    }
    free(img);

    /* Seen from behind (yaw 180): the same coverage, mirrored, still lit
     * (two-sided); a different background colour. */
    o.view = MR_VIEW_CUSTOM;
    o.yaw = 180;
    o.background = 0x102030;
    img = render(tri_pos, 3, tri_idx, 1, &o);
    assert_int_equal(pixel(img, 100, 89, 89), o.color);
    assert_int_equal(pixel(img, 100, 10, 60), 0x102030);
    n = count_not(img, 100, 100, 0x102030);
    assert_true(n >= 4900 && n <= 5100);
    free(img);

    /* Anti-aliasing: at 4x4 samples the diagonal gets blended pixels. */
    front_options(&o, 100);
    o.supersample = 4;
    img = render(tri_pos, 3, tri_idx, 1, &o);
    size_t mixed = 0;
    for (int i = 0; i < 100 * 100; i++) {
        uint32_t c = pixel(img, 100, i % 100, i / 100);
        mixed += c != o.color && c != 0xffffff;
    }
    assert_true(mixed >= 50 && mixed <= 300);
    free(img);
}

/* Two triangles sharing the diagonal of a square: every pixel covered
 * once (no cracks), and the wireframe darkens the shared edge. */
static void test_square_no_cracks_and_wire(void **state)
{
    (void)state;
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    mr_render_options o;
    front_options(&o, 64);
    uint8_t *img = render(pos, 4, idx, 2, &o);
    assert_int_equal(count_not(img, 64, 64, 0xffffff), 64 * 64);
    for (int i = 0; i < 64 * 64; i++)
        assert_int_equal(pixel(img, 64, i % 64, i / 64), o.color);
    free(img);

    o.wire = 1;
    img = render(pos, 4, idx, 2, &o);
    /* On the diagonal: the wire colour; in the middle of a triangle: the
     * surface. */
    assert_int_equal(pixel(img, 64, 32, 31), o.wire_color);
    assert_int_equal(pixel(img, 64, 48, 40), o.color);
    assert_int_equal(pixel(img, 64, 16, 24), o.color);
    free(img);
}

/* A unit cube from a view that shows three faces at different angles. */
static void test_cube(void **state)
{
    (void)state;
    const float pos[24] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                           0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
    const uint32_t idx[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                              3, 6, 2, 3, 7, 6, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
    mr_render_options o;
    mr_render_options_default(&o);
    o.width = 200;
    o.height = 160;
    o.view = MR_VIEW_CUSTOM;
    o.yaw = 30;
    o.pitch = 25;
    o.supersample = 2;
    uint8_t *img = render(pos, 8, idx, 12, &o);
    /* The corners are background, the centre is the cube. */
    assert_int_equal(pixel(img, 200, 0, 0), 0xffffff);
    assert_int_equal(pixel(img, 200, 199, 159), 0xffffff);
    assert_int_not_equal(pixel(img, 200, 100, 80), 0xffffff);
    /* The silhouette fills a good part of the image but not all of it. */
    size_t n = count_not(img, 200, 160, 0xffffff);
    assert_true(n > 200 * 160 / 4 && n < 200 * 160 * 3 / 4);
    /* Three faces, three shades: top (above the centre), front-right and
     * front-left (below it, either side), each flat. */
    uint32_t top = pixel(img, 200, 100, 40), left = pixel(img, 200, 75, 110),
             right = pixel(img, 200, 125, 110);
    assert_int_not_equal(top, left);
    assert_int_not_equal(top, right);
    assert_int_not_equal(left, right);
    assert_int_equal(pixel(img, 200, 70, 115), left);
    assert_int_equal(pixel(img, 200, 130, 115), right);
    free(img);
}

/* The same bytes at every thread count. */
static void test_deterministic_across_threads(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_SCAN, 30000, 3, &m, &err), MR_OK);
    mr_render_options o;
    mr_render_options_default(&o);
    o.width = 320;
    o.height = 240;
    o.wire = 1;
    uint8_t *ref = NULL;
    for (int t = 1; t <= 4; t++) {
        o.threads = t;
        uint8_t *img = render(m.positions, m.vertex_count, m.indices, m.triangle_count, &o);
        if (!ref)
            ref = img;
        else {
            assert_memory_equal(ref, img, 320 * 240 * 4);
            free(img);
        }
    }
    /* A point cloud too. */
    free(ref);
    ref = NULL;
    for (int t = 1; t <= 3; t++) {
        o.threads = t;
        uint8_t *img = render(m.positions, m.vertex_count, NULL, 0, &o);
        if (!ref)
            ref = img;
        else {
            assert_memory_equal(ref, img, 320 * 240 * 4);
            free(img);
        }
    }
    free(ref);
    mr_mesh_free(&m);

    /* A fanned polygon: wide slivers take the row-span path. */
    enum { N = 3000 };
    float *fp = malloc(3 * N * sizeof *fp);
    uint32_t *fi = malloc(3 * (N - 2) * sizeof *fi);
    assert_non_null(fp);
    assert_non_null(fi);
    for (int i = 0; i < N; i++) {
        const double a = 6.283185307179586 * i / N;
        fp[3 * i] = (float)cos(a);
        fp[3 * i + 1] = (float)(0.6 * sin(a));
        fp[3 * i + 2] = (float)(0.1 * sin(3 * a));
    }
    for (int t = 0; t < N - 2; t++) {
        fi[3 * t] = 0;
        fi[3 * t + 1] = (uint32_t)t + 1;
        fi[3 * t + 2] = (uint32_t)t + 2;
    }
    ref = NULL;
    const int counts[] = {1, 2, 3, 8};
    for (int c = 0; c < 4; c++) {
        o.threads = counts[c];
        uint8_t *img = render(fp, N, fi, N - 2, &o);
        if (!ref)
            ref = img;
        else {
            assert_memory_equal(ref, img, 320 * 240 * 4);
            free(img);
        }
    }
    free(ref);
    free(fp);
    free(fi);
}

/* A point cloud: splats around the projected points, z-tested. */
static void test_point_cloud(void **state)
{
    (void)state;
    const float pos[6] = {0, 0, 0, 1, 1, 0};
    mr_render_options o;
    front_options(&o, 100);
    o.point_radius = 4;
    o.margin = 0.1;
    uint8_t *img = render(pos, 2, NULL, 0, &o);
    /* Centres at (10, 90) and (90, 10) (pixel corners): nearly full
     * strength in the pixels there (the ball's normal turns away from the
     * eye towards the rim). */
    for (int k = 0; k < 2; k++) {
        uint32_t c = pixel(img, 100, k ? 90 : 10, k ? 10 : 90);
        for (int s = 0; s < 24; s += 8) {
            int got = (int)(c >> s & 255), want = (int)(o.color >> s & 255);
            assert_true(got <= want && got >= want - 6);
        }
    }
    assert_int_equal(pixel(img, 100, 50, 50), 0xffffff);
    assert_int_equal(pixel(img, 100, 10, 80), 0xffffff); /* outside the radius */
    size_t n = count_not(img, 100, 100, 0xffffff);
    assert_true(n >= 2 * 40 && n <= 2 * 64); /* two discs of radius 4 */
    free(img);
}

/* ---- heat maps ----------------------------------------------------------------- */

static void test_colormap_endpoints(void **state)
{
    (void)state;
    uint8_t a[3], b[3], c[3];
    mr_colormap(0, a);
    mr_colormap(-5, b);
    assert_memory_equal(a, b, 3);
    mr_colormap(NAN, b);
    assert_memory_equal(a, b, 3);
    mr_colormap(1, c);
    mr_colormap(7, b);
    assert_memory_equal(c, b, 3);
    /* Blue at the bottom, red at the top. */
    assert_true(a[2] > a[0] && a[2] > a[1]);
    assert_true(c[0] > c[1] && c[0] > c[2]);
    /* Continuous: neighbouring values give neighbouring colours. */
    for (int i = 0; i < 1000; i++) {
        mr_colormap(i / 1000.0, a);
        mr_colormap((i + 1) / 1000.0, b);
        for (int k = 0; k < 3; k++)
            assert_true(abs((int)a[k] - (int)b[k]) <= 2);
    }
}

static void test_heat_render_endpoints(void **state)
{
    (void)state;
    /* The square again, one triangle at the bottom of the scale, one at
     * the top: front-facing, so each shows its colour-map end exactly. */
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    const float heat[2] = {0.5f, 3.0f};
    mr_render_options o;
    front_options(&o, 64);
    o.face_scalar = heat;
    o.scalar_min = 0.5;
    o.scalar_max = 2.0; /* 3.0 clamps to the top */
    uint8_t *img = render(pos, 4, idx, 2, &o);
    uint8_t lo[3], hi[3];
    mr_colormap(0, lo);
    mr_colormap(1, hi);
    uint32_t clo = (uint32_t)lo[0] << 16 | (uint32_t)lo[1] << 8 | lo[2];
    uint32_t chi = (uint32_t)hi[0] << 16 | (uint32_t)hi[1] << 8 | hi[2];
    assert_int_equal(pixel(img, 64, 50, 40), clo); /* first triangle: lower right */
    assert_int_equal(pixel(img, 64, 14, 24), chi); /* second: upper left */
    free(img);

    /* Per-vertex values interpolate: 0 on the left edge, 1 on the right. */
    const float vheat[4] = {0, 1, 1, 0};
    o.face_scalar = NULL;
    o.vertex_scalar = vheat;
    o.scalar_min = 0;
    o.scalar_max = 1;
    img = render(pos, 4, idx, 2, &o);
    uint8_t mid[3];
    mr_colormap(32.5 / 64, mid); /* pixel centre x = 32.5 of 64 */
    uint32_t cmid = (uint32_t)mid[0] << 16 | (uint32_t)mid[1] << 8 | mid[2];
    uint8_t left[3];
    mr_colormap(0.5 / 64, left);
    assert_int_equal(pixel(img, 64, 0, 10),
                     (uint32_t)left[0] << 16 | (uint32_t)left[1] << 8 | left[2]);
    assert_int_equal(pixel(img, 64, 32, 50), cmid);
    free(img);

    /* Both kinds at once is an error. */
    o.face_scalar = heat;
    uint8_t buf[64 * 64 * 4];
    mr_error err;
    assert_int_equal(mr_render(pos, 4, idx, 2, &o, buf, 0, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "not both");
}

static void test_surface_distances(void **state)
{
    (void)state;
    /* Reference: the square [0,4]^2 at z = 0. Test: a triangle lifted to
     * z = 0.25 inside it, and one with two corners on the plane and one at
     * z = 1. */
    const float ref[12] = {0, 0, 0, 4, 0, 0, 4, 4, 0, 0, 4, 0};
    const uint32_t ref_idx[6] = {0, 1, 2, 0, 2, 3};
    const float test[18] = {1, 1, 0.25f, 2, 1, 0.25f, 1, 2, 0.25f,
                            2, 2, 0, 3, 2, 0, 2, 3, 1};
    const uint32_t test_idx[6] = {0, 1, 2, 3, 4, 5};
    float d[2];
    double mx = -1;
    mr_error err;
    assert_int_equal(mr_surface_distances(ref, 4, ref_idx, 2, test, 6, test_idx, 2, 0, d, &mx,
                                          &err),
                     MR_OK);
    assert_float_equal(d[0], 0.25, 1e-6);
    assert_float_equal(d[1], 1.0, 1e-6); /* the corner at z = 1 */
    assert_float_equal(mx, 1.0, 1e-6);

    /* A point cloud: one distance per point. */
    float p[6];
    assert_int_equal(mr_surface_distances(ref, 4, ref_idx, 2, test, 6, NULL, 0, 1, p, &mx, &err),
                     MR_OK);
    assert_float_equal(p[0], 0.25, 1e-6);
    assert_float_equal(p[3], 0.0, 1e-6);
    assert_float_equal(p[5], 1.0, 1e-6);

    /* No reference surface. */
    assert_int_equal(mr_surface_distances(ref, 4, NULL, 0, test, 6, test_idx, 2, 0, d, NULL,
                                          &err),
                     MR_ERR_EMPTY);
    tu_assert_contains(err.message, "no triangles");
    const uint32_t bad[3] = {0, 1, 9};
    assert_int_equal(mr_surface_distances(ref, 4, ref_idx, 2, test, 6, bad, 1, 0, d, NULL, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "vertex 9");
}

/* ---- fans of slivers ------------------------------------------------------------- */

#define FAN_PI 3.14159265358979323846

/*
 * The polygon of `corners` corners on the ellipse (cos t, 0.6 sin t, dz),
 * triangulated as the OBJ reader does a face `f 1 2 ... N` (the fan (0, i,
 * i + 1): one vertex in every triangle, long slivers) or, with `pinwheel`,
 * around an extra centre vertex (the last one).
 */
static mr_mesh polygon(size_t corners, int pinwheel, float dz)
{
    mr_mesh m;
    mr_mesh_init(&m);
    m.vertex_count = corners + (pinwheel ? 1 : 0);
    m.triangle_count = pinwheel ? corners : corners - 2;
    m.positions = malloc(3 * m.vertex_count * sizeof *m.positions);
    m.indices = malloc(3 * m.triangle_count * sizeof *m.indices);
    assert_non_null(m.positions);
    assert_non_null(m.indices);
    for (size_t i = 0; i < corners; i++) {
        const double t = 2 * FAN_PI * (double)i / (double)corners;
        m.positions[3 * i] = (float)cos(t);
        m.positions[3 * i + 1] = (float)(0.6 * sin(t));
        m.positions[3 * i + 2] = dz;
    }
    if (pinwheel) {
        float *c = m.positions + 3 * corners;
        c[0] = c[1] = 0;
        c[2] = dz;
    }
    for (size_t i = 0; i < m.triangle_count; i++) {
        uint32_t *t = m.indices + 3 * i;
        t[0] = pinwheel ? (uint32_t)corners : 0;
        t[1] = (uint32_t)(pinwheel ? i : i + 1);
        t[2] = (uint32_t)(pinwheel ? (i + 1) % corners : i + 2);
    }
    return m;
}

/* A 100,000-corner polygon (it took a minute when every sliver scanned its
 * whole bounding box): its pixels are the ellipse's, and exactly those of
 * another triangulation of the same polygon, as a triangulation cannot
 * change which samples a polygon covers (shared edges give each sample to
 * one side, the boundary edges are the same). */
static void test_fan_render(void **state)
{
    (void)state;
    const size_t n = 100000;
    mr_mesh fan = polygon(n, 0, 0), wheel = polygon(n, 1, 0);
    mr_render_options o;
    front_options(&o, 300);
    o.height = 200;
    for (int k = 1; k <= 3; k += 2) {
        o.supersample = k;
        uint8_t *a = render(fan.positions, fan.vertex_count, fan.indices, fan.triangle_count, &o);
        uint8_t *b = render(wheel.positions, wheel.vertex_count, wheel.indices,
                            wheel.triangle_count, &o);
        assert_memory_equal(a, b, 300 * 200 * 4);
        /* Framed without margin: 150 pixels per unit (the ellipse is 2 x
         * 1.2 units in 300 x 200 pixels), area pi 0.6 150^2 pixels. */
        const double want = FAN_PI * 0.6 * 150 * 150;
        const size_t got = count_not(a, 300, 200, 0xffffff);
        assert_true(fabs((double)got - want) < 0.01 * want);
        assert_int_equal(pixel(a, 300, 150, 100), o.color);
        assert_int_equal(pixel(a, 300, 2, 2), 0xffffff);
        free(a);
        free(b);
    }
    /* The wireframe: every sample is within a sliver's width of an edge. */
    o.wire = 1;
    uint8_t *w = render(fan.positions, fan.vertex_count, fan.indices, fan.triangle_count, &o);
    assert_int_equal(pixel(w, 300, 150, 100), o.wire_color);
    assert_int_equal(pixel(w, 300, 2, 2), 0xffffff);
    free(w);
    mr_mesh_free(&fan);
    mr_mesh_free(&wheel);
}

/* Wide triangles walk the exact span of each row, small ones scan their
 * box: the same samples and depths either way. A square as 2 triangles and
 * as 64 x 64 x 2 (their corners on the sample grid, so the outline is the
 * same), behind a triangle that crosses it, render identically. */
static void test_span_matches_box(void **state)
{
    (void)state;
    const int g = 64;
    const size_t nv = (size_t)(g + 1) * (g + 1) + 3, nt = 2 * (size_t)g * g + 1;
    float *pos = malloc(3 * nv * sizeof *pos);
    uint32_t *fine = malloc(3 * nt * sizeof *fine);
    float *heat = malloc(nt * sizeof *heat);
    for (int y = 0; y <= g; y++)
        for (int x = 0; x <= g; x++) {
            float *p = pos + 3 * ((size_t)y * (g + 1) + (size_t)x);
            p[0] = (float)x / g;
            p[1] = (float)y / g;
            p[2] = 0;
        }
    const float front[9] = {0.1f, 0.23f, 0.5f, 0.93f, 0.41f, 0.5f, 0.27f, 0.97f, 0.5f};
    memcpy(pos + 3 * (nv - 3), front, sizeof front);
    size_t k = 0;
    for (int y = 0; y < g; y++)
        for (int x = 0; x < g; x++) {
            const uint32_t i = (uint32_t)(y * (g + 1) + x);
            const uint32_t t[6] = {i, i + 1, i + g + 2, i, i + g + 2, i + g + 1};
            memcpy(fine + 3 * k, t, sizeof t);
            k += 2;
        }
    const uint32_t last[3] = {(uint32_t)nv - 3, (uint32_t)nv - 2, (uint32_t)nv - 1};
    memcpy(fine + 3 * k, last, sizeof last);
    const uint32_t c00 = 0, c10 = (uint32_t)g, c11 = (uint32_t)((g + 1) * (g + 1) - 1),
                   c01 = (uint32_t)(g * (g + 1));
    const uint32_t coarse[9] = {c00, c10, c11, c00, c11, c01, last[0], last[1], last[2]};
    for (size_t i = 0; i < nt; i++)
        heat[i] = i + 1 < nt ? 0.0f : 1.0f;
    const float coarse_heat[3] = {0, 0, 1};
    mr_render_options o;
    front_options(&o, 128);
    o.height = 96;
    o.scalar_min = 0;
    o.scalar_max = 1;
    for (int ss = 1; ss <= 3; ss++) {
        o.supersample = ss;
        o.face_scalar = heat;
        uint8_t *a = render(pos, nv, fine, nt, &o);
        o.face_scalar = coarse_heat;
        uint8_t *b = render(pos, nv, coarse, 3, &o);
        assert_memory_equal(a, b, 128 * 96 * 4);
        free(a);
        free(b);
    }
    free(pos);
    free(fine);
    free(heat);
}

/* The samples a triangle covers, independently of the rasterizer: with the
 * camera framed on the unit box from the front (no margin, 1 sample a
 * pixel), corner x maps to w / 2 + s (x - 0.5), y to h / 2 - s (y - 0.5),
 * s = min(w, h), rounded to 1/256 sample; a sample centre (i + 1/2, j +
 * 1/2) strictly inside counts in *inside, one exactly on an edge (which
 * the tie rule gives to one side or none) in *edge. */
static void expected_coverage(const float v[9], int w, int h, size_t *inside, size_t *edge)
{
    const double s = w < h ? w : h;
    int64_t x[3], y[3];
    for (int k = 0; k < 3; k++) {
        x[k] = (int64_t)lrint((0.5 * w + s * ((double)v[3 * k] - 0.5)) * 256);
        y[k] = (int64_t)lrint((0.5 * h - s * ((double)v[3 * k + 1] - 0.5)) * 256);
    }
    *inside = *edge = 0;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            const int64_t px = (int64_t)i * 256 + 128, py = (int64_t)j * 256 + 128;
            int pos = 0, neg = 0, zero = 0;
            for (int k = 0; k < 3; k++) {
                const int a = k, b = (k + 1) % 3;
                const int64_t o = (x[b] - x[a]) * (py - y[a]) - (y[b] - y[a]) * (px - x[a]);
                pos += o > 0;
                neg += o < 0;
                zero += o == 0;
            }
            if (zero == 0 && (pos == 3 || neg == 3))
                (*inside)++;
            else if (zero > 0 && (pos == 0 || neg == 0) && zero < 3)
                (*edge)++;
        }
}

/* Random triangles one at a time, wide and narrow, slivers in every
 * direction, some reaching out of the image: each covers the samples
 * inside it, plus some of those exactly on its edges, and no others. */
static void test_raster_exact_coverage(void **state)
{
    (void)state;
    const int w = 160, h = 120;
    mr_render_options o;
    front_options(&o, w);
    o.height = h;
    o.threads = 1; /* 400 small images: threads would only wait on each other */
    o.use_bounds = 1;
    for (int k = 0; k < 3; k++) {
        o.bounds_lo[k] = 0;
        o.bounds_hi[k] = 1;
    }
    const uint32_t idx[3] = {0, 1, 2};
    uint64_t rng = 77;
    for (int n = 0; n < 400; n++) {
        float v[9];
        for (int k = 0; k < 3; k++) {
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            v[3 * k] = (float)((rng >> 11) * 0x1p-53 * 1.2 - 0.1);
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            v[3 * k + 1] = (float)((rng >> 11) * 0x1p-53 * 1.2 - 0.1);
            v[3 * k + 2] = 0.5f;
        }
        if (n % 4 == 1) { /* a sliver: the third corner close to the first */
            v[6] = v[0] + (v[3] - v[0]) * 0.5f + 0.003f * (float)(n % 7);
            v[7] = v[1] + (v[4] - v[1]) * 0.5f - 0.002f * (float)(n % 5);
        } else if (n % 4 == 2) { /* small */
            for (int k = 3; k < 9; k += 3) {
                v[k] = v[0] + 0.03f * (v[k] - v[0]);
                v[k + 1] = v[1] + 0.03f * (v[k + 1] - v[1]);
            }
        }
        uint8_t *img = render(v, 3, idx, 1, &o);
        const size_t got = count_not(img, w, h, 0xffffff);
        size_t inside, edge;
        expected_coverage(v, w, h, &inside, &edge);
        if (!(got >= inside && got <= inside + edge)) {
            print_error("triangle %d: %zu pixels, want %zu inside + up to %zu on edges\n", n,
                        got, inside, edge);
            fail();
        }
        free(img);
    }
}

/* Heat values of a fan against a copy lifted off its plane: every face is
 * dz away; a sheet of both. */
static void test_fan_heat_and_sheet(void **state)
{
    (void)state;
    const size_t n = 100000;
    const float dz = 1e-3f;
    mr_mesh fan = polygon(n, 0, 0), lifted = polygon(n, 0, dz);
    float *d = malloc(fan.triangle_count * sizeof *d);
    double mx = 0;
    mr_error err;
    assert_int_equal(mr_surface_distances(lifted.positions, lifted.vertex_count, lifted.indices,
                                          lifted.triangle_count, fan.positions,
                                          fan.vertex_count, fan.indices, fan.triangle_count, 0,
                                          d, &mx, &err),
                     MR_OK);
    for (size_t i = 0; i < fan.triangle_count; i++)
        assert_float_equal(d[i], dz, 1e-9);
    assert_float_equal(mx, dz, 1e-9);

    mr_sheet_panel panels[2] = {
        {.positions = lifted.positions, .vertex_count = lifted.vertex_count,
         .indices = lifted.indices, .triangle_count = lifted.triangle_count, .caption = "lifted"},
        {.positions = fan.positions, .vertex_count = fan.vertex_count, .indices = fan.indices,
         .triangle_count = fan.triangle_count, .caption = "fan", .face_scalar = d}};
    mr_sheet_options so;
    mr_sheet_options_default(&so);
    so.render.width = 160;
    so.render.height = 120;
    so.scalar_max = 2 * dz;
    uint8_t *img;
    int w, h;
    assert_int_equal(mr_render_sheet(panels, 2, &so, &img, &w, &h, &err), MR_OK);
    assert_true(w > 2 * 160 && h > 120);
    free(img);
    free(d);
    mr_mesh_free(&fan);
    mr_mesh_free(&lifted);
}

/* ---- text and sheets ------------------------------------------------------------ */

static void test_text(void **state)
{
    (void)state;
    int w, h;
    mr_text_size("ab\ncde", 2, &w, &h);
    assert_int_equal(w, (3 * 6 - 1) * 2);
    assert_int_equal(h, (2 * 9 - 2) * 2);
    mr_text_size("", 1, &w, &h);
    assert_int_equal(w, 0);

    /* 'T' at scale 1: its top bar is row 0, columns 0..4; its stem column 2. */
    uint8_t img[8 * 10 * 4];
    memset(img, 255, sizeof img);
    mr_draw_text(img, 8, 10, 0, 1, 1, "T", 1, 0x000000);
    for (int x = 1; x <= 5; x++)
        assert_int_equal(pixel(img, 8, x, 1), 0);
    for (int y = 2; y <= 7; y++) {
        assert_int_equal(pixel(img, 8, 3, y), 0);
        assert_int_equal(pixel(img, 8, 2, y), 0xffffff);
    }
    assert_int_equal(pixel(img, 8, 0, 0), 0xffffff);
    /* Clipped at the border without writing outside. */
    mr_draw_text(img, 8, 10, 0, 5, 7, "WW", 3, 0x000000);
}

static void test_sheet_same_camera(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 2000, 1, &m, &err), MR_OK);
    float *heat = malloc(sizeof(float) * m.triangle_count);
    for (size_t i = 0; i < m.triangle_count; i++)
        heat[i] = 0.5f;
    mr_sheet_panel panels[2] = {
        {.positions = m.positions, .vertex_count = m.vertex_count, .indices = m.indices,
         .triangle_count = m.triangle_count, .caption = "first\nline 2"},
        {.positions = m.positions, .vertex_count = m.vertex_count, .indices = m.indices,
         .triangle_count = m.triangle_count, .caption = "second"}};
    mr_sheet_options so;
    mr_sheet_options_default(&so);
    so.render.width = 120;
    so.render.height = 100;
    uint8_t *img;
    int w, h;
    assert_int_equal(mr_render_sheet(panels, 2, &so, &img, &w, &h, &err), MR_OK);
    assert_true(w > 2 * 120 && w < 2 * 120 + 60);
    assert_true(h > 100 && h < 100 + 80);
    /* The same mesh in both panels, from one camera: the panels' pixels
     * are identical (panel 2 starts one cell further right). */
    int pad = 5, cell = 120 + 2 + pad;
    for (int y = pad + 1; y < pad + 1 + 100; y++)
        assert_memory_equal(img + 4 * ((size_t)y * w + pad + 1),
                            img + 4 * ((size_t)y * w + pad + 1 + cell), 120 * 4);
    free(img);

    /* With heat values: a colour bar is added below, its ends the
     * colour-map ends. */
    panels[1].face_scalar = heat;
    so.colorbar_label = "distance";
    int h2;
    assert_int_equal(mr_render_sheet(panels, 2, &so, &img, &w, &h2, &err), MR_OK);
    assert_true(h2 > h);
    uint8_t lo[3], hi[3];
    mr_colormap(0, lo);
    mr_colormap(1, hi);
    uint32_t clo = (uint32_t)lo[0] << 16 | (uint32_t)lo[1] << 8 | lo[2];
    uint32_t chi = (uint32_t)hi[0] << 16 | (uint32_t)hi[1] << 8 | hi[2];
    int found = 0;
    for (int y = h; y < h2 && !found; y++)
        for (int x = 0; x + 1 < w; x++)
            if (pixel(img, w, x, y) == clo) {
                /* Walk right along the bar to its last pixel. */
                int e = x;
                while (e + 1 < w && pixel(img, w, e + 1, y) != 0x808080)
                    e++;
                assert_int_equal(pixel(img, w, e, y), chi);
                found = 1;
                break;
            }
    assert_true(found);
    free(img);

    /* Bad input: no panels; a panel without vertices. */
    assert_int_equal(mr_render_sheet(panels, 0, &so, &img, &w, &h, &err), MR_ERR_EMPTY);
    panels[0].vertex_count = 0;
    assert_int_equal(mr_render_sheet(panels, 2, &so, &img, &w, &h, &err), MR_ERR_EMPTY);
    tu_assert_contains(err.message, "panel 1 has no vertices");
    assert_null(img);
    free(heat);
    mr_mesh_free(&m);
}

/* ---- bad input ------------------------------------------------------------------- */

static void test_bad_render_input(void **state)
{
    (void)state;
    mr_render_options o;
    mr_render_options_default(&o);
    o.width = 0;
    uint8_t buf[16 * 16 * 4];
    mr_error err;
    assert_int_equal(mr_render(tri_pos, 3, tri_idx, 1, &o, buf, 0, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "image size 0x768 is invalid");
    o.width = o.height = 16;
    o.supersample = 9;
    assert_int_equal(mr_render(tri_pos, 3, tri_idx, 1, &o, buf, 0, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "supersampling");
    o.supersample = 2;
    assert_int_equal(mr_render(tri_pos, 0, NULL, 0, &o, buf, 0, &err), MR_ERR_EMPTY);
    const uint32_t bad[3] = {0, 1, 3};
    assert_int_equal(mr_render(tri_pos, 3, bad, 1, &o, buf, 0, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "triangle 0 uses vertex 3");
    float nan_pos[9] = {0, 0, 0, 1, 0, 0, 0, NAN, 0};
    assert_int_equal(mr_render(nan_pos, 3, tri_idx, 1, &o, buf, 0, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "vertex 2 has a non-finite coordinate");
    assert_int_equal(mr_render(tri_pos, 3, tri_idx, 1, &o, buf, 8, &err),
                     MR_ERR_INVALID_ARGUMENT);
}

/* ---- PNG -------------------------------------------------------------------------- */

static uint8_t *read_png(const char *path, int *w, int *h)
{
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&im, path))
        return NULL;
    im.format = PNG_FORMAT_RGBA;
    uint8_t *buf = malloc(PNG_IMAGE_SIZE(im));
    if (!png_image_finish_read(&im, NULL, buf, 0, NULL)) {
        free(buf);
        return NULL;
    }
    *w = (int)im.width;
    *h = (int)im.height;
    return buf;
}

static void test_png_round_trip(void **state)
{
    (void)state;
    mr_render_options o;
    front_options(&o, 40);
    o.height = 30;
    uint8_t *img = render(tri_pos, 3, tri_idx, 1, &o);
    const char *path = tu_tmp_path("tri.png");
    mr_error err;
    assert_int_equal(mr_png_write(path, img, 40, 30, &err), MR_OK);
    int w, h;
    uint8_t *back = read_png(path, &w, &h);
    assert_non_null(back);
    assert_int_equal(w, 40);
    assert_int_equal(h, 30);
    assert_memory_equal(back, img, 40 * 30 * 4);
    free(back);

    /* Unwritable: an error naming the file, and no file. */
    const char *bad = "/nonexistent-dir/x.png";
    assert_int_equal(mr_png_write(bad, img, 40, 30, &err), MR_ERR_IO);
    tu_assert_contains(err.message, bad);
    assert_false(tu_file_exists(bad));
    assert_int_equal(mr_png_write(path, img, 0, 30, &err), MR_ERR_INVALID_ARGUMENT);
    free(img);
}

/* ---- textures, materials, vertex colours ------------------------------------------------ */

/* A 16 x 8 JPEG (quality 95, no chroma subsampling): its left half
 * (200, 40, 40), its right half (30, 60, 210). */
static const uint8_t two_colours_jpeg[] = {
    0xff, 0xd8, 0xff, 0xe0, 0x00, 0x10, 0x4a, 0x46, 0x49, 0x46, 0x00, 0x01, 0x01, 0x00, 0x00,
    0x01, 0x00, 0x01, 0x00, 0x00, 0xff, 0xdb, 0x00, 0x43, 0x00, 0x02, 0x01, 0x01, 0x01, 0x01,
    0x01, 0x02, 0x01, 0x01, 0x01, 0x02, 0x02, 0x02, 0x02, 0x02, 0x04, 0x03, 0x02, 0x02, 0x02,
    0x02, 0x05, 0x04, 0x04, 0x03, 0x04, 0x06, 0x05, 0x06, 0x06, 0x06, 0x05, 0x06, 0x06, 0x06,
    0x07, 0x09, 0x08, 0x06, 0x07, 0x09, 0x07, 0x06, 0x06, 0x08, 0x0b, 0x08, 0x09, 0x0a, 0x0a,
    0x0a, 0x0a, 0x0a, 0x06, 0x08, 0x0b, 0x0c, 0x0b, 0x0a, 0x0c, 0x09, 0x0a, 0x0a, 0x0a, 0xff,
    0xdb, 0x00, 0x43, 0x01, 0x02, 0x02, 0x02, 0x02, 0x02, 0x02, 0x05, 0x03, 0x03, 0x05, 0x0a,
    0x07, 0x06, 0x07, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a,
    0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a,
    0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a,
    0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0x0a, 0xff, 0xc0, 0x00, 0x11, 0x08, 0x00, 0x08,
    0x00, 0x10, 0x03, 0x01, 0x11, 0x00, 0x02, 0x11, 0x01, 0x03, 0x11, 0x01, 0xff, 0xc4, 0x00,
    0x15, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x07, 0x08, 0xff, 0xc4, 0x00, 0x14, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xff, 0xc4, 0x00,
    0x15, 0x01, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x09, 0x07, 0xff, 0xc4, 0x00, 0x14, 0x11, 0x01, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xff, 0xda, 0x00,
    0x0c, 0x03, 0x01, 0x00, 0x02, 0x11, 0x03, 0x11, 0x00, 0x3f, 0x00, 0x97, 0xd1, 0x32, 0x80,
    0x2f, 0x35, 0x81, 0x4d, 0xff, 0xd9
};

static int near_rgb(uint32_t c, int r, int g, int b, int tol)
{
    return abs((int)(c >> 16 & 255) - r) <= tol && abs((int)(c >> 8 & 255) - g) <= tol &&
           abs((int)(c & 255) - b) <= tol;
}

/* Colour c is mostly channel ch (0 red, 1 green, 2 blue; 3: white). */
static int mostly(uint32_t c, int ch)
{
    const int v[3] = {(int)(c >> 16 & 255), (int)(c >> 8 & 255), (int)(c & 255)};
    for (int k = 0; k < 3; k++)
        if (ch == 3 || k == ch ? v[k] < 200 : v[k] > 90)
            return 0;
    return 1;
}

static void test_image_decode(void **state)
{
    (void)state;
    mr_image im;
    mr_error err;
    /* JPEG: the two halves */
    assert_int_equal(mr_image_decode(two_colours_jpeg, sizeof two_colours_jpeg, "two.jpg", &im,
                                     &err),
                     MR_OK);
    assert_int_equal(im.width, 16);
    assert_int_equal(im.height, 8);
    assert_true(near_rgb(pixel(im.rgba, 16, 2, 4), 200, 40, 40, 6));
    assert_true(near_rgb(pixel(im.rgba, 16, 13, 4), 30, 60, 210, 6));
    assert_int_equal(im.rgba[3], 255);
    mr_image_free(&im);

    /* PNG: what mr_png_write wrote comes back */
    uint8_t px[4 * 6] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255,
                         10, 20, 30, 255, 40, 50, 60, 255, 70, 80, 90, 255};
    const char *path = tu_tmp_path("decode.png");
    assert_int_equal(mr_png_write(path, px, 3, 2, &err), MR_OK);
    assert_int_equal(mr_image_read(path, &im, &err), MR_OK);
    assert_int_equal(im.width, 3);
    assert_int_equal(im.height, 2);
    assert_memory_equal(im.rgba, px, sizeof px);
    mr_image_free(&im);

    /* Damaged and unknown data: one clear error each, no pixels */
    size_t n;
    char *png = tu_read_file(path, &n);
    assert_int_equal(mr_image_decode(png, n / 2, "half.png", &im, &err), MR_ERR_PARSE);
    tu_assert_contains(err.message, "half.png");
    assert_null(im.rgba);
    free(png);
    assert_int_equal(mr_image_decode(two_colours_jpeg, 100, "cut.jpg", &im, &err),
                     MR_ERR_PARSE);
    tu_assert_contains(err.message, "cut.jpg");
    assert_null(im.rgba);
    assert_int_equal(mr_image_decode("GIF89a....", 10, "x.gif", &im, &err), MR_ERR_UNSUPPORTED);
    tu_assert_contains(err.message, "neither a PNG nor a JPEG");
    assert_int_equal(mr_image_read("/nonexistent/t.png", &im, &err), MR_ERR_IO);
}

/* The unit square in the xy plane as two triangles, texture coordinates
 * equal to the positions (u right, v up). */
static const float quad_pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static const float quad_uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
static const uint32_t quad_idx[6] = {0, 1, 2, 0, 2, 3};

static void test_textured_render(void **state)
{
    (void)state;
    /* a 2 x 2 texture, top row red, green; bottom row blue, white */
    uint8_t tex[16] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255};
    mr_image im = {2, 2, tex};
    mr_render_material mat = {{1, 1, 1, 1}, &im, MR_WRAP_CLAMP, MR_WRAP_CLAMP, 1};
    mr_render_options o;
    front_options(&o, 64);
    o.texcoords = quad_uv;
    o.materials = &mat;
    o.material_count = 1;
    /* facing the camera (full light): each quarter shows its texel */
    uint8_t *img = render(quad_pos, 4, quad_idx, 2, &o);
    assert_true(near_rgb(pixel(img, 64, 8, 8), 255, 0, 0, 2));     /* top left */
    assert_true(near_rgb(pixel(img, 64, 56, 8), 0, 255, 0, 2));    /* top right */
    assert_true(near_rgb(pixel(img, 64, 8, 56), 0, 0, 255, 2));    /* bottom left */
    assert_true(near_rgb(pixel(img, 64, 56, 56), 255, 255, 255, 2));
    assert_true(mostly(pixel(img, 64, 16, 16), 0));
    assert_true(mostly(pixel(img, 64, 48, 48), 3));
    /* bilinear: between two texels, their blend */
    uint32_t mid = pixel(img, 64, 32, 16);
    assert_true((mid >> 16 & 255) > 60 && (mid >> 8 & 255) > 60);
    /* the same bytes at 1, 2, 3 and 8 threads */
    const int threads[] = {1, 2, 3, 8};
    for (int i = 0; i < 4; i++) {
        o.threads = threads[i];
        uint8_t *again = render(quad_pos, 4, quad_idx, 2, &o);
        assert_memory_equal(img, again, 64 * 64 * 4);
        free(again);
    }
    o.threads = 0;
    free(img);

    /* v down (glTF's way): the image upside down */
    mat.v_up = 0;
    img = render(quad_pos, 4, quad_idx, 2, &o);
    assert_true(near_rgb(pixel(img, 64, 8, 8), 0, 0, 255, 2));
    assert_true(near_rgb(pixel(img, 64, 8, 56), 255, 0, 0, 2));
    free(img);

    /* repeat: coordinates 0..2 show the texture twice across */
    mat.v_up = 1;
    mat.wrap_s = mat.wrap_t = MR_WRAP_REPEAT;
    const float uv2[8] = {0, 0, 2, 0, 2, 2, 0, 2};
    o.texcoords = uv2;
    img = render(quad_pos, 4, quad_idx, 2, &o);
    assert_true(mostly(pixel(img, 64, 8, 8), 0));
    assert_true(mostly(pixel(img, 64, 40, 8), 0));
    assert_true(mostly(pixel(img, 64, 24, 8), 1));
    assert_true(mostly(pixel(img, 64, 56, 56), 3));
    free(img);

    /* the material's colour multiplies the texture */
    o.texcoords = quad_uv;
    mat.wrap_s = mat.wrap_t = MR_WRAP_CLAMP;
    mat.color[1] = 0; /* (1, 0, 1): white becomes magenta, green black */
    img = render(quad_pos, 4, quad_idx, 2, &o);
    assert_true(near_rgb(pixel(img, 64, 56, 56), 255, 0, 255, 2));
    assert_true(near_rgb(pixel(img, 64, 56, 8), 0, 0, 0, 2));
    free(img);

    /* a texture without pixels is refused */
    mr_image empty = {0, 0, NULL};
    mat.texture = &empty;
    uint8_t buf[64 * 64 * 4];
    mr_error err;
    assert_int_equal(mr_render(quad_pos, 4, quad_idx, 2, &o, buf, 0, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "texture");
}

static void test_materials_and_vertex_colors(void **state)
{
    (void)state;
    mr_render_options o;
    front_options(&o, 64);
    /* per-face materials: the lower-right triangle red, the other plain */
    mr_render_material red = {{1, 0, 0, 1}, NULL, MR_WRAP_REPEAT, MR_WRAP_REPEAT, 0};
    const uint32_t fm[2] = {0, UINT32_MAX};
    o.materials = &red;
    o.material_count = 1;
    o.face_material = fm;
    uint8_t *img = render(quad_pos, 4, quad_idx, 2, &o);
    assert_true(near_rgb(pixel(img, 64, 56, 56), 255, 0, 0, 2));
    mr_render_options plain;
    front_options(&plain, 64);
    uint8_t *p = render(quad_pos, 4, quad_idx, 2, &plain);
    const uint32_t grey = pixel(p, 64, 8, 8);
    free(p);
    /* the plain face in the surface colour (in linear light, full light:
     * the colour itself) */
    assert_true(near_rgb(pixel(img, 64, 8, 8), (int)(grey >> 16), (int)(grey >> 8 & 255),
                         (int)(grey & 255), 2));
    free(img);

    /* vertex colours: interpolated across the face */
    const float vc[16] = {1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 1};
    mr_render_options v;
    front_options(&v, 64);
    v.vertex_colors = vc;
    img = render(quad_pos, 4, quad_idx, 2, &v);
    assert_true(mostly(pixel(img, 64, 32, 60), 0)); /* bottom: red */
    assert_true(mostly(pixel(img, 64, 32, 3), 2));  /* top: blue */
    assert_true(pixel(img, 64, 32, 32) != pixel(img, 64, 32, 40)); /* a gradient */
    free(img);
    /* and on a point cloud's splats */
    v.point_radius = 3;
    img = render(quad_pos, 4, NULL, 0, &v);
    size_t red_px = 0, blue_px = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            red_px += near_rgb(pixel(img, 64, x, y), 255, 0, 0, 40);
            blue_px += near_rgb(pixel(img, 64, x, y), 0, 0, 255, 40);
        }
    assert_true(red_px > 4 && blue_px > 4);
    free(img);
}

/* An OBJ's mtllib and usemtl: each face's material, Kd, map_Kd. */
static void test_obj_look(void **state)
{
    (void)state;
    const char *jpg = tu_tmp_path("look-two.jpg");
    tu_write_file(jpg, two_colours_jpeg, sizeof two_colours_jpeg);
    const char *mtl = tu_tmp_path("look.mtl");
    const char *m = "# two materials\nnewmtl plain\nKd 0.2 0.4 0.6\n\n"
                    "newmtl photo\nKd 1 1 1\nmap_Kd -clamp on look-two.jpg\n";
    tu_write_file(mtl, m, strlen(m));
    const char *obj = tu_tmp_path("look.obj");
    const char *o = "mtllib look.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                    "f 1/1 2/2 3/3\nusemtl photo\nf 1/1 2/2 3/3 4/4\nusemtl nothing\n"
                    "f 1/1 3/3 4/4\nusemtl plain\nf 1/1 2/2 3/3\n";
    tu_write_file(obj, o, strlen(o));
    mr_look look;
    mr_error err;
    assert_int_equal(mr_look_read(obj, &look, &err), MR_OK);
    assert_int_equal(look.mesh.triangle_count, 5);
    /* the materials in the order of the usemtl names: photo, nothing
     * (no library defines it: its faces plain), plain */
    assert_int_equal(look.material_count, 3);
    assert_non_null(look.face_material);
    const uint32_t want[5] = {UINT32_MAX, 0, 0, UINT32_MAX, 2};
    for (int i = 0; i < 5; i++)
        assert_int_equal(look.face_material[i], want[i]);
    assert_float_equal(look.materials[2].color[1], 0.4, 1e-6);
    assert_null(look.materials[2].texture);
    assert_non_null(look.materials[0].texture);
    assert_int_equal(look.materials[0].texture->width, 16);
    assert_int_equal(look.materials[0].wrap_s, MR_WRAP_CLAMP);
    assert_int_equal(look.materials[0].v_up, 1);
    mr_look_free(&look);

    /* a library whose last line has no line break: "Kd r" is grey r */
    const char *m3 = "newmtl plain\nKd 0.25";
    tu_write_file(mtl, m3, strlen(m3));
    assert_int_equal(mr_look_read(obj, &look, &err), MR_OK);
    for (int k = 0; k < 3; k++)
        assert_float_equal(look.materials[2].color[k], 0.25, 1e-6);
    mr_look_free(&look);

    /* a texture file missing: an error naming the material and the file */
    const char *m2 = "newmtl photo\nmap_Kd gone.png\n";
    tu_write_file(mtl, m2, strlen(m2));
    assert_int_equal(mr_look_read(obj, &look, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "photo");
    tu_assert_contains(err.message, "gone.png");
    assert_null(look.mesh.positions);
    /* the library missing too */
    remove(mtl);
    assert_int_equal(mr_look_read(obj, &look, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "look.mtl");
    /* render says so, and draws it --plain */
    const char *png = tu_tmp_path("look.png");
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o '%s' --size 40x40", obj, png), &out), 1);
    tu_assert_contains(out, "look.mtl");
    assert_false(tu_file_exists(png));
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o '%s' --size 40x40 --plain -q", obj, png),
                                NULL),
                     0);
    assert_true(tu_file_exists(png));
}

/* A glTF sample with a texture (when the shared data is there): its
 * material and texture read, and the render shows the texture's colours
 * where --plain shows one colour. */
static void test_gltf_look(void **state)
{
    (void)state;
    const char *duck = tu_shared_data("gltf/Duck/glTF-Binary/Duck.glb");
    if (!duck || !tu_file_exists(duck)) {
        skip();
        return;
    }
    mr_look look;
    mr_error err;
    mr_status st = mr_look_read(duck, &look, &err);
    if (st == MR_ERR_UNSUPPORTED) {
        skip(); /* built without glTF */
        return;
    }
    assert_int_equal(st, MR_OK);
    assert_int_equal(look.material_count, 1);
    assert_non_null(look.materials[0].texture);
    assert_true(look.materials[0].texture->width >= 64);
    assert_non_null(look.mesh.texcoords);
    for (size_t t = 0; t < look.mesh.triangle_count; t++)
        assert_int_equal(look.face_material[t], 0);
    mr_render_options o;
    mr_render_options_default(&o);
    o.width = o.height = 96;
    uint8_t *plain = render(look.mesh.positions, look.mesh.vertex_count, look.mesh.indices,
                            look.mesh.triangle_count, &o);
    o.texcoords = look.mesh.texcoords;
    o.face_material = look.face_material;
    o.materials = look.materials;
    o.material_count = look.material_count;
    uint8_t *tex = render(look.mesh.positions, look.mesh.vertex_count, look.mesh.indices,
                          look.mesh.triangle_count, &o);
    /* the duck is yellow: red and green well above blue where drawn */
    size_t yellow = 0, drawn = 0;
    for (int i = 0; i < 96 * 96; i++) {
        const uint8_t *p = tex + 4 * i;
        if (pixel(plain, 96, i % 96, i / 96) == 0xffffff)
            continue;
        drawn++;
        yellow += p[0] > p[2] + 60 && p[1] > p[2] + 60;
    }
    assert_true(drawn > 1000);
    assert_true(yellow > drawn / 2);
    free(plain);
    free(tex);
    mr_look_free(&look);
}

/* ---- the command-line tool ------------------------------------------------------------ */

static void test_cli_render(void **state)
{
    (void)state;
    const char *mesh = tu_tmp_path("render-sphere.ply");
    const char *low = tu_tmp_path("render-sphere-low.ply");
    assert_int_equal(
        tu_run_cli(tu_fmt("generate sphere --triangles 5000 -o '%s' -q", mesh), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 20%%", mesh, low), NULL), 0);

    const char *one = tu_tmp_path("render-one.png");
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o '%s' --size 160x120 --view front --wire",
                                       mesh, one),
                                &out),
                     0);
    tu_assert_contains(out, "160x120");
    free(out);
    int w, h;
    uint8_t *img = read_png(one, &w, &h);
    assert_non_null(img);
    assert_int_equal(w, 160);
    assert_int_equal(h, 120);
    assert_int_equal(pixel(img, w, 0, 0), 0xffffff);
    assert_int_not_equal(pixel(img, w, 80, 60), 0xffffff);
    free(img);

    /* A sheet with a heat map; --threads does not change a byte. */
    const char *sheet = tu_tmp_path("render-sheet.png");
    const char *sheet1 = tu_tmp_path("render-sheet1.png");
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' '%s' --error-to '%s' -o '%s' --size 100x100 "
                                       "--samples 10k --json",
                                       mesh, low, mesh, sheet),
                                &out),
                     0);
    tu_assert_contains(out, "\"hausdorff_rel\"");
    tu_assert_contains(out, "\"heat_max\"");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("--threads 1 render '%s' '%s' --error-to '%s' -o '%s' "
                                       "--size 100x100 --samples 10k",
                                       mesh, low, mesh, sheet1),
                                NULL),
                     0);
    size_t n1, n2;
    char *a = tu_read_file(sheet, &n1), *b = tu_read_file(sheet1, &n2);
    assert_non_null(a);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1);
    free(a);
    free(b);
}

static void test_cli_render_bad_input(void **state)
{
    (void)state;
    const char *png = tu_tmp_path("render-bad.png");
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("render /nonexistent/mesh.obj -o '%s'", png), &out), 1);
    tu_assert_contains(out, "/nonexistent/mesh.obj");
    free(out);
    assert_false(tu_file_exists(png));

    const char *mesh = tu_tmp_path("render-bad.obj");
    tu_write_file(mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 32);
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o '%s' --size 0x10", mesh, png), &out), 2);
    tu_assert_contains(out, "--size needs WIDTHxHEIGHT");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o '%s.jpg'", mesh, png), &out), 2);
    tu_assert_contains(out, "must be a .png");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o /nonexistent-dir/out.png", mesh), &out),
                     1);
    tu_assert_contains(out, "/nonexistent-dir/out.png");
    free(out);
    const char *broken = tu_tmp_path("render-broken.obj");
    tu_write_file(broken, "v 0 0 0\nf 1 2 3\n", 16);
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o '%s'", broken, png), &out), 1);
    tu_assert_contains(out, "render-broken.obj");
    free(out);
    assert_false(tu_file_exists(png));
    /* A point cloud cannot be the reference surface. */
    const char *cloud = tu_tmp_path("render-cloud.xyz");
    tu_write_file(cloud, "0 0 0\n1 0 0\n0 1 0\n", 18);
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' --error-to '%s' -o '%s'", mesh, cloud, png),
                                &out),
                     1);
    tu_assert_contains(out, "no triangles");
    free(out);
    assert_false(tu_file_exists(png));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_single_triangle),
        cmocka_unit_test(test_square_no_cracks_and_wire),
        cmocka_unit_test(test_cube),
        cmocka_unit_test(test_deterministic_across_threads),
        cmocka_unit_test(test_point_cloud),
        cmocka_unit_test(test_colormap_endpoints),
        cmocka_unit_test(test_heat_render_endpoints),
        cmocka_unit_test(test_surface_distances),
        cmocka_unit_test(test_fan_render),
        cmocka_unit_test(test_span_matches_box),
        cmocka_unit_test(test_raster_exact_coverage),
        cmocka_unit_test(test_fan_heat_and_sheet),
        cmocka_unit_test(test_text),
        cmocka_unit_test(test_sheet_same_camera),
        cmocka_unit_test(test_bad_render_input),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_cli_render),
        cmocka_unit_test(test_cli_render_bad_input),
        cmocka_unit_test(test_image_decode),
        cmocka_unit_test(test_textured_render),
        cmocka_unit_test(test_materials_and_vertex_colors),
        cmocka_unit_test(test_obj_look),
        cmocka_unit_test(test_gltf_look),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
