/* The PLY reader and writer: round trips, every type and layout the
 * reader accepts, skipped elements and properties, triangle strips, and
 * the errors bad files get. */
#define _DEFAULT_SOURCE /* MAP_ANONYMOUS, MAP_NORESERVE */
#include "testutil.h"

#include <math.h>
#include <sys/mman.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* Building PLY files in memory                                             */
/* ------------------------------------------------------------------------ */

enum { ASCII = 0, LE = 1, BE = 2 };
static const char *const enc_name[] = {"ascii", "binary_little_endian", "binary_big_endian"};

typedef struct builder {
    unsigned char *d;
    size_t n, cap;
    int enc;
} builder;

static void b_raw(builder *b, const void *p, size_t n)
{
    if (b->n + n + 1 > b->cap) {
        b->cap = (b->n + n + 1) * 2;
        b->d = realloc(b->d, b->cap);
        assert_non_null(b->d);
    }
    memcpy(b->d + b->n, p, n);
    b->n += n;
    b->d[b->n] = 0; /* handy for printing; not part of the file */
}

static void b_str(builder *b, const char *s) { b_raw(b, s, strlen(s)); }

/* "ply", the format line for the builder's encoding, `decl` (element and
 * property lines) and end_header. */
static void b_header(builder *b, int enc, const char *decl)
{
    memset(b, 0, sizeof *b);
    b->enc = enc;
    char line[128];
    snprintf(line, sizeof line, "ply\nformat %s 1.0\ncomment test\n", enc_name[enc]);
    b_str(b, line);
    b_str(b, decl);
    b_str(b, "end_header\n");
}

static int host_is_le(void)
{
    const uint16_t one = 1;
    unsigned char c;
    memcpy(&c, &one, 1);
    return c == 1;
}

/* One value of the named PLY type: as text (followed by a blank) or as
 * bytes in the builder's byte order. */
static void b_val(builder *b, const char *type, double v)
{
    if (b->enc == ASCII) {
        char s[64];
        snprintf(s, sizeof s, "%.17g ", v);
        b_str(b, s);
        return;
    }
    unsigned char bytes[8];
    size_t n;
    if (!strcmp(type, "char") || !strcmp(type, "int8")) {
        int8_t x = (int8_t)v;
        memcpy(bytes, &x, n = 1);
    } else if (!strcmp(type, "uchar") || !strcmp(type, "uint8")) {
        uint8_t x = (uint8_t)v;
        memcpy(bytes, &x, n = 1);
    } else if (!strcmp(type, "short") || !strcmp(type, "int16")) {
        int16_t x = (int16_t)v;
        memcpy(bytes, &x, n = 2);
    } else if (!strcmp(type, "ushort") || !strcmp(type, "uint16")) {
        uint16_t x = (uint16_t)v;
        memcpy(bytes, &x, n = 2);
    } else if (!strcmp(type, "int") || !strcmp(type, "int32")) {
        int32_t x = (int32_t)v;
        memcpy(bytes, &x, n = 4);
    } else if (!strcmp(type, "uint") || !strcmp(type, "uint32")) {
        uint32_t x = (uint32_t)v;
        memcpy(bytes, &x, n = 4);
    } else if (!strcmp(type, "float") || !strcmp(type, "float32")) {
        float x = (float)v;
        memcpy(bytes, &x, n = 4);
    } else {
        memcpy(bytes, &v, n = 8);
    }
    if ((b->enc == LE) != host_is_le())
        for (size_t i = 0; i < n / 2; i++) {
            unsigned char t = bytes[i];
            bytes[i] = bytes[n - 1 - i];
            bytes[n - 1 - i] = t;
        }
    b_raw(b, bytes, n);
}

static void b_row_end(builder *b)
{
    if (b->enc == ASCII)
        b_str(b, "\n");
}

static mr_status read_buf(const void *data, size_t size, int threads, mr_mesh *m,
                          mr_error *err)
{
    mr_read_options o;
    mr_read_options_default(&o);
    o.format = MR_FORMAT_PLY;
    o.threads = threads;
    return mr_mesh_read_memory(data, size, "x.ply", &o, m, err);
}

static mr_status read_builder(builder *b, mr_mesh *m, mr_error *err)
{
    return read_buf(b->d, b->n, 1, m, err);
}

static mr_status read_text(const char *text, mr_mesh *m, mr_error *err)
{
    return read_buf(text, strlen(text), 1, m, err);
}

static void assert_tris(const mr_mesh *m, const uint32_t *expect, size_t count)
{
    if (m->triangle_count != count) {
        print_error("expected %zu triangles, got %zu\n", count, m->triangle_count);
        fail();
    }
    for (size_t i = 0; i < 3 * count; i++)
        if (m->indices[i] != expect[i]) {
            print_error("index %zu: expected %u, got %u\n", i, expect[i], m->indices[i]);
            fail();
        }
}

/* ------------------------------------------------------------------------ */
/* Round trips                                                              */
/* ------------------------------------------------------------------------ */

/* A grid mesh of 60 x 40 vertices with arbitrary coordinates (made here,
 * so that the test depends on nothing but the PLY code), awkward values
 * in front, and on request normals and texture coordinates. */
