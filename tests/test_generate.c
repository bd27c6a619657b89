/* The procedural generators: counts, topology, determinism, detail.
 * Topology is checked here with a plain sorted half-edge list, so these
 * tests do not depend on the library's own statistics. */
#include "testutil.h"

#include "mesh/generate.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifdef _OPENMP
#include <omp.h>
#endif

/* Documented bounds of the scan's radius around the origin. */
#define SCAN_RMIN 30.0
#define SCAN_RMAX 70.0

/* ------------------------------------------------------------------------ */
/* A small independent topology checker                                     */
/* ------------------------------------------------------------------------ */

typedef struct half_edge {
    uint64_t key; /* from << 32 | to */
    uint32_t tri;
} half_edge;

typedef struct topo {
    size_t referenced;        /* vertices used by a triangle */
    size_t edges;             /* undirected */
    size_t boundary_edges;    /* half-edges without a twin */
    size_t repeated_half_edges; /* a -> b twice: non-manifold or misoriented */
    size_t degenerate;        /* repeated index or zero area */
    size_t fans;              /* corner fans over all vertices */
    size_t boundary_loops;
    bool boundary_simple;     /* every boundary vertex has one way on */
    long long euler;
    double signed_volume;
    double mean_dihedral;     /* mean angle between adjacent normals */
} topo;

static int cmp_half_edge(const void *a, const void *b)
{
    uint64_t x = ((const half_edge *)a)->key, y = ((const half_edge *)b)->key;
    return x < y ? -1 : x > y;
}

static uint64_t he_key(uint32_t from, uint32_t to) { return (uint64_t)from << 32 | to; }

/* Index of half-edge from -> to in the sorted list, or -1. */
static long find_half_edge(const half_edge *he, size_t n, uint64_t key)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (he[mid].key < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && he[lo].key == key ? (long)lo : -1;
}

static void normal_of(const mr_mesh *m, size_t t, double n[3])
{
    const float *p[3];
    for (int k = 0; k < 3; k++)
        p[k] = m->positions + 3 * (size_t)m->indices[3 * t + k];
    double u[3], v[3];
    for (int k = 0; k < 3; k++) {
        u[k] = (double)p[1][k] - p[0][k];
        v[k] = (double)p[2][k] - p[0][k];
    }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
}

static uint32_t corner_vertex(const mr_mesh *m, size_t c) { return m->indices[c]; }
static size_t corner_prev(size_t c) { return c - c % 3 + (c + 2) % 3; }

/* Fans: corner c at vertex v continues to the corner of v in the triangle
 * across edge prev(c) -> v. Chains (open fans) and cycles (closed fans) of
 * that map, counted together, are one per vertex exactly on a manifold. */
static size_t count_fans(const mr_mesh *m, const half_edge *he, size_t nhe)
{
    size_t nc = 3 * m->triangle_count;
    size_t *next = malloc(nc * sizeof *next);
    bool *has_pred = calloc(nc, 1), *seen = calloc(nc, 1);
    assert_true(next && has_pred && seen);
    for (size_t c = 0; c < nc; c++) {
        uint32_t v = corner_vertex(m, c), p = corner_vertex(m, corner_prev(c));
        long h = find_half_edge(he, nhe, he_key(v, p));
        next[c] = SIZE_MAX;
        if (h < 0)
            continue;
        size_t t = he[h].tri;
        for (int k = 0; k < 3; k++)
            if (m->indices[3 * t + k] == v)
                next[c] = 3 * t + (size_t)k;
        assert_true(next[c] != SIZE_MAX);
        has_pred[next[c]] = true;
    }
    size_t fans = 0;
    for (int pass = 0; pass < 2; pass++) /* chains first, then cycles */
        for (size_t c = 0; c < nc; c++) {
            if (seen[c] || (pass == 0 && has_pred[c]))
                continue;
            fans++;
            for (size_t x = c; x != SIZE_MAX && !seen[x]; x = next[x])
                seen[x] = true;
        }
    free(next);
    free(has_pred);
    free(seen);
    return fans;
}

