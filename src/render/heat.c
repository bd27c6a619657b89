/*
 * Heat maps: the distance of a test surface to a reference surface, per
 * face (or per point of a point cloud), through the nearest-triangle
 * hierarchy of src/metrics; and the colour map that shows it.
 */
#include "../metrics/reference.h"

#include "../core/omp_compat.h"

/* Control points of the colour map, evenly spaced over [0, 1]: dark blue,
 * blue, cyan, green, yellow, red. */
static const float ramp[6][3] = {
    {0.16f, 0.18f, 0.55f}, {0.15f, 0.42f, 0.85f}, {0.20f, 0.72f, 0.78f},
    {0.50f, 0.82f, 0.35f}, {0.98f, 0.78f, 0.20f}, {0.85f, 0.15f, 0.12f},
};

void mr_colormap(double t, uint8_t rgb[3])
{
    if (!(t > 0)) /* also NaN */
        t = 0;
    if (t > 1)
        t = 1;
    double x = t * 5;
    int i = (int)x;
    if (i > 4)
        i = 4;
    double f = x - i;
    for (int c = 0; c < 3; c++) {
        double v = ramp[i][c] + f * (ramp[i + 1][c] - ramp[i][c]);
        rgb[c] = (uint8_t)lrint(v * 255);
    }
}

/* Indices in range and referenced positions finite; `what` names the mesh. */
static mr_status check_mesh(const float *pos, size_t nv, const uint32_t *idx, size_t nt,
                            const char *what, mr_error *err)
{
    if (nv && !pos)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "heat map", "%s has no positions",
                             what);
    if (nt && !idx)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "heat map", "%s has no indices",
                             what);
    if (nv > UINT32_MAX || nt > UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, "heat map",
                             "%s: more than 2^32 - 1 vertices or triangles", what);
    size_t n = nt ? 3 * nt : nv;
    for (size_t i = 0; i < n; i++) {
        uint32_t v = nt ? idx[i] : (uint32_t)i;
        if (v >= nv)
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "heat map",
                                 "%s: triangle %zu uses vertex %u, but there are %zu vertices",
                                 what, i / 3, v, nv);
        const float *p = pos + 3 * (size_t)v;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "heat map",
                                 "%s: vertex %u has a non-finite coordinate", what, v);
    }
    return MR_OK;
}

static float point_distance(const mr_tri_bvh *bvh, const double p[3], uint32_t *hint)
{
    uint32_t tri = MR_NO_HINT;
    double d2 = mr_tri_bvh_nearest(bvh, p, *hint, &tri, NULL);
    *hint = tri;
    return (float)sqrt(d2);
}

/* The distances of the test mesh's faces (or points) to the surface of the
 * hierarchy bvh: mr_surface_distances' values. */