static void make_mesh(mr_mesh *m, int normals, int texcoords)
{
    const size_t w = 60, h = 40;
    mr_error err;
    unsigned attrs = (normals ? MR_ATTR_NORMALS : 0) | (texcoords ? MR_ATTR_TEXCOORDS : 0);
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, w * h, 2 * (w - 1) * (h - 1), attrs, &err), MR_OK);
    uint32_t x = 99;
    for (size_t i = 0; i < m->vertex_count; i++)
        for (int k = 0; k < 3; k++) {
            x = x * 1664525u + 1013904223u;
            m->positions[3 * i + (size_t)k] =
                (float)(i % w) + (float)(x >> 8) / 16777216.0f * ldexpf(1.0f, (int)(x % 40) - 20);
        }
    m->positions[0] = -0.0f;
    m->positions[1] = 1e-40f; /* subnormal */
    m->positions[2] = 3.4e38f;
    m->positions[3] = -1.17549435e-38f;
    for (size_t i = 0; normals && i < m->vertex_count * 3; i++) {
        x = x * 1664525u + 1013904223u;
        m->normals[i] = (float)((x >> 8) & 0xffff) / 65536.0f - 0.5f;
    }
    for (size_t i = 0; texcoords && i < m->vertex_count * 2; i++) {
        x = x * 1664525u + 1013904223u;
        m->texcoords[i] = (float)x / 4294967296.0f * 3.0f - 1.0f;
    }
    uint32_t *t = m->indices;
    for (uint32_t r = 0; r + 1 < h; r++)
        for (uint32_t c = 0; c + 1 < w; c++) {
            uint32_t a = r * (uint32_t)w + c, b = a + 1, d = a + (uint32_t)w, e = d + 1;
            const uint32_t tri[6] = {a, b, e, a, e, d};
            memcpy(t, tri, sizeof tri);
            t += 6;
        }
}

static void test_round_trip_bit_exact(void **state)
{
    (void)state;
    const mr_encoding encs[] = {MR_ENCODING_ASCII, MR_ENCODING_BINARY_LE,
                                MR_ENCODING_BINARY_BE, MR_ENCODING_DEFAULT};
    for (int attrs = 0; attrs < 4; attrs++) {
        mr_mesh m;
        make_mesh(&m, attrs & 1, attrs & 2);
        for (int e = 0; e < 4; e++) {
            for (int cloud = 0; cloud < 2; cloud++) {
                mr_mesh src = m;
                if (cloud)
                    src.triangle_count = 0;
                mr_write_options w;
                mr_write_options_default(&w);
                w.encoding = encs[e];
                mr_error err;
                const char *path = tu_tmp_path("rt.ply");
                assert_int_equal(mr_mesh_write(path, &src, &w, &err), MR_OK);
                for (int threads = 1; threads <= 3; threads += 2) {
                    mr_read_options o;
                    mr_read_options_default(&o);
                    o.threads = threads;
                    mr_mesh r;
                    if (mr_mesh_read(path, &o, &r, &err) != MR_OK) {
                        print_error("%s\n", err.message);
                        fail();
                    }
                    tu_assert_mesh_equal(&src, &r);
                    if (cloud)
                        assert_null(r.indices);
                    mr_mesh_free(&r);
                }
            }
        }
        /* attributes present but not asked for are left out */
        mr_write_options w;
        mr_write_options_default(&w);
        w.write_normals = w.write_texcoords = 0;
        mr_error err;
        const char *path = tu_tmp_path("rt-plain.ply");
        assert_int_equal(mr_mesh_write(path, &m, &w, &err), MR_OK);
        mr_mesh r;
        assert_int_equal(mr_mesh_read(path, NULL, &r, &err), MR_OK);
        assert_null(r.normals);
        assert_null(r.texcoords);
        assert_memory_equal(r.positions, m.positions, m.vertex_count * 12);
        mr_mesh_free(&r);
        mr_mesh_free(&m);
    }
}

static void test_writer_header(void **state)
{
    (void)state;
    mr_mesh m;
    make_mesh(&m, 1, 0);
    mr_error err;
    const char *path = tu_tmp_path("hdr.ply");
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_OK);
    char *text = tu_read_file(path, NULL);
    assert_non_null(text);
    const char *start = "ply\nformat binary_little_endian 1.0\n"
                        "comment generated by meshreduce\n";
    assert_true(strncmp(text, start, strlen(start)) == 0);
    tu_assert_contains(text, "property float nx\n");
    tu_assert_contains(text, "element face ");
    tu_assert_contains(text, "property list uchar int vertex_indices\nend_header\n");
    free(text);

    /* a point cloud has no face element */
    m.triangle_count = 0;
    mr_write_options w;
    mr_write_options_default(&w);
    w.encoding = MR_ENCODING_ASCII;
    assert_int_equal(mr_mesh_write(path, &m, &w, &err), MR_OK);
    text = tu_read_file(path, NULL);
    assert_null(strstr(text, "element face"));
    tu_assert_contains(text, "format ascii 1.0\n");
    free(text);
    mr_mesh_free(&m);
}

