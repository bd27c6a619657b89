/* Mesh statistics on hand-made meshes, plus the adjacency building blocks. */
#include "testutil.h"
#include "mesh/adjacency.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#define COUNT(a) (sizeof(a) / sizeof *(a))

static mr_stats stats_of(const float *positions, size_t vc, const uint32_t *indices, size_t tc)
{
    mr_stats s;
    mr_error err;
    mr_status st = mr_stats_compute(positions, 0, vc, indices, tc, &s, &err);
    if (st != MR_OK) {
        print_error("mr_stats_compute: %s\n", err.message);
        fail();
    }
    return s;
}

/* ---- hand-made meshes ---------------------------------------------------- */

static const float tetra_pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static const uint32_t tetra_idx[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

static const float octa_pos[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
static const uint32_t octa_idx[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                    2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};

static const float cube_pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                                 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
/* Outward-facing; the first two triangles are the bottom face z = 0. */
static const uint32_t cube_idx[] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                    1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};

static void test_single_triangle(void **state)
{
    (void)state;
    const float pos[] = {0, 0, 0, 2, 0, 0, 0, 2, 0};
    const uint32_t idx[] = {0, 1, 2};
    mr_stats s = stats_of(pos, 3, idx, 1);
    assert_int_equal(s.vertex_count, 3);
    assert_int_equal(s.referenced_vertices, 3);
    assert_int_equal(s.unreferenced_vertices, 0);
    assert_int_equal(s.triangle_count, 1);
    assert_int_equal(s.edge_count, 3);
    assert_int_equal(s.boundary_edges, 3);
    assert_int_equal(s.boundary_loops, 1);
    assert_int_equal(s.nonmanifold_edges, 0);
    assert_int_equal(s.nonmanifold_vertices, 0);
    assert_int_equal(s.components, 1);
    assert_int_equal(s.euler_characteristic, 1);
    assert_false(s.closed);
    assert_true(s.manifold);
    assert_true(s.surface_area == 2.0);
    assert_true(s.bbox_min[0] == 0 && s.bbox_max[0] == 2 && s.bbox_max[1] == 2);
    assert_true(s.bbox_max[2] == 0);
    assert_true(fabs(s.bbox_diagonal - sqrt(8.0)) < 1e-12);
}

static void assert_closed_genus0(mr_stats s)
{
    assert_true(s.closed);
    assert_true(s.manifold);
    assert_int_equal(s.euler_characteristic, 2);
    assert_int_equal(s.boundary_edges, 0);
    assert_int_equal(s.boundary_loops, 0);
    assert_int_equal(s.nonmanifold_edges, 0);
    assert_int_equal(s.nonmanifold_vertices, 0);
    assert_int_equal(s.components, 1);
    assert_int_equal(s.degenerate_triangles, 0);
    assert_int_equal(s.duplicate_triangles, 0);
    assert_int_equal(s.misoriented_edges, 0);
    assert_true(s.oriented);
}

static void test_tetrahedron(void **state)
{
    (void)state;
    mr_stats s = stats_of(tetra_pos, 4, tetra_idx, 4);
    assert_closed_genus0(s);
    assert_int_equal(s.edge_count, 6);
    assert_true(fabs(s.surface_area - (1.5 + sqrt(3.0) / 2)) < 1e-12);
}

static void test_octahedron(void **state)
{
    (void)state;
    mr_stats s = stats_of(octa_pos, 6, octa_idx, 8);
    assert_closed_genus0(s);
    assert_int_equal(s.edge_count, 12);
    assert_true(fabs(s.surface_area - 4 * sqrt(3.0)) < 1e-12);
    assert_true(s.bbox_min[0] == -1 && s.bbox_max[2] == 1);
}

static void test_cube(void **state)
{
    (void)state;
    mr_stats s = stats_of(cube_pos, 8, cube_idx, 12);
    assert_closed_genus0(s);
    assert_int_equal(s.edge_count, 18);
    assert_true(s.surface_area == 6.0);
}

/* One triangle wound the other way: its three edges are misoriented, the
 * mesh still a closed manifold. */
static void test_cube_misoriented(void **state)
{
    (void)state;
    uint32_t idx[36];
    memcpy(idx, cube_idx, sizeof idx);
    const uint32_t x = idx[4];
    idx[4] = idx[5];
    idx[5] = x;
    mr_stats s = stats_of(cube_pos, 8, idx, 12);
    assert_true(s.closed);
    assert_true(s.manifold);
    assert_int_equal(s.misoriented_edges, 3);
    assert_false(s.oriented);
}

static void test_cube_missing_face(void **state)
{
    (void)state;
    mr_stats s = stats_of(cube_pos, 8, cube_idx + 6, 10);
    assert_int_equal(s.boundary_edges, 4);
    assert_int_equal(s.boundary_loops, 1);
    assert_int_equal(s.edge_count, 17);
    assert_int_equal(s.euler_characteristic, 1);
    assert_false(s.closed);
    assert_true(s.manifold);
    assert_int_equal(s.components, 1);
}

/* An open cylinder of n quads: two boundary loops, Euler 0. */
static void test_open_cylinder(void **state)
{
    (void)state;
    enum { N = 8 };
    float pos[2 * N * 3];
    uint32_t idx[2 * N * 3];
    for (int i = 0; i < N; i++) {
        double a = 2 * 3.14159265358979323846 * i / N;
        for (int r = 0; r < 2; r++) {
            pos[3 * (r * N + i) + 0] = (float)cos(a);
            pos[3 * (r * N + i) + 1] = (float)sin(a);
            pos[3 * (r * N + i) + 2] = (float)r;
        }
        uint32_t a0 = (uint32_t)i, a1 = (uint32_t)((i + 1) % N), b0 = a0 + N, b1 = a1 + N;
        uint32_t q[6] = {a0, a1, b1, a0, b1, b0};
        memcpy(idx + 6 * i, q, sizeof q);
    }
    mr_stats s = stats_of(pos, 2 * N, idx, 2 * N);
    assert_int_equal(s.boundary_loops, 2);
    assert_int_equal(s.boundary_edges, 2 * N);
    assert_int_equal(s.edge_count, 4 * N);
    assert_int_equal(s.euler_characteristic, 0);
    assert_true(s.manifold);
    assert_false(s.closed);
    assert_int_equal(s.components, 1);

    /* Flipping one triangle's orientation changes nothing topological. */
    uint32_t t = idx[1];
    idx[1] = idx[2];
    idx[2] = t;
    mr_stats f = stats_of(pos, 2 * N, idx, 2 * N);
    assert_int_equal(f.boundary_loops, 2);
    assert_int_equal(f.euler_characteristic, 0);
    assert_true(f.manifold);
}

/* Three triangles on one edge ("book with three pages"). */
static void test_nonmanifold_edge(void **state)
{
    (void)state;
    const float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
    const uint32_t idx[] = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    mr_stats s = stats_of(pos, 5, idx, 3);
    assert_int_equal(s.nonmanifold_edges, 1);
    assert_int_equal(s.nonmanifold_vertices, 2);
    assert_int_equal(s.edge_count, 7);
    assert_int_equal(s.boundary_edges, 6);
    /* Each page's boundary is a chain ending at the shared edge. */
    assert_int_equal(s.boundary_loops, 3);
    assert_false(s.manifold);
    assert_false(s.closed);
    assert_int_equal(s.components, 1);
    assert_int_equal(s.euler_characteristic, 5 - 7 + 3);
}

/* Two triangles that share only a vertex. */
static void test_bowtie(void **state)
{
    (void)state;
    const float pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0};
    const uint32_t idx[] = {0, 1, 2, 0, 3, 4};
    mr_stats s = stats_of(pos, 5, idx, 2);
    assert_int_equal(s.nonmanifold_vertices, 1);
    assert_int_equal(s.nonmanifold_edges, 0);
    assert_int_equal(s.components, 1); /* connected through the shared vertex */
    assert_int_equal(s.boundary_loops, 2);
    assert_int_equal(s.boundary_edges, 6);
    assert_false(s.manifold);
    assert_false(s.closed);
    assert_int_equal(s.euler_characteristic, 5 - 6 + 2);
}

