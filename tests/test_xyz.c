/* XYZ point clouds: columns, separators, comments, diagnostics, round
 * trips, and the parallel reader agreeing with the serial one. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void expect_points(const char *text, size_t count, const float *positions,
                          const float *normals)
{
    mr_mesh m;
    mr_error err;
    mr_status st = tu_read_string(text, "p.xyz", &m, &err);
    if (st != MR_OK)
        print_error("%s\n", err.message);
    assert_int_equal(st, MR_OK);
    assert_int_equal(m.vertex_count, count);
    assert_int_equal(m.triangle_count, 0);
    assert_memory_equal(m.positions, positions, count * 3 * sizeof(float));
    if (normals) {
        assert_non_null(m.normals);
        assert_memory_equal(m.normals, normals, count * 3 * sizeof(float));
    } else {
        assert_null(m.normals);
    }
    assert_null(m.colors);
    assert_null(m.texcoords);
    mr_mesh_free(&m);
}

static void expect_error(const char *text, mr_status status, const char *needle)
{
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(text, "p.xyz", &m, &err), status);
    assert_int_equal(err.status, status);
    tu_assert_contains(err.message, needle);
    assert_null(m.positions);
}

static const float p2[6] = {1, 2, 3, -4.5f, 5e-3f, 6e3f};

static void test_three_columns(void **state)
{
    (void)state;
    expect_points("1 2 3\n-4.5 5e-3 6e3\n", 2, p2, NULL);
    expect_points("1 2 3\n-4.5 5e-3 6e3", 2, p2, NULL); /* no final newline */
    expect_points("  1\t2  3  \r\n-4.5 5e-3 6e3\r\n", 2, p2, NULL);
}

static void test_six_columns(void **state)
{
    (void)state;
    const float n2[6] = {0, 0, 1, 0.6f, 0.8f, 0};
    expect_points("1 2 3 0 0 1\n-4.5 5e-3 6e3 0.6 0.8 0\n", 2, p2, n2);
}

static void test_separators(void **state)
{
    (void)state;
    expect_points("1,2,3\n-4.5,5e-3,6e3\n", 2, p2, NULL);
    expect_points("1;2;3\n-4.5 ; 5e-3 ; 6e3\n", 2, p2, NULL);
    expect_points("1, 2 ,3\n-4.5\t,5e-3;6e3\n", 2, p2, NULL);
    /* Numbers too long for the fast path, comma-separated without blanks. */
    const float one[3] = {1, 2, 3};
    expect_points("1.00000000000000000000001,2.00000000000000000000001,"
                  "3.00000000000000000000001\n",
                  1, one, NULL);
    expect_points("1.000000000000000000000000001e0;2.000000000000000000000000001;"
                  "3.000000000000000000000000001e+0;4.000000000000000000000000001;"
                  "5.000000000000000000000000001;6.000000000000000000000000001\n"
                  "1e0;2;3;4;5;6\n",
                  2, (const float[]){1, 2, 3, 1, 2, 3}, (const float[]){4, 5, 6, 4, 5, 6});
}

static void test_comments_and_blank_lines(void **state)
{
    (void)state;
    expect_points("# exported points\n"
                  "\n"
                  "   \t\r\n"
                  "1 2 3 # first\n"
                  "  # indented comment: 1 2\n"
                  "-4.5 5e-3 6e3#second\n"
                  "\n",
                  2, p2, NULL);
}

static void test_column_count_errors(void **state)
{
    (void)state;
    expect_error("# header\n1 2 3 4\n", MR_ERR_PARSE,
                 "p.xyz:2: found 4 columns; an XYZ line holds 3 (x y z) or 6");
    expect_error("1 2\n", MR_ERR_PARSE, "p.xyz:1: found 2 columns");
    expect_error("1\n", MR_ERR_PARSE, "p.xyz:1: found 1 column;");
    expect_error("1 2 3 255 255 255 1\n", MR_ERR_PARSE, "p.xyz:1: found 7 columns");
    expect_error("1 2 3\n4 5 6\n\n1 2 3 0 0 1\n", MR_ERR_PARSE,
                 "p.xyz:4: found 6 columns, but line 1 has 3");
    expect_error("# c\n1 2 3 0 0 1\n4 5 6\n", MR_ERR_PARSE,
                 "p.xyz:3: found 3 columns, but line 2 has 6");
}

