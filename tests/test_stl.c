/* STL reader and writer: binary and ascii, welding, format detection,
 * and the diagnostics for malformed files. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- building test input --------------------------------------------- */

static void put_le32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

static uint32_t get_le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put_float(unsigned char *p, float f)
{
    uint32_t bits;
    memcpy(&bits, &f, 4);
    put_le32(p, bits);
}

static float get_float(const unsigned char *p)
{
    uint32_t bits = get_le32(p);
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

/*
 * A binary STL of `stored` triangles (9 floats each in `corners`) whose
 * header announces `announced` triangles and starts with `header_text`
 * (padded with spaces, so that only the size tells it from ascii).
 * Returns a malloc'd buffer and its size in *size.
 */
static unsigned char *binary_stl(const char *header_text, uint32_t announced,
                                 const float *corners, size_t stored, size_t *size)
{
    *size = 84 + 50 * stored;
    unsigned char *buf = calloc(1, *size);
    assert_non_null(buf);
    memset(buf, ' ', 80);
    memcpy(buf, header_text, strlen(header_text));
    put_le32(buf + 80, announced);
    for (size_t t = 0; t < stored; t++) {
        unsigned char *rec = buf + 84 + 50 * t;
        for (int i = 0; i < 9; i++)
            put_float(rec + 12 + 4 * i, corners[9 * t + (size_t)i]);
    }
    return buf;
}

/* Two triangles of the unit quad, corners stored separately as STL does. */
static const float quad[18] = {0, 0, 0, 1, 0, 0, 1, 1, 0, /* */ 0, 0, 0, 1, 1, 0, 0, 1, 0};

static mr_status read_buffer(const void *data, size_t size, const char *name, mr_mesh *mesh,
                             mr_error *err)
{
    return mr_mesh_read_memory(data, size, name, NULL, mesh, err);
}

/* A mesh whose vertices come in the order their triangles first use them
 * and whose positions are all distinct: what the reader gives back. */
static void make_test_mesh(mr_mesh *m, int n)
{
    /* n x n grid of quads on a bumpy surface, vertices row-major. */
    size_t nv = (size_t)(n + 1) * (size_t)(n + 1), nt = 2 * (size_t)n * (size_t)n;
    mr_mesh grid;
    mr_mesh_init(&grid);
    assert_int_equal(mr_mesh_alloc(&grid, nv, nt, 0, NULL), MR_OK);
    for (int y = 0; y <= n; y++)
        for (int x = 0; x <= n; x++) {
            float *p = grid.positions + 3 * ((size_t)y * (size_t)(n + 1) + (size_t)x);
            p[0] = (float)x * 0.1f + 1e-3f * (float)y;
            p[1] = (float)y * 0.1f;
            p[2] = sinf((float)x * 0.7f) * cosf((float)y * 0.3f) / 3.0f;
        }
    size_t t = 0;
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            uint32_t a = (uint32_t)(y * (n + 1) + x), b = a + 1, c = a + (uint32_t)n + 1,
                     d = c + 1;
            uint32_t tris[6] = {a, b, d, a, d, c};
            memcpy(grid.indices + 3 * t, tris, sizeof tris);
            t += 2;
        }
    /* Renumber by first use. */
    uint32_t *remap = malloc(nv * sizeof *remap);
    memset(remap, 0xff, nv * sizeof *remap);
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, nv, nt, 0, NULL), MR_OK);
    uint32_t next = 0;
    for (size_t i = 0; i < 3 * nt; i++) {
        uint32_t v = grid.indices[i];
        if (remap[v] == UINT32_MAX) {
            remap[v] = next;
            memcpy(m->positions + 3 * (size_t)next, grid.positions + 3 * (size_t)v,
                   3 * sizeof(float));
            next++;
        }
        m->indices[i] = remap[v];
    }
    assert_int_equal(next, nv);
    free(remap);
    mr_mesh_free(&grid);
}

static void round_trip(mr_encoding enc, const char *file, int n)
{
    mr_mesh in, out;
    make_test_mesh(&in, n);
    mr_write_options wo;
    mr_write_options_default(&wo);
    wo.encoding = enc;
    mr_error err;
    const char *path = tu_tmp_path(file);
    assert_int_equal(mr_mesh_write(path, &in, &wo, &err), MR_OK);
    assert_int_equal(mr_mesh_read(path, NULL, &out, &err), MR_OK);
    tu_assert_mesh_equal(&in, &out);
    assert_null(out.normals); /* facet normals are not vertex normals */
    mr_mesh_free(&in);
    mr_mesh_free(&out);
}