/* Boundary half-edges chained head to tail into loops. */
static void count_boundary_loops(const mr_mesh *m, const half_edge *he, size_t nhe, topo *t)
{
    uint32_t *next = malloc(m->vertex_count * sizeof *next);
    bool *seen = calloc(m->vertex_count, 1);
    assert_true(next && seen);
    for (size_t v = 0; v < m->vertex_count; v++)
        next[v] = UINT32_MAX;
    t->boundary_simple = true;
    for (size_t i = 0; i < nhe; i++) {
        uint32_t a = (uint32_t)(he[i].key >> 32), b = (uint32_t)he[i].key;
        if (find_half_edge(he, nhe, he_key(b, a)) >= 0)
            continue;
        if (next[a] != UINT32_MAX)
            t->boundary_simple = false;
        next[a] = b;
    }
    t->boundary_loops = 0;
    for (size_t v = 0; v < m->vertex_count; v++) {
        if (next[v] == UINT32_MAX || seen[v])
            continue;
        t->boundary_loops++;
        uint32_t x = (uint32_t)v;
        while (x != UINT32_MAX && !seen[x]) {
            seen[x] = true;
            x = next[x];
        }
        if (x != (uint32_t)v)
            t->boundary_simple = false; /* ran into another loop or a dead end */
    }
    free(next);
    free(seen);
}

static topo analyse(const mr_mesh *m)
{
    topo t;
    memset(&t, 0, sizeof t);
    size_t nt = m->triangle_count, nhe = 3 * nt;
    half_edge *he = malloc(nhe * sizeof *he);
    bool *used = calloc(m->vertex_count, 1);
    assert_true(he && used);

    for (size_t i = 0; i < nt; i++) {
        const uint32_t *v = m->indices + 3 * i;
        for (int k = 0; k < 3; k++) {
            assert_true(v[k] < m->vertex_count);
            used[v[k]] = true;
            he[3 * i + k].key = he_key(v[k], v[(k + 1) % 3]);
            he[3 * i + k].tri = (uint32_t)i;
        }
        double n[3];
        normal_of(m, i, n);
        if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2] ||
            n[0] * n[0] + n[1] * n[1] + n[2] * n[2] == 0)
            t.degenerate++;
        const float *p0 = m->positions + 3 * (size_t)v[0];
        t.signed_volume += (p0[0] * n[0] + p0[1] * n[1] + p0[2] * n[2]) / 6.0;
    }
    for (size_t v = 0; v < m->vertex_count; v++)
        t.referenced += used[v];
    qsort(he, nhe, sizeof *he, cmp_half_edge);

    size_t twinned = 0, dihedral_count = 0;
    double dihedral_sum = 0;
    for (size_t i = 0; i < nhe; i++) {
        if (i > 0 && he[i].key == he[i - 1].key)
            t.repeated_half_edges++;
        uint32_t a = (uint32_t)(he[i].key >> 32), b = (uint32_t)he[i].key;
        long tw = find_half_edge(he, nhe, he_key(b, a));
        if (tw < 0) {
            t.boundary_edges++;
            continue;
        }
        twinned++;
        if (a < b) {
            double n1[3], n2[3];
            normal_of(m, he[i].tri, n1);
            normal_of(m, he[tw].tri, n2);
            double d = n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2];
            double l = sqrt((n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]) *
                            (n2[0] * n2[0] + n2[1] * n2[1] + n2[2] * n2[2]));
            double c = l > 0 ? d / l : 1;
            dihedral_sum += acos(c > 1 ? 1 : c < -1 ? -1 : c);
            dihedral_count++;
        }
    }
    t.edges = twinned / 2 + t.boundary_edges;
    t.euler = (long long)t.referenced - (long long)t.edges + (long long)nt;
    t.mean_dihedral = dihedral_count ? dihedral_sum / (double)dihedral_count : 0;
    t.fans = count_fans(m, he, nhe);
    count_boundary_loops(m, he, nhe, &t);
    free(he);
    free(used);
    return t;
}

