/* Error metrics: point-triangle distance, the hierarchies, mr_compare,
 * mr_vertex_similarity and the compare command. */
#include "testutil.h"
#include "geometry/distance.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

static void assert_near(double got, double want, double tol)
{
    if (!(fabs(got - want) <= tol)) {
        print_error("got %.17g, want %.17g (tolerance %.3g)\n", got, want, tol);
        fail();
    }
}

static mr_mesh generated(mr_generator kind, size_t triangles, uint64_t seed)
{
    mr_mesh m;
    mr_error err;
    mr_mesh_init(&m);
    if (mr_generate(kind, triangles, seed, &m, &err) != MR_OK) {
        print_error("mr_generate: %s\n", err.message);
        fail();
    }
    return m;
}

static mr_compare_result compare_meshes(const mr_mesh *a, const mr_mesh *b, size_t samples,
                                        int threads)
{
    mr_compare_options o;
    mr_compare_options_default(&o);
    o.samples = samples;
    o.threads = threads;
    mr_compare_result r;
    mr_error err;
    if (mr_compare(a->positions, a->vertex_count, a->indices, a->triangle_count, b->positions,
                   b->vertex_count, b->indices, b->triangle_count, &o, &r, &err) != MR_OK) {
        print_error("mr_compare: %s\n", err.message);
        fail();
    }
    return r;
}

/* Deterministic uniform numbers for the tests. */
static double test_random(uint64_t *state)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*state >> 11) * 0x1p-53;
}

/* ---- point to triangle ---------------------------------------------------- */

typedef struct tri_case {
    double p[3], q[3], d2;
} tri_case;

static void check_case(const double a[3], const double b[3], const double c[3],
                       const tri_case *tc)
{
    double q[3];
    double d2 = mr_point_triangle_dist2(tc->p, a, b, c, q);
    assert_near(d2, tc->d2, 1e-12);
    for (int k = 0; k < 3; k++)
        assert_near(q[k], tc->q[k], 1e-12);
    /* NULL closest is allowed and gives the same distance */
    assert_true(mr_point_triangle_dist2(tc->p, a, b, c, NULL) == d2);
}

static void test_point_triangle_regions(void **state)
{
    (void)state;
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
    const tri_case cases[] = {
        {{-1, -1, 0}, {0, 0, 0}, 2},         /* vertex a */
        {{2, -1, 1}, {1, 0, 0}, 3},          /* vertex b */
        {{-0.5, 2, 3}, {0, 1, 0}, 10.25},    /* vertex c */
        {{0.5, -1, 2}, {0.5, 0, 0}, 5},      /* edge ab */
        {{-1, 0.5, -2}, {0, 0.5, 0}, 5},     /* edge ac */
        {{1, 1, 1}, {0.5, 0.5, 0}, 1.5},     /* edge bc */
        {{0.25, 0.25, -3}, {0.25, 0.25, 0}, 9}, /* face, below */
        {{0.2, 0.3, 0}, {0.2, 0.3, 0}, 0},   /* in the face */
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        check_case(a, b, c, &cases[i]);
        /* the same answers whatever corner comes first */
        check_case(b, c, a, &cases[i]);
        check_case(c, a, b, &cases[i]);
        check_case(a, c, b, &cases[i]);
    }
    /* a vertex is exactly at distance 0 from its triangle */
    assert_true(mr_point_triangle_dist2(b, a, b, c, NULL) == 0);
    assert_true(mr_point_triangle_dist2(c, a, b, c, NULL) == 0);
}

static void test_point_triangle_degenerate(void **state)
{
    (void)state;
    /* collinear, with the middle point last: the segment a b */
    const double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {1, 0, 0};
    const tri_case line[] = {
        {{1, 1, 0}, {1, 0, 0}, 1},
        {{1.5, 0, -2}, {1.5, 0, 0}, 4},
        {{3, 0, 0}, {2, 0, 0}, 1},
        {{-1, 1, 0}, {0, 0, 0}, 2},
    };
    for (size_t i = 0; i < sizeof line / sizeof *line; i++) {
        check_case(a, b, c, &line[i]);
        check_case(c, a, b, &line[i]);
    }
    /* two coincident corners: the segment to the third */
    const double s0[3] = {0, 0, 0}, s1[3] = {0, 0, 2};
    const tri_case seg = {{1, 0, 1}, {0, 0, 1}, 1};
    check_case(s0, s0, s1, &seg);
    check_case(s0, s1, s0, &seg);
    check_case(s1, s0, s0, &seg);
    /* all three coincident: a point */
    const double pt[3] = {1, 1, 1};
    const tri_case point = {{1, 1, 3}, {1, 1, 1}, 4};
    check_case(pt, pt, pt, &point);
    /* segment helper */
    double q[3];
    assert_near(mr_point_segment_dist2((double[3]){0, 5, 0}, s0, s0, q), 25, 0);
}

/* ---- hierarchies against brute force --------------------------------------- */

static double brute_triangle(const mr_mesh *m, const double p[3])
{
    double best = INFINITY;
    for (size_t t = 0; t < m->triangle_count; t++) {
        double v[3][3];
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                v[k][j] = m->positions[3 * m->indices[3 * t + k] + j];
        double d = mr_point_triangle_dist2(p, v[0], v[1], v[2], NULL);
        best = d < best ? d : best;
    }
    return best;
}

static void random_point(uint64_t *rng, double p[3], double extent)
{
    for (int k = 0; k < 3; k++)
        p[k] = (2 * test_random(rng) - 1) * extent;
}