static void test_colors_round_trip(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_alloc(&m, 300, 1, MR_ATTR_COLORS, &err), MR_OK);
    for (size_t i = 0; i < m.vertex_count; i++) {
        m.positions[3 * i] = (float)i;
        m.positions[3 * i + 1] = m.positions[3 * i + 2] = 0;
        for (int k = 0; k < 4; k++)
            m.colors[4 * i + k] = (float)((i * 7 + (size_t)k * 31) % 1000) / 999.0f;
    }
    m.colors[0] = -0.5f; /* clamped */
    m.colors[1] = 2.0f;
    m.indices[0] = 0;
    m.indices[1] = 1;
    m.indices[2] = 2;
    const mr_encoding encs[] = {MR_ENCODING_ASCII, MR_ENCODING_BINARY_LE,
                                MR_ENCODING_BINARY_BE};
    for (int e = 0; e < 3; e++) {
        mr_write_options w;
        mr_write_options_default(&w);
        w.encoding = encs[e];
        const char *path = tu_tmp_path("colors.ply");
        assert_int_equal(mr_mesh_write(path, &m, &w, &err), MR_OK);
        mr_mesh r;
        assert_int_equal(mr_mesh_read(path, NULL, &r, &err), MR_OK);
        assert_non_null(r.colors);
        assert_float_equal(r.colors[0], 0.0f, 1e-6);
        assert_float_equal(r.colors[1], 1.0f, 1e-6);
        for (size_t i = 2; i < 4 * m.vertex_count; i++)
            assert_float_equal(r.colors[i], m.colors[i], 1.0 / 255.0);
        mr_mesh_free(&r);
    }
    mr_mesh_free(&m);
}

/* ------------------------------------------------------------------------ */
/* Types and layouts                                                        */
/* ------------------------------------------------------------------------ */

static void test_coordinate_types(void **state)
{
    (void)state;
    const char *types[] = {"char",   "int8",   "uchar", "uint8",   "short",
                           "int16",  "ushort", "uint16", "int",    "int32",
                           "uint",   "uint32", "float", "float32", "double",
                           "float64"};
    for (int enc = 0; enc < 3; enc++)
        for (size_t t = 0; t < sizeof types / sizeof *types; t++) {
            char decl[512];
            snprintf(decl, sizeof decl,
                     "element vertex 3\nproperty %s x\nproperty %s y\nproperty %s z\n"
                     "element face 1\nproperty list uchar int vertex_indices\n",
                     types[t], types[t], types[t]);
            builder b;
            b_header(&b, enc, decl);
            for (int v = 0; v < 3; v++) {
                for (int k = 0; k < 3; k++)
                    b_val(&b, types[t], 10 * v + k + 1);
                b_row_end(&b);
            }
            b_val(&b, "uchar", 3);
            for (int k = 0; k < 3; k++)
                b_val(&b, "int", k);
            b_row_end(&b);
            mr_mesh m;
            mr_error err;
            if (read_builder(&b, &m, &err) != MR_OK) {
                print_error("%s %s: %s\n", enc_name[enc], types[t], err.message);
                fail();
            }
            assert_int_equal(m.vertex_count, 3);
            for (int v = 0; v < 3; v++)
                for (int k = 0; k < 3; k++)
                    assert_true(m.positions[3 * v + k] == (float)(10 * v + k + 1));
            assert_int_equal(m.triangle_count, 1);
            mr_mesh_free(&m);
            free(b.d);
        }

    /* fractional doubles round to the nearest float */
    builder b;
    b_header(&b, LE, "element vertex 1\nproperty double x\nproperty double y\n"
                     "property double z\n");
    b_val(&b, "double", 0.1);
    b_val(&b, "double", -1e-3);
    b_val(&b, "double", 12345.678);
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_builder(&b, &m, &err), MR_OK);
    assert_true(m.positions[0] == 0.1f && m.positions[1] == -1e-3f &&
                m.positions[2] == 12345.678f);
    mr_mesh_free(&m);
    free(b.d);
}

static void test_index_types(void **state)
{
    (void)state;
    const char *pairs[][2] = {{"uchar", "ushort"}, {"ushort", "int"},   {"char", "uchar"},
                              {"uint", "uint"},    {"int8", "int16"},   {"uint16", "uint32"},
                              {"int", "short"},    {"uchar", "uint8"}};
    for (int enc = 0; enc < 3; enc++)
        for (size_t t = 0; t < sizeof pairs / sizeof *pairs; t++) {
            char decl[512];
            snprintf(decl, sizeof decl,
                     "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face 2\nproperty list %s %s vertex_indices\n",
                     pairs[t][0], pairs[t][1]);
            builder b;
            b_header(&b, enc, decl);
            for (int v = 0; v < 4; v++) {
                for (int k = 0; k < 3; k++)
                    b_val(&b, "float", v == k + 1);
                b_row_end(&b);
            }
            const int faces[2][3] = {{0, 1, 2}, {3, 2, 1}};
            for (int f = 0; f < 2; f++) {
                b_val(&b, pairs[t][0], 3);
                for (int k = 0; k < 3; k++)
                    b_val(&b, pairs[t][1], faces[f][k]);
                b_row_end(&b);
            }
            mr_mesh m;
            mr_error err;
            if (read_builder(&b, &m, &err) != MR_OK) {
                print_error("%s %s %s: %s\n", enc_name[enc], pairs[t][0], pairs[t][1],
                            err.message);
                fail();
            }
            const uint32_t expect[] = {0, 1, 2, 3, 2, 1};
            assert_tris(&m, expect, 2);
            mr_mesh_free(&m);
            free(b.d);
        }
}