/* A closed, consistently oriented 2-manifold of genus 0, facing out. */
static void assert_closed_sphere_like(const mr_mesh *m)
{
    topo t = analyse(m);
    assert_int_equal(t.referenced, m->vertex_count);
    assert_int_equal(t.repeated_half_edges, 0);
    assert_int_equal(t.boundary_edges, 0);
    assert_int_equal(t.degenerate, 0);
    assert_int_equal(t.fans, m->vertex_count);
    assert_int_equal(t.edges * 2, 3 * m->triangle_count);
    assert_int_equal(t.euler, 2);
    assert_true(t.signed_volume > 0);
}

/* ------------------------------------------------------------------------ */
/* Helpers                                                                  */
/* ------------------------------------------------------------------------ */

static void generate_ok(mr_generator kind, size_t n, uint64_t seed, mr_mesh *m)
{
    mr_error err;
    mr_mesh_init(m);
    mr_status st = mr_generate(kind, n, seed, m, &err);
    if (st != MR_OK)
        print_error("%s %zu: %s\n", mr_generator_name(kind), n, err.message);
    assert_int_equal(st, MR_OK);
    assert_non_null(m->positions);
    assert_non_null(m->indices);
    assert_null(m->normals);
    assert_null(m->texcoords);
    assert_null(m->colors);
}

static size_t size_diff(size_t a, size_t b) { return a > b ? a - b : b - a; }

static void assert_within_5_percent(size_t got, size_t wanted)
{
    if (size_diff(got, wanted) * 20 > wanted) {
        print_error("%zu triangles for %zu requested\n", got, wanted);
        fail();
    }
}

/* ------------------------------------------------------------------------ */
/* Names and arguments                                                      */
/* ------------------------------------------------------------------------ */

/* ---- in pieces and streamed --------------------------------------------- */

/* The generator in pieces gives mr_generate's positions and triangles for
 * any range: the whole mesh read back in ragged blocks, and every
 * frequency from 1 to 12 (the inverse of the face-interior numbering). */
static void test_stream_pieces(void **state)
{
    (void)state;
    const size_t sizes[] = {20, 80, 180, 320, 500, 720, 980, 1280, 1620, 2000, 2420, 2880,
                            50000};
    for (int kind = 0; kind < 2; kind++) {
        const mr_generator k = kind ? MR_GEN_SCAN : MR_GEN_SPHERE;
        for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++) {
            mr_mesh m;
            mr_error err;
            assert_int_equal(mr_generate(k, sizes[si], 7, &m, &err), MR_OK);
            mr_gen_stream *gs;
            assert_int_equal(mr_gen_stream_open(k, sizes[si], 7, &gs, &err), MR_OK);
            assert_int_equal(mr_gen_stream_vertex_count(gs), m.vertex_count);
            assert_int_equal(mr_gen_stream_triangle_count(gs), m.triangle_count);
            float *pos = malloc(12 * m.vertex_count);
            uint32_t *idx = malloc(12 * m.triangle_count);
            assert_non_null(pos);
            assert_non_null(idx);
            /* ragged blocks: 1, 2, 3, ... items, then the rest */
            for (size_t v = 0, n = 1; v < m.vertex_count; v += n, n++) {
                n = n < m.vertex_count - v ? n : m.vertex_count - v;
                mr_gen_stream_positions(gs, v, n, pos + 3 * v);
            }
            for (size_t t = 0, n = 1; t < m.triangle_count; t += n, n += 3) {
                n = n < m.triangle_count - t ? n : m.triangle_count - t;
                assert_int_equal(mr_gen_stream_triangles(gs, t, n, idx + 3 * t, &err), MR_OK);
            }
            assert_memory_equal(pos, m.positions, 12 * m.vertex_count);
            assert_memory_equal(idx, m.indices, 12 * m.triangle_count);
            free(pos);
            free(idx);
            mr_gen_stream_close(gs);
            mr_mesh_free(&m);
        }
    }
    mr_gen_stream *gs;
    mr_error err;
    assert_int_equal(mr_gen_stream_open(MR_GEN_TORUS, 1000, 1, &gs, &err), MR_ERR_UNSUPPORTED);
}

