/* Epsilon welding: S-Weld, P-Weld, P-Weld-Async against a brute-force
 * reference and each other, the paper's toy graph, Open3D, the epsilon
 * finder, attributes, errors and the command line. */
#include "testutil.h"

#include "cluster/grid.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const mr_weld_algorithm algorithms[] = {MR_WELD_SERIAL, MR_WELD_PWELD,
                                               MR_WELD_PWELD_ASYNC};
static const int thread_counts[] = {1, 2, 3, 8};

static void weld_ok(const float *p, size_t n, const uint32_t *idx, size_t tc,
                    const mr_weld_options *o, mr_welded *r)
{
    mr_error err;
    if (mr_weld(p, 0, n, idx, tc, o, r, &err) != MR_OK) {
        print_error("mr_weld: %s\n", err.message);
        fail();
    }
}

static void assert_welded_equal(const mr_welded *a, const mr_welded *b, size_t n)
{
    assert_int_equal(a->vertex_count, b->vertex_count);
    assert_int_equal(a->triangle_count, b->triangle_count);
    assert_memory_equal(a->positions, b->positions, a->vertex_count * 3 * sizeof(float));
    assert_memory_equal(a->remap, b->remap, n * sizeof(uint32_t));
    if (a->triangle_count)
        assert_memory_equal(a->indices, b->indices, a->triangle_count * 3 * sizeof(uint32_t));
}

/* The definition, O(n^2): visit in order, an unclustered vertex takes
 * every unclustered vertex within eps; the mean in increasing index order. */
static void brute_weld(const float *p, size_t n, double eps, int strict, uint32_t *label,
                       float *rep, size_t *clusters)
{
    for (size_t i = 0; i < n; i++)
        label[i] = UINT32_MAX;
    uint32_t k = 0;
    for (size_t i = 0; i < n; i++) {
        if (label[i] != UINT32_MAX)
            continue;
        double s[3] = {0, 0, 0};
        size_t cnt = 0;
        for (size_t j = i; j < n; j++) {
            if (label[j] != UINT32_MAX)
                continue;
            double dx = (double)p[3 * i] - p[3 * j], dy = (double)p[3 * i + 1] - p[3 * j + 1],
                   dz = (double)p[3 * i + 2] - p[3 * j + 2];
            double d2 = dx * dx + dy * dy + dz * dz;
            if (j == i || (strict ? d2 < eps * eps : d2 <= eps * eps)) {
                label[j] = k;
                for (int c = 0; c < 3; c++)
                    s[c] += p[3 * j + (size_t)c];
                cnt++;
            }
        }
        for (int c = 0; c < 3; c++)
            rep[3 * k + (size_t)c] = (float)(s[c] / (double)cnt);
        k++;
    }
    *clusters = k;
}

/* Points on a coarse lattice (many exact distances and duplicates) with
 * some jittered ones. */
static float *random_points(size_t n, uint64_t seed)
{
    float *p = malloc(n * 3 * sizeof *p);
    uint64_t s = seed;
    for (size_t i = 0; i < 3 * n; i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        uint32_t r = (uint32_t)(s >> 33);
        p[i] = (r & 1) ? (float)(r % 12) * 0.25f : (float)(r % 100000) * 3e-5f;
    }
    return p;
}

static void test_against_brute_force(void **state)
{
    (void)state;
    const size_t n = 1500;
    const double radii[] = {0, 0.1, 0.25, 0.3, 0.5, 1.0, 1e3};
    for (uint64_t seed = 1; seed <= 2; seed++) {
        float *p = random_points(n, seed);
        uint32_t *label = malloc(n * sizeof *label);
        float *rep = malloc(n * 3 * sizeof *rep);
        for (size_t e = 0; e < sizeof radii / sizeof *radii; e++)
            for (int strict = 0; strict <= 1; strict++) {
                size_t k;
                brute_weld(p, n, radii[e], strict, label, rep, &k);
                mr_weld_options o;
                mr_weld_options_default(&o);
                o.eps = radii[e];
                o.strict = strict;
                o.algorithm = MR_WELD_SERIAL;
                o.threads = 1;
                mr_welded ref;
                weld_ok(p, n, NULL, 0, &o, &ref);
                assert_int_equal(ref.vertex_count, k);
                assert_memory_equal(ref.remap, label, n * sizeof *label);
                assert_memory_equal(ref.positions, rep, k * 3 * sizeof *rep);
                if (radii[e] == 1e3)
                    assert_int_equal(k, 1);
                if (radii[e] == 0 && strict)
                    assert_int_equal(k, n);
                for (size_t a = 0; a < 3; a++)
                    for (size_t t = 0; t < 4; t++) {
                        mr_welded r;
                        o.algorithm = algorithms[a];
                        o.threads = thread_counts[t];
                        weld_ok(p, n, NULL, 0, &o, &r);
                        assert_welded_equal(&ref, &r, n);
                        mr_welded_free(&r);
                    }
                mr_welded_free(&ref);
            }
        free(p);
        free(label);
        free(rep);
    }
}

