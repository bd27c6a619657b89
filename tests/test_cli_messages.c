/* The command-line tool's messages and options: every message names the
 * file it is about, conflicting options are usage errors, short PLY faces
 * are refused like OBJ's, huge numbers are out of range, clean reports only
 * what it wrote, and every command takes -q. */
#include "testutil.h"
#include "io/text.h"

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A 2k-triangle sphere, made once per test that needs it. */
static const char *sphere(void)
{
    const char *path = tu_tmp_path("msg-sphere.ply");
    if (!tu_file_exists(path))
        assert_int_equal(
            tu_run_cli(tu_fmt("generate sphere --triangles 2k -o '%s' -q", path), NULL), 0);
    return path;
}

/* A copy of a formatted string (tu_fmt's buffer is one for all calls). */
static const char *fmt2(char *buf, size_t cap, const char *format, ...)
    __attribute__((format(printf, 3, 4)));
static const char *fmt2(char *buf, size_t cap, const char *format, ...)
{
    va_list ap;
    va_start(ap, format);
    vsnprintf(buf, cap, format, ap);
    va_end(ap);
    return buf;
}

/* Run `args`, expect `status`, and the output to contain every needle. */
static void expect(const char *args, int status, const char *needle, const char *needle2)
{
    char *out = NULL;
    int rc = tu_run_cli(args, &out);
    if (rc != status) {
        print_error("'%s' exited %d, not %d:\n%s\n", args, rc, status, out ? out : "");
        fail();
    }
    if (needle)
        tu_assert_contains(out, needle);
    if (needle2)
        tu_assert_contains(out, needle2);
    free(out);
}

static void test_simplify_names_the_file(void **state)
{
    (void)state;
    const char *cloud = tu_tmp_path("msg-cloud.obj"), *never = tu_tmp_path("msg-never.ply");
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
    tu_write_file(cloud, text, strlen(text));
    /* was "meshreduce: simplify: the mesh has no triangles" */
    char args[2048], needle[2048];
    expect(fmt2(args, sizeof args, "simplify '%s' -o '%s' --ratio 0.5", cloud, never), 1,
           fmt2(needle, sizeof needle, "meshreduce: %s: a point cloud (4 vertices, no triangles)",
                cloud),
           "meshreduce weld");
    /* was "meshreduce: simplify: target of 100000 vertices exceeds ..." */
    const char *in = sphere();
    expect(fmt2(args, sizeof args, "simplify '%s' -o '%s' --vertices 100000", in, never), 1,
           fmt2(needle, sizeof needle,
                "meshreduce: %s: target of 100000 vertices exceeds the input's 1002 "
                "referenced vertices",
                in),
           NULL);
    assert_false(tu_file_exists(never));
}

static void test_cluster_on_one_point(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("msg-point.obj"), *never = tu_tmp_path("msg-never.ply");
    const char *text = "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n";
    tu_write_file(in, text, strlen(text));
    char *out;
    /* was "meshreduce: grid cell size must be a finite number > 0, got 0" */
    assert_int_equal(tu_run_cli(tu_fmt("cluster '%s' -o '%s' --cell-rel 0.1", in, never), &out),
                     1);
    tu_assert_contains(out, tu_fmt("meshreduce: %s: all 3 vertices are at one point", in));
    assert_null(strstr(out, "got 0"));
    free(out);
    assert_false(tu_file_exists(never));
}