static void test_bvh_vs_brute_force(void **state)
{
    (void)state;
    mr_mesh m = generated(MR_GEN_TORUS, 3000, 7);
    mr_tri_bvh t;
    mr_error err;
    assert_int_equal(mr_tri_bvh_build(&t, m.positions, m.indices, m.triangle_count, 0, &err),
                     MR_OK);
    assert_int_equal(t.thin.prim_count, 0); /* no slivers: one box tree */
    uint64_t rng = 12345;
    uint32_t hint = MR_NO_HINT;
    for (int i = 0; i < 10000; i++) {
        double p[3], q[3];
        /* mostly near the surface, some far away */
        random_point(&rng, p, i % 10 == 0 ? 5.0 : 1.5);
        uint32_t tri;
        /* alternate: no hint, the previous answer, a random triangle */
        uint32_t h = i % 3 == 0   ? MR_NO_HINT
                     : i % 3 == 1 ? hint
                                  : (uint32_t)(test_random(&rng) * m.triangle_count);
        double d = mr_tri_bvh_nearest(&t, p, h, &tri, q);
        double want = brute_triangle(&m, p);
        assert_near(d, want, 1e-12 * (1 + want));
        assert_true(tri < m.triangle_count);
        /* the reported triangle and closest point agree with the distance */
        double v[3][3];
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                v[k][j] = m.positions[3 * m.indices[3 * tri + k] + j];
        assert_true(mr_point_triangle_dist2(p, v[0], v[1], v[2], NULL) == d);
        double dq = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                    (p[2] - q[2]) * (p[2] - q[2]);
        assert_near(dq, d, 1e-12 * (1 + d));
        hint = tri;
    }
    mr_tri_bvh_free(&t);

    /* nearest vertex, over the odd vertices only (ids map through the list) */
    size_t n = m.vertex_count / 2;
    uint32_t *ids = malloc(n * sizeof *ids);
    for (size_t i = 0; i < n; i++)
        ids[i] = (uint32_t)(2 * i + 1);
    mr_point_bvh pb;
    assert_int_equal(mr_point_bvh_build(&pb, m.positions, ids, n, 1, &err), MR_OK);
    for (int i = 0; i < 10000; i++) {
        double p[3];
        random_point(&rng, p, i % 10 == 0 ? 5.0 : 1.5);
        double want = INFINITY;
        for (size_t j = 0; j < n; j++) {
            const float *f = m.positions + 3 * ids[j];
            double d = (p[0] - f[0]) * (p[0] - f[0]) + (p[1] - f[1]) * (p[1] - f[1]) +
                       (p[2] - f[2]) * (p[2] - f[2]);
            want = d < want ? d : want;
        }
        uint32_t id;
        double d = mr_point_bvh_nearest(&pb, p, i % 2 ? (uint32_t)(i % n) : MR_NO_HINT, &id);
        assert_true(d == want);
        assert_true(id < n);
    }
    mr_point_bvh_free(&pb);
    free(ids);
    mr_mesh_free(&m);
}

static void test_bvh_tiny_and_flat(void **state)
{
    (void)state;
    /* one triangle; and many identical triangles (no split possible) */
    float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint32_t idx[3 * 100];
    for (int i = 0; i < 300; i++)
        idx[i] = (uint32_t)(i % 3);
    mr_error err;
    for (size_t n = 1; n <= 100; n += 99) {
        mr_tri_bvh t;
        assert_int_equal(mr_tri_bvh_build(&t, pos, idx, n, 0, &err), MR_OK);
        uint32_t tri;
        double d = mr_tri_bvh_nearest(&t, (double[3]){0.25, 0.25, 2}, MR_NO_HINT, &tri, NULL);
        assert_near(d, 4, 0);
        assert_true(tri < n);
        mr_tri_bvh_free(&t);
    }
    mr_bvh b;
    assert_int_equal(mr_bvh_build(&b, pos, pos, 0, 0, &err), MR_ERR_INVALID_ARGUMENT);
}

/* ---- fans of slivers: one vertex in every triangle ------------------------ */

/*
 * A polygon of `corners` corners on the ellipse x = cos t, y = 0.6 sin t
 * (its radius scaled by 1 + 0.15 sin 5t + 0.05 sin(17t + 1) when
 * `irregular`; z = crown sin 3t), fan-triangulated as an OBJ reader does a
 * face `f 1 2 ... N`: triangles (0, i, i + 1), one vertex in all of them,
 * long slivers. `shift` moves every vertex.
 */
#define FAN_PI 3.14159265358979323846

static mr_mesh polygon_fan(size_t corners, int irregular, double crown, const double shift[3])
{
    mr_mesh m;
    mr_mesh_init(&m);
    m.vertex_count = corners;
    m.triangle_count = corners - 2;
    m.positions = malloc(3 * corners * sizeof *m.positions);
    m.indices = malloc(3 * m.triangle_count * sizeof *m.indices);
    assert_non_null(m.positions);
    assert_non_null(m.indices);
    for (size_t i = 0; i < corners; i++) {
        const double t = 2 * FAN_PI * (double)i / (double)corners;
        const double r = irregular ? 1 + 0.15 * sin(5 * t) + 0.05 * sin(17 * t + 1) : 1;
        m.positions[3 * i] = (float)(r * cos(t) + shift[0]);
        m.positions[3 * i + 1] = (float)(0.6 * r * sin(t) + shift[1]);
        m.positions[3 * i + 2] = (float)(crown * sin(3 * t) + shift[2]);
    }
    for (size_t i = 0; i < m.triangle_count; i++) {
        m.indices[3 * i] = 0;
        m.indices[3 * i + 1] = (uint32_t)(i + 1);
        m.indices[3 * i + 2] = (uint32_t)(i + 2);
    }
    return m;
}

static const double no_shift[3] = {0, 0, 0};

/* A point of triangle t at barycentric (1 - r1, r1 (1 - r2), r1 r2). */
static void point_on(const mr_mesh *m, size_t t, double r1, double r2, double p[3])
{
    for (int k = 0; k < 3; k++) {
        const double a = m->positions[3 * m->indices[3 * t] + k];
        const double b = m->positions[3 * m->indices[3 * t + 1] + k];
        const double c = m->positions[3 * m->indices[3 * t + 2] + k];
        p[k] = (1 - r1) * a + r1 * (1 - r2) * b + r1 * r2 * c;
    }
}

