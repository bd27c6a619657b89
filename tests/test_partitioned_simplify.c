/* The partitioned strategy (MR_STRATEGY_PARTITIONED, issue 16) and its
 * boundary-aware variant (MR_STRATEGY_PARTITIONED_BOUNDARY):
 *   - the slabs and the interior/boundary classification on a hand-made
 *     two-slab strip (slab planes at vertex-count quantiles, not at the
 *     middle of the box; an edge is interior exactly when every vertex of
 *     every triangle of both its ends lies in one slab), and with one slab
 *     every edge is interior;
 *   - for a fixed number of partitions the output is byte-identical at 1,
 *     2, 3 and 8 threads (generated scan and sphere, the shared meshes when
 *     present; full and half collapse; ratios 0.1 and 0.01; 16 and 5
 *     slabs); closed manifold inputs stay closed and manifold; vertex
 *     targets are hit exactly, triangle targets within the one triangle a
 *     collapse may overshoot;
 *   - with one partition there are no boundary collapses and the surface
 *     error (RMS, mr_compare) is within 1 % of the default strategy's;
 *   - the CLI takes --strategy partitioned and --partitions;
 *   - the variant: the claims admit two collapses together exactly when no
 *     end of one shares a triangle with an end of the other (collapse.h's
 *     condition for concurrent application), on a strip and on a sphere;
 *     the same determinism, topology and target checks; each rebalance
 *     trigger fires at its threshold and not below, and the load-imbalance
 *     one on a half-flat sheet; its RMS within 5 % of the partitioned
 *     strategy's (the benchmark's aim is 2 %).
 * With MR_TEST_QUICK set (sanitizer stages) the meshes shrink. */
#include "testutil.h"
#include "core/omp_compat.h"
#include "qem/strategies/partitioned.h"
#include "qem/entry.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const int thread_counts[] = {1, 2, 3, 8};
#define NTHREADS (sizeof thread_counts / sizeof thread_counts[0])

static bool quick(void)
{
    const char *q = getenv("MR_TEST_QUICK");
    return q && *q && strcmp(q, "0") != 0;
}

static void generate(mr_generator kind, size_t triangles, mr_mesh *m)
{
    mr_mesh_init(m);
    assert_int_equal(mr_generate(kind, triangles, 7, m, NULL), MR_OK);
}

/* The strategy under test: the partitioned one, or its variant. */
static mr_strategy strategy = MR_STRATEGY_PARTITIONED;

static void options(mr_simplify_options *o, unsigned parts, int threads)
{
    mr_simplify_options_default(o);
    o->strategy = strategy;
    o->partitions = parts;
    o->threads = threads;
}

static void run(const mr_mesh *m, const mr_simplify_options *o, mr_simplified *r)
{
    const int saved = omp_get_max_threads();
    omp_set_num_threads(o->threads > 0 ? o->threads : saved);
    mr_error err;
    const mr_status st = mr_simplify(m->positions, 0, m->vertex_count, m->indices,
                                     m->triangle_count, o, r, &err);
    omp_set_num_threads(saved);
    if (st != MR_OK) {
        print_error("simplify: %s\n", err.message);
        fail();
    }
}

static bool closed_manifold(const float *pos, size_t nv, const uint32_t *idx, size_t nt)
{
    mr_stats s;
    assert_int_equal(mr_stats_compute(pos, 0, nv, idx, nt, &s, NULL), MR_OK);
    return s.closed && s.manifold && s.boundary_edges == 0 && s.nonmanifold_edges == 0 &&
           s.nonmanifold_vertices == 0;
}

/* ---- classification ------------------------------------------------------- */

/* A flat strip, COLS columns by ROWS rows, each quad split in two. The
 * columns are evenly spaced but for the last one, far out: the middle of
 * the box lies beyond column 8, the vertex-count median between columns 4
 * and 5. */
#define COLS 10
#define ROWS 4