static void test_conflicting_options(void **state)
{
    (void)state;
    const char *in = sphere(), *never = tu_tmp_path("msg-never.ply");
    struct {
        const char *args, *message;
    } cases[] = {
        {"weld IN -o OUT --eps 0.1 --eps-rel 0.01", "--eps-rel conflicts with --eps"},
        {"weld IN -o OUT --reduce 10 --eps 0.1", "--eps conflicts with --reduce"},
        {"weld IN -o OUT --eps 0.1 --eps=0.2", "--eps is given twice"},
        {"cluster IN -o OUT --cell 0.1 --target-vertices 10",
         "--target-vertices conflicts with --cell"},
        {"cluster IN -o OUT --cell-rel 0.1 --cell 2", "--cell conflicts with --cell-rel"},
        {"convert IN OUT --ascii --binary", "--binary conflicts with --ascii"},
        {"clean IN -o OUT -o OUT2", "-o is given twice"},
        {"clean IN -o OUT --no-weld --weld-attributes",
         "--weld-attributes conflicts with --no-weld"},
        {"render IN -o OUT.png --view top --yaw 30", "--yaw conflicts with --view"},
        {"render IN -o OUT.png --pitch 30 --view top", "--view conflicts with --pitch"},
        {"render IN -o OUT.png --error-max 5", "--error-max sets the colour scale of --error-to"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        /* substitute the files into the template */
        char args[2048];
        const char *t = cases[i].args;
        size_t o = 0;
        while (*t && o + 600 < sizeof args) {
            if (!strncmp(t, "OUT2", 4)) {
                o += (size_t)snprintf(args + o, sizeof args - o, "'%s.2.ply'", never);
                t += 4;
            } else if (!strncmp(t, "OUT.png", 7)) {
                o += (size_t)snprintf(args + o, sizeof args - o, "'%s.png'", never);
                t += 7;
            } else if (!strncmp(t, "OUT", 3)) {
                o += (size_t)snprintf(args + o, sizeof args - o, "'%s'", never);
                t += 3;
            } else if (!strncmp(t, "IN", 2)) {
                o += (size_t)snprintf(args + o, sizeof args - o, "'%s'", in);
                t += 2;
            } else {
                args[o++] = *t++;
            }
        }
        args[o] = '\0';
        expect(args, 2, cases[i].message, "--help");
        assert_false(tu_file_exists(never));
    }
    /* what stays allowed: simplify's targets together (the first reached
     * stops), one encoding twice, --yaw with --pitch */
    const char *ok = tu_tmp_path("msg-ok.ply");
    expect(tu_fmt("simplify '%s' -o '%s' --ratio 0.5 --vertices 300 -q", in, ok), 0, NULL, NULL);
    expect(tu_fmt("convert '%s' '%s' --ascii --ascii -q", in, ok), 0, NULL, NULL);
    expect(tu_fmt("render '%s' -o '%s.png' --size 32x32 --yaw 10 --pitch 20 -q", in, ok), 0,
           NULL, NULL);
}

/* PLY face lists of 0, 1 and 2 indices, ascii and binary: refused, naming
 * the face, as OBJ refuses a face of 2 corners (they were dropped
 * silently). */
static void test_ply_short_faces(void **state)
{
    (void)state;
    static const char head[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 2\n"
                               "property list uchar int vertex_indices\nend_header\n"
                               "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    static const char *const rows[3] = {"0\n", "1 0\n", "2 0 1\n"};
    static const char *const said[3] = {"face 1 has no vertex indices",
                                        "face 1 has only 1 vertex index",
                                        "face 1 has only 2 vertex indices"};
    for (int n = 0; n < 3; n++) {
        char text[512];
        snprintf(text, sizeof text, "%s%s", head, rows[n]);
        const char *in = tu_tmp_path(tu_fmt("msg-short%d.ply", n));
        tu_write_file(in, text, strlen(text));
        char args[1200], needle[1200];
        expect(fmt2(args, sizeof args, "info '%s'", in), 1,
               fmt2(needle, sizeof needle, "%s:14: %s (a face needs at least 3)", in, said[n]),
               NULL);
    }
    /* binary: every face of 2 indices (one list length, the fixed-stride
     * path), and a triangle then a face of 2 (the row walk) */
    for (int variant = 0; variant < 2; variant++) {
        unsigned char buf[512];
        size_t len = (size_t)snprintf((char *)buf, sizeof buf,
                                      "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                                      "property float x\nproperty float y\nproperty float z\n"
                                      "element face %d\nproperty list uchar int "
                                      "vertex_indices\nend_header\n",
                                      variant ? 2 : 1);
        const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
        memcpy(buf + len, xyz, sizeof xyz);
        len += sizeof xyz;
        if (variant) {
            const int32_t tri[3] = {0, 1, 2};
            buf[len++] = 3;
            memcpy(buf + len, tri, sizeof tri);
            len += sizeof tri;
        }
        const size_t short_at = len;
        const int32_t two[2] = {0, 1};
        buf[len++] = 2;
        memcpy(buf + len, two, sizeof two);
        len += sizeof two;
        const char *in = tu_tmp_path(tu_fmt("msg-short-bin%d.ply", variant));
        tu_write_file(in, buf, len);
        char args[1200], needle[1200];
        expect(fmt2(args, sizeof args, "info '%s'", in), 1,
               fmt2(needle, sizeof needle, "%s: byte %zu: face %d has only 2 vertex indices", in,
                    short_at, variant),
               NULL);
    }
}

/* A number of ten million digits: out of range, not malformed. */
static void test_huge_numbers_out_of_range(void **state)
{
    (void)state;
    const size_t digits = 10000000;
    static const char head[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 1\n"
                               "property list uchar int vertex_indices\nend_header\n";
    char *text = malloc(sizeof head + digits + 64);
    assert_non_null(text);
    /* a coordinate */
    size_t n = (size_t)sprintf(text, "%s", head);
    memset(text + n, '1', digits);
    n += digits;
    n += (size_t)sprintf(text + n, " 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    const char *in = tu_tmp_path("msg-huge-coordinate.ply");
    tu_write_file(in, text, n);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", in), &out), 1);
    tu_assert_contains(out, tu_fmt("%s:10: vertex 0: value '111111111111111111111111...' "
                                   "(10000000 digits) of 'x' is out of range",
                                   in));
    assert_null(strstr(out, "malformed"));
    assert_null(strstr(out, "expected a number"));
    free(out);
    /* an index */
    n = (size_t)sprintf(text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 ", head);
    memset(text + n, '9', digits);
    n += digits;
    text[n++] = '\n';
    in = tu_tmp_path("msg-huge-index.ply");
    tu_write_file(in, text, n);
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", in), &out), 1);
    tu_assert_contains(out, "face 0: value '999999999999999999999999...' (10000000 digits) of "
                            "'vertex_indices' is out of range");
    free(out);
    /* many digits of a number in range are fine: 0.111... */
    n = (size_t)sprintf(text, "%s0.", head);
    memset(text + n, '1', digits);
    n += digits;
    n += (size_t)sprintf(text + n, " 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    in = tu_tmp_path("msg-long-fraction.ply");
    tu_write_file(in, text, n);
    expect(tu_fmt("info --json '%s'", in), 0, "\"bbox_max\": [1, 1, 0]", NULL);
    free(text);
}

/* Under the messages, the parser: decimals of any length round as strtod
 * rounds them (it refused more than 127 characters), a decimal too large
 * for a double is infinite and flagged as too large, a written "inf" is
 * not. */
static void test_long_decimals(void **state)
{
    (void)state;
    enum { LEN = 3000 };
    char *s = malloc(LEN + 32);
    assert_non_null(s);
    uint32_t x = 7;
    for (int round = 0; round < 300; round++) {
        /* digits, a point somewhere, sometimes an exponent; sometimes a
         * long run of zeros or nines that makes the rounding hard */
        size_t n = 0, len = 20 + (size_t)(round * 37 % (LEN - 40));
        if (round % 3 == 0)
            s[n++] = '-';
        size_t point = (size_t)(round * 7919) % len;
        for (size_t i = 0; i < len; i++) {
            x = x * 1664525u + 1013904223u;
            char d = (char)('0' + (x >> 24) % 10);
            if (round % 4 == 1 && i > 17)
                d = i + 1 == len ? '1' : '0'; /* ...5000...01 near a halfway point */
            if (round % 4 == 2 && i > 17)
                d = '9';
            if (round % 4 == 1 && i == 17)
                d = '5';
            s[n++] = i == point && i > 0 ? '.' : d;
        }
        if (round % 5 == 0)
            n += (size_t)sprintf(s + n, "e%d", (int)(x % 600) - 300);
        s[n] = '\0';
        const char *p = s;
        double v = 0, ref = strtod(s, NULL);
        assert_true(mr_parse_double(&p, s + n, &v));
        assert_ptr_equal(p, s + n);
        if (memcmp(&v, &ref, sizeof v) != 0) {
            print_error("%.60s... (%zu chars): %.17g, strtod %.17g\n", s, n, v, ref);
            fail();
        }
        assert_int_equal(mr_number_too_large(s, s + n, false), isinf(ref) != 0);
    }
    free(s);
    const char *inf = "inf", *big = "1e400", *fits = "1e300", *i64 = "9223372036854775808";
    double v;
    const char *p = big;
    assert_true(mr_parse_double(&p, big + 5, &v) && isinf(v));
    assert_true(mr_number_too_large(big, big + 5, false));
    assert_false(mr_number_too_large(fits, fits + 5, false));
    assert_false(mr_number_too_large(inf, inf + 3, false));
    assert_true(mr_number_too_large(i64, i64 + 19, true));
    assert_false(mr_number_too_large(i64, i64 + 18, true));
    assert_false(mr_number_too_large(big, big + 5, true)); /* not an integer */
}

/* clean says what it cleaned only once the output is written: a failed
 * write leaves the error alone. */
static void test_clean_reports_after_the_write(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("msg-dirty.obj");
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 0\nf 1 2 3\nf 4 2 3\n";
    tu_write_file(in, text, strlen(text));
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("clean '%s' -o /nonexistent-dir/clean.ply", in), &out),
                     1);
    tu_assert_contains(out, "/nonexistent-dir/clean.ply: cannot write");
    assert_null(strstr(out, "cleaned:"));
    free(out);
    const char *ok = tu_tmp_path("msg-clean.ply");
    assert_int_equal(tu_run_cli(tu_fmt("clean '%s' -o '%s'", in, ok), &out), 0);
    tu_assert_contains(out, "cleaned: 1 vertices welded");
    tu_assert_contains(out, tu_fmt("%s: 3 vertices", ok));
    free(out);
}

/* Every command takes -q (and says so in its help); with it a successful
 * run prints no summary. */
static void test_quiet_everywhere(void **state)
{
    (void)state;
    const char *in = sphere();
    const char *o = tu_tmp_path("msg-q.ply"), *png = tu_tmp_path("msg-q.png");
    const char *dir = tu_tmp_path("msg-demo");
    struct {
        const char *command;
        bool silent; /* prints nothing at all with -q */
    } cases[] = {
        {"info", false}, /* the table is the output */
        {"convert", true}, {"clean", true},  {"generate", true},
        {"simplify", true}, {"compare", false}, /* the table is the output */
        {"weld", true},     {"cluster", true},  {"render", true},
        {"demo", true},
    };
    char args[10][1200];
    snprintf(args[0], sizeof args[0], "'%s'", in);
    snprintf(args[1], sizeof args[1], "'%s' '%s'", in, o);
    snprintf(args[2], sizeof args[2], "'%s' -o '%s'", in, o);
    snprintf(args[3], sizeof args[3], "sphere --triangles 500 -o '%s'", o);
    snprintf(args[4], sizeof args[4], "'%s' -o '%s' --ratio 0.5", in, o);
    snprintf(args[5], sizeof args[5], "'%s' '%s' --samples 1k", in, in);
    snprintf(args[6], sizeof args[6], "'%s' -o '%s' --eps 0", in, o);
    snprintf(args[7], sizeof args[7], "'%s' -o '%s' --cell 0.1", in, o);
    snprintf(args[8], sizeof args[8], "'%s' -o '%s' --size 32x32", in, png);
    snprintf(args[9], sizeof args[9], "--triangles 2k --dir '%s'", dir);
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        char *out;
        const char *line = tu_fmt("%s %s -q", cases[i].command, args[i]);
        int rc = tu_run_cli(line, &out);
        if (rc != 0) {
            print_error("'%s' exited %d:\n%s\n", line, rc, out);
            fail();
        }
        if (cases[i].silent && out[0] != '\0') {
            print_error("'%s' printed:\n%s\n", line, out);
            fail();
        }
        free(out);
        assert_int_equal(tu_run_cli(tu_fmt("%s --help", cases[i].command), &out), 0);
        tu_assert_contains(out, "-q");
        free(out);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_simplify_names_the_file),
        cmocka_unit_test(test_cluster_on_one_point),
        cmocka_unit_test(test_conflicting_options),
        cmocka_unit_test(test_ply_short_faces),
        cmocka_unit_test(test_huge_numbers_out_of_range),
        cmocka_unit_test(test_long_decimals),
        cmocka_unit_test(test_clean_reports_after_the_write),
        cmocka_unit_test(test_quiet_everywhere),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
