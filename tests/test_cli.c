/* The command-line tool end to end: exit statuses, messages, outputs. */
#include "testutil.h"

#include <math.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void test_help_and_usage(void **state)
{
    (void)state;
    char *out;
    assert_int_equal(tu_run_cli("--help", &out), 0);
    tu_assert_contains(out, "usage: meshreduce COMMAND");
    free(out);
    assert_int_equal(tu_run_cli("info --help", &out), 0);
    tu_assert_contains(out, "usage: meshreduce info FILE");
    free(out);
    assert_int_equal(tu_run_cli("frobnicate", &out), 2);
    tu_assert_contains(out, "unknown command 'frobnicate'");
    free(out);
    assert_int_equal(tu_run_cli("info --bogus x.obj", &out), 2);
    tu_assert_contains(out, "unknown option '--bogus'");
    free(out);
    assert_int_equal(tu_run_cli("--threads -3 info x.obj", &out), 2);
    tu_assert_contains(out, "--threads needs a count");
    free(out);
    assert_int_equal(tu_run_cli("--version", &out), 0);
    tu_assert_contains(out, MR_VERSION_STRING);
    free(out);
}

static void test_generate_info_json(void **state)
{
    (void)state;
    const char *path = tu_tmp_path("cli-sphere.ply");
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 2k -o '%s' -q", path), &out),
                     0);
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("info --json '%s'", path), &out), 0);
    tu_assert_contains(out, "\"triangles\": 2000");
    tu_assert_contains(out, "\"euler_characteristic\": 2");
    tu_assert_contains(out, "\"closed\": true");
    tu_assert_contains(out, "\"genus\": 0");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", path), &out), 0);
    tu_assert_contains(out, "closed, manifold");
    tu_assert_contains(out, "euler characteristic   2");
    free(out);

    /* same seed, same bytes; --threads does not change the result */
    const char *again = tu_tmp_path("cli-sphere2.ply");
    assert_int_equal(
        tu_run_cli(tu_fmt("--threads 1 generate sphere --triangles 2k -o '%s' -q", again), NULL), 0);
    size_t n1, n2;
    char *a = tu_read_file(path, &n1), *b = tu_read_file(again, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1);
    free(a);
    free(b);
}

static void test_torus_info(void **state)
{
    (void)state;
    const char *path = tu_tmp_path("cli-torus.obj");
    assert_int_equal(tu_run_cli(tu_fmt("generate torus --triangles 5000 -o '%s' -q", path), NULL),
                     0);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("info --json '%s'", path), &out), 0);
    tu_assert_contains(out, "\"closed\": false");
    tu_assert_contains(out, "\"manifold\": true");
    free(out);
}

