/*
 * MR_QUALITY_BEST (--quality best): the volume-preserving placement and the
 * final fit of the output to the input's surface.
 *   - flat parts stay flat: every output vertex of a subdivided box lies on
 *     the box, and a box with bevels keeps its 8 corners;
 *   - the fit never flips a triangle: a closed manifold input stays closed,
 *     manifold and consistently oriented, every triangle of a sphere faces
 *     outwards;
 *   - it is closer to the surface: lower RMS distance than the default on a
 *     generated scan and a sphere (and the bunny when ../shared/data is
 *     there), the Hausdorff distance within bounds;
 *   - the same bytes at 1, 2, 3 and 8 threads, through mr_simplify and
 *     through mr_mesh_simplify with attributes;
 *   - half-edge collapse is refused with one clear error, and the CLI
 *     takes --quality default|best.
 */
#include "testutil.h"
#include "core/omp_compat.h"
#include "geometry/selfint.h"
#include "qem/core/simplifier.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static bool quick(void)
{
    const char *q = getenv("MR_TEST_QUICK");
    return q && *q && strcmp(q, "0") != 0;
}

/* A box [-1, 1]^3, each face an n x n grid of squares, two triangles each,
 * wound outwards (vertices shared after mr_mesh_weld_exact). */
static void make_box(int n, mr_mesh *m)
{
    mr_mesh_init(m);
    const int per = (n + 1) * (n + 1);
    float *pos = malloc(sizeof *pos * 3 * (size_t)(6 * per));
    uint32_t *idx = malloc(sizeof *idx * 3 * (size_t)(6 * 2 * n * n));
    assert_non_null(pos);
    assert_non_null(idx);
    size_t nv = 0, nt = 0;
    for (int f = 0; f < 6; f++) {
        const int axis = f / 2;
        const double side = f % 2 ? 1 : -1;
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (int i = 0; i <= n; i++)
            for (int j = 0; j <= n; j++) {
                double p[3];
                p[axis] = side;
                p[u] = -1 + 2.0 * i / n;
                p[v] = -1 + 2.0 * j / n;
                for (int k = 0; k < 3; k++)
                    pos[3 * nv + (size_t)k] = (float)p[k];
                nv++;
            }
        const uint32_t base = (uint32_t)(f * per);
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++) {
                const uint32_t a = base + (uint32_t)(i * (n + 1) + j), b = a + (uint32_t)(n + 1),
                               c = b + 1, d = a + 1;
                /* (u, v, axis) is right-handed: this order faces +axis */
                const uint32_t t0[3] = {a, b, c}, t1[3] = {a, c, d};
                for (int k = 0; k < 3; k++) {
                    idx[3 * nt + (size_t)k] = side > 0 ? t0[k] : t0[2 - k];
                    idx[3 * nt + 3 + (size_t)k] = side > 0 ? t1[k] : t1[2 - k];
                }
                nt += 2;
            }
    }
    m->positions = pos;
    m->vertex_count = nv;
    m->indices = idx;
    m->triangle_count = nt;
    mr_error err;
    assert_int_equal(mr_mesh_weld_exact(m, 0, NULL, &err), MR_OK);
    assert_int_equal(mr_mesh_remove_unreferenced(m, NULL, &err), MR_OK);
}

/* A bevelled cube: the convex hull of the 24 points (+-e, +-e, +-1) and
 * permutations, as 6 squares, 12 bevel rectangles and 8 corner triangles,
 * each face subdivided n x n (triangles: squares and rectangles) or into
 * n^2 triangles (corners). Shared vertices (welded by exact position),
 * wound outwards by mr_mesh_orient. */
static void add_quad(float *pos, size_t *nv, uint32_t *idx, size_t *nt, const double p[4][3],
                     int n)
{
    const size_t base = *nv;
    for (int i = 0; i <= n; i++)
        for (int j = 0; j <= n; j++) {
            const double s = (double)i / n, t = (double)j / n;
            for (int k = 0; k < 3; k++)
                pos[3 * *nv + (size_t)k] =
                    (float)((1 - s) * (1 - t) * p[0][k] + s * (1 - t) * p[1][k] +
                            s * t * p[2][k] + (1 - s) * t * p[3][k]);
            (*nv)++;
        }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            const uint32_t a = (uint32_t)(base + (size_t)(i * (n + 1) + j)),
                           b = a + (uint32_t)(n + 1), c = b + 1, d = a + 1;
            const uint32_t t[6] = {a, b, c, a, c, d};
            memcpy(idx + 3 * *nt, t, sizeof t);
            *nt += 2;
        }
}