/* ---- round trips and welding ----------------------------------------- */

static void test_binary_round_trip(void **state)
{
    (void)state;
    round_trip(MR_ENCODING_DEFAULT, "rt_default.stl", 40);
    /* Large enough that the welder's small cache of recent positions
     * overflows and evicts. */
    round_trip(MR_ENCODING_BINARY_LE, "rt_binary.stl", 300);
    /* The default is binary: 84 + 50 * triangles bytes. */
    size_t size;
    char *data = tu_read_file(tu_tmp_path("rt_default.stl"), &size);
    assert_non_null(data);
    assert_int_equal(size, 84 + 50 * (2 * 40 * 40));
    assert_memory_equal(data, "meshreduce", 10);
    free(data);
}

static void test_ascii_round_trip(void **state)
{
    (void)state;
    round_trip(MR_ENCODING_ASCII, "rt_ascii.stl", 40);
    char *data = tu_read_file(tu_tmp_path("rt_ascii.stl"), NULL);
    assert_non_null(data);
    assert_memory_equal(data, "solid ", 6);
    tu_assert_contains(data, "facet normal");
    tu_assert_contains(data, "endsolid");
    free(data);
}

static void test_weld_quad(void **state)
{
    (void)state;
    size_t size;
    unsigned char *buf = binary_stl("quad", 2, quad, 2, &size);
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_buffer(buf, size, "quad.stl", &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 4);
    assert_int_equal(m.triangle_count, 2);
    const uint32_t expect[6] = {0, 1, 2, 0, 2, 3};
    assert_memory_equal(m.indices, expect, sizeof expect);
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    assert_memory_equal(m.positions, pos, sizeof pos);
    mr_mesh_free(&m);
    free(buf);
}

/* Welding is bitwise: -0 and +0 are different positions. */
static void test_weld_is_bitwise(void **state)
{
    (void)state;
    float c[18];
    memcpy(c, quad, sizeof c);
    c[9] = -0.0f; /* second triangle's first corner: (-0, 0, 0) */
    size_t size;
    unsigned char *buf = binary_stl("q", 2, c, 2, &size);
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_buffer(buf, size, "q.stl", &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 5);
    mr_mesh_free(&m);
    free(buf);
}

/* A triangle soup (no shared corners) makes the weld table grow several
 * times; every corner must still get its own vertex, in order. */
static void test_weld_soup(void **state)
{
    (void)state;
    size_t n = 20000;
    float *c = malloc(n * 9 * sizeof(float));
    for (size_t i = 0; i < n * 9; i++)
        c[i] = (float)i * 0.5f;
    size_t size;
    unsigned char *buf = binary_stl("soup", (uint32_t)n, c, n, &size);
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_buffer(buf, size, "soup.stl", &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 3 * n);
    for (size_t i = 0; i < 3 * n; i++)
        assert_int_equal(m.indices[i], i);
    assert_memory_equal(m.positions, c, n * 9 * sizeof(float));
    mr_mesh_free(&m);
    free(c);
    free(buf);
}

/* ---- telling binary from ascii --------------------------------------- */

static void test_binary_with_solid_header(void **state)
{
    (void)state;
    size_t size;
    unsigned char *buf = binary_stl("solid exported by some CAD tool", 2, quad, 2, &size);
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_buffer(buf, size, "part.stl", &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 4);
    assert_int_equal(m.triangle_count, 2);
    mr_mesh_free(&m);
    free(buf);
}

static const char *ascii_quad =
    "solid quad\n"
    "  facet normal 0 0 1\n"
    "    outer loop\n"
    "      vertex 0 0 0\n"
    "      vertex 1 0 0\n"
    "      vertex 1 1 0\n"
    "    endloop\n"
    "  endfacet\n"
    "  facet normal 0 0 1\n"
    "    outer loop\n"
    "      vertex 0 0 0\n"
    "      vertex 1 1 0\n"
    "      vertex 0 1 0\n"
    "    endloop\n"
    "  endfacet\n"
    "endsolid quad\n";

static void assert_is_quad(const mr_mesh *m)
{
    assert_int_equal(m->vertex_count, 4);
    assert_int_equal(m->triangle_count, 2);
    const uint32_t expect[6] = {0, 1, 2, 0, 2, 3};
    assert_memory_equal(m->indices, expect, sizeof expect);
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    assert_memory_equal(m->positions, pos, sizeof pos);
}

static void test_ascii_basic(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(ascii_quad, "quad.stl", &m, &err), MR_OK);
    assert_is_quad(&m);
    mr_mesh_free(&m);
}