static void test_polygons_fan(void **state)
{
    (void)state;
    for (int enc = 0; enc < 3; enc++) {
        builder b;
        b_header(&b, enc,
                 "element vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
                 "element face 3\nproperty list uchar int vertex_indices\n");
        for (int v = 0; v < 6; v++) {
            b_val(&b, "float", v);
            b_val(&b, "float", v * v);
            b_val(&b, "float", 0);
            b_row_end(&b);
        }
        const int quad[] = {0, 1, 2, 3}, penta[] = {1, 2, 3, 4, 5}, tri[] = {5, 4, 0};
        b_val(&b, "uchar", 4);
        for (int k = 0; k < 4; k++)
            b_val(&b, "int", quad[k]);
        b_row_end(&b);
        b_val(&b, "uchar", 5);
        for (int k = 0; k < 5; k++)
            b_val(&b, "int", penta[k]);
        b_row_end(&b);
        b_val(&b, "uchar", 3);
        for (int k = 0; k < 3; k++)
            b_val(&b, "int", tri[k]);
        b_row_end(&b);
        mr_mesh m;
        mr_error err;
        assert_int_equal(read_builder(&b, &m, &err), MR_OK);
        const uint32_t expect[] = {0, 1, 2, 0, 2, 3, 1, 2, 3, 1, 3, 4, 1, 4, 5, 5, 4, 0};
        assert_tris(&m, expect, 6);
        mr_mesh_free(&m);
        free(b.d);

        /* a face of fewer than 3 corners is an error, as in OBJ (it was
         * dropped silently) */
        for (int n = 0; n < 3; n++) {
            b_header(&b, enc,
                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face 1\nproperty list uchar int vertex_indices\n");
            for (int v = 0; v < 3; v++) {
                b_val(&b, "float", v);
                b_val(&b, "float", 0);
                b_val(&b, "float", 0);
                b_row_end(&b);
            }
            b_val(&b, "uchar", n);
            for (int k = 0; k < n; k++)
                b_val(&b, "int", k);
            b_row_end(&b);
            assert_int_equal(read_builder(&b, &m, &err), MR_ERR_PARSE);
            tu_assert_contains(err.message, n == 0 ? "face 0 has no vertex indices"
                                                   : "face 0 has only");
            tu_assert_contains(err.message, "(a face needs at least 3)");
            mr_mesh_free(&m);
            free(b.d);
        }
    }
}

/* Attributes under their different names and types. */
static void test_vertex_attributes(void **state)
{
    (void)state;
    for (int enc = 0; enc < 3; enc++) {
        builder b;
        b_header(&b, enc,
                 "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                 "property float nx\nproperty float ny\nproperty float nz\n"
                 "property float texture_u\nproperty float texture_v\n"
                 "property uchar diffuse_red\nproperty uchar diffuse_green\n"
                 "property uchar diffuse_blue\n");
        for (int v = 0; v < 2; v++) {
            for (int k = 0; k < 8; k++)
                b_val(&b, "float", v * 10 + k);
            b_val(&b, "uchar", 255);
            b_val(&b, "uchar", 0);
            b_val(&b, "uchar", 51);
            b_row_end(&b);
        }
        mr_mesh m;
        mr_error err;
        assert_int_equal(read_builder(&b, &m, &err), MR_OK);
        assert_int_equal(m.triangle_count, 0);
        assert_non_null(m.normals);
        assert_non_null(m.texcoords);
        assert_non_null(m.colors);
        assert_true(m.normals[3] == 13.0f && m.texcoords[2] == 16.0f && m.texcoords[3] == 17.0f);
        assert_float_equal(m.colors[4], 1.0f, 1e-7);
        assert_float_equal(m.colors[5], 0.0f, 1e-7);
        assert_float_equal(m.colors[6], 0.2f, 1e-7);
        assert_float_equal(m.colors[7], 1.0f, 0); /* no alpha: opaque */
        mr_mesh_free(&m);
        free(b.d);
    }
    /* float colors as they are; u v texcoords; incomplete normals ignored */
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_text("ply\nformat ascii 1.0\nelement vertex 1\n"
                               "property float x\nproperty float y\nproperty float z\n"
                               "property float nx\nproperty float u\nproperty float v\n"
                               "property float red\nproperty float green\n"
                               "property float blue\nproperty float alpha\nend_header\n"
                               "1 2 3 0.5 0.25 0.75 0.1 0.2 0.3 0.4\n",
                               &m, &err),
                     MR_OK);
    assert_null(m.normals);
    assert_true(m.texcoords[0] == 0.25f && m.texcoords[1] == 0.75f);
    assert_true(m.colors[0] == 0.1f && m.colors[3] == 0.4f);
    mr_mesh_free(&m);
}

/* Elements and properties the reader does not use are stepped over in
 * every encoding, lists included. */