/* The nearest triangle of slivers (and of a mix of slivers and ordinary
 * triangles): bitwise the brute-force minimum, for points on, near and
 * far from the surface and at the shared vertex, with and without hints. */
static void check_nearest_exact(const mr_mesh *m, int queries, uint64_t seed)
{
    mr_tri_bvh t;
    mr_error err;
    assert_int_equal(mr_tri_bvh_build(&t, m->positions, m->indices, m->triangle_count, 0, &err),
                     MR_OK);
    /* the slivers have their tree of oriented boxes */
    assert_true(t.thin.prim_count > m->triangle_count / 2);
    uint64_t rng = seed;
    uint32_t hint = MR_NO_HINT;
    for (int i = 0; i < queries; i++) {
        double p[3];
        const size_t tri = (size_t)(test_random(&rng) * (double)m->triangle_count);
        point_on(m, tri, sqrt(test_random(&rng)), test_random(&rng), p);
        switch (i % 5) {
        case 1: /* just off the surface */
            for (int k = 0; k < 3; k++)
                p[k] += 1e-3 * (2 * test_random(&rng) - 1);
            break;
        case 2: /* anywhere around it */
            random_point(&rng, p, 1.6);
            break;
        case 3: /* the shared vertex, or near it */
            for (int k = 0; k < 3; k++)
                p[k] = m->positions[k] + (i % 10 == 3 ? 0 : 1e-4 * (2 * test_random(&rng) - 1));
            break;
        default: /* on the surface */
            break;
        }
        uint32_t got;
        const double d = mr_tri_bvh_nearest(&t, p, i % 3 ? hint : MR_NO_HINT, &got, NULL);
        const double want = brute_triangle(m, p);
        if (!(d == want)) {
            print_error("query %d (%.17g %.17g %.17g): %.17g, brute force %.17g\n", i, p[0],
                        p[1], p[2], d, want);
            fail();
        }
        assert_true(got < m->triangle_count);
        double v[3][3];
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                v[k][j] = m->positions[3 * m->indices[3 * got + k] + j];
        assert_true(mr_point_triangle_dist2(p, v[0], v[1], v[2], NULL) == d);
        hint = got;
    }
    mr_tri_bvh_free(&t);
}

static void test_fan_nearest_exact(void **state)
{
    (void)state;
    mr_mesh flat = polygon_fan(20000, 0, 0, no_shift);
    check_nearest_exact(&flat, 400, 1);
    mr_mesh_free(&flat);
    mr_mesh crown = polygon_fan(20000, 0, 0.2, no_shift);
    check_nearest_exact(&crown, 400, 2);
    mr_mesh_free(&crown);
    mr_mesh irregular = polygon_fan(20000, 1, 0, no_shift);
    check_nearest_exact(&irregular, 400, 3);
    mr_mesh_free(&irregular);

    /* Slivers and ordinary triangles in one mesh: a torus around a fan. */
    mr_mesh torus = generated(MR_GEN_TORUS, 4000, 5);
    mr_mesh fan = polygon_fan(20000, 0, 0.1, no_shift);
    mr_mesh mix;
    mr_mesh_init(&mix);
    mix.vertex_count = torus.vertex_count + fan.vertex_count;
    mix.triangle_count = torus.triangle_count + fan.triangle_count;
    mix.positions = malloc(3 * mix.vertex_count * sizeof *mix.positions);
    mix.indices = malloc(3 * mix.triangle_count * sizeof *mix.indices);
    memcpy(mix.positions, fan.positions, 3 * fan.vertex_count * sizeof *mix.positions);
    for (size_t i = 0; i < 3 * torus.vertex_count; i++)
        mix.positions[3 * fan.vertex_count + i] = 1.5f * torus.positions[i];
    memcpy(mix.indices, fan.indices, 3 * fan.triangle_count * sizeof *mix.indices);
    for (size_t i = 0; i < 3 * torus.triangle_count; i++)
        mix.indices[3 * fan.triangle_count + i] = torus.indices[i] + (uint32_t)fan.vertex_count;
    check_nearest_exact(&mix, 600, 4);
    mr_mesh_free(&mix);
    mr_mesh_free(&fan);
    mr_mesh_free(&torus);
}

/* A face of 100,000 corners, as `meshreduce compare poly.obj ...` reads it:
 * exact distances to itself, to a copy lifted off its plane and to one
 * moved within it, the same at every thread count. (Before the hierarchy
 * had a tree of oriented boxes for slivers, this took minutes.) */
static void test_fan_compare(void **state)
{
    (void)state;
    const size_t n = 100000;
    mr_mesh fan = polygon_fan(n, 0, 0, no_shift);
    const float dz = 1e-3f;
    mr_mesh lifted = polygon_fan(n, 0, 0, (double[3]){0, 0, dz});
    const double diag = sqrt(4 + 1.2 * 1.2); /* the box is [-1, 1] x [-0.6, 0.6] x 0 */

    mr_compare_result r = compare_meshes(&fan, &fan, 200000, 0);
    assert_near(r.diagonal, diag, 1e-6);
    assert_true(r.hausdorff < 1e-9 * diag);
    assert_true(r.rms < 1e-10 * diag);
    assert_true(r.modified_hausdorff == 0);

    /* Every point is exactly dz above or below the other surface. */
    r = compare_meshes(&fan, &lifted, 200000, 0);
    assert_near(r.hausdorff, dz, 1e-12);
    assert_near(r.ref_to_test_rms, dz, 1e-12);
    assert_near(r.test_to_ref_rms, dz, 1e-12);
    assert_near(r.mean, dz, 1e-12);
    assert_near(r.modified_hausdorff, dz, 1e-15);
    /* the sliver tree is built with tasks: the same figures at every
     * thread count */
    const int counts[] = {1, 2, 3, 8};
    for (int i = 0; i < 4; i++) {
        mr_compare_result rt = compare_meshes(&fan, &lifted, 200000, counts[i]);
        assert_memory_equal(&r, &rt, sizeof r);
    }

    /* Moved by dx along the long axis: the left end (a vertex) is dx from
     * the moved ellipse, nothing is farther, up to the polygon's chords. */
    const double dx = 0.01;
    mr_mesh moved = polygon_fan(n, 0, 0, (double[3]){dx, 0, 0});
    r = compare_meshes(&fan, &moved, 50000, 0);
    assert_near(r.ref_to_test_max, dx, 1e-6);
    assert_near(r.test_to_ref_max, dx, 1e-6);
    assert_true(r.rms > 0 && r.rms < dx);
    mr_mesh_free(&moved);
    mr_mesh_free(&lifted);
    mr_mesh_free(&fan);
}