static void test_ascii_crlf_mixed_case(void **state)
{
    (void)state;
    const char *text =
        "SOLID Quad\r\n"
        "Facet Normal 0.0E+00 0.0e0 1.0\r\n"
        "\tOUTER\tLOOP\r\n"
        "\t\tVERTEX 0 0 0\r\n"
        "\t\tVertex 1.0e0 0 0\r\n"
        "\t\tvertex 1 1 0\r\n"
        "\tENDLOOP\r\n"
        "ENDFACET\r\n"
        "facet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 1 0\r\n"
        "   vertex 0 +1 -0.0e0 endloop endfacet\r\n"
        "EndSolid Quad\r\n";
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(text, "quad.stl", &m, &err), MR_OK);
    /* "-0.0e0" is -0: bitwise a new position, so check all but that. */
    assert_int_equal(m.vertex_count, 4);
    assert_int_equal(m.triangle_count, 2);
    assert_true(m.positions[11] == 0.0f && signbit(m.positions[11]));
    mr_mesh_free(&m);
}

static void test_ascii_several_solids(void **state)
{
    (void)state;
    const char *text = "solid a\n"
                       "facet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 vertex 1 1 0 "
                       "endloop endfacet\n"
                       "endsolid a\n"
                       "solid b\n"
                       "facet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 1 0 vertex 0 1 0 "
                       "endloop endfacet\n"
                       "endsolid b\n";
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(text, "two.stl", &m, &err), MR_OK);
    assert_is_quad(&m);
    mr_mesh_free(&m);
}

/* Facet normals are dropped, so "nan" normals of degenerate facets, which
 * some exporters write, are accepted. */
static void test_ascii_nan_normal_accepted(void **state)
{
    (void)state;
    const char *text = "solid a\nfacet normal nan nan nan\nouter loop\nvertex 0 0 0\n"
                       "vertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\nendsolid a\n";
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(text, "a.stl", &m, &err), MR_OK);
    assert_int_equal(m.triangle_count, 1);
    mr_mesh_free(&m);
}

static void test_sniff_without_extension(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    /* ascii */
    assert_int_equal(tu_read_string(ascii_quad, "x.dat", &m, &err), MR_OK);
    assert_is_quad(&m);
    mr_mesh_free(&m);
    /* binary, with a "solid" header as many exporters write */
    size_t size;
    unsigned char *buf = binary_stl("solid binary", 2, quad, 2, &size);
    assert_int_equal(read_buffer(buf, size, "x.dat", &m, &err), MR_OK);
    assert_is_quad(&m);
    mr_mesh_free(&m);
    free(buf);
    buf = binary_stl("plain", 2, quad, 2, &size);
    assert_int_equal(read_buffer(buf, size, "x.dat", &m, &err), MR_OK);
    assert_is_quad(&m);
    mr_mesh_free(&m);
    free(buf);
}

/* ---- malformed input ------------------------------------------------- */

static void expect_text_error(const char *text, mr_status status, const char *needle)
{
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(text, "x.stl", &m, &err), status);
    assert_int_equal(err.status, status);
    tu_assert_contains(err.message, needle);
    /* The mesh is left empty on failure. */
    assert_int_equal(m.vertex_count, 0);
    assert_null(m.positions);
}

static void expect_binary_error(const unsigned char *buf, size_t size, mr_status status,
                                const char *needle, uint64_t offset)
{
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_buffer(buf, size, "x.stl", &m, &err), status);
    tu_assert_contains(err.message, needle);
    assert_int_equal(err.offset, offset);
    assert_null(m.positions);
}

static void test_binary_truncated(void **state)
{
    (void)state;
    float c[27];
    for (int i = 0; i < 27; i++)
        c[i] = (float)i;
    size_t size;
    unsigned char *buf = binary_stl("x", 10, c, 3, &size);
    expect_binary_error(buf, size, MR_ERR_PARSE,
                        "x.stl: byte 234: file holds 3 of the 10 triangles its header "
                        "announces",
                        234);
    /* Cut in the middle of the third triangle record: 2 complete ones. */
    expect_binary_error(buf, size - 20, MR_ERR_PARSE, "holds 2 of the 10", 184);
    free(buf);
    /* The same with a "solid" header: the NUL bytes of the count show it
     * is binary, so the diagnosis is about size rather than ascii syntax. */
    buf = binary_stl("solid x", 10, c, 3, &size);
    expect_binary_error(buf, size, MR_ERR_PARSE, "holds 3 of the 10 triangles", 234);
    free(buf);
}