static void test_unknown_skipped(void **state)
{
    (void)state;
    for (int enc = 0; enc < 3; enc++) {
        builder b;
        b_header(&b, enc,
                 "element material 2\nproperty uchar id\nproperty list uchar float weights\n"
                 "element vertex 3\nproperty double quality\nproperty float x\n"
                 "property list ushort int neighbours\nproperty float y\n"
                 "property short flags\nproperty float z\nproperty float confidence\n"
                 "element face 2\nproperty int tag\n"
                 "property list uchar uint texnumbers\n"
                 "property list uchar int vertex_indices\n"
                 "property list int double extra\nproperty uchar flag\n"
                 "element camera 1\nproperty float view_px\nproperty list uint char name\n");
        for (int i = 0; i < 2; i++) { /* material */
            b_val(&b, "uchar", i);
            b_val(&b, "uchar", 2 + i);
            for (int k = 0; k < 2 + i; k++)
                b_val(&b, "float", 0.5 * k);
            b_row_end(&b);
        }
        for (int v = 0; v < 3; v++) {
            b_val(&b, "double", 99.5);
            b_val(&b, "float", v);
            b_val(&b, "ushort", v);
            for (int k = 0; k < v; k++)
                b_val(&b, "int", -k);
            b_val(&b, "float", v + 10);
            b_val(&b, "short", -7);
            b_val(&b, "float", v + 20);
            b_val(&b, "float", 1);
            b_row_end(&b);
        }
        const int faces[2][3] = {{0, 1, 2}, {2, 1, 0}};
        for (int f = 0; f < 2; f++) {
            b_val(&b, "int", 1000 + f);
            b_val(&b, "uchar", f);
            for (int k = 0; k < f; k++)
                b_val(&b, "uint", 5);
            b_val(&b, "uchar", 3);
            for (int k = 0; k < 3; k++)
                b_val(&b, "int", faces[f][k]);
            b_val(&b, "int", 2);
            b_val(&b, "double", 1.5);
            b_val(&b, "double", 2.5);
            b_val(&b, "uchar", 1);
            b_row_end(&b);
        }
        b_val(&b, "float", 3);
        b_val(&b, "uint", 3);
        for (int k = 0; k < 3; k++)
            b_val(&b, "char", 'a' + k);
        b_row_end(&b);
        mr_mesh m;
        mr_error err;
        if (read_builder(&b, &m, &err) != MR_OK) {
            print_error("%s: %s\n", enc_name[enc], err.message);
            fail();
        }
        assert_int_equal(m.vertex_count, 3);
        for (int v = 0; v < 3; v++) {
            assert_true(m.positions[3 * v] == (float)v);
            assert_true(m.positions[3 * v + 1] == (float)(v + 10));
            assert_true(m.positions[3 * v + 2] == (float)(v + 20));
        }
        const uint32_t expect[] = {0, 1, 2, 2, 1, 0};
        assert_tris(&m, expect, 2);
        assert_null(m.normals);
        assert_null(m.colors);
        mr_mesh_free(&m);
        free(b.d);
    }
}

static void test_tristrips(void **state)
{
    (void)state;
    /* Strip 0 1 2 3 4, restart, 5 6 7 7 8 9 (a repeated vertex: two
     * degenerate connectors); a second row 3 2 9. By the strip rule
     * (odd triangles swap their first two vertices):
     *   (0,1,2) (2,1,3) (2,3,4) | (5,6,7) [(7,6,7)] [(7,7,8)] (8,7,9) || (3,2,9) */
    const int strip0[] = {0, 1, 2, 3, 4, -1, 5, 6, 7, 7, 8, 9};
    const int strip1[] = {3, 2, 9};
    const uint32_t expect[] = {0, 1, 2, 2, 1, 3, 2, 3, 4, 5, 6, 7, 8, 7, 9, 3, 2, 9};
    for (int enc = 0; enc < 3; enc++) {
        builder b;
        b_header(&b, enc,
                 "element vertex 10\nproperty float x\nproperty float y\nproperty float z\n"
                 "element tristrips 2\nproperty list int int vertex_indices\n");
        for (int v = 0; v < 10; v++) {
            b_val(&b, "float", v);
            b_val(&b, "float", v % 3);
            b_val(&b, "float", v % 2);
            b_row_end(&b);
        }
        b_val(&b, "int", 12);
        for (int k = 0; k < 12; k++)
            b_val(&b, "int", strip0[k]);
        b_row_end(&b);
        b_val(&b, "int", 3);
        for (int k = 0; k < 3; k++)
            b_val(&b, "int", strip1[k]);
        b_row_end(&b);
        mr_mesh m;
        mr_error err;
        if (read_builder(&b, &m, &err) != MR_OK) {
            print_error("%s: %s\n", enc_name[enc], err.message);
            fail();
        }
        assert_tris(&m, expect, 6);
        mr_mesh_free(&m);
        free(b.d);
    }

    /* -2 is not a restart, and indices are range-checked */
    mr_mesh m;
    mr_error err;
    const char *head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                       "property float y\nproperty float z\nelement tristrips 1\n"
                       "property list int int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n";
    char text[512];
    snprintf(text, sizeof text, "%s4 0 1 -2 2\n", head);
    assert_int_equal(read_text(text, &m, &err), MR_ERR_PARSE);
    tu_assert_contains(err.message, "x.ply:13: triangle strip 0: negative vertex index -2");
    snprintf(text, sizeof text, "%s4 0 1 2 3\n", head);
    assert_int_equal(read_text(text, &m, &err), MR_ERR_PARSE);
    tu_assert_contains(err.message, "vertex index 3 is out of range");
}