/* mr_generate_file writes mr_generate's mesh as mr_mesh_write does, byte
 * for byte: streamed for the sphere and the scan as PLY (binary little and
 * big endian, ascii; past one block of a million vertices and triangles),
 * in memory for the torus and OBJ. */
static void test_generate_file_bytes(void **state)
{
    (void)state;
    const bool quick = getenv("MR_TEST_QUICK") != NULL;
    struct {
        mr_generator kind;
        size_t triangles;
        const char *ext;
        mr_encoding enc;
    } cases[] = {
        {MR_GEN_SCAN, 20, "ply", MR_ENCODING_DEFAULT},
        {MR_GEN_SPHERE, 5000, "ply", MR_ENCODING_BINARY_BE},
        {MR_GEN_SCAN, 30000, "ply", MR_ENCODING_ASCII},
        {MR_GEN_SCAN, quick ? 300000 : 2200000, "ply", MR_ENCODING_DEFAULT},
        {MR_GEN_TORUS, 3000, "ply", MR_ENCODING_DEFAULT},
        {MR_GEN_SCAN, 3000, "obj", MR_ENCODING_DEFAULT},
    };
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        mr_write_options o;
        mr_write_options_default(&o);
        o.encoding = cases[c].enc;
        char a[1024], b[1024];
        snprintf(a, sizeof a, "%s", tu_tmp_path(tu_fmt("gen-stream-%zu.%s", c, cases[c].ext)));
        snprintf(b, sizeof b, "%s", tu_tmp_path(tu_fmt("gen-mesh-%zu.%s", c, cases[c].ext)));
        mr_error err;
        size_t nv, nt;
        assert_int_equal(mr_generate_file(cases[c].kind, cases[c].triangles, 3, a, &o, &nv, &nt,
                                          &err),
                         MR_OK);
        mr_mesh m;
        assert_int_equal(mr_generate(cases[c].kind, cases[c].triangles, 3, &m, &err), MR_OK);
        assert_int_equal(nv, m.vertex_count);
        assert_int_equal(nt, m.triangle_count);
        assert_int_equal(mr_mesh_write(b, &m, &o, &err), MR_OK);
        mr_mesh_free(&m);
        size_t na, nb;
        char *da = tu_read_file(a, &na), *db = tu_read_file(b, &nb);
        assert_non_null(da);
        assert_non_null(db);
        assert_int_equal(na, nb);
        assert_memory_equal(da, db, na);
        free(da);
        free(db);
        unlink(a);
        unlink(b);
    }
    /* a bad destination: the error, and no file */
    mr_error err;
    assert_int_equal(mr_generate_file(MR_GEN_SCAN, 1000, 1, tu_tmp_path("no/such/dir/x.ply"),
                                      NULL, NULL, NULL, &err),
                     MR_ERR_IO);
}

static void test_names(void **state)
{
    (void)state;
    const mr_generator kinds[] = {MR_GEN_SPHERE, MR_GEN_TORUS, MR_GEN_SCAN};
    const char *names[] = {"sphere", "torus", "scan"};
    for (int i = 0; i < 3; i++) {
        mr_generator k = (mr_generator)-1;
        assert_int_equal(mr_generator_from_name(names[i], &k), 0);
        assert_int_equal(k, kinds[i]);
        assert_string_equal(mr_generator_name(kinds[i]), names[i]);
    }
    const char *bad[] = {"", "cube", "Sphere", "scan ", "tor"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        mr_generator k = MR_GEN_TORUS;
        assert_int_equal(mr_generator_from_name(bad[i], &k), -1);
        assert_int_equal(k, MR_GEN_TORUS); /* untouched */
    }
    mr_generator k;
    assert_int_equal(mr_generator_from_name(NULL, &k), -1);
    assert_non_null(mr_generator_name((mr_generator)42));
}