static void test_convert_and_clean(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("cli-in.obj");
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 0\nv 9 9 9\n"
                       "f 1 2 3\nf 2 4 3\nf 3 2 4\nf 5 2 3\nf 1 1 2\n";
    tu_write_file(in, text, strlen(text));
    const char *ply = tu_tmp_path("cli-out.ply");
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' '%s' --ascii", in, ply), &out), 0);
    free(out);
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read(ply, NULL, &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 6); /* convert keeps everything */
    assert_int_equal(m.triangle_count, 5);
    mr_mesh_free(&m);

    const char *cleaned = tu_tmp_path("cli-clean.obj");
    assert_int_equal(tu_run_cli(tu_fmt("clean '%s' -o '%s'", in, cleaned), &out), 0);
    tu_assert_contains(out, "1 vertices welded");
    free(out);
    assert_int_equal(mr_mesh_read(cleaned, NULL, &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 4);   /* duplicate welded, (9,9,9) dropped */
    assert_int_equal(m.triangle_count, 2); /* duplicates and the degenerate gone */
    mr_mesh_free(&m);
}

/* A closed fan-capped cylinder whose side is wound against its caps: every
 * rim vertex is locked, and simplify says so; clean rewinds the side, and
 * then it simplifies; --keep-winding leaves it alone. */
static void test_misoriented_winding(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("cli-wound.obj");
    char text[8192];
    size_t len = 0;
    const int n = 24;
    for (int z = 0; z < 2; z++)
        for (int i = 0; i < n; i++) {
            const double a = 2 * 3.14159265358979323846 * i / n;
            len += (size_t)snprintf(text + len, sizeof text - len, "v %.6f %.6f %d\n", cos(a),
                                    sin(a), z);
        }
    len += (size_t)snprintf(text + len, sizeof text - len, "v 0 0 0\nv 0 0 1\n");
    for (int i = 0; i < n; i++) {
        const int a = i + 1, b = (i + 1) % n + 1, a2 = a + n, b2 = b + n;
        const int c0 = 2 * n + 1, c1 = 2 * n + 2;
        /* the side wound inward, the caps outward */
        len += (size_t)snprintf(text + len, sizeof text - len,
                                "f %d %d %d\nf %d %d %d\nf %d %d %d\nf %d %d %d\n", a, b2, b, a,
                                a2, b2, c0, b, a, c1, a2, b2);
    }
    tu_write_file(in, text, len);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", in), &out), 0);
    tu_assert_contains(out, "not consistently oriented");
    free(out);
    const char *simple = tu_tmp_path("cli-wound-10.obj");
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 10%%", in, simple), &out), 0);
    tu_assert_contains(out, "48 vertices stayed in place");
    tu_assert_contains(out, "meshreduce clean");
    free(out);
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 10%% --json -q", in, simple), &out), 0);
    tu_assert_contains(out, "\"locked_vertices\": 48");
    free(out);

    const char *kept = tu_tmp_path("cli-wound-kept.obj");
    assert_int_equal(tu_run_cli(tu_fmt("clean '%s' -o '%s' --keep-winding", in, kept), &out), 0);
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", kept), &out), 0);
    tu_assert_contains(out, "not consistently oriented");
    free(out);

    const char *fixed = tu_tmp_path("cli-wound-fixed.obj");
    assert_int_equal(tu_run_cli(tu_fmt("clean '%s' -o '%s'", in, fixed), &out), 0);
    tu_assert_contains(out, "48 triangles flipped");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("info '%s'", fixed), &out), 0);
    tu_assert_contains(out, "closed, manifold, consistently oriented");
    free(out);
    assert_int_equal(
        tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 10%% --stats", fixed, simple), &out), 0);
    tu_assert_contains(out, "50 -> 5");
    tu_assert_contains(out, "locked     0 vertices");
    free(out);
}