static void strip(mr_mesh *m)
{
    mr_mesh_init(m);
    m->vertex_count = COLS * ROWS;
    m->triangle_count = 2 * (COLS - 1) * (ROWS - 1);
    m->positions = malloc(3 * m->vertex_count * sizeof *m->positions);
    m->indices = malloc(3 * m->triangle_count * sizeof *m->indices);
    assert_non_null(m->positions);
    assert_non_null(m->indices);
    for (uint32_t c = 0; c < COLS; c++)
        for (uint32_t r = 0; r < ROWS; r++) {
            float *p = m->positions + 3 * (c * ROWS + r);
            p[0] = c == COLS - 1 ? 20.0f : (float)c;
            p[1] = (float)r;
            p[2] = 0.05f * (float)((c * 7 + r * 3) % 5); /* not quite flat */
        }
    uint32_t *t = m->indices;
    for (uint32_t c = 0; c + 1 < COLS; c++)
        for (uint32_t r = 0; r + 1 < ROWS; r++) {
            const uint32_t a = c * ROWS + r, b = (c + 1) * ROWS + r, d = a + 1, e = b + 1;
            *t++ = a, *t++ = b, *t++ = e;
            *t++ = a, *t++ = e, *t++ = d;
        }
}

static uint32_t column(uint32_t v) { return v / ROWS; }

/* What the strategy gathers, against the definitions worked out here from
 * the triangle list alone. */
static void check_classification(const mr_mesh *m, unsigned parts)
{
    mr_simplify_options o;
    options(&o, parts, 1);
    o.target_ratio = 0.5;
    mr_simplifier s;
    mr_error err;
    assert_int_equal(mr_simplify_setup(&s, m->positions, 0, m->vertex_count, m->indices,
                                        m->triangle_count, &o, NULL, &err),
                     MR_OK);
    assert_int_equal(mr_simplifier_fill_queue(&s, &err), MR_OK);
    const size_t nv = m->vertex_count, nt = m->triangle_count;
    /* slabs: by vertex counts (5 columns each), not at the box's middle */
    uint32_t slab[COLS * ROWS];
    for (uint32_t v = 0; v < nv; v++) {
        slab[v] = mr_partitioned_slab(&s, v, false);
        assert_int_equal(slab[v], parts == 1 ? 0 : column(v) >= COLS / 2);
        /* shifted slabs: planes at the quantiles (i - 1/2) / parts */
        const uint32_t c = column(v);
        assert_int_equal(mr_partitioned_slab(&s, v, true),
                         parts == 1 ? (c >= COLS / 2) : (c >= 3) + (c >= 8));
    }
    /* edges and their triangle counts; vertices on the open boundary */
    static uint8_t ntri[COLS * ROWS][COLS * ROWS];
    memset(ntri, 0, sizeof ntri);
    for (size_t t = 0; t < nt; t++)
        for (int j = 0; j < 3; j++) {
            const uint32_t a = m->indices[3 * t + j], b = m->indices[3 * t + (j + 1) % 3];
            ntri[a < b ? a : b][a < b ? b : a]++;
        }
    bool bnd[COLS * ROWS] = {false}, pure[COLS * ROWS];
    for (uint32_t a = 0; a < nv; a++)
        for (uint32_t b = a + 1; b < nv; b++)
            if (ntri[a][b] == 1)
                bnd[a] = bnd[b] = true;
    /* pure: every vertex of every triangle of v in v's slab */
    for (uint32_t v = 0; v < nv; v++) {
        pure[v] = true;
        for (size_t t = 0; t < nt; t++) {
            const uint32_t *x = m->indices + 3 * t;
            if (x[0] == v || x[1] == v || x[2] == v)
                for (int j = 0; j < 3; j++)
                    pure[v] &= slab[x[j]] == slab[v];
        }
    }
    /* the candidates: every edge, once, but inner edges between two
     * boundary vertices */
    uint32_t a[3 * 64], b[3 * 64];
    uint8_t in[3 * 64];
    const size_t n = mr_partitioned_edges(&s, a, b, in, 3 * 64);
    assert_true(n <= 3 * 64);
    static uint8_t seen[COLS * ROWS][COLS * ROWS];
    memset(seen, 0, sizeof seen);
    size_t interior = 0, boundary = 0;
    for (size_t i = 0; i < n; i++) {
        assert_true(a[i] < b[i]);
        assert_int_equal(ntri[a[i]][b[i]] > 0, 1);
        assert_int_equal(seen[a[i]][b[i]], 0);
        seen[a[i]][b[i]] = 1;
        /* interior exactly when both closed 1-rings lie in one slab */
        const bool want = pure[a[i]] && pure[b[i]] && slab[a[i]] == slab[b[i]];
        if (in[i] != want) {
            print_error("edge (%u, %u), columns %u and %u: interior %d, expected %d\n", a[i],
                        b[i], column(a[i]), column(b[i]), in[i], want);
            fail();
        }
        interior += in[i];
        boundary += !in[i];
        /* the boundary step: interior to a shifted slab exactly when both
         * closed 1-rings lie in it */
        if (!in[i]) {
            const uint32_t q = mr_partitioned_slab(&s, a[i], true);
            bool want2 = true;
            for (size_t t = 0; t < nt; t++) {
                const uint32_t *x = m->indices + 3 * t;
                const bool touches = x[0] == a[i] || x[1] == a[i] || x[2] == a[i] ||
                                     x[0] == b[i] || x[1] == b[i] || x[2] == b[i];
                for (int j = 0; touches && j < 3; j++)
                    want2 &= mr_partitioned_slab(&s, x[j], true) == q;
            }
            assert_int_equal(mr_partitioned_shifted_interior(&s, a[i], b[i]), want2);
            /* the plane between columns 4 and 5 lies inside shifted slab 1 */
            if (parts == 2 && column(a[i]) >= 4 && column(b[i]) >= 4 && column(a[i]) <= 5 &&
                column(b[i]) <= 5)
                assert_true(want2);
        }
    }
    size_t expected = 0;
    for (uint32_t x = 0; x < nv; x++)
        for (uint32_t y = x + 1; y < nv; y++)
            if (ntri[x][y] == 1 || (ntri[x][y] == 2 && !(bnd[x] && bnd[y]))) {
                expected++;
                assert_int_equal(seen[x][y], 1);
            }
    assert_int_equal(n, expected);
    if (parts == 1) {
        assert_int_equal(boundary, 0); /* one slab: no boundary queue */
    } else {
        /* both kinds, and the known ones: an edge within columns 1..3 is
         * interior; one at column 4 or 5 (next to the plane) is not */
        assert_true(interior > 0 && boundary > 0);
        for (size_t i = 0; i < n; i++) {
            const uint32_t ca = column(a[i]), cb = column(b[i]);
            if (ca >= 1 && cb >= 1 && ca <= 3 && cb <= 3)
                assert_int_equal(in[i], 1);
            if (ca == 4 || cb == 4 || ca == 5 || cb == 5)
                assert_int_equal(in[i], 0);
            if (ca >= 6 && cb >= 6 && ca <= 8 && cb <= 8)
                assert_int_equal(in[i], 1);
        }
    }
    mr_simplify_discard(&s);
}