static void test_bad_numbers(void **state)
{
    (void)state;
    expect_error("1 2 3\n4 5 abc\n", MR_ERR_PARSE, "p.xyz:2: expected a number, found 'abc'");
    expect_error("1 2 3\n4 5 6x\n", MR_ERR_PARSE, "p.xyz:2: expected a number, found '6x'");
    expect_error("1 2 3,\n", MR_ERR_PARSE, "p.xyz:1: expected a number, found end of line");
    expect_error("1,,2,3\n", MR_ERR_PARSE, "p.xyz:1: expected a number, found ',2,3'");
    expect_error(",1,2,3\n", MR_ERR_PARSE, "p.xyz:1: expected a number");
    expect_error("1 2 3\n\n4 nan 6\n", MR_ERR_PARSE, "p.xyz:3: value 'nan' is not a finite");
    expect_error("1 2 3\n4 5 -inf\n", MR_ERR_PARSE, "p.xyz:2: value '-inf'");
    expect_error("1 2 3 0 0 inf\n", MR_ERR_PARSE, "p.xyz:1: value 'inf'");
    expect_error("1 2 3e39\n", MR_ERR_PARSE, "p.xyz:1: value '3e39' is not a finite float");
}

static void test_empty(void **state)
{
    (void)state;
    expect_error("# nothing here\n\n   \n", MR_ERR_EMPTY, "holds no points");
    expect_error("\n", MR_ERR_EMPTY, "p.xyz");
}

/* Random finite floats, normals included, read back bit for bit. */
static void test_round_trip(void **state)
{
    (void)state;
    size_t n = 5000;
    mr_mesh in, out;
    mr_mesh_init(&in);
    assert_int_equal(mr_mesh_alloc(&in, n, 0, MR_ATTR_NORMALS, NULL), MR_OK);
    uint32_t x = 987654321u;
    for (size_t i = 0; i < 6 * n; i++) {
        float f;
        do {
            x = x * 1664525u + 1013904223u;
            memcpy(&f, &x, sizeof f);
        } while (!isfinite(f));
        (i % 6 < 3 ? in.positions : in.normals)[3 * (i / 6) + i % 3] = f;
    }
    mr_error err;
    const char *path = tu_tmp_path("rt.xyz");
    assert_int_equal(mr_mesh_write(path, &in, NULL, &err), MR_OK);
    assert_int_equal(mr_mesh_read(path, NULL, &out, &err), MR_OK);
    tu_assert_mesh_equal(&in, &out);
    mr_mesh_free(&out);

    /* Without normals when asked. */
    mr_write_options wo;
    mr_write_options_default(&wo);
    wo.write_normals = 0;
    assert_int_equal(mr_mesh_write(path, &in, &wo, &err), MR_OK);
    assert_int_equal(mr_mesh_read(path, NULL, &out, &err), MR_OK);
    assert_int_equal(out.vertex_count, n);
    assert_null(out.normals);
    assert_memory_equal(out.positions, in.positions, n * 3 * sizeof(float));
    mr_mesh_free(&out);
    mr_mesh_free(&in);
}

