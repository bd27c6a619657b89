/*
 * Self-intersections of a triangle mesh: pairs of triangles that share no
 * vertex and whose surfaces meet (cross, touch, or overlap in a plane).
 * Pairs that share a vertex are left out: they always meet there, and a
 * fold between neighbours is the collapse rules' business (no flips, no
 * turned normals). Candidates come from a sweep over the triangles' boxes
 * sorted along x, then the box overlap in y and z; each candidate pair gets
 * an exact-enough test in doubles (Moller's interval test, with a coplanar
 * branch that checks edge crossings and containment in the plane's best
 * 2D projection). The count does not depend on the thread count.
 */
#include "selfint.h"

#include "../core/omp_compat.h"

#include <math.h>
#include <stdlib.h>

typedef struct box {
    float lo[3], hi[3];
    uint32_t t;
} box;

static int box_cmp(const void *a, const void *b)
{
    const box *x = a, *y = b;
    if (x->lo[0] != y->lo[0])
        return x->lo[0] < y->lo[0] ? -1 : 1;
    return x->t < y->t ? -1 : x->t > y->t;
}

static void sub(const double a[3], const double b[3], double r[3])
{
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

static void cross(const double a[3], const double b[3], double r[3])
{
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* 2D: do segments (p, q) and (r, s) meet? */
static bool seg2_meet(const double p[2], const double q[2], const double r[2], const double s[2])
{
    const double d1 = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
    const double d2 = (q[0] - p[0]) * (s[1] - p[1]) - (q[1] - p[1]) * (s[0] - p[0]);
    const double d3 = (s[0] - r[0]) * (p[1] - r[1]) - (s[1] - r[1]) * (p[0] - r[0]);
    const double d4 = (s[0] - r[0]) * (q[1] - r[1]) - (s[1] - r[1]) * (q[0] - r[0]);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
        return true;
    return false; /* touching or collinear: not counted as a crossing */
}

/* 2D: is p strictly inside triangle (a, b, c) (either winding)? */
static bool inside2(const double p[2], const double a[2], const double b[2], const double c[2])
{
    const double d1 = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    const double d2 = (c[0] - b[0]) * (p[1] - b[1]) - (c[1] - b[1]) * (p[0] - b[0]);
    const double d3 = (a[0] - c[0]) * (p[1] - c[1]) - (a[1] - c[1]) * (p[0] - c[0]);
    return (d1 > 0 && d2 > 0 && d3 > 0) || (d1 < 0 && d2 < 0 && d3 < 0);
}

/* Coplanar triangles (normal n): overlap in the projection that drops n's
 * largest axis. */
static bool coplanar_meet(const double n[3], const double *u[3], const double *v[3])
{
    int drop = 0;
    if (fabs(n[1]) > fabs(n[drop]))
        drop = 1;
    if (fabs(n[2]) > fabs(n[drop]))
        drop = 2;
    const int i0 = drop == 0 ? 1 : 0, i1 = drop == 2 ? 1 : 2;
    double a[3][2], b[3][2];
    for (int k = 0; k < 3; k++) {
        a[k][0] = u[k][i0];
        a[k][1] = u[k][i1];
        b[k][0] = v[k][i0];
        b[k][1] = v[k][i1];
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (seg2_meet(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]))
                return true;
    return inside2(a[0], b[0], b[1], b[2]) || inside2(b[0], a[0], a[1], a[2]);
}

/* The interval of triangle (p0, p1, p2), with signed distances d to the
 * other's plane (not all of one sign, not all zero), along the line's
 * direction projections q. */
static void interval(const double q[3], const double d[3], double *lo, double *hi)
{
    /* the vertex alone on its side */
    int a;
    if ((d[0] > 0) == (d[1] > 0) && d[0] != 0 && d[1] != 0)
        a = 2;
    else if ((d[0] > 0) == (d[2] > 0) && d[0] != 0 && d[2] != 0)
        a = 1;
    else if ((d[1] > 0) == (d[2] > 0) && d[1] != 0 && d[2] != 0)
        a = 0;
    else if (d[0] != 0)
        a = 0;
    else if (d[1] != 0)
        a = 1;
    else
        a = 2;
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    double t1 = q[a], t2 = q[a];
    if (d[a] != d[b])
        t1 = q[a] + (q[b] - q[a]) * d[a] / (d[a] - d[b]);
    if (d[a] != d[c])
        t2 = q[a] + (q[c] - q[a]) * d[a] / (d[a] - d[c]);
    *lo = t1 < t2 ? t1 : t2;
    *hi = t1 < t2 ? t2 : t1;
}

/* The normal n of triangle t's plane and the signed distances d (times
 * |n|) of the other triangle's points o from it; false when all of o lie
 * strictly on one side. */
static bool straddles(const double *t[3], const double *o[3], double n[3], double d[3])
{
    double e1[3], e2[3];
    sub(t[1], t[0], e1);
    sub(t[2], t[0], e2);
    cross(e1, e2, n);
    const double off = -dot(n, t[0]);
    for (int k = 0; k < 3; k++)
        d[k] = dot(n, o[k]) + off;
    return !((d[0] > 0 && d[1] > 0 && d[2] > 0) || (d[0] < 0 && d[1] < 0 && d[2] < 0));
}

bool mr_triangles_meet(const double *u[3], const double *v[3])
{
    double nv[3], nu[3], du[3], dvv[3];
    if (!straddles(v, u, nv, du) || !straddles(u, v, nu, dvv))
        return false;
    if (du[0] == 0 && du[1] == 0 && du[2] == 0)
        return coplanar_meet(nv, u, v);
    double dir[3];
    cross(nv, nu, dir);
    double qu[3], qv[3];
    for (int k = 0; k < 3; k++) {
        qu[k] = dot(dir, u[k]);
        qv[k] = dot(dir, v[k]);
    }
    double a0, a1, b0, b1;
    interval(qu, du, &a0, &a1);
    interval(qv, dvv, &b0, &b1);
    return !(a1 < b0 || b1 < a0);
}

/* The boxes of the triangles, sorted by their low x (then index): NULL
 * when out of memory. */
static box *sorted_boxes(const float *positions, const uint32_t *indices, size_t triangle_count)
{
    box *bx = malloc(sizeof *bx * (triangle_count ? triangle_count : 1));
    if (!bx)
        return NULL;
    for (size_t t = 0; t < triangle_count; t++) {
        box *b = &bx[t];
        b->t = (uint32_t)t;
        for (int k = 0; k < 3; k++) {
            const float *p = positions + 3 * (size_t)indices[3 * t + (size_t)k];
            for (int c = 0; c < 3; c++) {
                b->lo[c] = k == 0 || p[c] < b->lo[c] ? p[c] : b->lo[c];
                b->hi[c] = k == 0 || p[c] > b->hi[c] ? p[c] : b->hi[c];
            }
        }
    }
    qsort(bx, triangle_count, sizeof *bx, box_cmp);
    return bx;
}

/* The triangles after box i in the sweep that share no vertex with its
 * triangle and meet it: their count, and when out is not NULL the pairs
 * (triangle indices, i's first) written there. */
static uint32_t row_pairs(const box *bx, size_t n, size_t i, const float *positions,
                          const uint32_t *indices, uint32_t *out)
{
    const box *a = &bx[i];
    const uint32_t *ta = indices + 3 * (size_t)a->t;
    double pa[3][3];
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++)
            pa[k][c] = positions[3 * (size_t)ta[k] + (size_t)c];
    const double *u[3] = {pa[0], pa[1], pa[2]};
    uint32_t count = 0;
    for (size_t j = i + 1; j < n && bx[j].lo[0] <= a->hi[0]; j++) {
        const box *b = &bx[j];
        if (b->lo[1] > a->hi[1] || b->hi[1] < a->lo[1] || b->lo[2] > a->hi[2] ||
            b->hi[2] < a->lo[2])
            continue;
        const uint32_t *tb = indices + 3 * (size_t)b->t;
        bool shared = false;
        for (int x = 0; x < 3; x++)
            for (int y = 0; y < 3; y++)
                shared |= ta[x] == tb[y];
        if (shared)
            continue;
        double pb[3][3];
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 3; c++)
                pb[k][c] = positions[3 * (size_t)tb[k] + (size_t)c];
        const double *v[3] = {pb[0], pb[1], pb[2]};
        if (!mr_triangles_meet(u, v))
            continue;
        if (out) {
            out[2 * (size_t)count] = a->t;
            out[2 * (size_t)count + 1] = b->t;
        }
        count++;
    }
    return count;
}