static void test_classification(void **state)
{
    (void)state;
    mr_mesh m;
    strip(&m);
    check_classification(&m, 2);
    check_classification(&m, 1);
    mr_mesh_free(&m);
}

/* ---- determinism, topology, targets ---------------------------------------- */

static void expect_same(const char *what, int threads, const mr_simplified *x,
                        const mr_simplified *y)
{
    bool same = x->vertex_count == y->vertex_count && x->triangle_count == y->triangle_count &&
                x->stats.collapses == y->stats.collapses &&
                memcmp(&x->stats.max_error, &y->stats.max_error, sizeof(double)) == 0 &&
                x->stats.stop == y->stats.stop &&
                x->stats.interior_collapses == y->stats.interior_collapses &&
                x->stats.boundary_collapses == y->stats.boundary_collapses &&
                x->stats.boundary_sequential == y->stats.boundary_sequential &&
                x->stats.tail_collapses == y->stats.tail_collapses &&
                x->stats.partition_passes == y->stats.partition_passes &&
                x->stats.rebalances == y->stats.rebalances &&
                x->stats.claim_conflicts == y->stats.claim_conflicts &&
                x->stats.rebalance_count == y->stats.rebalance_count &&
                x->stats.rebalance_imbalance == y->stats.rebalance_imbalance &&
                x->stats.rebalance_boundary == y->stats.rebalance_boundary &&
                x->stats.rebalance_acceptance == y->stats.rebalance_acceptance;
    same = same && memcmp(x->positions, y->positions, 3 * x->vertex_count * sizeof(float)) == 0;
    same = same && memcmp(x->indices, y->indices, 3 * x->triangle_count * sizeof(uint32_t)) == 0;
    same = same && memcmp(x->origin, y->origin, x->vertex_count * sizeof(uint32_t)) == 0;
    if (!same) {
        print_error("%s: the output at %d threads differs from the one at 1 thread\n", what,
                    threads);
        fail();
    }
}

/* m at every thread count, with these options: the same bytes; closed and
 * manifold when m is; the vertex target exactly. */