static void test_bad_arguments(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    mr_mesh_init(&m);
    for (int k = 0; k < 3; k++) {
        assert_int_equal(mr_generate((mr_generator)k, 0, 1, &m, &err), MR_ERR_INVALID_ARGUMENT);
        tu_assert_contains(err.message, "triangle count must be positive");
        assert_null(m.positions);
        assert_int_equal(m.vertex_count, 0);
        /* Beyond 32-bit indices: refused before allocating anything. */
        assert_int_equal(mr_generate((mr_generator)k, (size_t)5000000000ull, 1, &m, &err),
                         MR_ERR_TOO_LARGE);
        assert_int_equal(err.status, MR_ERR_TOO_LARGE);
        assert_int_equal(mr_generate((mr_generator)k, SIZE_MAX, 1, &m, &err),
                         MR_ERR_TOO_LARGE);
        assert_null(m.positions);
        assert_null(m.indices);
    }
    assert_int_equal(mr_generate((mr_generator)3, 100, 1, &m, &err), MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_generate((mr_generator)-1, 100, 1, &m, &err), MR_ERR_INVALID_ARGUMENT);
    assert_null(m.positions);
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 100, 1, NULL, &err), MR_ERR_INVALID_ARGUMENT);
    /* A NULL error record is allowed. */
    assert_int_equal(mr_generate(MR_GEN_SCAN, 0, 1, &m, NULL), MR_ERR_INVALID_ARGUMENT);
}

/* ------------------------------------------------------------------------ */
/* Sphere and scan                                                          */
/* ------------------------------------------------------------------------ */

/* 20 f^2 triangles, 10 f^2 + 2 vertices, f giving the count nearest n. */
static void assert_geodesic_counts(const mr_mesh *m, size_t n)
{
    size_t f = (size_t)llround(sqrt((double)m->triangle_count / 20.0));
    assert_true(f >= 1);
    assert_int_equal(m->triangle_count, 20 * f * f);
    assert_int_equal(m->vertex_count, 10 * f * f + 2);
    size_t diff = size_diff(20 * f * f, n);
    assert_true(diff <= size_diff(20 * (f + 1) * (f + 1), n));
    if (f > 1)
        assert_true(diff <= size_diff(20 * (f - 1) * (f - 1), n));
}

static void test_sphere_counts(void **state)
{
    (void)state;
    const size_t ns[] = {1, 19, 20, 21, 50, 79, 81, 100, 1000, 1125, 12345, 200000, 1000000};
    for (size_t i = 0; i < sizeof ns / sizeof *ns; i++) {
        mr_mesh m;
        generate_ok(MR_GEN_SPHERE, ns[i], 7, &m);
        assert_geodesic_counts(&m, ns[i]);
        mr_mesh_free(&m);
    }
    mr_mesh m;
    generate_ok(MR_GEN_SPHERE, 1, 0, &m); /* the icosahedron */
    assert_int_equal(m.triangle_count, 20);
    assert_int_equal(m.vertex_count, 12);
    mr_mesh_free(&m);
}

static void test_sphere_topology(void **state)
{
    (void)state;
    const size_t ns[] = {1, 80, 180, 320, 5000, 60000};
    for (size_t i = 0; i < sizeof ns / sizeof *ns; i++) {
        mr_mesh m;
        generate_ok(MR_GEN_SPHERE, ns[i], 0, &m);
        assert_closed_sphere_like(&m);
        for (size_t v = 0; v < m.vertex_count; v++) {
            const float *p = m.positions + 3 * v;
            double r = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
            assert_true(fabs(r - 1.0) < 1e-6);
        }
        mr_mesh_free(&m);
    }
}

static void radius_range(const mr_mesh *m, double *lo, double *hi)
{
    *lo = INFINITY;
    *hi = 0;
    for (size_t v = 0; v < m->vertex_count; v++) {
        const float *p = m->positions + 3 * v;
        double r = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
        *lo = r < *lo ? r : *lo;
        *hi = r > *hi ? r : *hi;
    }
}