/* A point on a needle triangle (angle 3e-5 at its first corner) is at
 * distance 0 from it to rounding, not 1e-7 (the barycentric formula's
 * cancellation), in every corner order. */
static void test_point_triangle_needle(void **state)
{
    (void)state;
    const double t = 3e-5;
    const double a[3] = {1, 0, 0}, b[3] = {-1, 0, 0}, c[3] = {cos(FAN_PI - t), sin(FAN_PI - t), 0};
    uint64_t rng = 9;
    for (int i = 0; i < 2000; i++) {
        const double r1 = sqrt(test_random(&rng)), r2 = test_random(&rng);
        double p[3];
        for (int k = 0; k < 3; k++)
            p[k] = (1 - r1) * a[k] + r1 * (1 - r2) * b[k] + r1 * r2 * c[k];
        assert_true(sqrt(mr_point_triangle_dist2(p, a, b, c, NULL)) < 1e-11);
        /* the small angle elsewhere costs the general formula 1e-16 / sin */
        assert_true(sqrt(mr_point_triangle_dist2(p, b, c, a, NULL)) < 1e-10);
        assert_true(sqrt(mr_point_triangle_dist2(p, c, a, b, NULL)) < 1e-10);
        /* above the plane: the height, and the foot as the closest point */
        double up[3] = {p[0], p[1], 0.5}, q[3];
        assert_near(mr_point_triangle_dist2(up, a, b, c, q), 0.25, 1e-12);
        assert_near(q[2], 0, 1e-12);
        assert_near(q[0], p[0], 1e-11);
    }
}

/* ---- mr_compare ------------------------------------------------------------- */

/* Two squares [-1, 1]^2, at z = 0 and z = d. */
static void test_parallel_planes(void **state)
{
    (void)state;
    const double d = 0.375;
    float a[] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    float b[12];
    memcpy(b, a, sizeof a);
    for (int i = 0; i < 4; i++)
        b[3 * i + 2] = (float)d;
    uint32_t idx[] = {0, 1, 2, 0, 2, 3};
    mr_compare_options o;
    mr_compare_options_default(&o);
    o.samples = 20000;
    mr_compare_result r;
    mr_error err;
    assert_int_equal(mr_compare(a, 4, idx, 2, b, 4, idx, 2, &o, &r, &err), MR_OK);
    const double diag = sqrt(8.0);
    assert_near(r.hausdorff, d, 1e-6 * d);
    assert_near(r.rms, d, 1e-6 * d);
    assert_near(r.mean, d, 1e-6 * d);
    assert_near(r.ref_to_test_max, d, 1e-6 * d);
    assert_near(r.test_to_ref_rms, d, 1e-6 * d);
    assert_near(r.modified_hausdorff, d, 1e-6 * d);
    assert_near(r.diagonal, diag, 1e-12);
    assert_near(r.hausdorff_rel, d / diag, 1e-6 * d / diag);
    assert_near(r.rms_rel, d / diag, 1e-6 * d / diag);
    assert_near(r.mean_rel, d / diag, 1e-6 * d / diag);
    assert_near(r.modified_hausdorff_rel, d / diag, 1e-6 * d / diag);
    assert_int_equal(r.ref_points, 4 + 20000);
    assert_int_equal(r.test_points, 4 + 20000);
}

/*
 * A mesh against itself. Vertices are at distance exactly 0 (the region
 * tests return the corner itself). A sample is computed in double from
 * its triangle's corners and lies on that triangle up to rounding, so its
 * distance is not exactly 0 but within 1e-9 of the diagonal (in practice
 * ~1e-16): that is what is asserted.
 */
static void test_self_compare(void **state)
{
    (void)state;
    mr_mesh m = generated(MR_GEN_SCAN, 20000, 3);
    mr_compare_result r = compare_meshes(&m, &m, 0, 0);
    assert_true(r.hausdorff == 0 && r.rms == 0 && r.mean == 0);
    assert_true(r.modified_hausdorff == 0);
    r = compare_meshes(&m, &m, 200000, 0);
    assert_true(r.hausdorff <= 1e-9 * r.diagonal);
    assert_true(r.rms <= 1e-9 * r.diagonal);
    assert_true(r.modified_hausdorff == 0);
    assert_true(r.diagonal > 50);
    mr_mesh_free(&m);
}

static void test_concentric_spheres(void **state)
{
    (void)state;
    mr_mesh a = generated(MR_GEN_SPHERE, 20000, 0);
    mr_mesh b;
    mr_error err;
    mr_mesh_init(&b);
    assert_int_equal(mr_mesh_copy(&b, &a, &err), MR_OK);
    for (size_t i = 0; i < 3 * b.vertex_count; i++)
        b.positions[i] *= 1.1f;
    mr_compare_result r = compare_meshes(&a, &b, 100000, 0);
    /* the chords of a 20k-triangle unit sphere sag by about 1e-4 */
    assert_near(r.hausdorff, 0.1, 2e-3);
    assert_near(r.rms, 0.1, 2e-3);
    assert_true(r.ref_to_test_max <= 0.1 + 1e-6);
    /* nearest vertices: each vertex's scaled copy, 0.1 away */
    assert_near(r.modified_hausdorff, 0.1, 1e-5);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
}