static void make_bevel_cube(int n, double e, mr_mesh *m)
{
    mr_mesh_init(m);
    float *pos = malloc(sizeof *pos * 3 * 26 * (size_t)((n + 1) * (n + 1)));
    /* e and n powers of two over small integers: every point is exact, so
     * the faces' shared edges weld */
    uint32_t *idx = malloc(sizeof *idx * 3 * 26 * (size_t)(2 * n * n));
    assert_non_null(pos);
    assert_non_null(idx);
    size_t nv = 0, nt = 0;
    /* corners of the 6 squares: on face axis a, side s */
    for (int a = 0; a < 3; a++)
        for (int sd = -1; sd <= 1; sd += 2) {
            const int u = (a + 1) % 3, v = (a + 2) % 3;
            double q[4][3];
            const double uv[4][2] = {{-e, -e}, {e, -e}, {e, e}, {-e, e}};
            for (int c = 0; c < 4; c++) {
                const int cc = sd > 0 ? c : 3 - c;
                q[c][a] = sd;
                q[c][u] = uv[cc][0];
                q[c][v] = uv[cc][1];
            }
            add_quad(pos, &nv, idx, &nt, q, n);
        }
    /* the 12 bevel rectangles: between face (a, sa) and face (b, sb) */
    for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++)
            for (int sa = -1; sa <= 1; sa += 2)
                for (int sb = -1; sb <= 1; sb += 2) {
                    const int c = 3 - a - b;
                    double q[4][3];
                    /* along axis c from -e to e */
                    const double ends[2] = {-e, e};
                    for (int k = 0; k < 2; k++) {
                        q[k == 0 ? 0 : 1][a] = sa;
                        q[k == 0 ? 0 : 1][b] = sb * e;
                        q[k == 0 ? 0 : 1][c] = ends[k];
                        q[k == 0 ? 3 : 2][a] = sa * e;
                        q[k == 0 ? 3 : 2][b] = sb;
                        q[k == 0 ? 3 : 2][c] = ends[k];
                    }
                    add_quad(pos, &nv, idx, &nt, q, n);
                }
    /* the 8 corner triangles, each edge cut in n as the rectangles' */
    for (int sx = -1; sx <= 1; sx += 2)
        for (int sy = -1; sy <= 1; sy += 2)
            for (int sz = -1; sz <= 1; sz += 2) {
                const double p[3][3] = {{sx, sy * e, sz * e}, {sx * e, sy, sz * e},
                                        {sx * e, sy * e, sz}};
                const size_t base = nv;
                for (int i = 0; i <= n; i++)
                    for (int j = 0; j <= n - i; j++) {
                        for (int k = 0; k < 3; k++)
                            pos[3 * nv + (size_t)k] =
                                (float)(p[0][k] + (double)i / n * (p[1][k] - p[0][k]) +
                                        (double)j / n * (p[2][k] - p[0][k]));
                        nv++;
                    }
                /* vertex (i, j) of this triangle */
#define AT(i, j) ((uint32_t)(base + (size_t)((i) * (2 * n + 3 - (i)) / 2 + (j))))
                for (int i = 0; i < n; i++)
                    for (int j = 0; j < n - i; j++) {
                        const uint32_t t0[3] = {AT(i, j), AT(i + 1, j), AT(i, j + 1)};
                        memcpy(idx + 3 * nt, t0, sizeof t0);
                        nt++;
                        if (j + 1 < n - i) {
                            const uint32_t t1[3] = {AT(i + 1, j), AT(i + 1, j + 1), AT(i, j + 1)};
                            memcpy(idx + 3 * nt, t1, sizeof t1);
                            nt++;
                        }
                    }
#undef AT
            }
    m->positions = pos;
    m->vertex_count = nv;
    m->indices = idx;
    m->triangle_count = nt;
    mr_error err;
    assert_int_equal(mr_mesh_weld_exact(m, 0, NULL, &err), MR_OK);
    assert_int_equal(mr_mesh_remove_unreferenced(m, NULL, &err), MR_OK);
    assert_int_equal(mr_mesh_orient(m, NULL, NULL, &err), MR_OK);
}

/* To `ratio` of the vertices, or to `triangles` triangles when not 0;
 * strategy < 0: the default one. */