/* Two closed tetrahedra touching at one tip: closed, but not manifold. */
static void test_touching_tetrahedra(void **state)
{
    (void)state;
    float pos[7 * 3];
    uint32_t idx[24];
    memcpy(pos, tetra_pos, sizeof tetra_pos);
    for (int i = 1; i < 4; i++)
        for (int k = 0; k < 3; k++)
            pos[3 * (3 + i) + k] = -tetra_pos[3 * i + k];
    memcpy(idx, tetra_idx, sizeof tetra_idx);
    const uint32_t map[4] = {0, 4, 5, 6};
    for (int c = 0; c < 12; c++)
        idx[12 + c] = map[tetra_idx[c]];
    mr_stats s = stats_of(pos, 7, idx, 8);
    assert_true(s.closed);
    assert_false(s.manifold);
    assert_int_equal(s.nonmanifold_vertices, 1);
    assert_int_equal(s.nonmanifold_edges, 0);
    assert_int_equal(s.components, 1);
    assert_int_equal(s.euler_characteristic, 7 - 12 + 8);
}

static void test_two_components(void **state)
{
    (void)state;
    float pos[8 * 3];
    uint32_t idx[24];
    for (int i = 0; i < 12; i++) {
        pos[i] = tetra_pos[i];
        pos[12 + i] = tetra_pos[i] + 5;
        idx[i] = tetra_idx[i];
        idx[12 + i] = tetra_idx[i] + 4;
    }
    mr_stats s = stats_of(pos, 8, idx, 8);
    assert_int_equal(s.components, 2);
    assert_int_equal(s.euler_characteristic, 4);
    assert_true(s.closed);
    assert_true(s.manifold);
    assert_true(s.bbox_max[0] == 6 && s.bbox_min[2] == 0);
}