static void test_point_cloud(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_text("ply\r\nformat ascii 1.0\r\ncomment crlf header\r\n"
                               "element vertex 2\r\nproperty float x\r\nproperty float y\r\n"
                               "property float z\r\nend_header\r\n1 2 3\r\n4 5 6\r\n",
                               &m, &err),
                     MR_OK);
    assert_int_equal(m.vertex_count, 2);
    assert_int_equal(m.triangle_count, 0);
    assert_true(m.positions[5] == 6.0f);
    mr_mesh_free(&m);

    /* a face element with no rows is a point cloud too */
    assert_int_equal(read_text("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 0\n"
                               "property list uchar int vertex_indices\nend_header\n1 2 3\n",
                               &m, &err),
                     MR_OK);
    assert_int_equal(m.triangle_count, 0);
    mr_mesh_free(&m);
}

/* Large enough for many parallel chunks: fixed-stride triangles and
 * mixed polygons give the same result at any thread count, errors
 * included. */
static void test_threads_agree(void **state)
{
    (void)state;
    const size_t nv = 50000, nf = 100000;
    for (int mixed = 0; mixed < 2; mixed++) {
        builder b;
        char decl[256];
        snprintf(decl, sizeof decl,
                 "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n"
                 "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                 "element face %zu\nproperty list uchar int vertex_indices\n",
                 nv, nf);
        b_header(&b, LE, decl);
        for (size_t v = 0; v < nv; v++) {
            b_val(&b, "float", (double)v);
            b_val(&b, "float", (double)(v % 100));
            b_val(&b, "float", 0.5);
            for (int k = 0; k < 3; k++)
                b_val(&b, "uchar", (double)((v + (size_t)k) % 256));
        }
        size_t tris = 0;
        for (size_t f = 0; f < nf; f++) {
            int n = mixed && f % 7 == 3 ? 4 : 3;
            b_val(&b, "uchar", n);
            for (int k = 0; k < n; k++)
                b_val(&b, "int", (double)((f * 13 + (size_t)k * 101) % nv));
            tris += (size_t)n - 2;
        }
        mr_mesh one, many;
        mr_error err;
        assert_int_equal(read_buf(b.d, b.n, 1, &one, &err), MR_OK);
        assert_int_equal(read_buf(b.d, b.n, 4, &many, &err), MR_OK);
        assert_int_equal(one.triangle_count, tris);
        tu_assert_mesh_equal(&one, &many);
        assert_float_equal(one.colors[4 * 300 + 1], 45.0f / 255.0f, 1e-7);
        mr_mesh_free(&one);
        mr_mesh_free(&many);

        /* two bad indices far apart: the first one is reported */
        size_t body = b.n - (nf * 13 + (mixed ? (nf + 3) / 7 * 4 : 0)) - nv * 15;
        size_t late = b.n - 4, early = body + nv * 15 + 20000 * 13 + 1;
        int32_t bad = (int32_t)nv, neg = -5;
        memcpy(b.d + late, &bad, 4);
        if (!mixed)
            memcpy(b.d + early, &neg, 4);
        mr_error e1, e4;
        assert_int_equal(read_buf(b.d, b.n, 1, &one, &e1), MR_ERR_PARSE);
        assert_int_equal(read_buf(b.d, b.n, 4, &many, &e4), MR_ERR_PARSE);
        assert_string_equal(e1.message, e4.message);
        if (!mixed) {
            tu_assert_contains(e1.message, "face 20000: negative vertex index -5");
            assert_int_equal(e1.offset, early);
        } else {
            tu_assert_contains(e1.message, "vertex index 50000 is out of range");
            assert_int_equal(e1.offset, late);
        }
        free(b.d);
    }
}

/* ------------------------------------------------------------------------ */
/* Bad files                                                                */
/* ------------------------------------------------------------------------ */

static const char *const tri_ascii_head =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

static void expect_error(const char *text, mr_status status, const char *needle)
{
    mr_mesh m;
    mr_error err;
    mr_status st = read_text(text, &m, &err);
    if (st != status) {
        print_error("expected status %s, got %s (%s) for:\n%s\n", mr_status_string(status),
                    mr_status_string(st), err.message, text);
        fail();
    }
    tu_assert_contains(err.message, needle);
    assert_int_equal(m.vertex_count, 0);
    assert_null(m.positions);
}

