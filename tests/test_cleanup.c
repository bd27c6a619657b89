/* Cleanup passes: unreferenced vertices, exact welding, degenerate and
 * duplicate triangles. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#define COUNT_OF(a) (sizeof(a) / sizeof *(a))

static const float cube_pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                                 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
/* Outward-facing, two triangles per face. */
static const uint32_t cube_idx[] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                    1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};

/* Attribute values that identify their vertex: v = vertex id. */
static void fill_attributes(mr_mesh *m)
{
    for (size_t v = 0; v < m->vertex_count; v++) {
        float f = (float)v;
        if (m->normals) {
            m->normals[3 * v] = f;
            m->normals[3 * v + 1] = f + 0.25f;
            m->normals[3 * v + 2] = -f;
        }
        if (m->texcoords) {
            m->texcoords[2 * v] = f * 0.5f;
            m->texcoords[2 * v + 1] = 1 - f;
        }
        if (m->colors)
            for (int k = 0; k < 4; k++)
                m->colors[4 * v + (size_t)k] = f + (float)k;
    }
}

static void make_mesh(mr_mesh *m, const float *pos, size_t vc, const uint32_t *idx, size_t tc,
                      unsigned attrs)
{
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, vc, tc, attrs, NULL), MR_OK);
    if (vc)
        memcpy(m->positions, pos, vc * 3 * sizeof(float));
    if (tc)
        memcpy(m->indices, idx, tc * 3 * sizeof(uint32_t));
    fill_attributes(m);
}

static mr_stats mesh_stats(const mr_mesh *m)
{
    mr_stats s;
    assert_int_equal(mr_stats_compute(m->positions, 0, m->vertex_count, m->indices,
                                      m->triangle_count, &s, NULL),
                     MR_OK);
    return s;
}

/* ---- unreferenced vertices ------------------------------------------------ */