/* The spatial graph of the paper's Fig. 3/4 walk-through: v1 has no
 * smaller neighbour and takes v2 and v3; v4 depends on both and, as they
 * are taken, starts its own cluster; v5 (no smaller neighbour) takes v6. */
static void test_toy_graph(void **state)
{
    (void)state;
    const float p[] = {0, 0, 0, 0.9f, 0.3f, 0, 0.9f, -0.3f, 0, 1.8f, 0, 0, 10, 0, 0, 10.5f, 0, 0};
    const uint32_t tris[] = {0, 1, 2, 1, 3, 2, 3, 4, 5};
    const uint32_t expect[] = {0, 0, 0, 1, 2, 2};
    for (size_t a = 0; a < 3; a++)
        for (size_t t = 0; t < 4; t++) {
            mr_weld_options o;
            mr_weld_options_default(&o);
            o.eps = 1.0;
            o.algorithm = algorithms[a];
            o.threads = thread_counts[t];
            mr_welded r;
            weld_ok(p, 6, tris, 3, &o, &r);
            assert_int_equal(r.vertex_count, 3);
            assert_memory_equal(r.remap, expect, sizeof expect);
            assert_int_equal(r.stats.graph_edges, 6); /* 1-2 1-3 2-3 2-4 3-4 5-6 */
            /* the mean, summed in double in index order, rounded once */
            assert_true(r.positions[0] == (float)((0.0 + (double)0.9f + (double)0.9f) / 3.0));
            assert_true(r.positions[1] == 0.0f);
            assert_true(r.positions[3] == 1.8f);
            assert_true(r.positions[6] == 10.25f);
            const uint32_t tri_expect[] = {0, 0, 0, 0, 1, 0, 1, 2, 2};
            assert_int_equal(r.triangle_count, 3); /* degenerate ones kept */
            assert_memory_equal(r.indices, tri_expect, sizeof tri_expect);
            mr_welded_free(&r);
            o.drop_degenerate = 1;
            weld_ok(p, 6, tris, 3, &o, &r);
            assert_int_equal(r.triangle_count, 0);
            mr_welded_free(&r);
        }
}

static void test_generated_meshes(void **state)
{
    (void)state;
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SCAN, 60000, 5, &m, NULL), MR_OK);
    mr_stats s;
    assert_int_equal(mr_stats_compute(m.positions, 0, m.vertex_count, NULL, 0, &s, NULL), MR_OK);
    const double rel[] = {0, 1e-4, 1e-3, 4e-3, 2e-2};
    for (size_t e = 0; e < sizeof rel / sizeof *rel; e++)
        for (int order = 0; order <= 1; order++)
            for (int drop = 0; drop <= 1; drop++) {
                mr_weld_options o;
                mr_weld_options_default(&o);
                o.eps = rel[e] * s.bbox_diagonal;
                o.order = order ? MR_WELD_ORDER_GRADE : MR_WELD_ORDER_INDEX;
                o.drop_degenerate = drop;
                o.algorithm = MR_WELD_SERIAL;
                o.threads = 1;
                mr_welded ref;
                weld_ok(m.positions, m.vertex_count, m.indices, m.triangle_count, &o, &ref);
                if (rel[e] == 0)
                    assert_int_equal(ref.vertex_count, m.vertex_count);
                else if (rel[e] >= 2e-2)
                    assert_true(ref.vertex_count < m.vertex_count);
                /* every vertex is within eps of its cluster's first member */
                size_t *first = malloc(ref.vertex_count * sizeof *first);
                for (size_t c = 0; c < ref.vertex_count; c++)
                    first[c] = SIZE_MAX;
                size_t degenerate = 0;
                for (size_t v = 0; v < m.vertex_count; v++) {
                    uint32_t c = ref.remap[v];
                    assert_true(c < ref.vertex_count);
                    if (order == 0 && first[c] == SIZE_MAX)
                        first[c] = v;
                }
                if (order == 0)
                    for (size_t v = 0; v < m.vertex_count; v++) {
                        const float *a = m.positions + 3 * v,
                                    *b = m.positions + 3 * first[ref.remap[v]];
                        double dx = (double)a[0] - b[0], dy = (double)a[1] - b[1],
                               dz = (double)a[2] - b[2];
                        assert_true(dx * dx + dy * dy + dz * dz <= o.eps * o.eps);
                    }
                for (size_t t = 0; t < ref.triangle_count; t++) {
                    const uint32_t *x = ref.indices + 3 * t;
                    degenerate += x[0] == x[1] || x[1] == x[2] || x[0] == x[2];
                }
                if (drop)
                    assert_int_equal(degenerate, 0);
                else
                    assert_int_equal(ref.triangle_count, m.triangle_count);
                free(first);
                for (size_t a = 0; a < 3; a++)
                    for (size_t t = 0; t < 4; t++) {
                        o.algorithm = algorithms[a];
                        o.threads = thread_counts[t];
                        mr_welded r;
                        weld_ok(m.positions, m.vertex_count, m.indices, m.triangle_count, &o,
                                &r);
                        assert_welded_equal(&ref, &r, m.vertex_count);
                        mr_welded_free(&r);
                    }
                mr_welded_free(&ref);
            }
    mr_mesh_free(&m);
}