static void check_threads(const char *name, const mr_mesh *m, mr_simplify_options *o)
{
    const bool closed = closed_manifold(m->positions, m->vertex_count, m->indices,
                                        m->triangle_count);
    char what[160];
    snprintf(what, sizeof what, "%s, %s, %u slabs, %s, %zu vertices, %zu triangles", name,
             strategy == MR_STRATEGY_PARTITIONED ? "partitioned" : "partitioned-boundary",
             o->partitions, o->collapse == MR_COLLAPSE_HALF ? "half" : "full",
             o->target_vertices, o->target_triangles);
    mr_simplified ref;
    for (size_t i = 0; i < NTHREADS; i++) {
        o->threads = thread_counts[i];
        mr_simplified r;
        run(m, o, &r);
        if (closed && !closed_manifold(r.positions, r.vertex_count, r.indices,
                                       r.triangle_count)) {
            print_error("%s at %d threads: not closed and manifold\n", what, o->threads);
            fail();
        }
        if (r.stats.stop == MR_STOP_TARGET && o->target_vertices)
            assert_int_equal(r.stats.output_points, o->target_vertices);
        if (r.stats.stop == MR_STOP_TARGET && o->target_triangles)
            assert_true(r.triangle_count <= o->target_triangles &&
                        r.triangle_count + 2 > o->target_triangles);
        if (i == 0) {
            ref = r;
            continue;
        }
        expect_same(what, o->threads, &ref, &r);
        mr_simplified_free(&r);
    }
    mr_simplified_free(&ref);
}

static void check_mesh(const char *name, const mr_mesh *m, bool reachable)
{
    static const unsigned parts[] = {16, 5};
    static const double ratios[] = {0.1, 0.01};
    /* (quick runs of the variant: 16 slabs only) */
    const size_t nparts = quick() && strategy == MR_STRATEGY_PARTITIONED_BOUNDARY ? 1 : 2;
    for (size_t p = 0; p < nparts; p++)
        for (size_t r = 0; r < 2; r++)
            for (int half = 0; half < 2; half++) {
                if (quick() && half && r)
                    continue;
                mr_simplify_options o;
                options(&o, parts[p], 1);
                o.collapse = half ? MR_COLLAPSE_HALF : MR_COLLAPSE_FULL;
                mr_stats in;
                assert_int_equal(mr_stats_compute(m->positions, 0, m->vertex_count,
                                                  m->indices, m->triangle_count, &in, NULL),
                                 MR_OK);
                o.target_vertices = (size_t)((double)m->vertex_count * ratios[r]);
                if (o.target_vertices < 8)
                    o.target_vertices = 8;
                check_threads(name, m, &o);
                if (reachable) {
                    /* the target is hit, and the work split as designed */
                    mr_simplified x;
                    o.threads = 2;
                    run(m, &o, &x);
                    assert_int_equal(x.stats.stop, MR_STOP_TARGET);
                    assert_true(x.stats.interior_collapses > 0);
                    assert_int_equal(x.stats.collapses, x.stats.interior_collapses +
                                                            x.stats.boundary_collapses +
                                                            x.stats.tail_collapses);
                    if (strategy == MR_STRATEGY_PARTITIONED_BOUNDARY) {
                        /* every rebalance has its trigger; no shifted
                         * slabs, no sequential remainder */
                        assert_int_equal(x.stats.rebalances,
                                         x.stats.rebalance_count +
                                             x.stats.rebalance_imbalance +
                                             x.stats.rebalance_boundary +
                                             x.stats.rebalance_acceptance);
                        assert_int_equal(x.stats.boundary_sequential, 0);
                        assert_true(x.stats.claim_conflicts > 0);
                    } else {
                        assert_int_equal(x.stats.claim_conflicts, 0);
                    }
                    mr_simplified_free(&x);
                }
            }
    /* a triangle target */
    mr_simplify_options o;
    options(&o, 16, 1);
    o.target_triangles = m->triangle_count / 7;
    check_threads(name, m, &o);
}

static void test_generated(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_SCAN, quick() ? 80000 : 300000, &m);
    check_mesh("scan", &m, true);
    mr_mesh_free(&m);
    generate(MR_GEN_SPHERE, quick() ? 20000 : 80000, &m);
    check_mesh("sphere", &m, true);
    mr_mesh_free(&m);
    generate(MR_GEN_TORUS, quick() ? 20000 : 60000, &m);
    check_mesh("torus with holes", &m, false);
    mr_mesh_free(&m);
}

static bool read_shared(const char *name, mr_mesh *m)
{
    const char *path = tu_shared_data(name);
    if (!path)
        return false;
    mr_mesh_init(m);
    mr_error err;
    if (mr_mesh_read(path, NULL, m, &err) != MR_OK) {
        print_error("%s: %s\n", path, err.message);
        fail();
    }
    return true;
}