static void test_bad_headers(void **state)
{
    (void)state;
    expect_error("ply\nformat binary_middle_endian 1.0\nend_header\n", MR_ERR_UNSUPPORTED,
                 "x.ply:2: unknown format 'binary_middle_endian'");
    expect_error("ply\nformat ascii 2.0\nend_header\n", MR_ERR_UNSUPPORTED,
                 "x.ply:2: format version '2.0'");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property int128 y\nproperty float z\nend_header\n0 0 0\n",
                 MR_ERR_UNSUPPORTED, "x.ply:5: unknown property type 'int128'");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property list float int y\nend_header\n0 0 0\n",
                 MR_ERR_UNSUPPORTED, "x.ply:5: list count type 'float' is not an integer");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property float y\nproperty float z\n",
                 MR_ERR_PARSE, "x.ply: the header has no end_header line");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property float y\nproperty float z\n0 0 0\n",
                 MR_ERR_PARSE, "x.ply:7: unexpected '0' in the header");
    expect_error("ply\nelement vertex 1\nproperty float x\nend_header\n0\n", MR_ERR_PARSE,
                 "no format line");
    expect_error("ply\nformat ascii 1.0\nproperty float x\nend_header\n", MR_ERR_PARSE,
                 "x.ply:3: property before any element");
    expect_error("ply\nformat ascii 1.0\nelement vertex -4\nend_header\n", MR_ERR_PARSE,
                 "x.ply:3: expected 'element NAME COUNT'");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\n"
                 "property float z\nend_header\n0 0\n",
                 MR_ERR_PARSE, "x.ply:3: the vertex element has no 'x' property");
    expect_error("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                 "property float y\nproperty float z\nend_header\n",
                 MR_ERR_EMPTY, "no vertices");
    expect_error("ply\nformat ascii 1.0\nelement face 0\n"
                 "property list uchar int vertex_indices\nend_header\n",
                 MR_ERR_EMPTY, "no vertices");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property float y\nproperty float z\nelement face 1\n"
                 "property list uchar float vertex_indices\nend_header\n0 0 0\n3 0 0 0\n",
                 MR_ERR_UNSUPPORTED, "face vertex indices must be integers");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property float y\nproperty float z\nelement face 1\n"
                 "property list uchar int corners\nend_header\n0 0 0\n3 0 0 0\n",
                 MR_ERR_PARSE, "x.ply:7: the face element has no vertex_indices list");

    /* not a PLY at all, with the format forced */
    mr_read_options o;
    mr_read_options_default(&o);
    o.format = MR_FORMAT_PLY;
    mr_mesh m;
    mr_error err;
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    assert_int_equal(mr_mesh_read_memory(obj, strlen(obj), "tri.obj", &o, &m, &err),
                     MR_ERR_PARSE);
    tu_assert_contains(err.message, "tri.obj: not a PLY file");
}

static void test_bad_ascii_bodies(void **state)
{
    (void)state;
    char text[1024];
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE,
                 "x.ply:13: face 0: vertex index 3 is out of range (there are 3 vertices)");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "x.ply:13: face 0: negative vertex index -1");
    snprintf(text, sizeof text, "%s0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "x.ply:11: vertex 1 has a non-finite coordinate");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "x.ply:12: vertex 2 has a non-finite coordinate");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 1e39\n3 0 1 2\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "vertex 2 has a non-finite coordinate");
    snprintf(text, sizeof text, "%s0 0 0\n1 zz 0\n0 1 0\n3 0 1 2\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "x.ply:11: vertex 1: expected a number for 'y', found 'zz'");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "x.ply:13: file ends inside face 0 of 1");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 2 7\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "x.ply:13: unexpected '7' after the last element");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "value 300 of 'vertex_indices' is out of range");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", tri_ascii_head);
    expect_error(text, MR_ERR_PARSE, "expected an integer for 'vertex_indices', found '1.5'");
    /* more rows announced than the text can hold: refused before reading */
    expect_error("ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n"
                 "property float y\nproperty float z\nend_header\n0 0 0\n",
                 MR_ERR_PARSE,
                 "x.ply:8: file ends before the 1000000000000 vertices its header announces");
}

/* A binary file with three vertices and one triangle, and where its
 * header ends. */
static void tri_binary(builder *b, int enc, size_t *body)
{
    b_header(b, enc,
             "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list uchar int vertex_indices\n");
    *body = b->n;
    for (int v = 0; v < 3; v++)
        for (int k = 0; k < 3; k++)
            b_val(b, "float", v == k);
    b_val(b, "uchar", 3);
    for (int k = 0; k < 3; k++)
        b_val(b, "int", k);
}

static void expect_binary_error(const builder *b, size_t size, mr_status status,
                                const char *needle, uint64_t offset)
{
    mr_mesh m;
    mr_error err;
    mr_status st = read_buf(b->d, size, 2, &m, &err);
    if (st != status) {
        print_error("expected %s, got %s: %s\n", mr_status_string(status),
                    mr_status_string(st), err.message);
        fail();
    }
    tu_assert_contains(err.message, needle);
    assert_int_equal(err.offset, offset);
    assert_int_equal(err.line, MR_NO_POSITION);
}