/* In grade order the first vertex visited is the one of highest grade and
 * index order is not what is followed: the result differs from index
 * order but is again a valid clustering. */
static void test_grade_order(void **state)
{
    (void)state;
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_TORUS, 5000, 2, &m, NULL), MR_OK);
    mr_weld_options o;
    mr_weld_options_default(&o);
    o.eps = 0.08;
    mr_welded a, b;
    weld_ok(m.positions, m.vertex_count, m.indices, m.triangle_count, &o, &a);
    o.order = MR_WELD_ORDER_GRADE;
    weld_ok(m.positions, m.vertex_count, m.indices, m.triangle_count, &o, &b);
    assert_true(a.vertex_count < m.vertex_count);
    assert_true(b.vertex_count < m.vertex_count);
    assert_true(a.vertex_count != b.vertex_count ||
                memcmp(a.remap, b.remap, m.vertex_count * 4) != 0);
    mr_welded_free(&a);
    mr_welded_free(&b);
    mr_mesh_free(&m);
}

static void test_point_cloud_attributes(void **state)
{
    (void)state;
    mr_mesh m, out;
    mr_mesh_init(&m);
    assert_int_equal(mr_mesh_alloc(&m, 4, 0, MR_ATTR_NORMALS | MR_ATTR_COLORS, NULL), MR_OK);
    const float p[] = {0, 0, 0, 0.5f, 0, 0, 3, 0, 0, 3, 0, 0};
    const float nr[] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1};
    memcpy(m.positions, p, sizeof p);
    memcpy(m.normals, nr, sizeof nr);
    for (int i = 0; i < 16; i++)
        m.colors[i] = (float)i / 16.0f;
    mr_weld_options o;
    mr_weld_options_default(&o);
    o.eps = 0.5; /* inclusive: 0 and 1 merge; 2 and 3 are duplicates */
    uint32_t *remap;
    mr_weld_stats st;
    assert_int_equal(mr_mesh_weld(&m, &o, &out, &remap, &st, NULL), MR_OK);
    assert_int_equal(out.vertex_count, 2);
    assert_int_equal(out.triangle_count, 0);
    assert_true(out.positions[0] == 0.25f && out.positions[3] == 3.0f);
    assert_true(out.normals[0] == 0.5f && out.normals[1] == 0.5f && out.normals[5] == 0.0f);
    assert_true(out.colors[0] == 0.125f); /* (0 + 4/16) / 2 */
    assert_true(out.colors[4] == (float)((8.0 + 12.0) / 32.0));
    assert_int_equal(remap[3], 1);
    assert_true(st.peak_bytes > 0);
    free(remap);
    mr_mesh_free(&out);
    o.strict = 1; /* exclusive: 0 and 1 (exactly 0.5 apart) stay apart */
    assert_int_equal(mr_mesh_weld(&m, &o, &out, NULL, NULL, NULL), MR_OK);
    assert_int_equal(out.vertex_count, 3);
    mr_mesh_free(&out);
    mr_mesh_free(&m);
}