static void test_scan_shape(void **state)
{
    (void)state;
    const size_t ns[] = {1, 1000, 1125, 20000, 150000};
    for (size_t i = 0; i < sizeof ns / sizeof *ns; i++) {
        for (uint64_t seed = 1; seed <= 3; seed++) {
            mr_mesh m;
            generate_ok(MR_GEN_SCAN, ns[i], seed, &m);
            assert_geodesic_counts(&m, ns[i]);
            if (ns[i] >= 10000)
                assert_within_5_percent(m.triangle_count, ns[i]);
            assert_closed_sphere_like(&m);
            double lo, hi;
            radius_range(&m, &lo, &hi);
            assert_true(lo > SCAN_RMIN * (1 - 1e-6));
            assert_true(hi < SCAN_RMAX * (1 + 1e-6));
            /* The lobes and noise make it anything but a ball. */
            if (ns[i] >= 1000)
                assert_true(hi - lo > 10.0);
            mr_mesh_free(&m);
        }
    }
}

/* At one resolution the scan bends between neighbouring triangles far more
 * than the smooth sphere: it has detail down to its edge length. */
static void test_scan_fine_detail(void **state)
{
    (void)state;
    mr_mesh sphere, scan;
    generate_ok(MR_GEN_SPHERE, 200000, 1, &sphere);
    generate_ok(MR_GEN_SCAN, 200000, 1, &scan);
    topo ts = analyse(&sphere), tc = analyse(&scan);
    print_message("mean dihedral deviation: sphere %.4f rad, scan %.4f rad\n",
                  ts.mean_dihedral, tc.mean_dihedral);
    assert_true(tc.mean_dihedral > 8 * ts.mean_dihedral);
    assert_true(tc.mean_dihedral > 0.05); /* about 3 degrees */
    mr_mesh_free(&sphere);

    /* Half the resolution is not rougher: each doubling of resolution
     * adds an octave of detail, where a smooth surface sampled finer would
     * halve its dihedral angles. */
    mr_mesh coarser;
    generate_ok(MR_GEN_SCAN, 50000, 1, &coarser);
    topo tk = analyse(&coarser);
    print_message("scan at 50k: %.4f rad\n", tk.mean_dihedral);
    assert_true(tc.mean_dihedral > 0.7 * tk.mean_dihedral);
    mr_mesh_free(&coarser);
    mr_mesh_free(&scan);
}

/* ------------------------------------------------------------------------ */
/* Torus                                                                    */
/* ------------------------------------------------------------------------ */

static void test_torus_counts(void **state)
{
    (void)state;
    const size_t ns[] = {1000, 1234, 5000, 20000, 100000, 1000000};
    for (size_t i = 0; i < sizeof ns / sizeof *ns; i++)
        for (uint64_t seed = 0; seed < 4; seed++) {
            mr_mesh m;
            generate_ok(MR_GEN_TORUS, ns[i], seed, &m);
            assert_within_5_percent(m.triangle_count, ns[i]);
            mr_mesh_free(&m);
        }
    mr_mesh m;
    generate_ok(MR_GEN_TORUS, 1, 0, &m); /* the coarsest grid: 3 x 3 cells */
    assert_int_equal(m.triangle_count, 18);
    assert_int_equal(m.vertex_count, 9);
    mr_mesh_free(&m);
}

static void test_torus_topology(void **state)
{
    (void)state;
    const size_t ns[] = {1, 50, 300, 600, 1000, 4000, 30000, 200000};
    for (size_t i = 0; i < sizeof ns / sizeof *ns; i++)
        for (uint64_t seed = 0; seed < (ns[i] > 100000 ? 2u : 8u); seed++) {
            mr_mesh m;
            generate_ok(MR_GEN_TORUS, ns[i], seed, &m);
            topo t = analyse(&m);
            /* Every edge once or twice, the two uses in opposite
             * directions; no unused vertex; every vertex one fan. */
            assert_int_equal(t.repeated_half_edges, 0);
            assert_int_equal(t.referenced, m.vertex_count);
            assert_int_equal(t.degenerate, 0);
            assert_int_equal(t.fans, m.vertex_count);
            assert_true(t.boundary_simple);
            /* A torus with h disks removed: V - E + F = 0 - h. */
            assert_int_equal(t.euler, -(long long)t.boundary_loops);
            if (ns[i] >= 1000) {
                assert_true(t.boundary_loops >= 3 && t.boundary_loops <= 6);
                assert_true(t.boundary_edges >= 2);
            }
            for (size_t v = 0; v < m.vertex_count; v++) {
                const float *p = m.positions + 3 * v;
                double ring = sqrt((double)p[0] * p[0] + (double)p[1] * p[1]) - 1.0;
                double r = sqrt(ring * ring + (double)p[2] * p[2]);
                assert_true(fabs(r - 0.35) < 1e-5);
            }
            mr_mesh_free(&m);
        }
}