mr_status mr_self_intersections(const float *positions, const uint32_t *indices,
                                size_t triangle_count, int threads, size_t *pairs,
                                mr_error *err)
{
    *pairs = 0;
    box *bx = sorted_boxes(positions, indices, triangle_count);
    if (!bx)
        return mr_fail_nomem(err, "self-intersections", sizeof *bx * triangle_count);
    size_t count = 0;
    const ptrdiff_t n = (ptrdiff_t)triangle_count;
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : count) num_threads(threads) \
    if (threads > 1 && n > 4096)
    for (ptrdiff_t i = 0; i < n; i++)
        count += row_pairs(bx, triangle_count, (size_t)i, positions, indices, NULL);
    free(bx);
    *pairs = count;
    return MR_OK;
}

mr_status mr_self_intersection_pairs(const float *positions, const uint32_t *indices,
                                     size_t triangle_count, int threads, uint32_t **pairs,
                                     size_t *count, mr_error *err)
{
    *pairs = NULL;
    *count = 0;
    box *bx = sorted_boxes(positions, indices, triangle_count);
    uint32_t *rows = malloc(sizeof *rows * (triangle_count ? triangle_count : 1));
    if (!bx || !rows) {
        free(bx);
        free(rows);
        return mr_fail_nomem(err, "self-intersections", (sizeof *bx + 4) * triangle_count);
    }
    const ptrdiff_t n = (ptrdiff_t)triangle_count;
    size_t total = 0;
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : total) num_threads(threads) \
    if (threads > 1 && n > 4096)
    for (ptrdiff_t i = 0; i < n; i++) {
        rows[i] = row_pairs(bx, triangle_count, (size_t)i, positions, indices, NULL);
        total += rows[i];
    }
    mr_status st = MR_OK;
    if (total > 0) {
        uint32_t *out = malloc(2 * total * sizeof *out);
        if (!out) {
            st = mr_fail_nomem(err, "self-intersections", 8 * total);
        } else {
            /* the rows with pairs again, each at its offset: sweep order */
            for (size_t i = 0, at = 0; i < triangle_count; i++) {
                if (rows[i])
                    row_pairs(bx, triangle_count, i, positions, indices, out + 2 * at);
                at += rows[i];
            }
            *pairs = out;
            *count = total;
        }
    }
    free(bx);
    free(rows);
    return st;
}
