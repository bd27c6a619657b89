/* The shared text scanners: number parsing and formatting. */
#include "testutil.h"
#include "io/text.h"

static double parse(const char *s, int *ok, size_t *used)
{
    const char *p = s, *end = s + strlen(s);
    double v = 0;
    *ok = mr_parse_double(&p, end, &v);
    *used = (size_t)(p - s);
    return v;
}

static void test_parse_double_matches_strtod(void **state)
{
    (void)state;
    const char *cases[] = {"0", "-0", "1", "-1.5", "3.14159265", "1e10", "1E-10", "+2.5e+3",
                           ".5", "5.", "0.000001234", "123456789012345678", "1.7976931348623157e308",
                           "4.9e-324", "0.1", "0.30000000000000004", "12345678901234567890123",
                           "1e-30", "-7.006492321624085e-46", "00012.5000"};
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        int ok;
        size_t used;
        double v = parse(cases[i], &ok, &used);
        assert_true(ok);
        assert_int_equal(used, strlen(cases[i]));
        double ref = strtod(cases[i], NULL);
        if (memcmp(&v, &ref, sizeof v) != 0) {
            print_error("%s: %.17g != %.17g\n", cases[i], v, ref);
            fail();
        }
    }
}

static void test_parse_double_rejects(void **state)
{
    (void)state;
    const char *bad[] = {"", "-", "+", ".", "abc", "e5", "0x10"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        int ok;
        size_t used;
        double v = parse(bad[i], &ok, &used);
        (void)v;
        if (ok && strcmp(bad[i], "0x10") == 0) {
            assert_int_equal(used, 1); /* "0" then garbage "x10" */
            continue;
        }
        assert_false(ok);
    }
}

static void test_parse_stops_at_bounds(void **state)
{
    (void)state;
    /* The buffer is not NUL-terminated: "12" followed by digits past end. */
    const char buf[] = "123456";
    const char *p = buf;
    double v;
    assert_true(mr_parse_double(&p, buf + 2, &v));
    assert_true(v == 12.0);
    assert_ptr_equal(p, buf + 2);
    int64_t i;
    p = buf;
    assert_true(mr_parse_i64(&p, buf + 3, &i));
    assert_int_equal(i, 123);
}

static void test_parse_special(void **state)
{
    (void)state;
    int ok;
    size_t used;
    double v = parse("nan", &ok, &used);
    assert_true(ok && isnan(v));
    v = parse("-inf", &ok, &used);
    assert_true(ok && isinf(v) && v < 0);
}

static void test_float_round_trip(void **state)
{
    (void)state;
    uint32_t x = 12345;
    for (int i = 0; i < 200000; i++) {
        x = x * 1664525u + 1013904223u;
        float f;
        memcpy(&f, &x, sizeof f);
        if (!isfinite(f))
            continue;
        char buf[32];
        int n = mr_format_float(buf, f);
        assert_true(n > 0 && n < 32);
        const char *p = buf;
        float g = 0;
        assert_true(mr_parse_float(&p, buf + n, &g));
        assert_int_equal(p - buf, n);
        if (memcmp(&f, &g, sizeof f) != 0) {
            print_error("%s: %.9g != %.9g\n", buf, (double)f, (double)g);
            fail();
        }
    }
    /* values in the range of mesh coordinates take the fast path */
    for (int i = 0; i < 400000; i++) {
        x = x * 1664525u + 1013904223u;
        float f = ((float)(x >> 8) / 16777216.0f - 0.5f) * (i % 2 ? 2000.0f : 0.02f);
        char buf[32];
        int n = mr_format_float(buf, f);
        const char *p = buf;
        float g = 0;
        assert_true(mr_parse_float(&p, buf + n, &g));
        assert_int_equal(p - buf, n);
        assert_true(n <= 16);
        if (memcmp(&f, &g, sizeof f) != 0) {
            print_error("%s: %.9g != %.9g\n", buf, (double)f, (double)g);
            fail();
        }
    }
    struct {
        float v;
        const char *text;
    } known[] = {{0.1f, "0.1"},     {1.0f, "1"},         {-2.5f, "-2.5"},
                 {100.0f, "100"},   {123.456f, "123.456"}, {-0.00123f, "-0.00123"},
                 {1e-5f, "1e-05"},  {1e9f, "1e+09"},     {0.0f, "0"},
                 {-0.0f, "-0"},     {16777216.0f, "16777216"}, {0.333333343f, "0.33333334"}};
    char buf[32];
    for (size_t i = 0; i < sizeof known / sizeof *known; i++) {
        mr_format_float(buf, known[i].v);
        assert_string_equal(buf, known[i].text);
    }
    mr_format_float(buf, 0.1f);
    assert_string_equal(buf, "0.1");
    mr_format_float(buf, 1.0f);
    assert_string_equal(buf, "1");
}

static void test_error_format(void **state)
{
    (void)state;
    mr_error err;
    mr_fail(&err, MR_ERR_PARSE, "a.obj", 12, MR_NO_POSITION, "bad %s", "thing");
    assert_string_equal(err.message, "a.obj:12: bad thing");
    assert_int_equal(err.line, 12);
    mr_fail(&err, MR_ERR_PARSE, "a.ply", MR_NO_POSITION, 40, "truncated");
    assert_string_equal(err.message, "a.ply: byte 40: truncated");
    mr_fail(&err, MR_ERR_IO, NULL, MR_NO_POSITION, MR_NO_POSITION, "x");
    assert_string_equal(err.message, "x");
    mr_fail(&err, MR_ERR_IO, NULL, 3, MR_NO_POSITION, "x");
    assert_string_equal(err.message, "line 3: x");
    assert_int_equal(mr_fail(NULL, MR_ERR_IO, "n", 1, 1, "y"), MR_ERR_IO);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_double_matches_strtod),
        cmocka_unit_test(test_parse_double_rejects),
        cmocka_unit_test(test_parse_stops_at_bounds),
        cmocka_unit_test(test_parse_special),
        cmocka_unit_test(test_float_round_trip),
        cmocka_unit_test(test_error_format),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