static void test_errors(void **state)
{
    (void)state;
    const float p[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t bad[] = {0, 1, 7};
    mr_weld_options o;
    mr_weld_options_default(&o);
    mr_welded r;
    mr_error err;
    const double bad_eps[] = {-1.0, NAN, INFINITY};
    for (int i = 0; i < 3; i++) {
        o.eps = bad_eps[i];
        assert_int_equal(mr_weld(p, 0, 3, NULL, 0, &o, &r, &err), MR_ERR_INVALID_ARGUMENT);
        tu_assert_contains(err.message, "eps must be a finite number >= 0");
        assert_null(r.positions);
    }
    o.eps = 0.1;
    assert_int_equal(mr_weld(p, 0, 0, NULL, 0, &o, &r, &err), MR_ERR_EMPTY);
    tu_assert_contains(err.message, "no vertices");
    assert_int_equal(mr_weld(p, 0, 3, bad, 1, &o, &r, &err), MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_weld(NULL, 0, 3, NULL, 0, &o, &r, &err), MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_weld(p, 4, 3, NULL, 0, &o, &r, &err), MR_ERR_INVALID_ARGUMENT);
    float q[] = {0, 0, 0, NAN, 0, 0};
    assert_int_equal(mr_weld(q, 0, 2, NULL, 0, &o, &r, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "vertex 1 has a non-finite coordinate");
    double eps;
    assert_int_equal(mr_weld_find_eps(p, 0, 3, 1.0, NULL, &eps, NULL, &err),
                     MR_ERR_INVALID_ARGUMENT);
    mr_mesh empty, out;
    mr_mesh_init(&empty);
    assert_int_equal(mr_mesh_weld(&empty, &o, &out, NULL, NULL, &err), MR_ERR_EMPTY);
}

/* A strided input gives the same result as a packed one. */
static void test_stride(void **state)
{
    (void)state;
    const size_t n = 500;
    float *p = random_points(n, 9);
    float *wide = malloc(n * 5 * sizeof *wide);
    for (size_t i = 0; i < n; i++) {
        memcpy(wide + 5 * i, p + 3 * i, 12);
        wide[5 * i + 3] = wide[5 * i + 4] = -7;
    }
    mr_weld_options o;
    mr_weld_options_default(&o);
    o.eps = 0.3;
    mr_welded a, b;
    weld_ok(p, n, NULL, 0, &o, &a);
    mr_error err;
    assert_int_equal(mr_weld(wide, 20, n, NULL, 0, &o, &b, &err), MR_OK);
    assert_welded_equal(&a, &b, n);
    mr_welded_free(&a);
    mr_welded_free(&b);
    free(p);
    free(wide);
}

static void test_find_eps(void **state)
{
    (void)state;
    mr_mesh m;
    mr_mesh_init(&m);
    assert_int_equal(mr_generate(MR_GEN_SCAN, 20000, 1, &m, NULL), MR_OK);
    const double shares[] = {0.001, 0.1, 0.5};
    for (int i = 0; i < 3; i++) {
        double eps;
        size_t removed;
        mr_error err;
        assert_int_equal(mr_weld_find_eps(m.positions, 0, m.vertex_count, shares[i], NULL, &eps,
                                          &removed, &err),
                         MR_OK);
        size_t target = (size_t)ceil(shares[i] * (double)m.vertex_count);
        assert_true(removed >= target);
        mr_weld_options o;
        mr_weld_options_default(&o);
        o.eps = eps;
        mr_welded r;
        weld_ok(m.positions, m.vertex_count, NULL, 0, &o, &r);
        assert_int_equal(m.vertex_count - r.vertex_count, removed);
        mr_welded_free(&r);
        o.eps = eps * (1 - 1e-5); /* just below: too few */
        weld_ok(m.positions, m.vertex_count, NULL, 0, &o, &r);
        assert_true(m.vertex_count - r.vertex_count < target);
        mr_welded_free(&r);
    }
    mr_mesh_free(&m);
}

/* Brute force against every algorithm and thread count on one cloud. */
static void check_cloud(const float *p, size_t n, double eps, int strict)
{
    uint32_t *label = malloc(n * sizeof *label);
    float *rep = malloc(n * 3 * sizeof *rep);
    size_t k;
    brute_weld(p, n, eps, strict, label, rep, &k);
    mr_weld_options o;
    mr_weld_options_default(&o);
    o.eps = eps;
    o.strict = strict;
    for (size_t a = 0; a < 3; a++)
        for (size_t t = 0; t < 4; t++) {
            mr_welded r;
            o.algorithm = algorithms[a];
            o.threads = thread_counts[t];
            weld_ok(p, n, NULL, 0, &o, &r);
            assert_int_equal(r.vertex_count, k);
            assert_memory_equal(r.remap, label, n * sizeof *label);
            assert_memory_equal(r.positions, rep, k * 3 * sizeof *rep);
            mr_welded_free(&r);
        }
    free(label);
    free(rep);
}

/* The sweep's grid: rows along the longest axis (x, y or z), points
 * exactly on cell boundaries and exactly eps apart, negative and offset
 * coordinates, duplicates, radii of 0, tiny (cells grown to 2^-20 of the
 * extent) and larger than the model. */
static void test_sweep_grid_edges(void **state)
{
    (void)state;
    const size_t n = 1000;
    float *p = malloc(n * 3 * sizeof *p);
    uint64_t s = 7;
    for (int axis = 0; axis < 3; axis++)
        for (int offset = 0; offset < 2; offset++) {
            /* a lattice of step 0.25, stretched along `axis`, around
             * -2 or -1000.5 */
            for (size_t i = 0; i < n; i++) {
                s = s * 6364136223846793005ull + 1442695040888963407ull;
                uint32_t r = (uint32_t)(s >> 33);
                float base = offset ? -1000.5f : -2.0f;
                for (int c = 0; c < 3; c++) {
                    int span = c == axis ? 64 : 6;
                    p[3 * i + (size_t)c] = base + 0.25f * (float)((r >> (8 * c)) % (uint32_t)span);
                }
                if (i % 7 == 3 && i > 0) /* duplicates of an earlier point */
                    memcpy(p + 3 * i, p + 3 * (i / 2), 3 * sizeof *p);
            }
            const double radii[] = {0, 1e-30, 0.25, 0.2500001, 0.5, 1e6};
            for (size_t e = 0; e < sizeof radii / sizeof *radii; e++)
                for (int strict = 0; strict <= 1; strict++)
                    check_cloud(p, n, radii[e], strict);
        }
    free(p);
    /* coordinates and radii whose squares overflow a float: the float
     * filter sees an infinite distance, the exact test decides */
    {
        const size_t m = 40;
        float *h = malloc(m * 3 * sizeof *h);
        for (size_t i = 0; i < m; i++) /* along the diagonal, 2e20 * sqrt(3) apart */
            for (int c = 0; c < 3; c++)
                h[3 * i + (size_t)c] = ((float)i - 20.0f) * 2e20f + (float)c * 1e17f;
        const double big[] = {1e19, 3e20, 4e20, 7e20, 1e22};
        for (size_t e = 0; e < sizeof big / sizeof *big; e++)
            for (int strict = 0; strict <= 1; strict++)
                check_cloud(h, m, big[e], strict);
        free(h);
    }
    /* above the parallel threshold: the threads share the rows */
    const size_t big = 17000;
    float *q = random_points(big, 3);
    check_cloud(q, big, 0.25, 0);
    free(q);
}


/* The neighbour graph itself, edge for edge, against a plain sweep over
 * the points sorted by x: a jittered wavy sheet (every point has
 * neighbours in the rows around its own) with duplicates, above the
 * parallel threshold, at every thread count. */
static int cmp_x(const void *a, const void *b, const float *p)
{
    const float xa = p[3 * *(const uint32_t *)a], xb = p[3 * *(const uint32_t *)b];
    return xa < xb ? -1 : xa > xb;
}

static const float *sort_pts;
static int cmp_sort(const void *a, const void *b) { return cmp_x(a, b, sort_pts); }

static int cmp_u32(const void *a, const void *b)
{
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

static void test_radius_graph_exact(void **state)
{
    (void)state;
    const size_t side = 180, n = side * side;
    float *p = malloc(n * 3 * sizeof *p);
    uint64_t s = 11;
    for (size_t i = 0; i < n; i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        const uint32_t r = (uint32_t)(s >> 33);
        const float u = (float)(i % side) + (float)(r % 1000) * 4e-4f,
                    v = (float)(i / side) + (float)((r >> 10) % 1000) * 4e-4f;
        p[3 * i] = 0.7f * u + 0.3f * v;
        p[3 * i + 1] = 0.2f * u - 0.6f * v;
        p[3 * i + 2] = 3.0f * sinf(0.05f * u) + 0.5f * v;
        if (i % 11 == 5) /* a duplicate of an earlier point */
            memcpy(p + 3 * i, p + 3 * (i / 3), 3 * sizeof *p);
    }
    uint32_t *order = malloc(n * sizeof *order);
    for (size_t i = 0; i < n; i++)
        order[i] = (uint32_t)i;
    sort_pts = p;
    qsort(order, n, sizeof *order, cmp_sort);
    double lo[3], hi[3];
    size_t bad;
    assert_true(mr_points_bounds(p, n, 1, lo, hi, &bad));
    const double box[6] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
    const double radii[] = {0.3, 0.75, 1.6};
    for (size_t e = 0; e < sizeof radii / sizeof *radii; e++)
        for (int strict = 0; strict <= 1; strict++) {
            const double eps = radii[e];
            /* the reference: larger neighbours of each point, and counts
             * of smaller ones */
            size_t cap = 1 << 16, len = 0;
            uint32_t *pairs = malloc(cap * 2 * sizeof *pairs);
            for (size_t a = 0; a < n; a++)
                for (size_t b = a + 1; b < n; b++) {
                    const float *x = p + 3 * order[a], *y = p + 3 * order[b];
                    if ((double)y[0] - (double)x[0] > eps)
                        break;
                    const double dx = (double)x[0] - y[0], dy = (double)x[1] - y[1],
                                 dz = (double)x[2] - y[2], d2 = dx * dx + dy * dy + dz * dz;
                    if (strict ? d2 < eps * eps : d2 <= eps * eps) {
                        if (len == cap)
                            pairs = realloc(pairs, (cap *= 2) * 2 * sizeof *pairs);
                        const uint32_t i = order[a], j = order[b];
                        pairs[2 * len] = i < j ? i : j;
                        pairs[2 * len + 1] = i < j ? j : i;
                        len++;
                    }
                }
            size_t *off = calloc(n + 1, sizeof *off);
            int32_t *dep = calloc(n, sizeof *dep);
            for (size_t k = 0; k < len; k++) {
                off[pairs[2 * k] + 1]++;
                dep[pairs[2 * k + 1]]++;
            }
            for (size_t i = 0; i < n; i++)
                off[i + 1] += off[i];
            uint32_t *adj = malloc((len + 1) * sizeof *adj), *fill = calloc(n, sizeof *fill);
            for (size_t k = 0; k < len; k++)
                adj[off[pairs[2 * k]] + fill[pairs[2 * k]]++] = pairs[2 * k + 1];
            for (size_t i = 0; i < n; i++)
                qsort(adj + off[i], off[i + 1] - off[i], sizeof *adj, cmp_u32);
            assert_true(len >= n / 11); /* at least the duplicates */
            for (size_t t = 0; t < 4; t++) {
                mr_radius_graph g;
                mr_error err;
                assert_int_equal(
                    mr_radius_graph_build(&g, p, n, eps, strict, box, thread_counts[t], &err),
                    MR_OK);
                assert_int_equal(g.edge_count, len);
                assert_memory_equal(g.offsets, off, (n + 1) * sizeof *off);
                assert_memory_equal(g.adj, adj, len * sizeof *adj);
                for (size_t i = 0; i < n; i++)
                    assert_int_equal(atomic_load(&g.depend[i]), dep[i]);
                mr_radius_graph_free(&g);
            }
            free(pairs);
            free(off);
            free(dep);
            free(adj);
            free(fill);
        }
    free(order);
    free(p);
}

/* The finder's filtered graph gives the radius a bisection over whole
 * welds gives: the same bracket and steps, each step a full mr_weld. */
static void test_find_eps_reference(void **state)
{
    (void)state;
    const size_t n = 3000;
    float *p = random_points(n, 11);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fmin(lo[c], p[3 * i + (size_t)c]);
            hi[c] = fmax(hi[c], p[3 * i + (size_t)c]);
        }
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const double shares[] = {0.0, 0.01, 0.3, 0.9};
    for (int strict = 0; strict <= 1; strict++)
        for (int i = 0; i < 4; i++) {
            mr_weld_options o;
            mr_weld_options_default(&o);
            o.strict = strict;
            o.threads = 2;
            double eps;
            size_t removed;
            mr_error err;
            assert_int_equal(
                mr_weld_find_eps(p, 0, n, shares[i], &o, &eps, &removed, &err), MR_OK);
            const size_t target = (size_t)ceil(shares[i] * (double)n);
            /* the reference */
            mr_welded r;
            o.eps = 0;
            weld_ok(p, n, NULL, 0, &o, &r);
            size_t got = n - r.vertex_count;
            mr_welded_free(&r);
            double want = 0;
            if (got < target) {
                double a = 0, b = diag * 1e-5;
                for (;;) {
                    o.eps = b;
                    weld_ok(p, n, NULL, 0, &o, &r);
                    got = n - r.vertex_count;
                    mr_welded_free(&r);
                    if (got >= target || b > 2 * diag)
                        break;
                    a = b;
                    b *= 2;
                }
                for (int it = 0; it < 60 && b - a > 1e-6 * b; it++) {
                    double m = 0.5 * (a + b);
                    o.eps = m;
                    weld_ok(p, n, NULL, 0, &o, &r);
                    if (n - r.vertex_count >= target) {
                        b = m;
                        got = n - r.vertex_count;
                    } else {
                        a = m;
                    }
                    mr_welded_free(&r);
                }
                want = b;
            }
            assert_true(eps == want);
            assert_int_equal(removed, got);
            assert_true(removed >= target);
        }
    free(p);
}

/* ---- Open3D --------------------------------------------------------------- */

static const char *open3d_script(void)
{
    static char path[4096];
    snprintf(path, sizeof path, "%s", __FILE__);
    char *slash = strrchr(path, '/');
    if (!slash)
        return NULL;
    snprintf(slash, sizeof path - (size_t)(slash - path), "/../bench/open3d_weld.py");
    return tu_file_exists(path) ? path : NULL;
}

static const char *python(void)
{
    const char *env = getenv("MR_PYTHON");
    return env && *env ? env : "/usr/bin/python3";
}

static int have_open3d(void)
{
    char *out = NULL;
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "'%s' -c 'import open3d' >/dev/null 2>&1 && echo yes", python());
    FILE *p = popen(cmd, "r");
    char buf[8] = "";
    if (p) {
        if (!fgets(buf, sizeof buf, p))
            buf[0] = '\0';
        pclose(p);
    }
    free(out);
    return !strncmp(buf, "yes", 3);
}

/* Same clusters as Open3D's merge_close_vertices (which compares strictly):
 * the same count, the same triangles (so the same vertex -> cluster map on
 * every referenced vertex) and the same means up to rounding: Open3D adds
 * the members in its k-d tree's order, we in index order, both in double,
 * and we round the mean to float. */
static void test_open3d_equivalence(void **state)
{
    (void)state;
    const char *script = open3d_script();
    if (!script || !have_open3d())
        skip();
    const struct {
        mr_generator kind;
        size_t tris;
    } meshes[] = {{MR_GEN_SCAN, 30000}, {MR_GEN_TORUS, 8000}};
    for (size_t mi = 0; mi < 2; mi++) {
        mr_mesh m;
        mr_mesh_init(&m);
        assert_int_equal(mr_generate(meshes[mi].kind, meshes[mi].tris, 4, &m, NULL), MR_OK);
        const char *in = tu_tmp_path("o3d-in.bin");
        FILE *f = fopen(in, "wb");
        int64_t hdr[2] = {(int64_t)m.vertex_count, (int64_t)m.triangle_count};
        fwrite(hdr, sizeof hdr, 1, f);
        fwrite(m.positions, 12, m.vertex_count, f);
        fwrite(m.indices, 12, m.triangle_count, f);
        fclose(f);
        double eps_list[3];
        mr_weld_options o;
        mr_weld_options_default(&o);
        o.strict = 1;
        const double shares[] = {0.01, 0.1, 0.5};
        for (int e = 0; e < 3; e++)
            assert_int_equal(mr_weld_find_eps(m.positions, 0, m.vertex_count, shares[e], &o,
                                              &eps_list[e], NULL, NULL),
                             MR_OK);
        for (int e = 0; e < 3; e++) {
            const char *out = tu_tmp_path("o3d-out.bin");
            char cmd[8192];
            snprintf(cmd, sizeof cmd, "'%s' '%s' check '%s' %.17g '%s'", python(), script, in,
                     eps_list[e], out);
            assert_int_equal(system(cmd), 0);
            size_t size;
            char *data = tu_read_file(out, &size);
            assert_non_null(data);
            int64_t nv, nt;
            memcpy(&nv, data, 8);
            memcpy(&nt, data + 8, 8);
            o.eps = eps_list[e];
            mr_welded r;
            weld_ok(m.positions, m.vertex_count, m.indices, m.triangle_count, &o, &r);
            assert_int_equal(r.vertex_count, (size_t)nv);
            assert_int_equal(r.triangle_count, (size_t)nt);
            assert_int_equal(size, 16 + (size_t)nv * 24 + (size_t)nt * 12);
            const char *vp = data + 16, *tp = data + 16 + nv * 24;
            for (size_t i = 0; i < (size_t)nv * 3; i++) {
                double theirs;
                memcpy(&theirs, vp + 8 * i, 8);
                double tol = 2.0 * FLT_EPSILON * fmax(1.0, fabs(theirs));
                if (fabs((double)r.positions[i] - theirs) > tol) {
                    print_error("coordinate %zu: %.9g vs Open3D %.17g\n", i, r.positions[i],
                                theirs);
                    fail();
                }
            }
            for (size_t i = 0; i < (size_t)nt * 3; i++) {
                int32_t t;
                memcpy(&t, tp + 4 * i, 4);
                assert_int_equal(r.indices[i], (uint32_t)t);
            }
            mr_welded_free(&r);
            free(data);
        }
        mr_mesh_free(&m);
    }
}

/* ---- command line ---------------------------------------------------------- */

static void test_cli(void **state)
{
    (void)state;
    const char *in = tu_tmp_path("weld-in.ply");
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate scan --triangles 20k -o '%s' -q", in), NULL),
                     0);
    const char *o1 = tu_tmp_path("weld-1.ply"), *o2 = tu_tmp_path("weld-2.ply");
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --eps-rel 0.003 --algorithm serial "
                                       "--threads 1 -q",
                                       in, o1),
                                NULL),
                     0);
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --eps-rel 0.003 --threads 3 --json",
                                       in, o2),
                                &out),
                     0);
    tu_assert_contains(out, "\"algorithm\": \"pweld-async\"");
    tu_assert_contains(out, "\"mapping\":");
    tu_assert_contains(out, "\"retriangulation\":");
    free(out);
    size_t n1, n2;
    char *a = tu_read_file(o1, &n1), *b = tu_read_file(o2, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1);
    free(a);
    free(b);

    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --reduce 10%% --stats --order grade "
                                       "--drop-degenerate",
                                       in, o1),
                                &out),
                     0);
    tu_assert_contains(out, "eps        ");
    tu_assert_contains(out, "removed");
    tu_assert_contains(out, "mapping");
    free(out);

    /* a point cloud as .xyz in and out */
    const char *xyz = tu_tmp_path("weld-in.xyz"), *xyz_out = tu_tmp_path("weld-out.xyz");
    tu_write_file(xyz, "0 0 0\n0.1 0 0\n5 5 5\n", 20);
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --eps 0.2 -q", xyz, xyz_out), NULL), 0);
    char *text = tu_read_file(xyz_out, NULL);
    assert_non_null(text);
    tu_assert_contains(text, "0.05 0 0\n5 5 5\n");
    free(text);

    /* errors: usage (2), bad files (1), no partial output */
    const char *none = tu_tmp_path("weld-none.ply");
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --eps -1", in, none), &out), 2);
    tu_assert_contains(out, "--eps needs a finite number >= 0");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --eps nan", in, none), &out), 2);
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s'", in, none), &out), 2);
    tu_assert_contains(out, "no radius given");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --eps 1 --algorithm fast", in, none),
                                &out),
                     2);
    free(out);
    const char *empty = tu_tmp_path("weld-empty.obj");
    tu_write_file(empty, "# nothing\n", 10);
    assert_int_equal(tu_run_cli(tu_fmt("weld '%s' -o '%s' --eps 1", empty, none), &out), 1);
    free(out);
    assert_false(tu_file_exists(none));
    assert_int_equal(tu_run_cli("weld --help", &out), 0);
    tu_assert_contains(out, "usage: meshreduce weld");
    free(out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_brute_force),
        cmocka_unit_test(test_toy_graph),
        cmocka_unit_test(test_generated_meshes),
        cmocka_unit_test(test_grade_order),
        cmocka_unit_test(test_point_cloud_attributes),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_stride),
        cmocka_unit_test(test_find_eps),
        cmocka_unit_test(test_sweep_grid_edges),
        cmocka_unit_test(test_radius_graph_exact),
        cmocka_unit_test(test_find_eps_reference),
        cmocka_unit_test(test_open3d_equivalence),
        cmocka_unit_test(test_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
