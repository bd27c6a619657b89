/*
 * Levels of detail (mr_mesh_lods, `simplify --lods`): each level from the
 * one before, at its share of the input's triangles; errors measured
 * against the input and never decreasing; origins composed into the
 * input; the same levels at 1, 2, 3 and 8 threads; bad lists refused; the
 * CLI's files written all or none.
 */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <sys/stat.h>

static void scan(size_t triangles, mr_mesh *m)
{
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_SCAN, triangles, 1, m, &err), MR_OK);
}

static void test_chain(void **state)
{
    (void)state;
    mr_mesh m;
    scan(getenv("MR_TEST_QUICK") ? 20000 : 60000, &m);
    const double fr[4] = {0.5, 0.2, 0.05, 0.01};
    for (int kind = 0; kind < 2; kind++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.collapse = kind ? MR_COLLAPSE_HALF : MR_COLLAPSE_FULL;
        mr_lod_level lv[4];
        mr_error err;
        assert_int_equal(mr_mesh_lods(&m, fr, 4, &o, 20000, lv, &err), MR_OK);
        double worst = 0;
        for (int k = 0; k < 4; k++) {
            const mr_lod_level *l = &lv[k];
            assert_int_equal(l->target_triangles,
                             (size_t)llround(fr[k] * (double)m.triangle_count));
            assert_true(l->stats.target_reached);
            assert_true(l->mesh.triangle_count <= l->target_triangles);
            assert_true(l->mesh.triangle_count + 4 >= l->target_triangles);
            assert_true(l->hausdorff_rel > 0 && l->rms_rel > 0 &&
                        l->rms_rel <= l->hausdorff_rel);
            worst = fmax(worst, l->hausdorff_rel);
            /* the closed genus-0 scan stays closed and manifold, genus 0 */
            mr_stats st;
            assert_int_equal(mr_stats_compute(l->mesh.positions, 0, l->mesh.vertex_count,
                                              l->mesh.indices, l->mesh.triangle_count, &st,
                                              NULL),
                             MR_OK);
            assert_true(st.closed && st.manifold);
            assert_int_equal(st.euler_characteristic, 2);
            assert_true(l->error_rel == worst);
            if (k)
                assert_true(l->error_rel >= lv[k - 1].error_rel);
            /* the origins lead into the input; half collapses keep input
             * positions, so each vertex is its origin's exactly */
            for (size_t v = 0; v < l->mesh.vertex_count; v++) {
                assert_true(l->origin[v] < m.vertex_count);
                if (kind)
                    assert_memory_equal(l->mesh.positions + 3 * v,
                                        m.positions + 3 * (size_t)l->origin[v], 12);
            }
        }
        print_message("%s: Hausdorff %.4f%% %.4f%% %.4f%% %.4f%%\n", kind ? "half" : "full",
                      100 * lv[0].hausdorff_rel, 100 * lv[1].hausdorff_rel,
                      100 * lv[2].hausdorff_rel, 100 * lv[3].hausdorff_rel);
        /* level k is mr_mesh_simplify of level k - 1 */
        mr_simplify_options o2 = o;
        o2.target_triangles = lv[2].target_triangles;
        mr_mesh again;
        assert_int_equal(mr_mesh_simplify(&lv[1].mesh, &o2, &again, NULL, NULL, NULL), MR_OK);
        tu_assert_mesh_equal(&again, &lv[2].mesh);
        mr_mesh_free(&again);
        mr_lod_levels_free(lv, 4);
    }
    mr_mesh_free(&m);
}