static void simplify_with(const mr_mesh *in, double ratio, size_t triangles, int strategy,
                          mr_simplify_quality q, int threads, mr_mesh *out)
{
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    if (strategy >= 0)
        o.strategy = (mr_strategy)strategy;
    o.target_ratio = triangles ? 0 : ratio;
    o.target_triangles = triangles;
    o.quality = q;
    o.threads = threads;
    const int saved = omp_get_max_threads();
    omp_set_num_threads(threads);
    mr_simplified s;
    mr_error err;
    const mr_status st = mr_simplify(in->positions, 0, in->vertex_count, in->indices,
                                     in->triangle_count, &o, &s, &err);
    omp_set_num_threads(saved);
    if (st != MR_OK) {
        print_error("%s\n", err.message);
        fail();
    }
    mr_mesh_init(out);
    out->positions = s.positions;
    out->vertex_count = s.vertex_count;
    out->indices = s.indices;
    out->triangle_count = s.triangle_count;
    free(s.origin);
}

static void simplify(const mr_mesh *in, double ratio, mr_simplify_quality q, int threads,
                     mr_mesh *out)
{
    simplify_with(in, ratio, 0, -1, q, threads, out);
}

static mr_compare_result distance(const mr_mesh *ref, const mr_mesh *test)
{
    mr_compare_options co;
    mr_compare_options_default(&co);
    co.samples = quick() ? 50000 : 200000;
    mr_compare_result r;
    mr_error err;
    assert_int_equal(mr_compare(ref->positions, ref->vertex_count, ref->indices,
                                ref->triangle_count, test->positions, test->vertex_count,
                                test->indices, test->triangle_count, &co, &r, &err),
                     MR_OK);
    return r;
}

static void assert_closed_oriented(const mr_mesh *m)
{
    mr_stats st;
    mr_error err;
    assert_int_equal(mr_stats_compute(m->positions, 0, m->vertex_count, m->indices,
                                      m->triangle_count, &st, &err),
                     MR_OK);
    assert_true(st.closed);
    assert_true(st.oriented);
    assert_int_equal(st.nonmanifold_vertices, 0);
}

static void test_flat_stays_flat(void **state)
{
    (void)state;
    mr_mesh box, out;
    make_box(quick() ? 16 : 40, &box);
    const double ratios[2] = {0.1, 0.02};
    for (int r = 0; r < 2; r++) {
        simplify(&box, ratios[r], MR_QUALITY_BEST, 2, &out);
        for (size_t v = 0; v < out.vertex_count; v++) {
            double far = 0;
            for (int k = 0; k < 3; k++)
                far = fmax(far, fabs((double)out.positions[3 * v + (size_t)k]));
            if (fabs(far - 1) > 1e-6) {
                print_error("vertex %zu at (%g, %g, %g): off the box\n", v,
                            (double)out.positions[3 * v], (double)out.positions[3 * v + 1],
                            (double)out.positions[3 * v + 2]);
                fail();
            }
        }
        assert_closed_oriented(&out);
        mr_mesh_free(&out);
    }
    mr_mesh_free(&box);
}

/* How far p lies outside the bevelled cube (0 on its surface, < 0
 * inside): the largest of its 26 planes' values. */
static double bevel_outside(const float *p, double e)
{
    const double x = fabs((double)p[0]), y = fabs((double)p[1]), z = fabs((double)p[2]);
    double f = fmax(fmax(x, y), z) - 1;
    f = fmax(f, (fmax(fmax(x + y, y + z), x + z) - 1 - e) / sqrt(2.0));
    return fmax(f, (x + y + z - 1 - 2 * e) / sqrt(3.0));
}