static mr_status distances(const mr_tri_bvh *bvh, int nthreads, const float *test_positions,
                           size_t test_vertex_count, const uint32_t *test_indices,
                           size_t test_triangle_count, float *face_distance, double *max_out,
                           mr_error *err)
{
    const float *tp = test_positions;
    const ptrdiff_t nv = (ptrdiff_t)test_vertex_count, nt = (ptrdiff_t)test_triangle_count;
    float *vdist = NULL;
    if (nt) {
        vdist = mr_alloc_array(test_vertex_count, sizeof *vdist);
        if (!vdist)
            return mr_fail_nomem(err, "heat map", test_vertex_count * sizeof *vdist);
        /* Unreferenced vertices keep NaN and are never read. */
        for (ptrdiff_t v = 0; v < nv; v++)
            vdist[v] = NAN;
        for (ptrdiff_t i = 0; i < 3 * nt; i++)
            vdist[test_indices[i]] = 0;
    }
    float *vout = nt ? vdist : face_distance;
    double maxd = 0;

#pragma omp parallel num_threads(nthreads)
    {
        uint32_t hint = MR_NO_HINT; /* only speeds queries up */
#pragma omp for schedule(static, 1024)
        for (ptrdiff_t v = 0; v < nv; v++) {
            if (nt && vdist[v] != 0) /* NaN: unreferenced */
                continue;
            const float *p = tp + 3 * v;
            double q[3] = {p[0], p[1], p[2]};
            vout[v] = point_distance(bvh, q, &hint);
        }
        if (nt) {
            /* The centroid and the three points (4, 1, 1) / 6. */
            static const double bary[4][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3},
                                              {4.0 / 6, 1.0 / 6, 1.0 / 6},
                                              {1.0 / 6, 4.0 / 6, 1.0 / 6},
                                              {1.0 / 6, 1.0 / 6, 4.0 / 6}};
#pragma omp for schedule(static, 1024) reduction(max : maxd)
            for (ptrdiff_t f = 0; f < nt; f++) {
                const uint32_t *t = test_indices + 3 * f;
                float m = fmaxf(vdist[t[0]], fmaxf(vdist[t[1]], vdist[t[2]]));
                for (int s = 0; s < 4; s++) {
                    double q[3];
                    for (int c = 0; c < 3; c++)
                        q[c] = bary[s][0] * tp[3 * (size_t)t[0] + c] +
                               bary[s][1] * tp[3 * (size_t)t[1] + c] +
                               bary[s][2] * tp[3 * (size_t)t[2] + c];
                    m = fmaxf(m, point_distance(bvh, q, &hint));
                }
                face_distance[f] = m;
                if (m > maxd)
                    maxd = m;
            }
        } else {
#pragma omp for schedule(static) reduction(max : maxd)
            for (ptrdiff_t v = 0; v < nv; v++)
                if (face_distance[v] > maxd)
                    maxd = face_distance[v];
        }
    }
    free(vdist);
    if (max_out)
        *max_out = maxd;
    return MR_OK;
}

mr_status mr_surface_distances(const float *ref_positions, size_t ref_vertex_count,
                               const uint32_t *ref_indices, size_t ref_triangle_count,
                               const float *test_positions, size_t test_vertex_count,
                               const uint32_t *test_indices, size_t test_triangle_count,
                               int threads, float *face_distance, double *max_out,
                               mr_error *err)
{
    mr_error_clear(err);
    if (!face_distance)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "heat map", "no output array given");
    if (ref_triangle_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, "heat map",
                             "the reference has no triangles: no surface to measure against");
    if (test_vertex_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, "heat map", "the test mesh has no vertices");
    mr_status st = check_mesh(ref_positions, ref_vertex_count, ref_indices, ref_triangle_count,
                              "reference", err);
    if (st == MR_OK)
        st = check_mesh(test_positions, test_vertex_count, test_indices, test_triangle_count,
                        "test mesh", err);
    if (st != MR_OK)
        return st;

    const int nthreads = mr_thread_count(threads);
    mr_tri_bvh bvh;
    memset(&bvh, 0, sizeof bvh);
    if ((st = mr_tri_bvh_build(&bvh, ref_positions, ref_indices, ref_triangle_count, nthreads,
                               err)) != MR_OK)
        return st;

    st = distances(&bvh, nthreads, test_positions, test_vertex_count, test_indices,
                   test_triangle_count, face_distance, max_out, err);
    mr_tri_bvh_free(&bvh);
    return st;
}

mr_status mr_surface_distances_with(const mr_reference *ref, const float *test_positions,
                                    size_t test_vertex_count, const uint32_t *test_indices,
                                    size_t test_triangle_count, float *face_distance,
                                    double *max_out, mr_error *err)
{
    mr_error_clear(err);
    if (!ref || !face_distance)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "heat map",
                             "no reference or no output array given");
    if (test_vertex_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, "heat map", "the test mesh has no vertices");
    mr_status st = check_mesh(test_positions, test_vertex_count, test_indices,
                              test_triangle_count, "test mesh", err);
    if (st != MR_OK)
        return st;
    return distances(mr_reference_hierarchy(ref), mr_reference_threads(ref), test_positions,
                     test_vertex_count, test_indices, test_triangle_count, face_distance,
                     max_out, err);
}