static void test_shared_meshes(void **state)
{
    (void)state;
    static const char *const names[] = {"stanford-bunny.obj", "fandisk.obj", "armadillo.obj"};
    size_t found = 0;
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        if (quick() && i > 1)
            break;
        mr_mesh m;
        if (!read_shared(names[i], &m))
            continue;
        found++;
        check_mesh(names[i], &m, false);
        mr_mesh_free(&m);
    }
    if (!found)
        skip();
}

/* ---- one partition ----------------------------------------------------------- */

static double rms_of(const mr_mesh *m, const mr_simplified *r)
{
    mr_compare_options co;
    mr_compare_options_default(&co);
    co.samples = 100000;
    mr_compare_result res;
    mr_error err;
    assert_int_equal(mr_compare(m->positions, m->vertex_count, m->indices, m->triangle_count,
                                r->positions, r->vertex_count, r->indices, r->triangle_count,
                                &co, &res, &err),
                     MR_OK);
    return res.rms;
}

/* The RMS distance of y's output over x's (both run on m), printed; y's
 * within `bound` times x's. */
static void rms_within(const char *name, const mr_mesh *m, double ratio, const char *xname,
                       const mr_simplified *x, const char *yname, const mr_simplified *y,
                       double bound)
{
    const double a = rms_of(m, x), b = rms_of(m, y);
    print_message("%s at %g: RMS %s %.6g, %s %.6g (%+.2f %%)\n", name, ratio, xname, a, yname,
                  b, 100.0 * (b / a - 1));
    assert_int_equal(y->vertex_count, x->vertex_count);
    assert_true(b <= bound * a);
}

static void check_one_partition(const char *name, const mr_mesh *m, size_t nratios)
{
    static const double ratios[] = {0.1, 0.01};
    for (size_t i = 0; i < nratios; i++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_ratio = ratios[i];
        mr_simplified def, one;
        run(m, &o, &def);
        options(&o, 1, 2);
        o.target_ratio = ratios[i];
        run(m, &o, &one);
        assert_int_equal(one.stats.boundary_collapses, 0);
        rms_within(name, m, ratios[i], "default", &def, "one partition", &one, 1.01);
        mr_simplified_free(&def);
        mr_simplified_free(&one);
    }
}

/* check(name, mesh, ratios) on the bunny (when present) and a generated
 * scan. */
static void on_bunny_and_scan(void (*check)(const char *, const mr_mesh *, size_t))
{
    mr_mesh m;
    if (read_shared("stanford-bunny.obj", &m)) {
        check("bunny", &m, 2);
        mr_mesh_free(&m);
    }
    /* (the quick scan's 1 % -- 200 vertices -- is too coarse to compare
     * within 1 %) */
    generate(MR_GEN_SCAN, quick() ? 40000 : 200000, &m);
    check("scan", &m, quick() ? 1 : 2);
    mr_mesh_free(&m);
}

static void test_one_partition(void **state)
{
    (void)state;
    on_bunny_and_scan(check_one_partition);
}

/* ---- options and CLI ---------------------------------------------------------- */

static void test_options(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_SPHERE, 2000, &m);
    mr_simplify_options o;
    options(&o, MR_PARTITIONS_MAX + 1, 1);
    o.target_ratio = 0.5;
    mr_simplified r;
    mr_error err;
    assert_int_equal(mr_simplify(m.positions, 0, m.vertex_count, m.indices, m.triangle_count,
                                 &o, &r, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "partitions");
    /* 0 is the default, a constant */
    options(&o, 0, 3);
    o.target_ratio = 0.2;
    mr_simplified x, y;
    run(&m, &o, &x);
    o.partitions = MR_PARTITIONS_DEFAULT;
    o.threads = 1;
    run(&m, &o, &y);
    expect_same("default partitions", 3, &y, &x);
    mr_simplified_free(&x);
    mr_simplified_free(&y);
    /* more slabs than vertices */
    options(&o, MR_PARTITIONS_MAX, 2);
    o.target_ratio = 0.1;
    run(&m, &o, &x);
    assert_int_equal(x.stats.stop, MR_STOP_TARGET);
    assert_true(closed_manifold(x.positions, x.vertex_count, x.indices, x.triangle_count));
    mr_simplified_free(&x);
    mr_mesh_free(&m);
}