static void test_bevel_corners(void **state)
{
    (void)state;
    const double e = 0.75;
    mr_mesh cube;
    make_bevel_cube(quick() ? 8 : 16, e, &cube);
    for (int qi = 0; qi < 2; qi++) {
        const mr_simplify_quality quality = qi ? MR_QUALITY_BEST : MR_QUALITY_DEFAULT;
        mr_mesh out;
        simplify(&cube, 0.1, quality, 2, &out);
        assert_closed_oriented(&out);
        /* every output vertex on the surface: faces flat, creases straight */
        for (size_t w = 0; w < out.vertex_count; w++)
            if (fabs(bevel_outside(out.positions + 3 * w, e)) > 1e-5) {
                print_error("vertex %zu off the bevelled cube by %g\n", w,
                            bevel_outside(out.positions + 3 * w, e));
                fail();
            }
        /* the 24 points where a square, two bevels and a corner meet are
         * still vertices: the 8 corners and 12 crease lines are kept */
        size_t kept = 0;
        for (size_t v = 0; v < cube.vertex_count; v++) {
            const float *p = cube.positions + 3 * v;
            int ones = 0, es = 0;
            for (int k = 0; k < 3; k++) {
                ones += fabsf(p[k]) == 1.0f;
                es += fabsf(p[k]) == (float)e;
            }
            if (ones != 1 || es != 2)
                continue;
            for (size_t w = 0; w < out.vertex_count; w++) {
                const float *q = out.positions + 3 * w;
                if (fabsf(q[0] - p[0]) + fabsf(q[1] - p[1]) + fabsf(q[2] - p[2]) < 1e-5f) {
                    kept++;
                    break;
                }
            }
        }
        assert_int_equal(kept, 24);
        mr_mesh_free(&out);
    }
    mr_mesh_free(&cube);
}