static void test_bad_inputs_fail_cleanly(void **state)
{
    (void)state;
    struct {
        const char *name, *content, *message;
    } cases[] = {
        {"bad-index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "bad-index.obj:4:"},
        {"bad-range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "bad-range.obj:4:"},
        {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "nan.obj:2:"},
        {"empty.ply", "", "empty.ply: file is empty"},
        {"text.stl", "hello there, not a mesh\n", "text.stl"},
        {"format.ply", "ply\nformat fancy 1.0\nend_header\n", "format.ply:2:"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        const char *in = tu_tmp_path(cases[i].name);
        tu_write_file(in, cases[i].content, strlen(cases[i].content));
        const char *outp = tu_tmp_path("never-written.ply");
        char *out;
        assert_int_equal(tu_run_cli(tu_fmt("convert '%s' '%s'", in, outp), &out), 1);
        tu_assert_contains(out, "meshreduce: ");
        tu_assert_contains(out, cases[i].message);
        /* exactly one line of error */
        assert_non_null(strchr(out, '\n'));
        assert_null(strchr(strchr(out, '\n') + 1, '\n'));
        free(out);
        assert_false(tu_file_exists(outp));
    }
    char *out;
    assert_int_equal(tu_run_cli("info /nonexistent/mesh.obj", &out), 1);
    tu_assert_contains(out, "/nonexistent/mesh.obj: cannot open for reading");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere -o '%s'", tu_tmp_path("x.unknown")), &out),
                     2);
    tu_assert_contains(out, "cannot tell the output format");
    free(out);
    assert_int_equal(tu_run_cli("generate cube -o x.obj", &out), 2);
    tu_assert_contains(out, "unknown kind 'cube'");
    free(out);
    assert_int_equal(tu_run_cli("generate sphere --triangles 0 -o x.obj", &out), 2);
    tu_assert_contains(out, "--triangles needs a positive count");
    free(out);
    assert_int_equal(
        tu_run_cli("generate sphere --triangles 100 -o /nonexistent-dir/x.obj", &out), 1);
    tu_assert_contains(out, "/nonexistent-dir/x.obj: cannot write");
    free(out);
}

static void test_demo_small(void **state)
{
    (void)state;
    char *out;
    const char *dir = tu_tmp_path("demo");
    assert_int_equal(tu_run_cli(tu_fmt("demo --triangles 20000 --dir '%s'", dir), &out), 0);
    tu_assert_contains(out, "generate scan");
    tu_assert_contains(out, "identical to what was written");
    tu_assert_contains(out, "closed, manifold, 1 component, euler 2");
    tu_assert_contains(out, "simplify to 10% (QEM)");
    tu_assert_contains(out, "hausdorff");
    free(out);
}

static void test_simplify_cli(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("cli-simp-in.ply");
    const char *out_path = tu_tmp_path("cli-simp-out.obj");
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 20k -o '%s' -q", in), NULL), 0);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 10%% --json", in, out_path),
                                &out), 0);
    tu_assert_contains(out, "\"output_vertices\": 1024");
    tu_assert_contains(out, "\"input_vertices\": 10242");
    free(out);
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read(out_path, NULL, &m, &err), MR_OK);
    assert_int_equal(m.vertex_count, 1024);
    mr_mesh_free(&m);
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --triangles 500 --collapse half "
                                    "--stats", in, out_path), &out), 0);
    tu_assert_contains(out, "triangles  20,480 -> 500\n");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.1 --strategy greedy "
                                    "--json", in, out_path), &out), 0);
    tu_assert_contains(out, "\"output_vertices\": 1024");
    free(out);

    /* bad targets: usage errors, nothing written */
    const char *never = tu_tmp_path("cli-simp-never.obj");
    struct {
        const char *args, *message;
        int status;
    } bad[] = {
        {"--ratio 0", "--ratio needs a fraction in (0, 1]", 2},
        {"--ratio 1.5", "--ratio needs a fraction", 2},
        {"--ratio 150%", "--ratio needs a fraction", 2},
        {"", "no target given", 2},
        {"--collapse quarter --ratio 0.5", "--collapse is full or half", 2},
        {"--strategy best --ratio 0.5", "--strategy is greedy, batched, ppq, rppq, fppq, multiqueue, partitioned or partitioned-boundary", 2},
        {"--triangles 30000", "target of 30000 triangles exceeds the input's 20480", 1},
        {"--max-normal-turn 0 --ratio 0.5", "--max-normal-turn needs degrees", 2},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' %s", in, never, bad[i].args),
                                    &out),
                         bad[i].status);
        tu_assert_contains(out, bad[i].message);
        free(out);
        assert_false(tu_file_exists(never));
    }
    assert_int_equal(tu_run_cli(tu_fmt("simplify /nonexistent.obj -o '%s' --ratio 0.5", never),
                                &out), 1);
    tu_assert_contains(out, "/nonexistent.obj: cannot open for reading");
    free(out);
    assert_false(tu_file_exists(never));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_help_and_usage),
        cmocka_unit_test(test_generate_info_json),
        cmocka_unit_test(test_torus_info),
        cmocka_unit_test(test_convert_and_clean),
        cmocka_unit_test(test_misoriented_winding),
        cmocka_unit_test(test_bad_inputs_fail_cleanly),
        cmocka_unit_test(test_demo_small),
        cmocka_unit_test(test_simplify_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
