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
        {m.positions, m.vertex_count, m.indices, m.triangle_count, "first\nline 2", NULL, NULL},
        {m.positions, m.vertex_count, m.indices, m.triangle_count, "second", NULL, NULL}};
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
        cmocka_unit_test(test_text),
        cmocka_unit_test(test_sheet_same_camera),
        cmocka_unit_test(test_bad_render_input),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_cli_render),
        cmocka_unit_test(test_cli_render_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