static void test_closer_and_sound(void **state)
{
    (void)state;
    mr_mesh in[3];
    const char *name[3] = {"scan", "sphere", "bunny"};
    mr_error err;
    mr_mesh_init(&in[0]);
    mr_mesh_init(&in[1]);
    assert_int_equal(mr_generate(MR_GEN_SCAN, quick() ? 20000 : 80000, 3, &in[0], &err), MR_OK);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, quick() ? 5000 : 20000, 0, &in[1], &err), MR_OK);
    int n = 2;
    const char *bunny = tu_shared_data("stanford-bunny.obj");
    mr_mesh_init(&in[2]);
    if (bunny && !quick() && mr_mesh_read(bunny, NULL, &in[2], &err) == MR_OK)
        n = 3;
    for (int i = 0; i < n; i++) {
        const double ratios[2] = {0.1, 0.01};
        for (int r = 0; r < 2; r++) {
            mr_mesh a, b;
            simplify(&in[i], ratios[r], MR_QUALITY_DEFAULT, 2, &a);
            /* at the same size (best keeps more boundary vertices: more
             * triangles at the same vertex count) */
            simplify_with(&in[i], 0, a.triangle_count, -1, MR_QUALITY_BEST, 2, &b);
            /* a collapse removes one triangle or two: the count may land
             * one below */
            assert_true(b.triangle_count <= a.triangle_count &&
                        b.triangle_count + 1 >= a.triangle_count);
            const mr_compare_result da = distance(&in[i], &a), db = distance(&in[i], &b);
            print_message("%s %.0f %%: RMS %.5f %% -> %.5f %%, Hausdorff %.4f %% -> %.4f %%\n",
                          name[i], 100 * ratios[r], 100 * da.rms_rel, 100 * db.rms_rel,
                          100 * da.hausdorff_rel, 100 * db.hausdorff_rel);
            assert_true(db.rms_rel < 0.95 * da.rms_rel);
            assert_true(db.hausdorff_rel < 3 * da.hausdorff_rel);
            if (i < 2)
                assert_closed_oriented(&b);
            if (i == 1) /* a sphere's triangles all face outwards */
                for (size_t t = 0; t < b.triangle_count; t++) {
                    const float *p0 = b.positions + 3 * (size_t)b.indices[3 * t],
                                *p1 = b.positions + 3 * (size_t)b.indices[3 * t + 1],
                                *p2 = b.positions + 3 * (size_t)b.indices[3 * t + 2];
                    const double u[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
                    const double v[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
                    const double nn[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                                          u[0] * v[1] - u[1] * v[0]};
                    assert_true(nn[0] * p0[0] + nn[1] * p0[1] + nn[2] * p0[2] > 0);
                }
            mr_mesh_free(&a);
            mr_mesh_free(&b);
        }
        mr_mesh_free(&in[i]);
    }
    if (n < 3)
        print_message("the bunny skipped (../shared/data absent, or MR_TEST_QUICK)\n");
}

static size_t self_intersections_at(const mr_mesh *m, int threads)
{
    size_t n = 0;
    mr_error err;
    assert_int_equal(mr_self_intersections(m->positions, m->indices, m->triangle_count, threads,
                                           &n, &err),
                     MR_OK);
    return n;
}

static size_t self_intersections(const mr_mesh *m)
{
    return self_intersections_at(m, 2);
}

/* The self-intersection count: triangle pairs by hand, then meshes. */
static void test_self_intersections(void **state)
{
    (void)state;
    const double a0[3] = {0, 0, 0}, a1[3] = {2, 0, 0}, a2[3] = {0, 2, 0};
    const double *a[3] = {a0, a1, a2};
    /* crossing: a vertical triangle through a's inside */
    const double b0[3] = {0.5, 0.5, -1}, b1[3] = {0.5, 0.5, 1}, b2[3] = {0.6, 0.4, 1};
    const double *b[3] = {b0, b1, b2};
    assert_true(mr_triangles_meet(a, b));
    assert_true(mr_triangles_meet(b, a));
    /* above: no */
    const double c0[3] = {0.5, 0.5, 0.1}, c1[3] = {0.5, 0.5, 1}, c2[3] = {0.6, 0.4, 1};
    const double *c[3] = {c0, c1, c2};
    assert_false(mr_triangles_meet(a, c));
    /* coplanar overlap and coplanar apart */
    const double d0[3] = {0.2, 0.2, 0}, d1[3] = {3, 0.2, 0}, d2[3] = {0.2, 3, 0};
    const double *d[3] = {d0, d1, d2};
    assert_true(mr_triangles_meet(a, d));
    const double e0[3] = {5, 5, 0}, e1[3] = {6, 5, 0}, e2[3] = {5, 6, 0};
    const double *e[3] = {e0, e1, e2};
    assert_false(mr_triangles_meet(a, e));
    /* beside the plane's crossing line but outside the triangle: no */
    const double f0[3] = {3, 3, -1}, f1[3] = {3, 3, 1}, f2[3] = {3.1, 2.9, 1};
    const double *f[3] = {f0, f1, f2};
    assert_false(mr_triangles_meet(a, f));

    /* a sphere has none; a sphere and its copy moved by half the radius
     * cross along a circle */
    mr_mesh s1, s2;
    mr_error err;
    mr_mesh_init(&s1);
    mr_mesh_init(&s2);
    /* above the count's parallel threshold (4096 triangles) */
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 6000, 0, &s1, &err), MR_OK);
    assert_int_equal(self_intersections(&s1), 0);
    s2.vertex_count = 2 * s1.vertex_count;
    s2.triangle_count = 2 * s1.triangle_count;
    s2.positions = malloc(sizeof *s2.positions * 3 * s2.vertex_count);
    s2.indices = malloc(sizeof *s2.indices * 3 * s2.triangle_count);
    assert_non_null(s2.positions);
    assert_non_null(s2.indices);
    for (size_t i = 0; i < 3 * s1.vertex_count; i++) {
        s2.positions[i] = s1.positions[i];
        s2.positions[3 * s1.vertex_count + i] = s1.positions[i] + (i % 3 == 0 ? 0.5f : 0);
    }
    for (size_t i = 0; i < 3 * s1.triangle_count; i++) {
        s2.indices[i] = s1.indices[i];
        s2.indices[3 * s1.triangle_count + i] = s1.indices[i] + (uint32_t)s1.vertex_count;
    }
    const size_t crossing = self_intersections_at(&s2, 1);
    assert_true(crossing > 20);
    const int threads[3] = {2, 3, 8}; /* the same count on any number of threads */
    for (int i = 0; i < 3; i++)
        assert_int_equal(self_intersections_at(&s2, threads[i]), crossing);
    /* the pairs listed: as many, each a crossing of one sphere with the
     * other, the same list on any number of threads */
    uint32_t *list1 = NULL;
    size_t n1 = 0;
    assert_int_equal(mr_self_intersection_pairs(s2.positions, s2.indices, s2.triangle_count, 1,
                                                &list1, &n1, &err),
                     MR_OK);
    assert_int_equal(n1, crossing);
    for (size_t k = 0; k < n1; k++)
        assert_true((list1[2 * k] < s1.triangle_count) != (list1[2 * k + 1] < s1.triangle_count));
    for (int i = 0; i < 3; i++) {
        uint32_t *list = NULL;
        size_t n = 0;
        assert_int_equal(mr_self_intersection_pairs(s2.positions, s2.indices, s2.triangle_count,
                                                    threads[i], &list, &n, &err),
                         MR_OK);
        assert_int_equal(n, n1);
        assert_memory_equal(list, list1, 2 * n * sizeof *list);
        free(list);
    }
    free(list1);
    assert_int_equal(mr_self_intersection_pairs(s1.positions, s1.indices, s1.triangle_count, 2,
                                                &list1, &n1, &err),
                     MR_OK);
    assert_int_equal(n1, 0);
    assert_null(list1);
    mr_mesh_free(&s1);
    mr_mesh_free(&s2);

    /* the bunny and the armadillo at 10 %, either quality, and where the
     * surface fit once added some (the nefertiti at 2 %, the homer at 5
     * %): none added */
    const char *files[4] = {"stanford-bunny.obj", "armadillo.obj", "nefertiti.obj", "homer.obj"};
    const double ratios[4] = {0.1, 0.1, 0.02, 0.05};
    for (int i = 0; i < 4; i++) {
        const char *path = tu_shared_data(files[i]);
        mr_mesh in;
        mr_mesh_init(&in);
        if (!path || quick() || mr_mesh_read(path, NULL, &in, &err) != MR_OK) {
            print_message("%s skipped (../shared/data absent, or MR_TEST_QUICK)\n", files[i]);
            continue;
        }
        const size_t before = self_intersections(&in);
        for (int q = i < 2 ? 0 : 1; q < 2; q++) {
            mr_mesh out;
            simplify(&in, ratios[i], q ? MR_QUALITY_BEST : MR_QUALITY_DEFAULT, 2, &out);
            const size_t after = self_intersections(&out);
            print_message("%s at %g %% (%s): %zu self-intersecting pairs (input: %zu)\n",
                          files[i], 100 * ratios[i], q ? "best" : "default", after, before);
            assert_true(after <= before);
            mr_mesh_free(&out);
        }
        mr_mesh_free(&in);
    }
}