static void test_threads(void **state)
{
    (void)state;
    mr_mesh m;
    /* above the parallel loops' 65,536 triangles, even in the quick runs */
    scan(getenv("MR_TEST_QUICK") ? 70000 : 150000, &m);
    const double fr[2] = {0.3, 0.05};
    mr_lod_level first[2];
    const int threads[4] = {1, 2, 3, 8};
    for (int i = 0; i < 4; i++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.threads = threads[i];
        mr_lod_level lv[2];
        assert_int_equal(mr_mesh_lods(&m, fr, 2, &o, 10000, i ? lv : first, NULL), MR_OK);
        if (!i)
            continue;
        for (int k = 0; k < 2; k++) {
            tu_assert_mesh_equal(&first[k].mesh, &lv[k].mesh);
            assert_memory_equal(first[k].origin, lv[k].origin, 4 * lv[k].mesh.vertex_count);
            assert_true(first[k].hausdorff_rel == lv[k].hausdorff_rel);
            assert_true(first[k].rms_rel == lv[k].rms_rel);
        }
        mr_lod_levels_free(lv, 2);
    }
    mr_lod_levels_free(first, 2);
    mr_mesh_free(&m);
}

static void test_bad(void **state)
{
    (void)state;
    mr_mesh m;
    scan(2000, &m);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    mr_lod_level lv[3];
    mr_error err;
    const double bad[][3] = {{0.5, 0.5, 0.1}, {0.5, 0.7, 0.1}, {1, 0.5, 0.1}, {0.5, 0.2, 0}};
    for (size_t i = 0; i < 4; i++) {
        assert_int_equal(mr_mesh_lods(&m, bad[i], 3, &o, 0, lv, &err), MR_ERR_INVALID_ARGUMENT);
        tu_assert_contains(err.message, "fraction");
        mr_lod_levels_free(lv, 3);
    }
    const double ok[2] = {0.5, 0.1};
    o.target_ratio = 0.5;
    assert_int_equal(mr_mesh_lods(&m, ok, 2, &o, 0, lv, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "the levels are the targets");
    mr_lod_levels_free(lv, 2);
    mr_mesh_free(&m);
}

static void test_cli(void **state)
{
    (void)state;
    mr_mesh m;
    scan(8000, &m);
    const char *in = tu_tmp_path("lods-in.ply");
    assert_int_equal(mr_mesh_write(in, &m, NULL, NULL), MR_OK);
    const char *out = tu_tmp_path("lods-out.obj");
    char *text = NULL;
    assert_int_equal(tu_run_cli(tu_fmt("simplify %s -o %s --lods 50%%,0.1,2%% --json", in, out),
                                &text),
                     0);
    tu_assert_contains(text, "\"levels\": [");
    tu_assert_contains(text, "lods-out.lod3.obj");
    free(text);
    size_t prev = m.triangle_count;
    for (int k = 0; k <= 3; k++) {
        const char *p = k ? tu_tmp_path(tu_fmt("lods-out.lod%d.obj", k)) : out;
        mr_mesh r;
        assert_int_equal(mr_mesh_read(p, NULL, &r, NULL), MR_OK);
        if (k)
            assert_true(r.triangle_count < prev);
        else
            assert_int_equal(r.triangle_count, m.triangle_count);
        prev = r.triangle_count;
        mr_mesh_free(&r);
    }
    /* all or none: level 2's path is a folder, so nothing is left */
    const char *out2 = tu_tmp_path("lods-fail.ply");
    assert_int_equal(mkdir(tu_tmp_path("lods-fail.lod2.ply"), 0755) == 0 || errno == EEXIST, 1);
    assert_int_not_equal(tu_run_cli(tu_fmt("simplify %s -o %s --lods 50%%,10%%", in, out2), &text),
                         0);
    free(text);
    assert_false(tu_file_exists(out2));
    assert_false(tu_file_exists(tu_tmp_path("lods-fail.lod1.ply")));
    /* refused lists and combinations */
    const char *bad[] = {"--lods 50%,60%", "--lods 0", "--lods 100%", "--lods x",
                         "--lods 50% --ratio 0.1"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        assert_int_not_equal(tu_run_cli(tu_fmt("simplify %s -o %s %s", in, out2, bad[i]), &text),
                             0);
        tu_assert_contains(text, "--lods");
        free(text);
    }
    mr_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chain),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_bad),
        cmocka_unit_test(test_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