static void test_remove_unreferenced(void **state)
{
    (void)state;
    /* Seven vertices; the two triangles use 1, 3, 4 and 6. */
    float pos[7 * 3];
    for (int i = 0; i < 21; i++)
        pos[i] = (float)i;
    const uint32_t idx[] = {1, 3, 4, 4, 3, 6};
    mr_mesh m;
    make_mesh(&m, pos, 7, idx, 2, MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS);
    mr_mesh orig;
    mr_mesh_init(&orig);
    assert_int_equal(mr_mesh_copy(&orig, &m, NULL), MR_OK);

    size_t removed = 99;
    assert_int_equal(mr_mesh_remove_unreferenced(&m, &removed, NULL), MR_OK);
    assert_int_equal(removed, 3);
    assert_int_equal(m.vertex_count, 4);
    assert_int_equal(m.triangle_count, 2);
    const uint32_t kept[4] = {1, 3, 4, 6};
    for (size_t v = 0; v < 4; v++) {
        size_t o = kept[v];
        assert_memory_equal(m.positions + 3 * v, orig.positions + 3 * o, 3 * sizeof(float));
        assert_memory_equal(m.normals + 3 * v, orig.normals + 3 * o, 3 * sizeof(float));
        assert_memory_equal(m.texcoords + 2 * v, orig.texcoords + 2 * o, 2 * sizeof(float));
        assert_memory_equal(m.colors + 4 * v, orig.colors + 4 * o, 4 * sizeof(float));
    }
    const uint32_t expect[] = {0, 1, 2, 2, 1, 3};
    assert_memory_equal(m.indices, expect, sizeof expect);

    /* Nothing left to remove: unchanged, removed may be NULL. */
    mr_mesh again;
    mr_mesh_init(&again);
    assert_int_equal(mr_mesh_copy(&again, &m, NULL), MR_OK);
    assert_int_equal(mr_mesh_remove_unreferenced(&m, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    assert_int_equal(mr_mesh_remove_unreferenced(&m, NULL, NULL), MR_OK);
    tu_assert_mesh_equal(&m, &again);
    mr_mesh_free(&again);
    mr_mesh_free(&orig);
    mr_mesh_free(&m);
}

static void test_remove_unreferenced_point_cloud_and_empty(void **state)
{
    (void)state;
    mr_mesh m, copy;
    make_mesh(&m, cube_pos, 8, NULL, 0, MR_ATTR_NORMALS);
    mr_mesh_init(&copy);
    assert_int_equal(mr_mesh_copy(&copy, &m, NULL), MR_OK);
    size_t removed = 99;
    assert_int_equal(mr_mesh_remove_unreferenced(&m, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    tu_assert_mesh_equal(&m, &copy);
    mr_mesh_free(&m);
    mr_mesh_free(&copy);

    mr_mesh_init(&m);
    assert_int_equal(mr_mesh_remove_unreferenced(&m, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    assert_int_equal(mr_mesh_weld_exact(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    assert_int_equal(mr_mesh_remove_degenerate(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    assert_int_equal(m.vertex_count, 0);
}

/* ---- welding ---------------------------------------------------------------- */

static uint32_t word(float f)
{
    uint32_t w;
    memcpy(&w, &f, sizeof w);
    return w == 0x80000000u ? 0 : w;
}

static int same_floats(const float *a, const float *b, int n)
{
    for (int i = 0; i < n; i++)
        if (word(a[i]) != word(b[i]))
            return 0;
    return 1;
}

static int same_vertex(const mr_mesh *m, size_t a, size_t b, int attrs)
{
    if (!same_floats(m->positions + 3 * a, m->positions + 3 * b, 3))
        return 0;
    if (!attrs)
        return 1;
    return (!m->normals || same_floats(m->normals + 3 * a, m->normals + 3 * b, 3)) &&
           (!m->texcoords || same_floats(m->texcoords + 2 * a, m->texcoords + 2 * b, 2)) &&
           (!m->colors || same_floats(m->colors + 4 * a, m->colors + 4 * b, 4));
}

/* The obvious quadratic weld, as the reference. */
static void reference_weld(const mr_mesh *in, int attrs, mr_mesh *out)
{
    size_t vc = in->vertex_count;
    uint32_t *rep = malloc((vc + 1) * sizeof *rep);
    uint32_t *new_id = malloc((vc + 1) * sizeof *new_id);
    size_t kept = 0;
    for (size_t v = 0; v < vc; v++) {
        rep[v] = (uint32_t)v;
        for (size_t u = 0; u < v; u++) {
            if (rep[u] == u && same_vertex(in, u, v, attrs)) {
                rep[v] = (uint32_t)u;
                break;
            }
        }
        if (rep[v] == v)
            new_id[v] = (uint32_t)kept++;
    }
    mr_mesh_init(out);
    assert_int_equal(mr_mesh_alloc(out, kept, in->triangle_count, mr_mesh_attributes(in), NULL),
                     MR_OK);
    for (size_t v = 0; v < vc; v++) {
        if (rep[v] != v)
            continue;
        size_t j = new_id[v];
        memcpy(out->positions + 3 * j, in->positions + 3 * v, 3 * sizeof(float));
        if (in->normals)
            memcpy(out->normals + 3 * j, in->normals + 3 * v, 3 * sizeof(float));
        if (in->texcoords)
            memcpy(out->texcoords + 2 * j, in->texcoords + 2 * v, 2 * sizeof(float));
        if (in->colors)
            memcpy(out->colors + 4 * j, in->colors + 4 * v, 4 * sizeof(float));
    }
    for (size_t c = 0; c < 3 * in->triangle_count; c++)
        out->indices[c] = new_id[rep[in->indices[c]]];
    free(rep);
    free(new_id);
}

/* The cube with every face on its own four vertices and a flat normal per
 * face, as a reader makes it from a file with hard edges. */
static void make_split_cube(mr_mesh *m)
{
    float pos[24 * 3];
    uint32_t idx[36];
    size_t vc = 0;
    for (int f = 0; f < 6; f++) {
        uint32_t local[8], nlocal = 0;
        for (int c = 0; c < 6; c++) {
            uint32_t v = cube_idx[6 * f + c], k = 0;
            while (k < nlocal && local[k] != v)
                k++;
            if (k == nlocal) {
                local[nlocal++] = v;
                memcpy(pos + 3 * (vc + k), cube_pos + 3 * v, 3 * sizeof(float));
            }
            idx[6 * f + c] = (uint32_t)(vc + k);
        }
        vc += nlocal;
    }
    assert_int_equal(vc, 24);
    make_mesh(m, pos, 24, idx, 12, MR_ATTR_NORMALS);
    for (size_t v = 0; v < 24; v++) /* one normal per face */
        for (int k = 0; k < 3; k++)
            m->normals[3 * v + (size_t)k] = (float)(v / 4) + (float)k;
}

static void test_weld_split_cube(void **state)
{
    (void)state;
    mr_mesh m, ref;
    make_split_cube(&m);
    /* The split is in the attributes only: the surface is closed. */
    mr_stats split = mesh_stats(&m);
    assert_true(split.closed);
    assert_true(split.manifold);
    assert_int_equal(split.surface_vertices, 8);
    assert_int_equal(split.split_vertices, 16);
    assert_int_equal(split.referenced_vertices, 24);
    assert_int_equal(split.euler_characteristic, 2);
    reference_weld(&m, 0, &ref);
    size_t removed = 0;
    assert_int_equal(mr_mesh_weld_exact(&m, 0, &removed, NULL), MR_OK);
    assert_int_equal(removed, 16);
    assert_int_equal(m.vertex_count, 8);
    tu_assert_mesh_equal(&m, &ref);
    assert_non_null(m.normals); /* the first vertex's normal is kept */
    mr_stats s = mesh_stats(&m);
    assert_true(s.closed);
    assert_true(s.manifold);
    assert_int_equal(s.euler_characteristic, 2);
    mr_mesh_free(&ref);
    mr_mesh_free(&m);

    /* The normals differ across every seam: nothing welds. */
    make_split_cube(&m);
    mr_mesh copy;
    mr_mesh_init(&copy);
    assert_int_equal(mr_mesh_copy(&copy, &m, NULL), MR_OK);
    assert_int_equal(mr_mesh_weld_exact(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    tu_assert_mesh_equal(&m, &copy);
    mr_mesh_free(&copy);
    mr_mesh_free(&m);
}

/* A strip of quads split down the middle into two halves that each have
 * their own copy of the seam vertices; `uv_seam` gives the copies different
 * texture coordinates. */
static void make_split_strip(mr_mesh *m, int uv_seam)
{
    enum { W = 4, H = 5 }; /* vertices per half-row, rows */
    float pos[2 * W * H * 3];
    uint32_t idx[2 * (W - 1) * (H - 1) * 6];
    size_t t = 0;
    for (int half = 0; half < 2; half++) {
        for (int y = 0; y < H; y++) {
            for (int x = 0; x < W; x++) {
                float *p = pos + 3 * ((size_t)half * W * H + (size_t)y * W + (size_t)x);
                p[0] = (float)(half * (W - 1) + x);
                p[1] = (float)y;
                p[2] = 0;
            }
        }
        for (int y = 0; y + 1 < H; y++) {
            for (int x = 0; x + 1 < W; x++) {
                uint32_t a = (uint32_t)(half * W * H + y * W + x), b = a + 1, c = a + W,
                         d = c + 1;
                uint32_t q[6] = {a, b, d, a, d, c};
                memcpy(idx + t, q, sizeof q);
                t += 6;
            }
        }
    }
    make_mesh(m, pos, 2 * W * H, idx, t / 3, MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS);
    for (size_t v = 0; v < m->vertex_count; v++) {
        m->normals[3 * v] = 0;
        m->normals[3 * v + 1] = 0;
        m->normals[3 * v + 2] = 1;
        m->texcoords[2 * v] = m->positions[3 * v] / 8;
        m->texcoords[2 * v + 1] = m->positions[3 * v + 1] / 8;
        if (uv_seam && v >= W * H)
            m->texcoords[2 * v] += 0.5f;
    }
}

static void test_weld_seam(void **state)
{
    (void)state;
    for (int uv_seam = 0; uv_seam < 2; uv_seam++) {
        for (int attrs = 0; attrs < 2; attrs++) {
            mr_mesh m, ref;
            make_split_strip(&m, uv_seam);
            /* two halves by index, one surface split down a seam */
            mr_stats before = mesh_stats(&m);
            assert_int_equal(before.components, 1);
            assert_int_equal(before.split_vertices, 5);
            assert_int_equal(before.boundary_loops, 1);
            reference_weld(&m, attrs, &ref);
            size_t removed = 99;
            assert_int_equal(mr_mesh_weld_exact(&m, attrs, &removed, NULL), MR_OK);
            tu_assert_mesh_equal(&m, &ref);
            mr_stats s = mesh_stats(&m);
            if (uv_seam && attrs) {
                assert_int_equal(removed, 0);
                assert_int_equal(s.components, 1);
                assert_int_equal(s.split_vertices, 5);
            } else {
                assert_int_equal(removed, 5); /* the seam column */
                assert_int_equal(s.components, 1);
                assert_int_equal(s.euler_characteristic, 1);
                assert_int_equal(s.boundary_loops, 1);
            }
            mr_mesh_free(&ref);
            mr_mesh_free(&m);
        }
    }
}

/* mr_mesh_weld_seams merges one surface point's vertices whose remaining
 * attributes agree: a UV seam goes once the texture coordinates do. */
static void test_weld_seams(void **state)
{
    (void)state;
    mr_mesh m;
    make_split_strip(&m, 1);
    size_t removed = 99;
    assert_int_equal(mr_mesh_weld_seams(&m, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    assert_int_equal(m.vertex_count, 40);
    free(m.texcoords);
    m.texcoords = NULL;
    assert_int_equal(mr_mesh_weld_seams(&m, &removed, NULL), MR_OK);
    assert_int_equal(removed, 5);
    assert_int_equal(m.vertex_count, 35);
    mr_stats s = mesh_stats(&m);
    assert_int_equal(s.split_vertices, 0);
    assert_int_equal(s.components, 1);
    assert_int_equal(s.euler_characteristic, 1);
    mr_mesh_free(&m);

    /* Two tetrahedra that share one corner position (separately indexed):
     * the weld by position joins them, the seam weld does not. */
    const float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1,
                         0, 0, 0, -1, 0, 0, 0, -1, 0, 0, 0, -1};
    const uint32_t idx[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3,
                            4, 5, 6, 4, 7, 5, 4, 6, 7, 5, 7, 6};
    make_mesh(&m, pos, 8, idx, 8, 0);
    s = mesh_stats(&m);
    assert_int_equal(s.components, 2);
    assert_int_equal(s.nonmanifold_vertices, 0);
    assert_int_equal(s.split_vertices, 0);
    assert_int_equal(mr_mesh_weld_seams(&m, &removed, NULL), MR_OK);
    assert_int_equal(removed, 0);
    assert_int_equal(mr_mesh_weld_exact(&m, 0, &removed, NULL), MR_OK);
    assert_int_equal(removed, 1);
    s = mesh_stats(&m);
    assert_int_equal(s.components, 1);
    assert_int_equal(s.nonmanifold_vertices, 1);
    mr_mesh_free(&m);
}

static void test_weld_zero_sign_and_unreferenced(void **state)
{
    (void)state;
    const float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0,  /* triangle 0 */
                         7, 7, 7,                    /* unreferenced, unique: stays */
                         -0.0f, 0, -0.0f,            /* equals vertex 0 */
                         1, 0, 0,                    /* equals vertex 1, unreferenced */
                         0, 1, 0};                   /* equals vertex 2 */
    const uint32_t idx[] = {0, 1, 2, 4, 6, 1};
    mr_mesh m;
    make_mesh(&m, pos, 7, idx, 2, 0);
    size_t removed = 0;
    assert_int_equal(mr_mesh_weld_exact(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, 3);
    assert_int_equal(m.vertex_count, 4);
    const uint32_t expect[] = {0, 1, 2, 0, 2, 1};
    assert_memory_equal(m.indices, expect, sizeof expect);
    const float expect_pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 7, 7, 7};
    assert_memory_equal(m.positions, expect_pos, sizeof expect_pos);
    mr_mesh_free(&m);

    /* A point cloud: duplicate points merge too. */
    const float cloud[] = {1, 2, 3, 4, 5, 6, 1, 2, 3, 1, 2, 3, 4, 5, 6};
    make_mesh(&m, cloud, 5, NULL, 0, MR_ATTR_COLORS);
    for (size_t i = 0; i < 5 * 4; i++) /* equal colors: welds with attributes */
        m.colors[i] = 0.5f;
    assert_int_equal(mr_mesh_weld_exact(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, 3);
    assert_int_equal(m.vertex_count, 2);
    assert_memory_equal(m.positions, cloud, 6 * sizeof(float));
    mr_mesh_free(&m);
}

/* Triangle soup of a large grid: every triangle on its own three vertices. */
static void make_grid_soup(size_t n, mr_mesh *m)
{
    size_t tc = 2 * (n - 1) * (n - 1);
    mr_mesh_init(m);
    assert_int_equal(mr_mesh_alloc(m, 3 * tc, tc, MR_ATTR_TEXCOORDS, NULL), MR_OK);
    size_t c = 0;
    for (size_t y = 0; y + 1 < n; y++) {
        for (size_t x = 0; x + 1 < n; x++) {
            const int corner[6][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 0}, {1, 1}, {0, 1}};
            for (int k = 0; k < 6; k++, c++) {
                float px = (float)(x + (size_t)corner[k][0]) * 0.1f;
                float py = (float)(y + (size_t)corner[k][1]) * 0.1f;
                m->positions[3 * c] = px;
                m->positions[3 * c + 1] = py;
                m->positions[3 * c + 2] = px * py;
                m->texcoords[2 * c] = px;
                m->texcoords[2 * c + 1] = py;
                m->indices[c] = (uint32_t)c;
            }
        }
    }
}

static void test_weld_large_and_deterministic(void **state)
{
    (void)state;
    const size_t n = 300;
    mr_mesh a, b;
    make_grid_soup(n, &a);
    make_grid_soup(n, &b);
    mr_mesh soup;
    mr_mesh_init(&soup);
    assert_int_equal(mr_mesh_copy(&soup, &a, NULL), MR_OK);
    size_t ra = 0, rb = 0;
#ifdef _OPENMP
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
#endif
    assert_int_equal(mr_mesh_weld_exact(&a, 1, &ra, NULL), MR_OK);
#ifdef _OPENMP
    omp_set_num_threads(2);
#endif
    assert_int_equal(mr_mesh_weld_exact(&b, 1, &rb, NULL), MR_OK);
#ifdef _OPENMP
    omp_set_num_threads(saved);
#endif
    tu_assert_mesh_equal(&a, &b);
    assert_int_equal(a.vertex_count, n * n);
    assert_int_equal(ra, soup.vertex_count - n * n);
    /* Every corner still sits where it did. */
    for (size_t c = 0; c < 3 * a.triangle_count; c++)
        assert_memory_equal(a.positions + 3 * (size_t)a.indices[c],
                            soup.positions + 3 * (size_t)soup.indices[c], 3 * sizeof(float));
    mr_stats s = mesh_stats(&a);
    assert_int_equal(s.components, 1);
    assert_int_equal(s.euler_characteristic, 1);
    assert_true(s.manifold);
    assert_int_equal(s.unreferenced_vertices, 0);
    mr_mesh_free(&a);
    mr_mesh_free(&b);
    mr_mesh_free(&soup);
}

/* ---- degenerate and duplicate triangles ------------------------------------ */

static void test_remove_degenerate(void **state)
{
    (void)state;
    const float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
    const uint32_t idx[] = {
        0, 1, 2, /* 0 */
        0, 0, 1, /* 1 degenerate */
        2, 1, 0, /* 2 = 0 reversed */
        1, 3, 2, /* 3 */
        2, 0, 1, /* 4 = 0 rotated */
        3, 3, 3, /* 5 degenerate */
        3, 2, 1, /* 6 = 3 reversed */
        0, 2, 3, /* 7 */
    };
    mr_mesh m;
    make_mesh(&m, pos, 4, idx, 8, 0);
    mr_stats s = mesh_stats(&m);
    assert_int_equal(s.degenerate_triangles, 2);
    assert_int_equal(s.duplicate_triangles, 3);

    size_t removed = 0;
    assert_int_equal(mr_mesh_remove_degenerate(&m, 0, &removed, NULL), MR_OK);
    assert_int_equal(removed, 2);
    const uint32_t keep_dups[] = {0, 1, 2, 2, 1, 0, 1, 3, 2, 2, 0, 1, 3, 2, 1, 0, 2, 3};
    assert_int_equal(m.triangle_count, 6);
    assert_memory_equal(m.indices, keep_dups, sizeof keep_dups);
    assert_int_equal(m.vertex_count, 4); /* vertices are not touched */
    mr_mesh_free(&m);

    make_mesh(&m, pos, 4, idx, 8, 0);
    assert_int_equal(mr_mesh_remove_degenerate(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, 5);
    const uint32_t clean[] = {0, 1, 2, 1, 3, 2, 0, 2, 3};
    assert_int_equal(m.triangle_count, 3);
    assert_memory_equal(m.indices, clean, sizeof clean);
    s = mesh_stats(&m);
    assert_int_equal(s.degenerate_triangles, 0);
    assert_int_equal(s.duplicate_triangles, 0);
    assert_int_equal(mr_mesh_remove_degenerate(&m, 1, NULL, NULL), MR_OK);
    assert_int_equal(m.triangle_count, 3);
    mr_mesh_free(&m);
}

static void test_remove_duplicates_long_run(void **state)
{
    (void)state;
    /* 50 triangles over edge 0-1, alternating between two third vertices
     * and both orientations: one long run of the sort. */
    uint32_t idx[50 * 3];
    for (uint32_t i = 0; i < 50; i++) {
        uint32_t third = 2 + (i * 7) % 3;
        uint32_t t[3] = {0, 1, third};
        if (i % 2) {
            t[0] = third;
            t[2] = 0;
        }
        memcpy(idx + 3 * i, t, sizeof t);
    }
    const float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    mr_mesh m;
    make_mesh(&m, pos, 5, idx, 50, 0);
    size_t removed = 0;
    assert_int_equal(mr_mesh_remove_degenerate(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, 47);
    assert_int_equal(m.triangle_count, 3);
    assert_memory_equal(m.indices, idx, 9 * sizeof *idx); /* the first three */
    mr_mesh_free(&m);
}

static void test_remove_duplicates_large(void **state)
{
    (void)state;
    /* A welded grid, then every triangle again reversed: half goes. */
    mr_mesh m;
    make_grid_soup(200, &m);
    assert_int_equal(mr_mesh_weld_exact(&m, 0, NULL, NULL), MR_OK);
    size_t tc = m.triangle_count;
    uint32_t *idx = realloc(m.indices, 6 * tc * sizeof *idx);
    assert_non_null(idx);
    m.indices = idx;
    for (size_t t = 0; t < tc; t++) {
        idx[3 * (tc + t)] = idx[3 * t + 2];
        idx[3 * (tc + t) + 1] = idx[3 * t + 1];
        idx[3 * (tc + t) + 2] = idx[3 * t];
    }
    m.triangle_count = 2 * tc;
    mr_stats s = mesh_stats(&m);
    assert_int_equal(s.duplicate_triangles, tc);
    assert_false(s.manifold); /* inner edges now have four triangles */
    size_t removed = 0;
    assert_int_equal(mr_mesh_remove_degenerate(&m, 1, &removed, NULL), MR_OK);
    assert_int_equal(removed, tc);
    assert_int_equal(m.triangle_count, tc);
    s = mesh_stats(&m);
    assert_int_equal(s.duplicate_triangles, 0);
    assert_int_equal(s.euler_characteristic, 1);
    mr_mesh_free(&m);
}

/* ---- arguments ---------------------------------------------------------------- */

/* ---- orientation ---------------------------------------------------------- */

static void flip_triangle(uint32_t *idx, size_t t)
{
    const uint32_t x = idx[3 * t + 1];
    idx[3 * t + 1] = idx[3 * t + 2];
    idx[3 * t + 2] = x;
}

/* A cube with some triangles flipped comes back as it was, and a cube
 * wound inward throughout is turned outward (closed parts face out). */
static void test_orient_cube(void **state)
{
    (void)state;
    const size_t sets[][3] = {{0, 5, 11}, {3, 3, 3}, {1, 2, 7}};
    for (size_t k = 0; k < COUNT_OF(sets); k++) {
        uint32_t idx[36];
        memcpy(idx, cube_idx, sizeof idx);
        size_t want = 0;
        for (size_t i = 0; i < 3; i++) {
            if (i > 0 && sets[k][i] == sets[k][i - 1])
                continue;
            flip_triangle(idx, sets[k][i]);
            want++;
        }
        mr_mesh m;
        make_mesh(&m, cube_pos, 8, idx, 12, 0);
        mr_stats before = mesh_stats(&m);
        assert_true(before.manifold);
        assert_false(before.oriented);
        assert_int_equal(before.misoriented_edges, 3 * want - (k == 2 ? 2 : 0));
        size_t flipped = 99, bad = 99;
        assert_int_equal(mr_mesh_orient(&m, &flipped, &bad, NULL), MR_OK);
        assert_int_equal(flipped, want);
        assert_int_equal(bad, 0);
        assert_memory_equal(m.indices, cube_idx, sizeof cube_idx);
        mr_stats after = mesh_stats(&m);
        assert_true(after.oriented);
        assert_int_equal(after.misoriented_edges, 0);
        mr_mesh_free(&m);
    }
    uint32_t inward[36];
    memcpy(inward, cube_idx, sizeof inward);
    for (size_t t = 0; t < 12; t++)
        flip_triangle(inward, t);
    mr_mesh m;
    make_mesh(&m, cube_pos, 8, inward, 12, 0);
    assert_true(mesh_stats(&m).oriented);
    size_t flipped = 99;
    assert_int_equal(mr_mesh_orient(&m, &flipped, NULL, NULL), MR_OK);
    assert_int_equal(flipped, 12);
    assert_memory_equal(m.indices, cube_idx, sizeof cube_idx);
    mr_mesh_free(&m);
    /* open: the majority's winding, here the inward one of 9 of 10 */
    uint32_t open[30];
    memcpy(open, inward + 6, sizeof open);
    flip_triangle(open, 4);
    make_mesh(&m, cube_pos, 8, open, 10, 0);
    assert_int_equal(mr_mesh_orient(&m, &flipped, NULL, NULL), MR_OK);
    assert_int_equal(flipped, 1);
    assert_memory_equal(m.indices, inward + 6, sizeof open);
    mr_mesh_free(&m);
}

/* A Moebius strip cannot be oriented: it is left as it is and counted; a
 * separate, flipped triangle pair next to it is still fixed. */
static void test_orient_moebius(void **state)
{
    (void)state;
    /* a strip of 6 quads around a loop, joined with a half twist */
    const size_t n = 6;
    float pos[3 * 12 + 3 * 4];
    uint32_t idx[3 * 12 + 6];
    for (size_t i = 0; i < n; i++) {
        const double a = 2 * 3.14159265358979323846 * (double)i / (double)n;
        const double h = 0.3 * cos(a / 2), r = 0.3 * sin(a / 2);
        for (int side = 0; side < 2; side++) {
            const double s = side ? 1 : -1;
            float *p = pos + 3 * (2 * i + (size_t)side);
            p[0] = (float)((1 + s * r) * cos(a));
            p[1] = (float)((1 + s * r) * sin(a));
            p[2] = (float)(s * h);
        }
    }
    for (size_t i = 0; i < n; i++) {
        uint32_t a0 = (uint32_t)(2 * i), a1 = a0 + 1;
        uint32_t b0 = (uint32_t)(2 * ((i + 1) % n)), b1 = b0 + 1;
        if (i == n - 1) { /* the half twist */
            const uint32_t x = b0;
            b0 = b1;
            b1 = x;
        }
        const uint32_t q[6] = {a0, b0, b1, a0, b1, a1};
        memcpy(idx + 6 * i, q, sizeof q);
    }
    /* the separate pair: a square of two triangles, the second flipped */
    const float sq[12] = {5, 0, 0, 6, 0, 0, 6, 1, 0, 5, 1, 0};
    memcpy(pos + 36, sq, sizeof sq);
    const uint32_t pair[6] = {12, 13, 14, 12, 15, 14};
    memcpy(idx + 36, pair, sizeof pair);
    mr_mesh m, copy;
    make_mesh(&m, pos, 16, idx, 14, 0);
    mr_mesh_init(&copy);
    assert_int_equal(mr_mesh_copy(&copy, &m, NULL), MR_OK);
    size_t flipped = 99, bad = 99;
    assert_int_equal(mr_mesh_orient(&m, &flipped, &bad, NULL), MR_OK);
    assert_int_equal(bad, 1);
    assert_int_equal(flipped, 1);
    /* the strip untouched; the pair's second triangle (a tie: the first
     * one's winding wins) flipped */
    assert_memory_equal(m.indices, copy.indices, 36 * sizeof(uint32_t));
    const uint32_t fixed[6] = {12, 13, 14, 12, 14, 15};
    assert_memory_equal(m.indices + 36, fixed, sizeof fixed);
    mr_mesh_free(&copy);
    mr_mesh_free(&m);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    mr_error err;
    size_t removed = 99;
    assert_int_equal(mr_mesh_remove_unreferenced(NULL, &removed, &err), MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(err.status, MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(removed, 0);
    assert_int_equal(mr_mesh_weld_exact(NULL, 0, &removed, &err), MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_mesh_remove_degenerate(NULL, 0, &removed, &err),
                     MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_mesh_remove_unreferenced(NULL, NULL, NULL), MR_ERR_INVALID_ARGUMENT);
    assert_int_equal(mr_mesh_orient(NULL, &removed, NULL, &err), MR_ERR_INVALID_ARGUMENT);

    /* An index out of range is reported, and the mesh is left as it was. */
    const uint32_t idx[] = {0, 1, 2, 3, 2, 8};
    mr_mesh m, copy;
    make_mesh(&m, cube_pos, 8, idx, 2, MR_ATTR_NORMALS);
    mr_mesh_init(&copy);
    assert_int_equal(mr_mesh_copy(&copy, &m, NULL), MR_OK);
    assert_int_equal(mr_mesh_remove_unreferenced(&m, &removed, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "triangle 1");
    assert_int_equal(mr_mesh_weld_exact(&m, 1, &removed, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "triangle 1");
    assert_int_equal(mr_mesh_remove_degenerate(&m, 1, &removed, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "triangle 1");
    assert_int_equal(mr_mesh_orient(&m, &removed, NULL, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "triangle 1");
    tu_assert_mesh_equal(&m, &copy);
    mr_mesh_free(&copy);
    mr_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_remove_unreferenced),
        cmocka_unit_test(test_remove_unreferenced_point_cloud_and_empty),
        cmocka_unit_test(test_weld_split_cube),
        cmocka_unit_test(test_weld_seam),
        cmocka_unit_test(test_weld_seams),
        cmocka_unit_test(test_weld_zero_sign_and_unreferenced),
        cmocka_unit_test(test_weld_large_and_deterministic),
        cmocka_unit_test(test_remove_degenerate),
        cmocka_unit_test(test_remove_duplicates_long_run),
        cmocka_unit_test(test_remove_duplicates_large),
        cmocka_unit_test(test_orient_cube),
        cmocka_unit_test(test_orient_moebius),
        cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