static void test_thread_determinism(void **state)
{
    (void)state;
    mr_mesh a = generated(MR_GEN_SCAN, 30000, 1);
    mr_mesh b = generated(MR_GEN_SCAN, 8000, 1);
    mr_compare_result r1 = compare_meshes(&a, &b, 100000, 1);
    mr_compare_result r3 = compare_meshes(&a, &b, 100000, 3);
#ifdef _OPENMP
    int saved = omp_get_max_threads();
    omp_set_num_threads(2);
    mr_compare_result r2 = compare_meshes(&a, &b, 100000, 0);
    omp_set_num_threads(1);
    mr_compare_result r0 = compare_meshes(&a, &b, 100000, 0);
    omp_set_num_threads(saved);
    assert_memory_equal(&r1, &r2, sizeof r1);
    assert_memory_equal(&r1, &r0, sizeof r1);
#endif
    assert_memory_equal(&r1, &r3, sizeof r1);
    assert_true(r1.hausdorff > 0 && r1.rms > 0 && r1.rms <= r1.hausdorff);
    assert_true(r1.mean <= r1.rms);
    /* another seed gives other samples, hence (slightly) other figures */
    mr_compare_options o;
    mr_compare_options_default(&o);
    assert_int_equal(o.samples, 1000000);
    o.samples = 100000;
    o.seed = 99;
    mr_compare_result rs;
    mr_error err;
    assert_int_equal(mr_compare(a.positions, a.vertex_count, a.indices, a.triangle_count,
                                b.positions, b.vertex_count, b.indices, b.triangle_count, &o,
                                &rs, &err),
                     MR_OK);
    assert_true(rs.rms != r1.rms);
    assert_near(rs.rms, r1.rms, 0.05 * r1.rms);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
}

/* A reference prepared once gives every measurement's figures bit for bit:
 * mr_compare_with as mr_compare, mr_surface_distances_with as
 * mr_surface_distances, for several test meshes in turn and at 1, 2, 3 and
 * 8 threads; a bad test mesh fails as it does without the reference. */
static void test_prepared_reference(void **state)
{
    (void)state;
    mr_mesh ref = generated(MR_GEN_SCAN, 30000, 1);
    mr_mesh tests[2] = {generated(MR_GEN_SCAN, 8000, 1), generated(MR_GEN_SCAN, 3000, 2)};
    static const int threads[] = {1, 2, 3, 8};
    for (int ti = 0; ti < 4; ti++) {
        mr_compare_options o;
        mr_compare_options_default(&o);
        o.samples = 50000;
        o.threads = threads[ti];
        mr_reference *pr;
        mr_error err;
        assert_int_equal(mr_reference_build(ref.positions, ref.vertex_count, ref.indices,
                                            ref.triangle_count, &o, &pr, &err),
                         MR_OK);
        for (int k = 0; k < 2; k++) {
            const mr_mesh *t = &tests[k];
            mr_compare_result a, b;
            assert_int_equal(mr_compare(ref.positions, ref.vertex_count, ref.indices,
                                        ref.triangle_count, t->positions, t->vertex_count,
                                        t->indices, t->triangle_count, &o, &a, &err),
                             MR_OK);
            assert_int_equal(mr_compare_with(pr, t->positions, t->vertex_count, t->indices,
                                             t->triangle_count, &b, &err),
                             MR_OK);
            assert_memory_equal(&a, &b, sizeof a);
            float *da = malloc(t->triangle_count * sizeof *da);
            float *db = malloc(t->triangle_count * sizeof *db);
            assert_non_null(da);
            assert_non_null(db);
            double ma, mb;
            assert_int_equal(mr_surface_distances(ref.positions, ref.vertex_count, ref.indices,
                                                  ref.triangle_count, t->positions,
                                                  t->vertex_count, t->indices,
                                                  t->triangle_count, threads[ti], da, &ma, &err),
                             MR_OK);
            assert_int_equal(mr_surface_distances_with(pr, t->positions, t->vertex_count,
                                                       t->indices, t->triangle_count, db, &mb,
                                                       &err),
                             MR_OK);
            assert_memory_equal(da, db, t->triangle_count * sizeof *da);
            assert_true(ma == mb);
            free(da);
            free(db);
        }
        const uint32_t bad[3] = {0, 1, 99999999};
        mr_compare_result r;
        assert_int_equal(mr_compare_with(pr, tests[0].positions, tests[0].vertex_count, bad, 1,
                                         &r, &err),
                         MR_ERR_INVALID_ARGUMENT);
        mr_reference_free(pr);
    }
    mr_mesh_free(&ref);
    mr_mesh_free(&tests[0]);
    mr_mesh_free(&tests[1]);
}

static void test_modified_hausdorff_translation(void **state)
{
    (void)state;
    mr_mesh a = generated(MR_GEN_SPHERE, 5000, 0);
    mr_mesh b;
    mr_error err;
    mr_mesh_init(&b);
    assert_int_equal(mr_mesh_copy(&b, &a, &err), MR_OK);
    const float shift[3] = {0.006f, -0.008f, 0}; /* length 0.01; edges are ~0.05 */
    for (size_t i = 0; i < b.vertex_count; i++)
        for (int k = 0; k < 3; k++)
            b.positions[3 * i + k] += shift[k];
    mr_compare_result r = compare_meshes(&a, &b, 1000, 0);
    assert_near(r.modified_hausdorff, 0.01, 1e-4 * 0.01);
    assert_near(r.modified_hausdorff_rel, 0.01 / r.diagonal, 1e-4 * 0.01 / r.diagonal);
    /* the surfaces are closer than the vertices */
    assert_true(r.hausdorff <= 0.01 + 1e-6);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
}

