/* Grid clustering: determinism at any thread count, targets, point clouds,
 * attributes, errors and the command line. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void cluster_ok(const mr_mesh *m, const mr_cluster_options *o, mr_mesh *out,
                       mr_cluster_stats *st)
{
    mr_error err;
    if (mr_mesh_cluster(m, o, out, st, &err) != MR_OK) {
        print_error("mr_mesh_cluster: %s\n", err.message);
        fail();
    }
}

static void test_deterministic_and_valid(void **state)
{
    (void)state;
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SCAN, 80000, 2, &m, NULL), MR_OK);
    mr_cluster_options o;
    mr_cluster_options_default(&o);
    o.cell = 3.0;
    o.threads = 1;
    mr_mesh ref;
    mr_cluster_stats st;
    cluster_ok(&m, &o, &ref, &st);
    assert_true(ref.vertex_count > 100 && ref.vertex_count < m.vertex_count / 4);
    assert_true(ref.triangle_count > 0);
    mr_stats s;
    assert_int_equal(mr_stats_compute(ref.positions, 0, ref.vertex_count, ref.indices,
                                      ref.triangle_count, &s, NULL),
                     MR_OK);
    assert_int_equal(s.degenerate_triangles, 0);
    assert_int_equal(s.duplicate_triangles, 0);
    assert_int_equal(s.unreferenced_vertices, 0);
    /* every output vertex lies in the input's bounding box, expanded by
     * a cell */
    mr_stats si;
    assert_int_equal(mr_stats_compute(m.positions, 0, m.vertex_count, NULL, 0, &si, NULL), MR_OK);
    for (size_t v = 0; v < ref.vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            assert_true(ref.positions[3 * v + (size_t)k] >= si.bbox_min[k] - o.cell);
            assert_true(ref.positions[3 * v + (size_t)k] <= si.bbox_max[k] + o.cell);
        }
    const int threads[] = {2, 3, 8};
    for (int t = 0; t < 3; t++) {
        o.threads = threads[t];
        mr_mesh r;
        cluster_ok(&m, &o, &r, NULL);
        tu_assert_mesh_equal(&ref, &r);
        mr_mesh_free(&r);
    }
    mr_mesh_free(&ref);

    /* a vertex target: about that many occupied cells */
    mr_cluster_options_default(&o);
    o.target_vertices = 2000;
    cluster_ok(&m, &o, &ref, &st);
    assert_true(st.cells >= 2000 && st.cells < 2300);
    assert_true(ref.vertex_count <= st.cells);
    mr_mesh_free(&ref);
    mr_mesh_free(&m);
}

/* A flat square grid of points: the quadric pins nothing off the plane,
 * so each cell's vertex is the mean of its points. */
static void test_point_cloud_means(void **state)
{
    (void)state;
    mr_mesh m, out;
    mr_mesh_init(&m);
    assert_int_equal(mr_mesh_alloc(&m, 8, 0, MR_ATTR_COLORS, NULL), MR_OK);
    const float p[] = {0.1f, 0.1f, 0, 0.3f, 0.1f, 0, 0.1f, 0.3f, 0, 0.3f, 0.3f, 0,
                       5.5f, 0.1f, 0, 5.7f, 0.1f, 0, 5.5f, 0.3f, 0, 5.7f, 0.3f, 0};
    memcpy(m.positions, p, sizeof p);
    for (int i = 0; i < 32; i++)
        m.colors[i] = i < 16 ? 1.0f : 0.5f;
    mr_cluster_options o;
    mr_cluster_options_default(&o);
    o.cell = 1.0;
    cluster_ok(&m, &o, &out, NULL);
    assert_int_equal(out.vertex_count, 2);
    assert_int_equal(out.triangle_count, 0);
    assert_float_equal(out.positions[0], 0.2f, 1e-6);
    assert_float_equal(out.positions[1], 0.2f, 1e-6);
    assert_float_equal(out.positions[3], 5.6f, 1e-6);
    assert_true(out.colors[0] == 1.0f && out.colors[4] == 0.5f);
    mr_mesh_free(&out);
    mr_mesh_free(&m);
}

static void test_errors(void **state)
{
    (void)state;
    mr_mesh m, out;
    mr_mesh_init(&m);
    mr_error err;
    mr_cluster_options o;
    mr_cluster_options_default(&o);
    o.cell = 1;
    assert_int_equal(mr_mesh_cluster(&m, &o, &out, NULL, &err), MR_ERR_EMPTY);
    assert_int_equal(mr_mesh_alloc(&m, 3, 0, 0, NULL), MR_OK);
    memset(m.positions, 0, 9 * sizeof(float));
    o.cell = -1;
    assert_int_equal(mr_mesh_cluster(&m, &o, &out, NULL, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "cell size must be a finite number > 0");
    o.cell = NAN;
    assert_int_equal(mr_mesh_cluster(&m, &o, &out, NULL, &err), MR_ERR_INVALID_ARGUMENT);
    o.cell = 1;
    m.positions[4] = INFINITY;
    assert_int_equal(mr_mesh_cluster(&m, &o, &out, NULL, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "vertex 1 has a non-finite coordinate");
    mr_mesh_free(&m);
}

static void test_cli(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("cluster-in.ply"), *o1 = tu_tmp_path("cluster-1.ply"),
               *o2 = tu_tmp_path("cluster-2.ply");
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate scan --triangles 20k -o '%s' -q", in), NULL),
                     0);
    assert_int_equal(
        tu_run_cli(tu_fmt("--threads 1 cluster '%s' -o '%s' --target-vertices 1000 -q", in, o1),
                   NULL),
        0);
    assert_int_equal(
        tu_run_cli(tu_fmt("--threads 2 cluster '%s' -o '%s' --target-vertices 1000 --json", in,
                          o2),
                   &out),
        0);
    tu_assert_contains(out, "\"cells\": ");
    free(out);
    size_t n1, n2;
    char *a = tu_read_file(o1, &n1), *b = tu_read_file(o2, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1);
    free(a);
    free(b);
    assert_int_equal(tu_run_cli(tu_fmt("cluster '%s' -o '%s' --cell 0", in, o1), &out), 2);
    tu_assert_contains(out, "--cell needs a finite number > 0");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("cluster '%s' -o '%s'", in, o1), &out), 2);
    free(out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_deterministic_and_valid),
        cmocka_unit_test(test_point_cloud_means),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