static void test_cli(void **state)
{
    (void)state;
    mr_mesh m;
    generate(MR_GEN_SPHERE, 5000, &m);
    const char *in = tu_tmp_path("part_in.ply");
    mr_error err;
    assert_int_equal(mr_mesh_write(in, &m, NULL, &err), MR_OK);
    mr_mesh_free(&m);
    char *out = NULL;
    const char *o1 = tu_tmp_path("part_1.ply");
    int rc = tu_run_cli(tu_fmt("simplify %s -o %s --ratio 0.1 --strategy partitioned "
                               "--partitions 4 --threads 1 --json",
                               in, o1),
                        &out);
    assert_int_equal(rc, 0);
    tu_assert_contains(out, "\"partitioned\": {\"passes\": ");
    tu_assert_contains(out, "\"interior_collapses\": ");
    free(out);
    const char *o2 = tu_tmp_path("part_2.ply");
    rc = tu_run_cli(tu_fmt("simplify %s -o %s --ratio 0.1 --strategy partitioned "
                           "--partitions 4 --threads 2 -q",
                           in, o2),
                    NULL);
    assert_int_equal(rc, 0);
    size_t n1, n2;
    char *b1 = tu_read_file(o1, &n1), *b2 = tu_read_file(o2, &n2);
    assert_non_null(b1);
    assert_non_null(b2);
    assert_true(n1 == n2 && memcmp(b1, b2, n1) == 0);
    free(b1);
    free(b2);
    rc = tu_run_cli(tu_fmt("simplify %s -o %s --ratio 0.1 --strategy partitioned "
                           "--partitions 0",
                           in, o2),
                    &out);
    assert_int_equal(rc, 2);
    tu_assert_contains(out, "--partitions needs a count in 1..4096");
    free(out);
    rc = tu_run_cli("simplify --help", &out);
    assert_int_equal(rc, 0);
    tu_assert_contains(out, "--partitions P");
    tu_assert_contains(out, "default 16");
    free(out);
}

/* ---- the boundary-aware variant ---------------------------------------------- */

/* The closed 1-ring of each vertex (the vertices of its triangles, itself
 * included), from a triangle list: ring[v * RING_MAX ..] (nring[v]). */
#define RING_MAX 32

static void closed_rings(const uint32_t *idx, size_t nt, size_t nv, uint32_t *ring,
                         uint32_t *nring)
{
    memset(nring, 0, nv * sizeof *nring);
    for (size_t t = 0; t < nt; t++)
        for (int j = 0; j < 3; j++) {
            const uint32_t v = idx[3 * t + j];
            for (int k = 0; k < 3; k++) {
                const uint32_t w = idx[3 * t + k];
                bool have = false;
                for (uint32_t i = 0; i < nring[v]; i++)
                    have |= ring[(size_t)v * RING_MAX + i] == w;
                if (!have) {
                    assert_true(nring[v] < RING_MAX);
                    ring[(size_t)v * RING_MAX + nring[v]++] = w;
                }
            }
        }
}

/* Does an end of (a, b) share a triangle with an end of (c, d)? (is c or d
 * in the closed 1-ring of a or b) */
static bool conflict(const uint32_t *ring, const uint32_t *nring, uint32_t a, uint32_t b,
                     uint32_t c, uint32_t d)
{
    const uint32_t e[2] = {a, b};
    for (int j = 0; j < 2; j++)
        for (uint32_t i = 0; i < nring[e[j]]; i++) {
            const uint32_t w = ring[(size_t)e[j] * RING_MAX + i];
            if (w == c || w == d)
                return true;
        }
    return false;
}

/* Walk every edge of m in order, taking each one the claims admit: the
 * claims must admit an edge exactly when it conflicts with none taken
 * before (collapse.h: such collapses commute and may run at once). */