static void test_binary_size_mismatch(void **state)
{
    (void)state;
    float c[27] = {0};
    for (int i = 0; i < 27; i++)
        c[i] = (float)i;
    size_t size;
    unsigned char *buf = binary_stl("x", 2, c, 3, &size);
    expect_binary_error(buf, size, MR_ERR_PARSE, "50 bytes follow the 2 triangles", 184);
    free(buf);
    /* Too short even for a header. */
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string("hello", "x.stl", &m, &err), MR_ERR_PARSE);
    tu_assert_contains(err.message, "x.stl: file of 5 bytes is neither a binary STL");
}

static void test_binary_huge_count_fails_fast(void **state)
{
    (void)state;
    size_t size;
    unsigned char *buf = binary_stl("x", UINT32_MAX, quad, 2, &size);
    expect_binary_error(buf, size, MR_ERR_PARSE, "holds 2 of the 4294967295 triangles", 184);
    free(buf);
}

static void test_binary_empty(void **state)
{
    (void)state;
    size_t size;
    unsigned char *buf = binary_stl("x", 0, NULL, 0, &size);
    mr_mesh m;
    mr_error err;
    assert_int_equal(read_buffer(buf, size, "x.stl", &m, &err), MR_ERR_EMPTY);
    tu_assert_contains(err.message, "no triangles");
    free(buf);
}

static void test_binary_non_finite(void **state)
{
    (void)state;
    float c[18];
    memcpy(c, quad, sizeof c);
    c[13] = NAN; /* triangle 1, vertex 2, y */
    size_t size;
    unsigned char *buf = binary_stl("x", 2, c, 2, &size);
    expect_binary_error(buf, size, MR_ERR_PARSE, "triangle 1, vertex 2 of 3 has a non-finite",
                        84 + 50 + 12 + 12);
    c[13] = 0;
    c[0] = INFINITY;
    free(buf);
    buf = binary_stl("x", 2, c, 2, &size);
    expect_binary_error(buf, size, MR_ERR_PARSE, "triangle 0, vertex 1", 84 + 12);
    free(buf);
}

static void test_ascii_bad_keyword(void **state)
{
    (void)state;
    expect_text_error("solid x\n"
                      "facet normal 0 0 1\n"
                      " outer loop\n"
                      "  vertex 0 0 0\n"
                      "  vertex 1 0 0\n"
                      "\n"
                      "  vertx 1 1 0\n"
                      " endloop\nendfacet\nendsolid x\n",
                      MR_ERR_PARSE, "x.stl:7: expected 'vertex', found 'vertx'");
    expect_text_error("solid x\nfacet normal 0 0 1\n outer lop\n", MR_ERR_PARSE,
                      "x.stl:3: expected 'loop', found 'lop'");
    expect_text_error("solid x\nfacet nrmal 0 0 1\n", MR_ERR_PARSE,
                      "x.stl:2: expected 'normal', found 'nrmal'");
    expect_text_error("solid x\nfacets\n", MR_ERR_PARSE,
                      "x.stl:2: expected 'facet' or 'endsolid', found 'facets'");
    expect_text_error("solid x\nfacet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 "
                      "vertex 1 1 0 endloop\nendfacte\n",
                      MR_ERR_PARSE, "x.stl:3: expected 'endfacet'");
    expect_text_error("solid x\nfacet normal 0 0 1 outer loop\nvertex 0 0 0\nvertex 1 0 0\n"
                      "vertex 1 1 0\nendlop\n",
                      MR_ERR_PARSE, "x.stl:6: expected 'endloop', found 'endlop'");
    expect_text_error("solid x\nendsolid x\ngarbage\n", MR_ERR_PARSE,
                      "x.stl:3: expected 'solid' or end of file after 'endsolid', found "
                      "'garbage'");
}

static void test_ascii_bad_number(void **state)
{
    (void)state;
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zero\n",
                      MR_ERR_PARSE, "x.stl:4: expected a number, found 'zero'");
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 1.5x\n",
                      MR_ERR_PARSE, "x.stl:4: expected a number, found '1.5x'");
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\nendloop\n",
                      MR_ERR_PARSE, "x.stl:5: expected a number, found 'endloop'");
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                      "vertex 1 nan 0\n",
                      MR_ERR_PARSE, "x.stl:5: vertex coordinate 'nan' is not a finite float");
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex -inf 0 0\n",
                      MR_ERR_PARSE, "x.stl:4: vertex coordinate '-inf'");
    /* Finite as a double, infinite as a float. */
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 1e39 0 0\n",
                      MR_ERR_PARSE, "x.stl:4: vertex coordinate '1e39' is not a finite");
}