/* ------------------------------------------------------------------------ */
/* Determinism                                                              */
/* ------------------------------------------------------------------------ */

static void test_same_seed_same_mesh(void **state)
{
    (void)state;
    for (int k = 0; k < 3; k++) {
        mr_mesh a, b;
        generate_ok((mr_generator)k, 30000, 42, &a);
        generate_ok((mr_generator)k, 30000, 42, &b);
        tu_assert_mesh_equal(&a, &b);
        mr_mesh_free(&a);
        mr_mesh_free(&b);
    }
}

static void test_seed_changes_mesh(void **state)
{
    (void)state;
    mr_mesh a, b;
    generate_ok(MR_GEN_SCAN, 30000, 1, &a);
    generate_ok(MR_GEN_SCAN, 30000, 2, &b);
    assert_int_equal(a.vertex_count, b.vertex_count);
    assert_memory_equal(a.indices, b.indices, a.triangle_count * 3 * sizeof(uint32_t));
    size_t differ = 0;
    for (size_t i = 0; i < 3 * a.vertex_count; i++)
        differ += a.positions[i] != b.positions[i];
    assert_true(differ > 3 * a.vertex_count * 9 / 10);
    mr_mesh_free(&a);
    mr_mesh_free(&b);

    /* The torus's holes move with the seed. */
    generate_ok(MR_GEN_TORUS, 30000, 1, &a);
    generate_ok(MR_GEN_TORUS, 30000, 2, &b);
    assert_true(a.vertex_count != b.vertex_count || a.triangle_count != b.triangle_count ||
                memcmp(a.indices, b.indices, a.triangle_count * 3 * sizeof(uint32_t)) != 0);
    mr_mesh_free(&a);
    mr_mesh_free(&b);

    /* The sphere has nothing random in it. */
    generate_ok(MR_GEN_SPHERE, 30000, 1, &a);
    generate_ok(MR_GEN_SPHERE, 30000, 2, &b);
    tu_assert_mesh_equal(&a, &b);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
}

static void test_thread_count_independent(void **state)
{
    (void)state;
#ifdef _OPENMP
    int saved = omp_get_max_threads();
    for (int k = 0; k < 3; k++) {
        mr_mesh ref;
        omp_set_num_threads(1);
        generate_ok((mr_generator)k, 60000, 9, &ref);
        for (int threads = 2; threads <= 3; threads++) {
            mr_mesh m;
            omp_set_num_threads(threads);
            generate_ok((mr_generator)k, 60000, 9, &m);
            tu_assert_mesh_equal(&ref, &m);
            mr_mesh_free(&m);
        }
        mr_mesh_free(&ref);
    }
    omp_set_num_threads(saved);
#else
    skip();
#endif
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_sphere_counts),
        cmocka_unit_test(test_sphere_topology),
        cmocka_unit_test(test_scan_shape),
        cmocka_unit_test(test_scan_fine_detail),
        cmocka_unit_test(test_torus_counts),
        cmocka_unit_test(test_torus_topology),
        cmocka_unit_test(test_same_seed_same_mesh),
        cmocka_unit_test(test_seed_changes_mesh),
        cmocka_unit_test(test_thread_count_independent),
        cmocka_unit_test(test_stream_pieces),
        cmocka_unit_test(test_generate_file_bytes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