static void test_compare_bad_input(void **state)
{
    (void)state;
    float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint32_t idx[] = {0, 1, 2};
    uint32_t bad[] = {0, 1, 2, 0, 3, 1};
    mr_compare_result r;
    mr_error err;
    assert_int_equal(mr_compare(pos, 3, idx, 1, pos, 3, idx, 1, NULL, NULL, &err),
                     MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_compare(NULL, 3, idx, 1, pos, 3, idx, 1, NULL, &r, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "reference mesh");
    assert_int_equal(mr_compare(pos, 3, idx, 1, pos, 3, NULL, 1, NULL, &r, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "test mesh");
    assert_int_equal(mr_compare(pos, 3, idx, 0, pos, 3, idx, 1, NULL, &r, &err), MR_ERR_EMPTY);
    tu_assert_contains(err.message, "reference mesh has no triangles");
    assert_int_equal(mr_compare(pos, 3, idx, 1, pos, 3, idx, 0, NULL, &r, &err), MR_ERR_EMPTY);
    tu_assert_contains(err.message, "test mesh has no triangles");
    assert_int_equal(mr_compare(pos, 3, idx, 1, pos, 3, bad, 2, NULL, &r, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "test mesh: triangle 1: vertex index 3 is out of range");
    float nan_pos[9];
    memcpy(nan_pos, pos, sizeof pos);
    nan_pos[4] = NAN;
    assert_int_equal(mr_compare(nan_pos, 3, idx, 1, pos, 3, idx, 1, NULL, &r, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "reference mesh: vertex 1 has a non-finite coordinate");
    /* NULL err is fine */
    assert_int_equal(mr_compare(pos, 3, idx, 0, pos, 3, idx, 1, NULL, &r, NULL), MR_ERR_EMPTY);
    /* all-degenerate triangles: no area, vertices only; an unreferenced
     * far vertex does not count */
    float flat[] = {0, 0, 0, 1, 0, 0, 2, 0, 0, 100, 100, 100};
    mr_compare_options o;
    mr_compare_options_default(&o);
    o.samples = 1000;
    assert_int_equal(mr_compare(flat, 4, idx, 1, pos, 3, idx, 1, &o, &r, &err), MR_OK);
    assert_int_equal(r.ref_points, 3);
    assert_int_equal(r.test_points, 3 + 1000);
    assert_near(r.diagonal, 2, 0);
    assert_near(r.ref_to_test_max, 1, 1e-12); /* (2, 0, 0) to the triangle */
}

/* ---- vertex similarity -------------------------------------------------------- */

static void test_vertex_similarity(void **state)
{
    (void)state;
    const float pa[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t oa[] = {10, 20, 30, 40};
    /* identical */
    assert_near(mr_vertex_similarity(pa, oa, 4, pa, oa, 4), 1.0, 0);
    /* disjoint origins */
    const uint32_t ob[] = {11, 21, 31, 41};
    assert_near(mr_vertex_similarity(pa, oa, 4, pa, ob, 4), 0.0, 0);
    /* b in another order, one vertex moved, one missing */
    const float pb[] = {0, 0, 1, 0, 1, 0, 1, 0, 0.5f};
    const uint32_t oc[] = {40, 30, 20};
    assert_near(mr_vertex_similarity(pa, oa, 4, pb, oc, 3), 0.5, 0);
    /* -0 is not bitwise +0 */
    const float pz[] = {-0.0f, 0, 0};
    assert_near(mr_vertex_similarity(pa, oa, 1, pz, oa, 1), 0.0, 0);
    /* a share of a's vertices: asymmetric */
    assert_near(mr_vertex_similarity(pb, oc, 3, pa, oa, 4), 2.0 / 3.0, 1e-15);
    /* empty and bad input */
    assert_near(mr_vertex_similarity(NULL, NULL, 0, NULL, NULL, 0), 1.0, 0);
    assert_near(mr_vertex_similarity(NULL, NULL, 0, pa, oa, 4), 0.0, 0);
    assert_near(mr_vertex_similarity(pa, oa, 4, NULL, NULL, 0), 0.0, 0);
    assert_true(isnan(mr_vertex_similarity(NULL, oa, 4, pa, oa, 4)));
}

static void test_vertex_similarity_large(void **state)
{
    (void)state;
    mr_mesh m = generated(MR_GEN_SPHERE, 200000, 0);
    const size_t n = m.vertex_count;
    uint32_t *oa = malloc(n * sizeof *oa), *ob = malloc(n * sizeof *ob);
    float *pb = malloc(3 * n * sizeof *pb);
    /* b: the same vertices reversed, every tenth one moved */
    size_t moved = 0;
    for (size_t i = 0; i < n; i++) {
        oa[i] = (uint32_t)(3 * i);
        ob[n - 1 - i] = (uint32_t)(3 * i);
        memcpy(pb + 3 * (n - 1 - i), m.positions + 3 * i, 3 * sizeof *pb);
        if (i % 10 == 0) {
            pb[3 * (n - 1 - i)] += 1;
            moved++;
        }
    }
    double s = mr_vertex_similarity(m.positions, oa, n, pb, ob, n);
    assert_near(s, (double)(n - moved) / (double)n, 1e-15);
    free(oa);
    free(ob);
    free(pb);
    mr_mesh_free(&m);
}

/* ---- the command ---------------------------------------------------------------- */

static void test_compare_cli(void **state)
{
    (void)state;
    const char *a = tu_tmp_path("cmp-a.ply"), *b = tu_tmp_path("cmp-b.obj");
    assert_int_equal(tu_run_cli(tu_fmt("generate scan --triangles 20k --seed 1 -o '%s' -q", a),
                                NULL),
                     0);
    assert_int_equal(tu_run_cli(tu_fmt("generate scan --triangles 5k --seed 1 -o '%s' -q", b),
                                NULL),
                     0);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("compare '%s' '%s' --samples 50k", a, b), &out), 0);
    tu_assert_contains(out, "hausdorff");
    tu_assert_contains(out, "reference -> test max");
    tu_assert_contains(out, "modified hausdorff");
    tu_assert_contains(out, "% of diagonal");
    tu_assert_contains(out, "50,000 samples each, seed 1");
    free(out);

    assert_int_equal(tu_run_cli(tu_fmt("--threads 1 compare --json '%s' '%s' --samples=50k", a, b),
                                &out),
                     0);
    tu_assert_contains(out, "{\"reference\": ");
    tu_assert_contains(out, "\"hausdorff\": ");
    tu_assert_contains(out, "\"modified_hausdorff_rel\": ");
    tu_assert_contains(out, "\"samples\": 50000");
    /* the figures do not depend on the thread count */
    char *h1 = strstr(out, "\"hausdorff\": ");
    char *out2;
    assert_int_equal(tu_run_cli(tu_fmt("--threads 2 compare --json '%s' '%s' --samples=50k", a, b),
                                &out2),
                     0);
    char *h2 = strstr(out2, "\"hausdorff\": ");
    assert_non_null(h2);
    assert_memory_equal(h1, h2, strstr(h1, "\"threads\"") - h1);
    free(out);
    free(out2);

    /* a mesh against itself */
    assert_int_equal(tu_run_cli(tu_fmt("compare --json '%s' '%s' --samples 0", a, a), &out), 0);
    tu_assert_contains(out, "\"hausdorff\": 0,");
    free(out);

    /* bad input: exit 1 with one clear message */
    assert_int_equal(tu_run_cli(tu_fmt("compare '%s' '%s'", a, tu_tmp_path("no-such.ply")), &out),
                     1);
    tu_assert_contains(out, "no-such.ply");
    free(out);
    const char *cloud = tu_tmp_path("cmp-cloud.xyz");
    tu_write_file(cloud, "0 0 0\n1 0 0\n0 1 0\n", 18);
    assert_int_equal(tu_run_cli(tu_fmt("compare '%s' '%s'", a, cloud), &out), 1);
    tu_assert_contains(out, "has no triangles");
    free(out);

    /* usage errors: exit 2 */
    assert_int_equal(tu_run_cli(tu_fmt("compare '%s' '%s' --frob", a, b), &out), 2);
    tu_assert_contains(out, "unknown option '--frob'");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("compare '%s'", a), &out), 2);
    tu_assert_contains(out, "needs two files");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("compare '%s' '%s' --samples lots", a, b), &out), 2);
    tu_assert_contains(out, "--samples needs a count");
    free(out);
    assert_int_equal(tu_run_cli(tu_fmt("compare '%s' '%s' '%s'", a, b, a), &out), 2);
    free(out);
    assert_int_equal(tu_run_cli("compare --help", &out), 0);
    tu_assert_contains(out, "usage: meshreduce compare REF TEST");
    free(out);
}