static void test_ascii_vertex_count(void **state)
{
    (void)state;
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                      "vertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n",
                      MR_ERR_PARSE, "x.stl:7: facet has a 4th vertex");
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                      "endloop\nendfacet\nendsolid x\n",
                      MR_ERR_PARSE, "x.stl:6: facet has 2 vertices");
}

static void test_ascii_empty_and_truncated(void **state)
{
    (void)state;
    expect_text_error("solid empty\nendsolid empty\n", MR_ERR_EMPTY, "holds no facets");
    expect_text_error("solid nothing at all", MR_ERR_PARSE,
                      "x.stl:1: expected 'facet' or 'endsolid', found end of file");
    expect_text_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n",
                      MR_ERR_PARSE, "x.stl:4: expected 'vertex', found end of file");
}

/* ---- writer ----------------------------------------------------------- */

static void test_write_normals_and_header(void **state)
{
    (void)state;
    /* One proper triangle (normal +z after normalisation) and one
     * degenerate (normal 0). */
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_mesh_alloc(&m, 4, 2, 0, NULL), MR_OK);
    const float pos[12] = {0, 0, 0, 2, 0, 0, 0, 3, 0, 5, 5, 5};
    const uint32_t idx[6] = {0, 1, 2, 3, 3, 3};
    memcpy(m.positions, pos, sizeof pos);
    memcpy(m.indices, idx, sizeof idx);
    const char *path = tu_tmp_path("normals.stl");
    mr_error err;
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_OK);
    size_t size;
    unsigned char *d = (unsigned char *)tu_read_file(path, &size);
    assert_int_equal(size, 84 + 100);
    assert_memory_equal(d, "meshreduce", 10);
    assert_int_equal(get_le32(d + 80), 2);
    assert_true(get_float(d + 84) == 0.0f && get_float(d + 88) == 0.0f &&
                get_float(d + 92) == 1.0f);
    for (int i = 0; i < 3; i++)
        assert_true(get_float(d + 134 + 4 * i) == 0.0f);
    assert_true(get_float(d + 84 + 12 + 12) == 2.0f); /* second vertex x */
    assert_int_equal(d[84 + 48] | d[84 + 49], 0);
    free(d);

    mr_write_options wo;
    mr_write_options_default(&wo);
    wo.encoding = MR_ENCODING_ASCII;
    assert_int_equal(mr_mesh_write(path, &m, &wo, &err), MR_OK);
    char *text = tu_read_file(path, NULL);
    tu_assert_contains(text, "facet normal 0 0 1\n");
    tu_assert_contains(text, "vertex 2 0 0\n");
    tu_assert_contains(text, "facet normal 0 0 0\n");
    free(text);
    mr_mesh_free(&m);
}

static void test_write_big_endian_refused(void **state)
{
    (void)state;
    mr_mesh m;
    make_test_mesh(&m, 2);
    mr_write_options wo;
    mr_write_options_default(&wo);
    wo.encoding = MR_ENCODING_BINARY_BE;
    mr_error err;
    const char *path = tu_tmp_path("be.stl");
    assert_int_equal(mr_mesh_write(path, &m, &wo, &err), MR_ERR_UNSUPPORTED);
    tu_assert_contains(err.message, "STL has no big-endian encoding");
    assert_false(tu_file_exists(path));
    mr_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_binary_round_trip),
        cmocka_unit_test(test_ascii_round_trip),
        cmocka_unit_test(test_weld_quad),
        cmocka_unit_test(test_weld_is_bitwise),
        cmocka_unit_test(test_weld_soup),
        cmocka_unit_test(test_binary_with_solid_header),
        cmocka_unit_test(test_ascii_basic),
        cmocka_unit_test(test_ascii_crlf_mixed_case),
        cmocka_unit_test(test_ascii_several_solids),
        cmocka_unit_test(test_ascii_nan_normal_accepted),
        cmocka_unit_test(test_sniff_without_extension),
        cmocka_unit_test(test_binary_truncated),
        cmocka_unit_test(test_binary_size_mismatch),
        cmocka_unit_test(test_binary_huge_count_fails_fast),
        cmocka_unit_test(test_binary_empty),
        cmocka_unit_test(test_binary_non_finite),
        cmocka_unit_test(test_ascii_bad_keyword),
        cmocka_unit_test(test_ascii_bad_number),
        cmocka_unit_test(test_ascii_vertex_count),
        cmocka_unit_test(test_ascii_empty_and_truncated),
        cmocka_unit_test(test_write_normals_and_header),
        cmocka_unit_test(test_write_big_endian_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