static void check_claims(const char *name, const mr_mesh *m)
{
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 0.5;
    mr_simplifier s;
    mr_error err;
    assert_int_equal(mr_simplify_setup(&s, m->positions, 0, m->vertex_count, m->indices,
                                        m->triangle_count, &o, NULL, &err),
                     MR_OK);
    const size_t nv = m->vertex_count, nt = m->triangle_count;
    uint32_t *ring = malloc(nv * RING_MAX * sizeof *ring), *nring = malloc(nv * sizeof *nring);
    uint8_t *claim = calloc(nv, 1);
    uint32_t *taken = malloc(2 * 3 * nt * sizeof *taken);
    assert_true(ring && nring && claim && taken);
    closed_rings(m->indices, nt, nv, ring, nring);
    size_t ntaken = 0, refused = 0;
    for (size_t t = 0; t < nt; t++)
        for (int j = 0; j < 3; j++) {
            const uint32_t a = m->indices[3 * t + j], b = m->indices[3 * t + (j + 1) % 3];
            if (a > b)
                continue; /* each inner edge once (and boundary edges one way) */
            bool want = true;
            for (size_t i = 0; i < ntaken && want; i++)
                want = !conflict(ring, nring, taken[2 * i], taken[2 * i + 1], a, b) &&
                       !conflict(ring, nring, a, b, taken[2 * i], taken[2 * i + 1]);
            const bool got = mr_claim_free(&s.m, claim, a, b);
            if (got != want) {
                print_error("%s: edge (%u, %u) after %zu taken: claims say %d, expected %d\n",
                            name, a, b, ntaken, got, want);
                fail();
            }
            if (got) {
                mr_claim_take(&s.m, claim, a, b);
                taken[2 * ntaken] = a;
                taken[2 * ntaken + 1] = b;
                ntaken++;
            } else {
                refused++;
            }
        }
    assert_true(ntaken > 0 && refused > 0);
    free(ring);
    free(nring);
    free(claim);
    free(taken);
    mr_simplifier_free(&s);
}

static void test_claims(void **state)
{
    (void)state;
    mr_mesh m;
    strip(&m);
    check_claims("strip", &m);
    mr_mesh_free(&m);
    generate(MR_GEN_SPHERE, 3000, &m);
    check_claims("sphere", &m);
    mr_mesh_free(&m);
}

/* Each trigger fires at its threshold and not just below it, in the order
 * count, imbalance, boundary, acceptance; the first pass after a balance
 * never fires. */
static void test_triggers(void **state)
{
    (void)state;
    pslab sl[4];
    memset(sl, 0, sizeof sl);
    for (int p = 0; p < 4; p++)
        sl[p].gathered = 100;
    /* reference: boundary fraction 0.1, acceptance 0.2 */
    mr_part_triggers tr = {1000, 0, 0, 0};
    assert_int_equal(mr_part_trigger(&tr, 400, sl, 4, 1000, 100, 500, 100), -1);
    mr_part_triggers t0 = tr;
    /* quiet */
    assert_int_equal(mr_part_trigger(&tr, 501, sl, 4, 1000, 100, 500, 100), -1);
    /* count: the live vertices halved */
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 500, sl, 4, 1000, 500, 500, 0), MR_TRIGGER_COUNT);
    /* imbalance: the largest slab 1.5x the mean */
    sl[0].gathered = 250; /* 4 * 250 = 1000 >= 1.5 * 550 */
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 900, sl, 4, 1000, 500, 500, 0),
                     MR_TRIGGER_IMBALANCE);
    sl[0].gathered = 150; /* 600 < 1.5 * 450 */
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 900, sl, 4, 1000, 100, 500, 100), -1);
    /* boundary: the fraction 1.25x its first value */
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 900, sl, 4, 1000, 126, 500, 100),
                     MR_TRIGGER_BOUNDARY);
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 900, sl, 4, 1000, 124, 500, 100), -1);
    /* acceptance: half its first rate */
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 900, sl, 4, 1000, 100, 500, 49),
                     MR_TRIGGER_ACCEPTANCE);
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 900, sl, 4, 1000, 100, 500, 51), -1);
    /* one slab: never imbalanced */
    tr = t0;
    assert_int_equal(mr_part_trigger(&tr, 900, sl, 1, 1000, 100, 500, 100), -1);
}

/* A sheet, flat for x < 0 and wavy beyond: the flat half goes first, its
 * slabs empty, and the imbalance trigger rebalances. */
static void half_flat(mr_mesh *m, uint32_t n)
{
    mr_mesh_init(m);
    m->vertex_count = (size_t)n * n;
    m->triangle_count = 2 * (size_t)(n - 1) * (n - 1);
    m->positions = malloc(3 * m->vertex_count * sizeof *m->positions);
    m->indices = malloc(3 * m->triangle_count * sizeof *m->indices);
    assert_true(m->positions && m->indices);
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = 0; j < n; j++) {
            float *p = m->positions + 3 * ((size_t)i * n + j);
            const double x = 2.0 * i / (n - 1) - 1, y = (double)j / (n - 1);
            p[0] = (float)x;
            p[1] = (float)y;
            p[2] = x < 0 ? 0.0f
                         : (float)(0.02 * sin(40 * x) * cos(37 * y) +
                                   0.001 * (double)((i * 7919u + j * 104729u) % 5));
        }
    uint32_t *t = m->indices;
    for (uint32_t i = 0; i + 1 < n; i++)
        for (uint32_t j = 0; j + 1 < n; j++) {
            const uint32_t a = i * n + j, b = a + n;
            *t++ = a, *t++ = b, *t++ = b + 1;
            *t++ = a, *t++ = b + 1, *t++ = a + 1;
        }
}