/* A flat n x n grid over [0, 100]^2 with UV = position / 100, in two
 * charts: the right half's UVs moved by `jump` in u (a seam down the
 * middle, its vertices split); every UV moved by `shift`. */
static void uv_plane(int n, double jump, const double shift[2], mr_mesh *m)
{
    const int half = n / 2, cols = n + 1;
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, (size_t)cols * n, 2 * (size_t)(n - 1) * (n - 1),
                                   MR_ATTR_TEXCOORDS, NULL),
                     MR_OK);
    for (int y = 0; y < n; y++)
        for (int c = 0; c < cols; c++) {
            const int x = c <= half ? c : c - 1;
            const size_t v = (size_t)y * cols + c;
            m->positions[3 * v] = (float)(100.0 * x / (n - 1));
            m->positions[3 * v + 1] = (float)(100.0 * y / (n - 1));
            m->positions[3 * v + 2] = 0;
            m->texcoords[2 * v] = (float)((double)x / (n - 1) + (c > half ? jump : 0) + shift[0]);
            m->texcoords[2 * v + 1] = (float)((double)y / (n - 1) + shift[1]);
        }
    uint32_t *t = m->indices;
    for (int y = 0; y + 1 < n; y++)
        for (int x = 0; x + 1 < n; x++) {
            const int c0 = x < half ? x : x + 1;
            const uint32_t a = (uint32_t)(y * cols + c0), b = a + 1, c = a + (uint32_t)cols,
                           d = c + 1;
            const uint32_t q[6] = {a, b, d, a, d, c};
            memcpy(t, q, sizeof q);
            t += 6;
        }
}

/* The texture deviation: 0 against itself across a seam whose UV jump
 * the texcoord distance sees; 5 where the UVs moved by (0.03, 0.04) on a
 * plane whose UV unit is 100 (the points of equal UV are (3, 4) away),
 * over the points the other map covers; the same at 1, 2, 3 and 8
 * threads. */
static void test_texture_deviation(void **state)
{
    (void)state;
    const double none[2] = {0, 0}, moved[2] = {0.03, 0.04};
    mr_mesh a, b;
    uv_plane(41, 2, none, &a);
    uv_plane(41, 2, moved, &b);
    mr_compare_options o;
    mr_compare_options_default(&o);
    o.samples = 20000;
    mr_attribute_error e, first;
    mr_error err;
    assert_int_equal(mr_compare_attributes(&a, &a, &o, &e, &err), MR_OK);
    assert_true(e.texture_max < 1e-9 && e.texture_points == e.points);
    static const int threads[4] = {1, 2, 3, 8};
    for (int t = 0; t < 4; t++) {
        o.threads = threads[t];
        assert_int_equal(mr_compare_attributes(&a, &b, &o, &e, &err), MR_OK);
        if (t == 0)
            first = e;
        assert_memory_equal(&first, &e, sizeof e);
    }
    print_message("texture deviation %.6g (max %.6g) over %zu of %zu points; uv %.4g\n",
                  e.texture_rms, e.texture_max, e.texture_points, e.points, e.texcoord_rms);
    assert_true(fabs(e.texture_rms - 5) < 1e-3 && fabs(e.texture_max - 5) < 1e-3);
    assert_true(fabs(e.texture_rms_rel - 5 / (100 * sqrt(2.0))) < 1e-5);
    /* the rims whose moved UVs leave the other map are not counted */
    assert_true(e.texture_points < e.points && e.texture_points > e.points * 8 / 10);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
}