/* A sheet of n x n squares at height z over [0, n]^2, its vertices from
 * *nv on, its triangles from *nt on, both wound upwards. */
static void add_sheet(int n, float z, float *pos, uint32_t *idx, size_t *nv, size_t *nt)
{
    const uint32_t base = (uint32_t)*nv;
    for (int i = 0; i <= n; i++)
        for (int j = 0; j <= n; j++) {
            float *p = pos + 3 * (*nv)++;
            p[0] = (float)i;
            p[1] = (float)j;
            p[2] = z;
        }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            const uint32_t a = base + (uint32_t)(i * (n + 1) + j), b = a + (uint32_t)(n + 1);
            const uint32_t t[6] = {a, b, b + 1, a, b + 1, a + 1};
            memcpy(idx + 3 * *nt, t, sizeof t);
            *nt += 2;
        }
}

/* The fit's last step (mr_fit_untangle): a move that pushes a vertex of
 * one sheet through another is put back, moves that cross nothing stay,
 * and so does a move of triangles that crossed before the fit already. */
static void test_fit_untangle(void **state)
{
    (void)state;
    enum { N = 4, PER = (N + 1) * (N + 1) };
    float before[3 * 3 * PER], pos[3 * 3 * PER];
    uint32_t idx[3 * 3 * 2 * N * N];
    size_t nv = 0, nt = 0;
    add_sheet(N, 0, before, idx, &nv, &nt); /* vertices 0 .. PER */
    add_sheet(N, 1, before, idx, &nv, &nt); /* PER .. 2 PER */
    add_sheet(N, 0.5f, before, idx, &nv, &nt); /* 2 PER .. 3 PER, turned upright below */
    for (size_t v = 2 * PER; v < 3 * PER; v++) { /* the plane x = 3.5 across the others */
        float *p = before + 3 * v;
        const float y = p[1], x = p[0];
        p[0] = 3.5f;
        p[1] = y;
        p[2] = -1 + 0.75f * x; /* z from -1 to 2: through both sheets */
    }
    memcpy(pos, before, sizeof pos);
    mr_error err;
    size_t np = 0;
    uint32_t *pairs = NULL;
    assert_int_equal(mr_self_intersection_pairs(before, idx, nt, 1, &pairs, &np, &err), MR_OK);
    assert_true(np > 0); /* the upright sheet crosses both */
    free(pairs);
    const uint32_t through = PER + 1 * (N + 1) + 1; /* the top sheet's (1, 1) */
    const uint32_t harmless = PER + 3 * (N + 1) + 2; /* the top sheet's (3, 2) */
    const uint32_t crossing = 2 * PER + 2 * (N + 1) + 2; /* the upright's middle */
    pos[3 * through + 2] = -0.5f; /* down through the bottom sheet */
    pos[3 * harmless + 2] = 1.2f;
    pos[3 * crossing + 1] += 0.1f; /* its triangles cross the sheets before and after */
    const int team[4] = {1, 2, 3, 8};
    for (int ti = 0; ti < 4; ti++) {
        const int threads = team[ti];
        float p[3 * 3 * PER];
        memcpy(p, pos, sizeof p);
        size_t back = 0;
        assert_int_equal(mr_fit_untangle(p, before, 3 * PER, idx, nt, 0.5, threads, &back, &err),
                         MR_OK);
        assert_int_equal(back, 1);
        assert_memory_equal(p + 3 * through, before + 3 * through, 3 * sizeof *p);
        assert_memory_equal(p + 3 * harmless, pos + 3 * harmless, 3 * sizeof *p);
        assert_memory_equal(p + 3 * crossing, pos + 3 * crossing, 3 * sizeof *p);
        /* what still meets is the upright sheet and the others */
        assert_int_equal(mr_self_intersection_pairs(p, idx, nt, threads, &pairs, &np, &err), MR_OK);
        assert_true(np > 0);
        for (size_t k = 0; k < np; k++)
            assert_true((pairs[2 * k] >= 4 * N * N) != (pairs[2 * k + 1] >= 4 * N * N));
        free(pairs);
    }
    /* nothing to put back: nothing changes */
    size_t back = 1;
    float p[3 * 3 * PER];
    memcpy(p, before, sizeof p);
    assert_int_equal(mr_fit_untangle(p, before, 3 * PER, idx, nt, 0.5, 2, &back, &err), MR_OK);
    assert_int_equal(back, 0);
    assert_memory_equal(p, before, sizeof p);
}