/* A mesh written as XYZ loses its triangles: it reads back as its points. */
static void test_mesh_written_as_points(void **state)
{
    (void)state;
    mr_mesh in, out;
    mr_mesh_init(&in);
    assert_int_equal(mr_mesh_alloc(&in, 3, 1, 0, NULL), MR_OK);
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0.25f};
    memcpy(in.positions, pos, sizeof pos);
    in.indices[0] = 0, in.indices[1] = 1, in.indices[2] = 2;
    mr_error err;
    const char *path = tu_tmp_path("mesh.xyz");
    assert_int_equal(mr_mesh_write(path, &in, NULL, &err), MR_OK);
    char *text = tu_read_file(path, NULL);
    assert_string_equal(text, "0 0 0\n1 0 0\n0 1 0.25\n");
    free(text);
    assert_int_equal(mr_mesh_read(path, NULL, &out, &err), MR_OK);
    assert_int_equal(out.vertex_count, 3);
    assert_int_equal(out.triangle_count, 0);
    assert_memory_equal(out.positions, pos, sizeof pos);
    mr_mesh_free(&out);
    mr_mesh_free(&in);
}

/* A text of `lines` lines (some comments and blanks) over several MB so
 * that the reader splits it into chunks; `bad_line` (1-based, 0 = none)
 * gets a malformed value. */
static char *big_text(size_t lines, size_t bad_line, size_t *len)
{
    size_t cap = lines * 64 + 1;
    char *buf = malloc(cap);
    size_t n = 0;
    for (size_t i = 1; i <= lines; i++) {
        if (i == bad_line)
            n += (size_t)snprintf(buf + n, cap - n, "1 2 oops 0 0 1\n");
        else if (i % 97 == 0)
            n += (size_t)snprintf(buf + n, cap - n, "# comment %zu\n", i);
        else if (i % 89 == 0)
            n += (size_t)snprintf(buf + n, cap - n, "\n");
        else
            n += (size_t)snprintf(buf + n, cap - n, "%zu.5 %zu.25 -%zu 0 0.6 0.8\n", i,
                                  i * 3, i % 1000);
    }
    *len = n;
    return buf;
}

static mr_status read_threads(const char *text, size_t len, int threads, mr_mesh *m,
                              mr_error *err)
{
    mr_read_options ro;
    mr_read_options_default(&ro);
    ro.threads = threads;
    return mr_mesh_read_memory(text, len, "big.xyz", &ro, m, err);
}

static void test_parallel_matches_serial(void **state)
{
    (void)state;
    size_t len;
    char *text = big_text(200000, 0, &len);
    assert_true(len > (size_t)4 << 20);
    mr_mesh a, b;
    mr_error err;
    assert_int_equal(read_threads(text, len, 1, &a, &err), MR_OK);
    assert_int_equal(read_threads(text, len, 7, &b, &err), MR_OK);
    tu_assert_mesh_equal(&a, &b);
    size_t expect = 0;
    for (size_t i = 1; i <= 200000; i++)
        expect += i % 97 != 0 && i % 89 != 0;
    assert_int_equal(a.vertex_count, expect);
    assert_true(a.positions[0] == 1.5f && a.positions[1] == 3.25f);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
    free(text);

    /* Two bad lines: every thread count reports the first. */
    text = big_text(200000, 150001, &len);
    memcpy(strstr(text, "\n3000.5 ") + 1, "3000.5 x", 8);
    mr_error e1, e7;
    assert_int_equal(read_threads(text, len, 1, &a, &e1), MR_ERR_PARSE);
    assert_int_equal(read_threads(text, len, 7, &b, &e7), MR_ERR_PARSE);
    assert_string_equal(e1.message, e7.message);
    assert_int_equal(e1.line, 3000);
    tu_assert_contains(e1.message, "big.xyz:3000: expected a number");
    free(text);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_three_columns),
        cmocka_unit_test(test_six_columns),
        cmocka_unit_test(test_separators),
        cmocka_unit_test(test_comments_and_blank_lines),
        cmocka_unit_test(test_column_count_errors),
        cmocka_unit_test(test_bad_numbers),
        cmocka_unit_test(test_empty),
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_mesh_written_as_points),
        cmocka_unit_test(test_parallel_matches_serial),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