/* The attributes' deviation: a mesh against itself is 0; against a copy
 * whose texture coordinates are shifted by (0.03, 0.04), whose colors'
 * red is 0.2 higher and whose normals are turned by 10 degrees about z,
 * 0.05, 0.2 and (about) 10 everywhere; the same figures at 1, 2, 3 and 8
 * threads; meshes without a shared attribute measure none. */
static void test_attribute_deviation(void **state)
{
    (void)state;
    mr_mesh a, b;
    mr_error err;
    /* (smaller for the sanitizers' runs) */
    const bool quick = getenv("MR_TEST_QUICK") != NULL;
    assert_int_equal(mr_generate(MR_GEN_SPHERE, quick ? 4000 : 20000, 1, &a, &err), MR_OK);
    mr_mesh_init(&b);
    assert_int_equal(mr_mesh_alloc(&b, a.vertex_count, a.triangle_count,
                                   MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS, &err),
                     MR_OK);
    mr_mesh c;
    mr_mesh_init(&c);
    assert_int_equal(mr_mesh_alloc(&c, a.vertex_count, a.triangle_count,
                                   MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS, &err),
                     MR_OK);
    const double turn = 10 * 3.14159265358979323846 / 180;
    for (size_t v = 0; v < a.vertex_count; v++) {
        const float *p = a.positions + 3 * v;
        memcpy(b.positions + 3 * v, p, 12);
        memcpy(c.positions + 3 * v, p, 12);
        const double l = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
        const double n[3] = {p[0] / l, p[1] / l, p[2] / l};
        for (int k = 0; k < 3; k++)
            b.normals[3 * v + (size_t)k] = (float)n[k];
        /* the normal turned about the axis n x z (10 degrees off itself) */
        double ax[3] = {n[1], -n[0], 0};
        const double al = sqrt(ax[0] * ax[0] + ax[1] * ax[1]);
        if (al > 1e-6)
            ax[0] /= al, ax[1] /= al;
        else
            ax[0] = 1, ax[1] = 0;
        const double cs = cos(turn), sn = sin(turn);
        const double cr[3] = {ax[1] * n[2] - ax[2] * n[1], ax[2] * n[0] - ax[0] * n[2],
                              ax[0] * n[1] - ax[1] * n[0]};
        for (int k = 0; k < 3; k++)
            c.normals[3 * v + (size_t)k] = (float)(n[k] * cs + cr[k] * sn);
        b.texcoords[2 * v] = p[0] * 0.01f, b.texcoords[2 * v + 1] = p[1] * 0.01f;
        c.texcoords[2 * v] = b.texcoords[2 * v] + 0.03f;
        c.texcoords[2 * v + 1] = b.texcoords[2 * v + 1] + 0.04f;
        for (int k = 0; k < 4; k++)
            b.colors[4 * v + (size_t)k] = c.colors[4 * v + (size_t)k] = 0.5f;
        c.colors[4 * v] = 0.7f;
    }
    memcpy(b.indices, a.indices, 12 * a.triangle_count);
    memcpy(c.indices, a.indices, 12 * a.triangle_count);
    mr_compare_options o;
    mr_compare_options_default(&o);
    o.samples = quick ? 10000 : 50000;
    mr_attribute_error e;
    assert_int_equal(mr_compare_attributes(&b, &b, &o, &e, &err), MR_OK);
    assert_int_equal(e.attributes, MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS);
    assert_true(e.normal_max < 0.01 && e.texcoord_max < 1e-6 && e.color_max < 1e-6);
    assert_int_equal(e.points, 2 * o.samples);
    mr_attribute_error first;
    static const int threads[4] = {1, 2, 3, 8};
    for (int t = 0; t < 4; t++) {
        o.threads = threads[t];
        assert_int_equal(mr_compare_attributes(&b, &c, &o, &e, &err), MR_OK);
        if (t == 0)
            first = e;
        assert_memory_equal(&first, &e, sizeof e);
    }
    print_message("attributes: normal %.4g deg (max %.4g), uv %.4g (max %.4g), color %.4g\n",
                  e.normal_rms, e.normal_max, e.texcoord_rms, e.texcoord_max, e.color_rms);
    assert_true(fabs(e.texcoord_rms - 0.05) < 1e-4 && fabs(e.texcoord_max - 0.05) < 1e-4);
    assert_true(fabs(e.color_rms - 0.2) < 1e-5 && fabs(e.color_max - 0.2) < 1e-5);
    assert_true(fabs(e.normal_rms - 10) < 0.2 && e.normal_max < 10.5);
    /* nothing shared: nothing measured */
    assert_int_equal(mr_compare_attributes(&a, &c, &o, &e, &err), MR_OK);
    assert_int_equal(e.attributes, 0);
    assert_true(e.normal_rms == 0 && e.points == 0);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
    mr_mesh_free(&c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_point_triangle_regions),
        cmocka_unit_test(test_point_triangle_degenerate),
        cmocka_unit_test(test_bvh_vs_brute_force),
        cmocka_unit_test(test_bvh_tiny_and_flat),
        cmocka_unit_test(test_point_triangle_needle),
        cmocka_unit_test(test_fan_nearest_exact),
        cmocka_unit_test(test_fan_compare),
        cmocka_unit_test(test_parallel_planes),
        cmocka_unit_test(test_self_compare),
        cmocka_unit_test(test_concentric_spheres),
        cmocka_unit_test(test_thread_determinism),
        cmocka_unit_test(test_prepared_reference),
        cmocka_unit_test(test_modified_hausdorff_translation),
        cmocka_unit_test(test_compare_bad_input),
        cmocka_unit_test(test_vertex_similarity),
        cmocka_unit_test(test_vertex_similarity_large),
        cmocka_unit_test(test_compare_cli),
        cmocka_unit_test(test_attribute_deviation),
        cmocka_unit_test(test_texture_deviation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