static void test_boundary_generated(void **state)
{
    (void)state;
    strategy = MR_STRATEGY_PARTITIONED_BOUNDARY;
    mr_mesh m;
    generate(MR_GEN_SCAN, quick() ? 40000 : 150000, &m);
    check_mesh("scan", &m, true);
    mr_mesh_free(&m);
    if (!quick()) { /* (the quick run: the closed scan and the open sheet) */
        generate(MR_GEN_SPHERE, 40000, &m);
        check_mesh("sphere", &m, true);
        mr_mesh_free(&m);
        generate(MR_GEN_TORUS, 30000, &m);
        check_mesh("torus with holes", &m, false);
        mr_mesh_free(&m);
    }
    half_flat(&m, quick() ? 120 : 200);
    mr_simplify_options o;
    options(&o, 16, 1);
    o.target_ratio = 0.05;
    check_threads("half-flat sheet", &m, &o);
    mr_simplified r;
    o.threads = 2;
    run(&m, &o, &r);
    print_message("half-flat sheet: %zu rebalances: %zu count, %zu imbalance, %zu boundary, "
                  "%zu acceptance\n",
                  r.stats.rebalances, r.stats.rebalance_count, r.stats.rebalance_imbalance,
                  r.stats.rebalance_boundary, r.stats.rebalance_acceptance);
    assert_true(r.stats.rebalance_imbalance > 0);
    mr_simplified_free(&r);
    mr_mesh_free(&m);
    strategy = MR_STRATEGY_PARTITIONED;
}

static void test_boundary_shared(void **state)
{
    (void)state;
    static const char *const names[] = {"fandisk.obj", "stanford-bunny.obj"};
    strategy = MR_STRATEGY_PARTITIONED_BOUNDARY;
    size_t found = 0;
    for (size_t i = 0; i < (quick() ? 1 : sizeof names / sizeof names[0]); i++) {
        mr_mesh m;
        if (!read_shared(names[i], &m))
            continue;
        found++;
        check_mesh(names[i], &m, false);
        mr_mesh_free(&m);
    }
    strategy = MR_STRATEGY_PARTITIONED;
    if (!found)
        skip();
}

/* The variant's surface error against the partitioned strategy's, at 16
 * slabs; with one slab there is nothing across slabs. */
static void check_boundary_quality(const char *name, const mr_mesh *m, size_t nratios)
{
    static const double ratios[] = {0.1, 0.01};
    for (size_t i = 0; i < nratios; i++) {
        mr_simplify_options o;
        mr_simplified part, bnd, one;
        strategy = MR_STRATEGY_PARTITIONED;
        options(&o, 16, 2);
        o.target_ratio = ratios[i];
        run(m, &o, &part);
        strategy = MR_STRATEGY_PARTITIONED_BOUNDARY;
        options(&o, 16, 2);
        o.target_ratio = ratios[i];
        run(m, &o, &bnd);
        options(&o, 1, 2);
        o.target_ratio = ratios[i];
        run(m, &o, &one);
        strategy = MR_STRATEGY_PARTITIONED;
        assert_int_equal(one.stats.boundary_collapses, 0);
        rms_within(name, m, ratios[i], "partitioned", &part, "boundary-aware", &bnd, 1.05);
        mr_simplified_free(&part);
        mr_simplified_free(&bnd);
        mr_simplified_free(&one);
    }
}

static void test_boundary_quality(void **state)
{
    (void)state;
    if (!quick()) {
        on_bunny_and_scan(check_boundary_quality);
        return;
    }
    mr_mesh m; /* the quick run: the scan at 10 % */
    generate(MR_GEN_SCAN, 40000, &m);
    check_boundary_quality("scan", &m, 1);
    mr_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_classification), cmocka_unit_test(test_options),
        cmocka_unit_test(test_generated),      cmocka_unit_test(test_shared_meshes),
        cmocka_unit_test(test_one_partition),  cmocka_unit_test(test_cli),
        cmocka_unit_test(test_claims),         cmocka_unit_test(test_triggers),
        cmocka_unit_test(test_boundary_generated), cmocka_unit_test(test_boundary_shared),
        cmocka_unit_test(test_boundary_quality),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