static void test_duplicates(void **state)
{
    (void)state;
    uint32_t idx[18];
    memcpy(idx, tetra_idx, sizeof tetra_idx);
    const uint32_t extra[] = {2, 1, 0, /* face 0 reversed */
                              1, 3, 0}; /* face 1 rotated, same orientation */
    memcpy(idx + 12, extra, sizeof extra);
    mr_stats s = stats_of(tetra_pos, 4, idx, 6);
    assert_int_equal(s.duplicate_triangles, 2);
    assert_int_equal(s.degenerate_triangles, 0);
    assert_int_equal(s.edge_count, 6);
    assert_int_equal(s.nonmanifold_edges, 5); /* every edge of faces 0 and 1 */
    assert_false(s.manifold);
    assert_false(s.closed);

    /* Many copies on one edge: more than the short-run path handles. */
    uint32_t many[3 * 40];
    for (int i = 0; i < 40; i++) {
        uint32_t t[3] = {0, 1, (uint32_t)(2 + i % 2)};
        if (i % 3 == 0) {
            t[0] = 1;
            t[1] = 0;
        }
        memcpy(many + 3 * i, t, sizeof t);
    }
    s = stats_of(tetra_pos, 4, many, 40);
    assert_int_equal(s.duplicate_triangles, 38);
    assert_int_equal(s.nonmanifold_edges, 5);
}

static void test_degenerate(void **state)
{
    (void)state;
    const float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5};
    const uint32_t idx[] = {0, 1, 2, 0, 0, 1, 1, 2, 2, 3, 3, 3};
    mr_stats s = stats_of(pos, 4, idx, 4);
    assert_int_equal(s.degenerate_triangles, 3);
    /* Degenerate triangles have no edges; they still count as faces and
     * reference their vertices. */
    assert_int_equal(s.edge_count, 3);
    assert_int_equal(s.boundary_edges, 3);
    assert_int_equal(s.boundary_loops, 1);
    assert_int_equal(s.referenced_vertices, 4);
    assert_int_equal(s.components, 2);
    assert_int_equal(s.euler_characteristic, 4 - 3 + 4);
    assert_true(s.manifold);
    assert_true(s.surface_area == 0.5);

    /* Only degenerate triangles: no edge, so neither closed nor manifold. */
    s = stats_of(pos, 4, idx + 3, 3);
    assert_int_equal(s.edge_count, 0);
    assert_false(s.closed);
    assert_false(s.manifold);
}