static void test_threads(void **state)
{
    (void)state;
    mr_mesh scan;
    mr_error err;
    mr_mesh_init(&scan);
    /* above the parallel loops' thresholds */
    assert_int_equal(mr_generate(MR_GEN_SCAN, quick() ? 140000 : 300000, 5, &scan, &err), MR_OK);
    const int threads[4] = {1, 2, 3, 8};
    mr_mesh ref;
    simplify(&scan, 0.05, MR_QUALITY_BEST, 1, &ref);
    for (int t = 1; t < 4; t++) {
        mr_mesh out;
        simplify(&scan, 0.05, MR_QUALITY_BEST, threads[t], &out);
        tu_assert_mesh_equal(&ref, &out);
        mr_mesh_free(&out);
    }
    mr_mesh_free(&ref);
    mr_mesh_free(&scan);

    /* the other edge strategies' memoryless collapses (their plans read
     * the fans: in the partitioned ones, on every slab at once) */
    assert_int_equal(mr_generate(MR_GEN_SCAN, quick() ? 40000 : 100000, 5, &scan, &err), MR_OK);
    const mr_strategy strategies[3] = {MR_STRATEGY_GREEDY, MR_STRATEGY_PARTITIONED,
                                                MR_STRATEGY_PARTITIONED_BOUNDARY};
    for (int k = 0; k < 3; k++) {
        simplify_with(&scan, 0.05, 0, (int)strategies[k], MR_QUALITY_BEST, 1, &ref);
        for (int t = 1; t < 4; t++) {
            mr_mesh out;
            simplify_with(&scan, 0.05, 0, (int)strategies[k], MR_QUALITY_BEST, threads[t], &out);
            tu_assert_mesh_equal(&ref, &out);
            mr_mesh_free(&out);
        }
        mr_mesh_free(&ref);
    }
    mr_mesh_free(&scan);

    /* with attributes and seams (mr_mesh_simplify): a sphere with texture
     * coordinates split along a seam */
    mr_mesh sph;
    mr_mesh_init(&sph);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, quick() ? 8000 : 80000, 0, &sph, &err), MR_OK);
    sph.texcoords = malloc(sizeof *sph.texcoords * 2 * sph.vertex_count);
    assert_non_null(sph.texcoords);
    for (size_t v = 0; v < sph.vertex_count; v++) {
        const float *p = sph.positions + 3 * v;
        sph.texcoords[2 * v] = (float)(atan2(p[1], p[0]) / 6.283185307179586 + 0.5);
        sph.texcoords[2 * v + 1] = (float)(p[2] * 0.5 + 0.5);
    }
    mr_mesh wref;
    for (int t = 0; t < 4; t++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_ratio = 0.05;
        o.quality = MR_QUALITY_BEST;
        o.threads = threads[t];
        const int saved = omp_get_max_threads();
        omp_set_num_threads(threads[t]);
        mr_mesh out;
        mr_mesh_init(&out);
        assert_int_equal(mr_mesh_simplify(&sph, &o, &out, NULL, NULL, &err), MR_OK);
        omp_set_num_threads(saved);
        if (t == 0) {
            wref = out;
            continue;
        }
        tu_assert_mesh_equal(&wref, &out);
        mr_mesh_free(&out);
    }
    mr_mesh_free(&wref);
    mr_mesh_free(&sph);
}