static void test_bad_binary_bodies(void **state)
{
    (void)state;
    for (int enc = LE; enc <= BE; enc++) {
        builder b;
        size_t body;
        tri_binary(&b, enc, &body);
        mr_mesh m;
        mr_error err;
        assert_int_equal(read_builder(&b, &m, &err), MR_OK);
        mr_mesh_free(&m);

        char needle[128];
        snprintf(needle, sizeof needle,
                 "x.ply: byte %zu: file ends before the 3 vertices its header announces", body);
        expect_binary_error(&b, body + 20, MR_ERR_PARSE, needle, body);
        snprintf(needle, sizeof needle, "x.ply: byte %zu: file ends before the 1 faces", body + 36);
        expect_binary_error(&b, body + 36, MR_ERR_PARSE, needle, body + 36);
        /* the count byte is there, not the whole list */
        expect_binary_error(&b, b.n - 3, MR_ERR_PARSE,
                            "file ends inside face 0: its list of 3 items needs 12 bytes, 9 "
                            "remain",
                            body + 37);

        /* index out of range, negative, and a NaN coordinate */
        builder c = b;
        c.d = malloc(b.n + 1);
        c.cap = b.n + 1;
        memcpy(c.d, b.d, b.n);
        c.n = b.n - 4;
        b_val(&c, "int", 3);
        snprintf(needle, sizeof needle, "byte %zu: face 0: vertex index 3 is out of range",
                 body + 45);
        expect_binary_error(&c, c.n, MR_ERR_PARSE, needle, body + 45);
        c.n = b.n - 8;
        b_val(&c, "int", -1);
        b_val(&c, "int", 2);
        expect_binary_error(&c, c.n, MR_ERR_PARSE, "face 0: negative vertex index -1",
                            body + 41);
        memcpy(c.d, b.d, b.n);
        c.n = body + 12;
        b_val(&c, "float", NAN);
        c.n = b.n;
        expect_binary_error(&c, c.n, MR_ERR_PARSE, "vertex 1 has a non-finite coordinate",
                            body + 12);
        free(c.d);
        free(b.d);
    }

    /* huge announced counts fail at once, without allocating for them */
    const char *heads[] = {
        "element vertex 1099511627776\nproperty float x\nproperty float y\n"
        "property float z\n",
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 4000000000\nproperty list uchar int vertex_indices\n",
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element blob 9223372036854775807\nproperty list uint uchar data\n",
    };
    const char *needles[] = {"file ends before the 1099511627776 vertices",
                             "file ends before the 4000000000 faces",
                             "file ends before the 9223372036854775807 'blob' elements"};
    for (int i = 0; i < 3; i++) {
        builder b;
        b_header(&b, LE, heads[i]);
        for (int k = 0; k < 9; k++)
            b_val(&b, "float", k);
        mr_mesh m;
        mr_error err;
        assert_int_equal(read_builder(&b, &m, &err), MR_ERR_PARSE);
        tu_assert_contains(err.message, needles[i]);
        free(b.d);
    }
    /* a list that claims four billion items */
    builder b;
    b_header(&b, LE,
             "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list uint int vertex_indices\n");
    for (int k = 0; k < 9; k++)
        b_val(&b, "float", k);
    b_val(&b, "uint", 4294967295.0);
    b_val(&b, "int", 0);
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_builder(&b, &m, &err), MR_ERR_PARSE);
    tu_assert_contains(err.message, "its list of 4294967295 items needs");
    free(b.d);
}

/* A header announcing more vertices than 32-bit indices can address, over
 * a body that is really that large: a mapping of untouched zero pages, of
 * which the reader must read nothing but the header. */
static void test_too_many_vertices(void **state)
{
    (void)state;
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\n"
                       "property char x\nproperty char y\nproperty char z\n"
                       "element empty 9000000000000000000\nend_header\n";
    size_t size = strlen(head) + (size_t)3 * 4294967295u;
    void *map = mmap(NULL, size, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (map == MAP_FAILED)
        skip();
    memcpy(map, head, strlen(head));
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_buf(map, size, 2, &m, &err), MR_ERR_TOO_LARGE);
    tu_assert_contains(err.message, "x.ply: 4294967295 vertices exceed the 32-bit index limit");
    /* one byte short, it is a truncated file instead */
    assert_int_equal(read_buf(map, size - 1, 2, &m, &err), MR_ERR_PARSE);
    tu_assert_contains(err.message, "file ends before the 4294967295 vertices");
    munmap(map, size);

    /* rows without properties cost nothing to skip, even in ascii */
    assert_int_equal(read_text("ply\nformat ascii 1.0\nelement nothing 9000000000000000000\n"
                               "element vertex 1\nproperty float x\nproperty float y\n"
                               "property float z\nend_header\n1 2 3\n",
                               &m, &err),
                     MR_OK);
    assert_int_equal(m.vertex_count, 1);
    mr_mesh_free(&m);
}

/* ------------------------------------------------------------------------ */
/* Shared data                                                              */
/* ------------------------------------------------------------------------ */

static void test_igea_tristrips(void **state)
{
    (void)state;
    const char *path = tu_shared_data("igea.ply");
    if (!path)
        skip();
    mr_mesh m;
    mr_error err;
    if (mr_mesh_read(path, NULL, &m, &err) != MR_OK) {
        print_error("%s\n", err.message);
        fail();
    }
    assert_int_equal(m.vertex_count, 134345);
    assert_true(m.triangle_count > 200000);
    for (size_t t = 0; t < m.triangle_count; t++) {
        const uint32_t *v = m.indices + 3 * t;
        assert_true(v[0] < m.vertex_count && v[1] < m.vertex_count && v[2] < m.vertex_count);
        assert_true(v[0] != v[1] && v[1] != v[2] && v[0] != v[2]);
    }
    mr_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_bit_exact),
        cmocka_unit_test(test_writer_header),
        cmocka_unit_test(test_colors_round_trip),
        cmocka_unit_test(test_coordinate_types),
        cmocka_unit_test(test_index_types),
        cmocka_unit_test(test_polygons_fan),
        cmocka_unit_test(test_vertex_attributes),
        cmocka_unit_test(test_unknown_skipped),
        cmocka_unit_test(test_tristrips),
        cmocka_unit_test(test_point_cloud),
        cmocka_unit_test(test_threads_agree),
        cmocka_unit_test(test_bad_headers),
        cmocka_unit_test(test_bad_ascii_bodies),
        cmocka_unit_test(test_bad_binary_bodies),
        cmocka_unit_test(test_too_many_vertices),
        cmocka_unit_test(test_igea_tristrips),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