static void test_unreferenced(void **state)
{
    (void)state;
    float pos[6 * 3];
    memcpy(pos, tetra_pos, sizeof tetra_pos);
    const float extra[] = {9, 9, 9, -9, 0, 0};
    memcpy(pos + 12, extra, sizeof extra);
    mr_stats s = stats_of(pos, 6, tetra_idx, 4);
    assert_int_equal(s.vertex_count, 6);
    assert_int_equal(s.referenced_vertices, 4);
    assert_int_equal(s.unreferenced_vertices, 2);
    assert_int_equal(s.euler_characteristic, 2);
    assert_int_equal(s.components, 1);
    assert_true(s.closed);
    /* The box covers every vertex. */
    assert_true(s.bbox_min[0] == -9 && s.bbox_max[0] == 9 && s.bbox_max[2] == 9);
}

static void test_empty_and_point_cloud(void **state)
{
    (void)state;
    mr_stats s;
    memset(&s, 0xab, sizeof s);
    assert_int_equal(mr_stats_compute(NULL, 0, 0, NULL, 0, &s, NULL), MR_OK);
    assert_int_equal(s.vertex_count, 0);
    assert_int_equal(s.edge_count, 0);
    assert_int_equal(s.components, 0);
    assert_int_equal(s.euler_characteristic, 0);
    assert_false(s.closed);
    assert_false(s.manifold);
    assert_true(s.bbox_diagonal == 0 && s.bbox_min[0] == 0 && s.bbox_max[2] == 0);
    assert_true(s.surface_area == 0);

    s = stats_of(tetra_pos, 4, NULL, 0);
    assert_int_equal(s.vertex_count, 4);
    assert_int_equal(s.unreferenced_vertices, 4);
    assert_int_equal(s.referenced_vertices, 0);
    assert_int_equal(s.components, 0);
    assert_true(s.bbox_max[0] == 1 && s.bbox_max[2] == 1);
}