/* Best's collapses are ranked by swept volume, but an error bound is still
 * a bound on the quadric error: the run stops at it and reports the
 * largest error left, within it; a tighter bound leaves more. */
static void test_best_error_bound(void **state)
{
    (void)state;
    mr_mesh scan;
    mr_error err;
    mr_mesh_init(&scan);
    assert_int_equal(mr_generate(MR_GEN_SCAN, 20000, 3, &scan, &err), MR_OK);
    size_t prev = 0;
    const double bounds[2] = {0.004, 0.001};
    for (int b = 0; b < 2; b++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_ratio = 0;
        o.max_error = bounds[b]; /* relative to the diagonal */
        o.quality = MR_QUALITY_BEST;
        mr_simplified s;
        assert_int_equal(mr_simplify(scan.positions, 0, scan.vertex_count, scan.indices,
                                     scan.triangle_count, &o, &s, &err),
                         MR_OK);
        assert_int_equal(s.stats.stop, MR_STOP_MAX_ERROR);
        mr_stats st;
        assert_int_equal(mr_stats_compute(scan.positions, 0, scan.vertex_count, scan.indices,
                                          scan.triangle_count, &st, &err),
                         MR_OK);
        assert_true(s.stats.max_error > 0);
        assert_true(s.stats.max_error <= bounds[b] * st.bbox_diagonal * (1 + 1e-6));
        assert_true(s.triangle_count > prev);
        prev = s.triangle_count;
        mr_simplified_free(&s);
    }
    mr_mesh_free(&scan);
}

static void test_options(void **state)
{
    (void)state;
    mr_mesh sph;
    mr_error err;
    mr_mesh_init(&sph);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 2000, 0, &sph, &err), MR_OK);
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    assert_int_equal(o.quality, MR_QUALITY_DEFAULT);
    o.target_ratio = 0.5;
    o.quality = MR_QUALITY_BEST;
    o.collapse = MR_COLLAPSE_HALF;
    mr_simplified s;
    assert_int_equal(mr_simplify(sph.positions, 0, sph.vertex_count, sph.indices,
                                 sph.triangle_count, &o, &s, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "half-edge collapse");
    o.collapse = MR_COLLAPSE_FULL;
    o.quality = (mr_simplify_quality)7;
    assert_int_equal(mr_simplify(sph.positions, 0, sph.vertex_count, sph.indices,
                                 sph.triangle_count, &o, &s, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "unknown quality");

    const char *in = tu_tmp_path("quality-in.ply"), *out = tu_tmp_path("quality-out.ply");
    mr_write_options wo;
    mr_write_options_default(&wo);
    assert_int_equal(mr_mesh_write(in, &sph, &wo, &err), MR_OK);
    char *text = NULL;
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.2 --quality best -q", in,
                                       out),
                                NULL),
                     0);
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.2 --quality great", in,
                                       out),
                                &text),
                     2);
    tu_assert_contains(text, "--quality is default or best");
    free(text);
    assert_int_equal(tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 0.2 --quality best "
                                       "--collapse half",
                                       in, out),
                                &text),
                     1);
    tu_assert_contains(text, "half-edge collapse");
    free(text);
    assert_int_equal(tu_run_cli("simplify --help", &text), 0);
    tu_assert_contains(text, "--quality default|best");
    free(text);
    mr_mesh_free(&sph);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_options),         cmocka_unit_test(test_best_error_bound),         cmocka_unit_test(test_flat_stays_flat),
        cmocka_unit_test(test_bevel_corners),   cmocka_unit_test(test_closer_and_sound),
        cmocka_unit_test(test_threads),        cmocka_unit_test(test_self_intersections),
        cmocka_unit_test(test_fit_untangle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