static void test_stride(void **state)
{
    (void)state;
    /* Positions interleaved with normals: 6 floats per vertex. */
    float interleaved[4 * 6];
    for (int v = 0; v < 4; v++) {
        for (int k = 0; k < 3; k++) {
            interleaved[6 * v + k] = tetra_pos[3 * v + k];
            interleaved[6 * v + 3 + k] = 1000.0f; /* must not be read as positions */
        }
    }
    mr_stats packed = stats_of(tetra_pos, 4, tetra_idx, 4), s;
    assert_int_equal(mr_stats_compute(interleaved, 6 * sizeof(float), 4, tetra_idx, 4, &s,
                                      NULL),
                     MR_OK);
    assert_memory_equal(&packed.bbox_min, &s.bbox_min, sizeof s.bbox_min);
    assert_memory_equal(&packed.bbox_max, &s.bbox_max, sizeof s.bbox_max);
    assert_true(packed.surface_area == s.surface_area);
    assert_int_equal(packed.euler_characteristic, s.euler_characteristic);
    /* An explicit tight stride is the same as 0. */
    assert_int_equal(mr_stats_compute(tetra_pos, 12, 4, tetra_idx, 4, &s, NULL), MR_OK);
    assert_true(packed.surface_area == s.surface_area);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    mr_stats s;
    mr_error err;
    assert_int_equal(mr_stats_compute(tetra_pos, 0, 4, tetra_idx, 4, NULL, &err),
                     MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_stats_compute(NULL, 0, 4, tetra_idx, 4, &s, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "positions");
    assert_int_equal(mr_stats_compute(tetra_pos, 0, 4, NULL, 4, &s, &err),
                     MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "indices");
    assert_int_equal(mr_stats_compute(tetra_pos, 8, 4, tetra_idx, 4, &s, &err),
                     MR_ERR_INVALID_ARGUMENT);
    const uint32_t bad[] = {0, 1, 2, 0, 1, 4, 0, 1, 7};
    assert_int_equal(mr_stats_compute(tetra_pos, 0, 4, bad, 3, &s, &err),
                     MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(err.status, MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "triangle 1");
    tu_assert_contains(err.message, "4");
    /* Vertices but no triangles, with no index array: fine. */
    assert_int_equal(mr_stats_compute(tetra_pos, 0, 4, NULL, 0, &s, &err), MR_OK);
}

/* ---- larger procedural meshes --------------------------------------------- */

/* An n x n vertex grid with a wavy height field, so the areas round. */
static void make_grid(size_t n, float **pos, uint32_t **idx, size_t *vc, size_t *tc)
{
    *vc = n * n;
    *tc = 2 * (n - 1) * (n - 1);
    *pos = malloc(*vc * 3 * sizeof(float));
    *idx = malloc(*tc * 3 * sizeof(uint32_t));
    assert_non_null(*pos);
    assert_non_null(*idx);
    for (size_t y = 0; y < n; y++) {
        for (size_t x = 0; x < n; x++) {
            float *p = *pos + 3 * (y * n + x);
            p[0] = (float)x;
            p[1] = (float)y;
            p[2] = (float)(0.3 * sin(0.37 * (double)x) * cos(0.21 * (double)y));
        }
    }
    uint32_t *t = *idx;
    for (size_t y = 0; y + 1 < n; y++) {
        for (size_t x = 0; x + 1 < n; x++) {
            uint32_t a = (uint32_t)(y * n + x), b = a + 1, c = a + (uint32_t)n, d = c + 1;
            uint32_t q[6] = {a, b, d, a, d, c};
            memcpy(t, q, sizeof q);
            t += 6;
        }
    }
}

static void assert_stats_identical(const mr_stats *a, const mr_stats *b)
{
    assert_int_equal(a->vertex_count, b->vertex_count);
    assert_int_equal(a->referenced_vertices, b->referenced_vertices);
    assert_int_equal(a->unreferenced_vertices, b->unreferenced_vertices);
    assert_int_equal(a->triangle_count, b->triangle_count);
    assert_int_equal(a->degenerate_triangles, b->degenerate_triangles);
    assert_int_equal(a->duplicate_triangles, b->duplicate_triangles);
    assert_int_equal(a->edge_count, b->edge_count);
    assert_int_equal(a->boundary_edges, b->boundary_edges);
    assert_int_equal(a->nonmanifold_edges, b->nonmanifold_edges);
    assert_int_equal(a->nonmanifold_vertices, b->nonmanifold_vertices);
    assert_int_equal(a->boundary_loops, b->boundary_loops);
    assert_int_equal(a->components, b->components);
    assert_int_equal(a->euler_characteristic, b->euler_characteristic);
    assert_int_equal(a->closed, b->closed);
    assert_int_equal(a->manifold, b->manifold);
    assert_memory_equal(a->bbox_min, b->bbox_min, sizeof a->bbox_min);
    assert_memory_equal(a->bbox_max, b->bbox_max, sizeof a->bbox_max);
    assert_memory_equal(&a->bbox_diagonal, &b->bbox_diagonal, sizeof(double));
    assert_memory_equal(&a->surface_area, &b->surface_area, sizeof(double));
}

static void test_grid_and_thread_determinism(void **state)
{
    (void)state;
    const size_t n = 300;
    float *pos;
    uint32_t *idx;
    size_t vc, tc;
    make_grid(n, &pos, &idx, &vc, &tc);
    /* Punch two holes (drop the triangles of two cells) and add a flap on a
     * third cell's diagonal to get a non-manifold edge. */
    const size_t holes[2] = {(50 * (n - 1) + 50) * 2, (200 * (n - 1) + 100) * 2};
    for (int h = 0; h < 2; h++)
        for (size_t k = 1; k < 6; k++)
            idx[3 * holes[h] + k] = idx[3 * holes[h]]; /* two degenerate triangles */
    uint32_t *idx2 = realloc(idx, (tc + 1) * 3 * sizeof *idx2);
    assert_non_null(idx2);
    idx = idx2;
    const size_t flap_cell = (120 * (n - 1) + 7) * 2;
    idx[3 * tc + 0] = idx[3 * flap_cell + 0];
    idx[3 * tc + 1] = idx[3 * flap_cell + 2];
    idx[3 * tc + 2] = (uint32_t)(250 * n + 250); /* a far interior vertex */
    tc++;

    mr_stats one, two;
#ifdef _OPENMP
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
#endif
    one = stats_of(pos, vc, idx, tc);
#ifdef _OPENMP
    omp_set_num_threads(2);
#endif
    two = stats_of(pos, vc, idx, tc);
#ifdef _OPENMP
    omp_set_num_threads(3);
    mr_stats three = stats_of(pos, vc, idx, tc);
    assert_stats_identical(&one, &three);
    omp_set_num_threads(saved);
#endif
    assert_stats_identical(&one, &two);

    const size_t grid_edges = 2 * n * (n - 1) + (n - 1) * (n - 1);
    assert_int_equal(one.vertex_count, n * n);
    assert_int_equal(one.degenerate_triangles, 4);
    assert_int_equal(one.nonmanifold_edges, 1);
    /* the flap's diagonal ends, and its far tip (a second fan there) */
    assert_int_equal(one.nonmanifold_vertices, 3);
    assert_int_equal(one.referenced_vertices, n * n);
    assert_int_equal(one.edge_count, grid_edges - 2 + 2); /* 2 diagonals out, 2 flap edges in */
    assert_int_equal(one.boundary_loops, 1 + 2 + 1); /* rim, two holes, the flap */
    assert_int_equal(one.components, 1);
    assert_false(one.manifold);
    assert_false(one.closed);

    /* The clean grid: a disc. */
    free(idx);
    free(pos);
    make_grid(n, &pos, &idx, &vc, &tc);
    mr_stats g = stats_of(pos, vc, idx, tc);
    assert_int_equal(g.edge_count, grid_edges);
    assert_int_equal(g.boundary_edges, 4 * (n - 1));
    assert_int_equal(g.boundary_loops, 1);
    assert_int_equal(g.euler_characteristic, 1);
    assert_true(g.manifold);
    assert_int_equal(g.nonmanifold_vertices, 0);
    assert_true(g.surface_area > (double)((n - 1) * (n - 1)));
    free(idx);
    free(pos);
}

/* ---- shared test meshes ---------------------------------------------------- */

static int read_shared(const char *file, mr_mesh *mesh)
{
    const char *path = tu_shared_data(file);
    if (!path)
        return 0;
    mr_mesh_init(mesh);
    mr_error err;
    mr_status st = mr_mesh_read(path, NULL, mesh, &err);
    if (st == MR_ERR_UNSUPPORTED)
        return 0; /* the reader is not there yet */
    if (st != MR_OK) {
        print_error("%s\n", err.message);
        fail();
    }
    return 1;
}

static void test_bunny(void **state)
{
    (void)state;
    mr_mesh m;
    if (!read_shared("stanford-bunny.obj", &m))
        skip();
    mr_stats s;
    assert_int_equal(mr_stats_compute(m.positions, 0, m.vertex_count, m.indices,
                                      m.triangle_count, &s, NULL),
                     MR_OK);
    assert_int_equal(s.referenced_vertices, 34834);
    assert_int_equal(s.unreferenced_vertices, 1113);
    assert_true(s.boundary_loops > 0);
    assert_false(s.closed);
    mr_mesh_free(&m);
}

static void test_armadillo(void **state)
{
    (void)state;
    mr_mesh m;
    if (!read_shared("armadillo.obj", &m))
        skip();
    mr_stats s;
    assert_int_equal(mr_stats_compute(m.positions, 0, m.vertex_count, m.indices,
                                      m.triangle_count, &s, NULL),
                     MR_OK);
    assert_true(s.closed);
    assert_true(s.manifold);
    assert_int_equal(s.euler_characteristic, 2);
    assert_int_equal(s.components, 1);
    mr_mesh_free(&m);
}

/* ---- adjacency building blocks --------------------------------------------- */

static uint64_t lcg(uint64_t *x)
{
    *x = *x * UINT64_C(6364136223846793005) + UINT64_C(1442695040888963407);
    return *x >> 11;
}

static void set_threads(int n)
{
#ifdef _OPENMP
    omp_set_num_threads(n);
#else
    (void)n;
#endif
}

static int max_threads(void)
{
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

static void test_radix_sort(void **state)
{
    (void)state;
    const size_t sizes[] = {0, 1, 2, 17, 1000, 200000};
    const unsigned bits[] = {64, 40, 33, 12, 1};
    uint64_t seed = 7;
    const int saved = max_threads();
    for (size_t si = 0; si < COUNT(sizes); si++) {
        /* uneven slices for several threads, too */
        set_threads(1 + (int)(si % 3));
        for (size_t bi = 0; bi < COUNT(bits); bi++) {
            size_t n = sizes[si];
            uint64_t mask = bits[bi] == 64 ? UINT64_MAX : (UINT64_C(1) << bits[bi]) - 1;
            uint64_t *keys = malloc((n + 1) * sizeof *keys);
            uint32_t *vals = malloc((n + 1) * sizeof *vals);
            for (size_t i = 0; i < n; i++) {
                /* few distinct keys, so stability is tested */
                keys[i] = (lcg(&seed) | (lcg(&seed) << 53)) & mask & ~UINT64_C(0xff0);
                vals[i] = (uint32_t)i;
            }
            /* the same keys, cut to 32 bits, through the 32-bit sort */
            uint32_t *k32 = malloc((n + 1) * sizeof *k32);
            uint32_t *v32 = malloc((n + 1) * sizeof *v32);
            for (size_t i = 0; i < n; i++) {
                k32[i] = (uint32_t)keys[i];
                v32[i] = (uint32_t)i;
            }
            /* 0 threads: the default team; else the slice count asked */
            const int threads = (int)(bi % 3);
            assert_int_equal(mr_radix_sort_u64(keys, vals, n, bits[bi], threads, NULL), MR_OK);
            assert_int_equal(
                mr_radix_sort_u32(k32, v32, n, bits[bi] < 32 ? bits[bi] : 32, threads, NULL),
                MR_OK);
            for (size_t i = 1; i < n; i++) {
                assert_true(keys[i - 1] <= keys[i]);
                if (keys[i - 1] == keys[i])
                    assert_true(vals[i - 1] < vals[i]);
                assert_true(k32[i - 1] <= k32[i]);
                if (k32[i - 1] == k32[i])
                    assert_true(v32[i - 1] < v32[i]);
            }
            free(keys);
            free(vals);
            free(k32);
            free(v32);
        }
    }
    set_threads(saved);
}

static void test_vertex_triangles(void **state)
{
    (void)state;
    /* Cube without its bottom, a degenerate triangle and an isolated vertex 8. */
    uint32_t idx[11 * 3];
    memcpy(idx, cube_idx + 6, 10 * 3 * sizeof *idx);
    const uint32_t deg[3] = {4, 4, 6};
    memcpy(idx + 30, deg, sizeof deg);
    mr_vertex_triangles vt;
    assert_int_equal(mr_vertex_triangles_build(&vt, idx, 11, 9, NULL), MR_OK);
    assert_int_equal(vt.vertex_count, 9);
    assert_int_equal(vt.offsets[0], 0);
    assert_int_equal(vt.offsets[9], 10 * 3 + 2);
    assert_int_equal(vt.offsets[9] - vt.offsets[8], 0);
    for (uint32_t v = 0; v < 9; v++) {
        for (uint32_t i = vt.offsets[v]; i < vt.offsets[v + 1]; i++) {
            uint32_t t = vt.triangles[i];
            assert_true(idx[3 * t] == v || idx[3 * t + 1] == v || idx[3 * t + 2] == v);
            if (i > vt.offsets[v])
                assert_true(vt.triangles[i - 1] < t);
        }
    }
    /* vertex 4: cube triangles 2, 3, 4, 5, 9 (-> 0, 1, 2, 3, 7 here) and
     * the degenerate one, listed once */
    assert_int_equal(vt.offsets[5] - vt.offsets[4], 6);
    assert_int_equal(vt.triangles[vt.offsets[5] - 1], 10);
    mr_vertex_triangles_free(&vt);
    mr_vertex_triangles_free(&vt); /* freeing twice is harmless */

    mr_edge_table et;
    assert_int_equal(mr_edge_table_build(&et, idx, 11, 9, NULL), MR_OK);
    assert_int_equal(et.count, 30);
    assert_int_equal(et.vertex_count, 9);
    assert_int_equal(et.offsets[9], 30);
    size_t runs = 0, boundary = 0;
    for (uint32_t lo = 0; lo < 9; lo++) {
        for (size_t i = et.offsets[lo], j; i < et.offsets[lo + 1]; i = j) {
            j = mr_edge_run_end(&et, lo, i);
            runs++;
            boundary += j - i == 1;
            uint32_t hi = mr_edge_hi(et.entries[i]);
            assert_true(lo < hi);
            for (size_t e = i; e < j; e++) {
                /* each entry is a half-edge lo-hi, in corner order */
                uint32_t c = mr_edge_corner(et.entries[e]);
                uint32_t a = idx[c], b = idx[c % 3 == 2 ? c - 2 : c + 1];
                assert_true((a == lo && b == hi) || (a == hi && b == lo));
                if (e > i)
                    assert_true(mr_edge_corner(et.entries[e - 1]) < c);
            }
        }
    }
    assert_int_equal(runs, 17);
    assert_int_equal(boundary, 4);
    mr_edge_table_free(&et);
    assert_int_equal(mr_index_bits(0), 1);
    assert_int_equal(mr_index_bits(2), 1);
    assert_int_equal(mr_index_bits(3), 2);
    assert_int_equal(mr_index_bits(256), 8);
    assert_int_equal(mr_index_bits(257), 9);
}

/* The parallel fills (atomic placement, then sorted buckets) give the same
 * tables as the sequential ones. */
static void test_adjacency_thread_determinism(void **state)
{
    (void)state;
    float *pos;
    uint32_t *idx;
    size_t vc, tc;
    make_grid(220, &pos, &idx, &vc, &tc);
    /* Shuffle the triangles so that the buckets fill out of order, and make
     * a few degenerate. */
    uint64_t seed = 3;
    for (size_t t = tc - 1; t > 0; t--) {
        size_t j = (size_t)(lcg(&seed) % (t + 1));
        uint32_t tmp[3];
        memcpy(tmp, idx + 3 * t, sizeof tmp);
        memcpy(idx + 3 * t, idx + 3 * j, sizeof tmp);
        memcpy(idx + 3 * j, tmp, sizeof tmp);
    }
    for (size_t t = 0; t < tc; t += 1000)
        idx[3 * t + 1] = idx[3 * t];
    const int saved = max_threads();
    mr_vertex_triangles vt[2];
    mr_edge_table et[2];
    for (int r = 0; r < 2; r++) {
        set_threads(r ? 2 : 1);
        assert_int_equal(mr_vertex_triangles_build(&vt[r], idx, tc, vc, NULL), MR_OK);
        assert_int_equal(mr_edge_table_build(&et[r], idx, tc, vc, NULL), MR_OK);
    }
    set_threads(saved);
    assert_memory_equal(vt[0].offsets, vt[1].offsets, (vc + 1) * sizeof *vt[0].offsets);
    assert_memory_equal(vt[0].triangles, vt[1].triangles,
                        vt[0].offsets[vc] * sizeof *vt[0].triangles);
    assert_int_equal(et[0].count, et[1].count);
    assert_memory_equal(et[0].offsets, et[1].offsets, (vc + 1) * sizeof *et[0].offsets);
    assert_memory_equal(et[0].entries, et[1].entries, et[0].count * sizeof *et[0].entries);
    for (size_t v = 0; v < vc; v++)
        for (uint32_t i = vt[0].offsets[v] + 1; i < vt[0].offsets[v + 1]; i++)
            assert_true(vt[0].triangles[i - 1] < vt[0].triangles[i]);
    for (int r = 0; r < 2; r++) {
        mr_vertex_triangles_free(&vt[r]);
        mr_edge_table_free(&et[r]);
    }
    free(pos);
    free(idx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_single_triangle),
        cmocka_unit_test(test_tetrahedron),
        cmocka_unit_test(test_octahedron),
        cmocka_unit_test(test_cube),
        cmocka_unit_test(test_cube_misoriented),
        cmocka_unit_test(test_cube_missing_face),
        cmocka_unit_test(test_open_cylinder),
        cmocka_unit_test(test_nonmanifold_edge),
        cmocka_unit_test(test_bowtie),
        cmocka_unit_test(test_touching_tetrahedra),
        cmocka_unit_test(test_two_components),
        cmocka_unit_test(test_duplicates),
        cmocka_unit_test(test_degenerate),
        cmocka_unit_test(test_unreferenced),
        cmocka_unit_test(test_empty_and_point_cloud),
        cmocka_unit_test(test_stride),
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_grid_and_thread_determinism),
        cmocka_unit_test(test_bunny),
        cmocka_unit_test(test_armadillo),
        cmocka_unit_test(test_radix_sort),
        cmocka_unit_test(test_vertex_triangles),
        cmocka_unit_test(test_adjacency_thread_determinism),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
