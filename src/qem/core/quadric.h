/*
 * Garland-Heckbert error quadrics, inline. Internal, not part of the API.
 *
 * A quadric Q measures the weighted sum of squared distances of a point to
 * a set of planes: Q(x) = x^T A x + 2 b.x + c, A symmetric 3x3. It is kept
 * as 10 numbers plus the sum of the weights of its planes, so that
 * Q(x) / weight is a mean squared distance.
 *
 * Conventions of the simplifiers (see simplify.c):
 *   - coordinates are normalised: translated to the bounding-box centre and
 *     scaled by 1 / diagonal, so every quadric is scale-free and a distance
 *     in normalised units is a distance relative to the diagonal;
 *   - a vertex's quadric is stored RELATIVE TO THE VERTEX'S OWN POSITION
 *     (x is measured from it). The planes of a vertex all pass through it
 *     at the start, so b = c = 0 there, and later b and c stay small: this
 *     avoids the cancellation of large terms that an absolute quadric
 *     suffers, which is what makes float storage (mr_quadricf, 44 bytes a
 *     vertex instead of 88) accurate enough. All arithmetic is in double;
 *   - plane quadrics of triangles are weighted by the triangle's area;
 *     the perpendicular planes that hold a boundary or seam edge in place
 *     by boundary_weight * edge length^2, which scales like an area;
 *   - the reported error of a collapse is the distance
 *     sqrt(Q(target) / weight): the root mean square distance of the new
 *     position to the planes the merged vertices stand for (weighted).
 */
#ifndef MR_QUADRIC_H
#define MR_QUADRIC_H

#include <math.h>

/* Order of the 10 coefficients: a00 a01 a02 a11 a12 a22 b0 b1 b2 c. */
typedef struct mr_quadric {
    double a00, a01, a02, a11, a12, a22;
    double b0, b1, b2;
    double c;
    double w; /* sum of plane weights */
} mr_quadric;

/* The same in float for storage (44 bytes). */
typedef struct mr_quadricf {
    float a00, a01, a02, a11, a12, a22;
    float b0, b1, b2;
    float c;
    float w;
} mr_quadricf;

static inline void mr_quadric_zero(mr_quadric *q)
{
    q->a00 = q->a01 = q->a02 = q->a11 = q->a12 = q->a22 = 0;
    q->b0 = q->b1 = q->b2 = q->c = q->w = 0;
}

static inline void mr_quadric_load(mr_quadric *q, const mr_quadricf *f)
{
    q->a00 = f->a00; q->a01 = f->a01; q->a02 = f->a02;
    q->a11 = f->a11; q->a12 = f->a12; q->a22 = f->a22;
    q->b0 = f->b0; q->b1 = f->b1; q->b2 = f->b2;
    q->c = f->c;
    q->w = f->w;
}

static inline void mr_quadric_store(mr_quadricf *f, const mr_quadric *q)
{
    f->a00 = (float)q->a00; f->a01 = (float)q->a01; f->a02 = (float)q->a02;
    f->a11 = (float)q->a11; f->a12 = (float)q->a12; f->a22 = (float)q->a22;
    f->b0 = (float)q->b0; f->b1 = (float)q->b1; f->b2 = (float)q->b2;
    f->c = (float)q->c;
    f->w = (float)q->w;
}

static inline void mr_quadric_add(mr_quadric *q, const mr_quadric *r)
{
    q->a00 += r->a00; q->a01 += r->a01; q->a02 += r->a02;
    q->a11 += r->a11; q->a12 += r->a12; q->a22 += r->a22;
    q->b0 += r->b0; q->b1 += r->b1; q->b2 += r->b2;
    q->c += r->c;
    q->w += r->w;
}

static inline void mr_quadric_scale(mr_quadric *q, double s)
{
    q->a00 *= s; q->a01 *= s; q->a02 *= s; q->a11 *= s; q->a12 *= s; q->a22 *= s;
    q->b0 *= s; q->b1 *= s; q->b2 *= s; q->c *= s; q->w *= s;
}

/* Add weight * (n.(x - o))^2 for a plane with UNIT normal n through the
 * origin o of q's coordinates (so b and c get nothing). */
static inline void mr_quadric_add_plane_through_origin(mr_quadric *q, const double n[3],
                                                       double weight)
{
    q->a00 += weight * n[0] * n[0];
    q->a01 += weight * n[0] * n[1];
    q->a02 += weight * n[0] * n[2];
    q->a11 += weight * n[1] * n[1];
    q->a12 += weight * n[1] * n[2];
    q->a22 += weight * n[2] * n[2];
    q->w += weight;
}

/* Add weight * (n.x + d)^2 for a plane n.x + d = 0 with unit normal n. */
static inline void mr_quadric_add_plane(mr_quadric *q, const double n[3], double d,
                                        double weight)
{
    mr_quadric_add_plane_through_origin(q, n, weight);
    q->b0 += weight * n[0] * d;
    q->b1 += weight * n[1] * d;
    q->b2 += weight * n[2] * d;
    q->c += weight * d * d;
}

/* Q(x), x in q's coordinates. */
static inline double mr_quadric_eval(const mr_quadric *q, const double x[3])
{
    const double ax = q->a00 * x[0] + q->a01 * x[1] + q->a02 * x[2];
    const double ay = q->a01 * x[0] + q->a11 * x[1] + q->a12 * x[2];
    const double az = q->a02 * x[0] + q->a12 * x[1] + q->a22 * x[2];
    return x[0] * ax + x[1] * ay + x[2] * az +
           2 * (q->b0 * x[0] + q->b1 * x[1] + q->b2 * x[2]) + q->c;
}

/* Move q's origin by d: afterwards q(x'') == old q(x'' + d). */
static inline void mr_quadric_shift(mr_quadric *q, const double d[3])
{
    const double ad0 = q->a00 * d[0] + q->a01 * d[1] + q->a02 * d[2];
    const double ad1 = q->a01 * d[0] + q->a11 * d[1] + q->a12 * d[2];
    const double ad2 = q->a02 * d[0] + q->a12 * d[1] + q->a22 * d[2];
    q->c += d[0] * ad0 + d[1] * ad1 + d[2] * ad2 +
            2 * (q->b0 * d[0] + q->b1 * d[1] + q->b2 * d[2]);
    q->b0 += ad0;
    q->b1 += ad1;
    q->b2 += ad2;
}

/* Unit normal and area of triangle (a, b, c); area 0 leaves n = 0. */
static inline double mr_triangle_normal(const double a[3], const double b[3],
                                        const double c[3], double n[3])
{
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len > 0) {
        n[0] /= len;
        n[1] /= len;
        n[2] /= len;
    }
    return 0.5 * len;
}

/*
 * The constraint plane of a boundary (or seam) edge a -> b of a triangle
 * with unit normal tn: the plane that contains the edge and is perpendicular
 * to the triangle. Adds weight * |b - a|^2 * dist^2 to q, for q's origin at
 * a (the plane passes through a). Keeps the edge from sliding sideways
 * while its vertices may still slide along it.
 */
static inline void mr_quadric_add_edge_constraint(mr_quadric *q, const double a[3],
                                                  const double b[3], const double tn[3],
                                                  double weight)
{
    const double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double len2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    double n[3] = {e[1] * tn[2] - e[2] * tn[1], e[2] * tn[0] - e[0] * tn[2],
                   e[0] * tn[1] - e[1] * tn[0]};
    const double nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(nl > 0) || !(weight > 0))
        return;
    n[0] /= nl;
    n[1] /= nl;
    n[2] /= nl;
    mr_quadric_add_plane_through_origin(q, n, weight * len2);
}

/*
 * The position minimising q, in q's coordinates, when A is well
 * conditioned: returns 1 and sets x. The test is relative: |det A| must
 * exceed MR_QUADRIC_DET_EPS times the product of A's diagonal (which is
 * det A for a diagonal A), so it does not depend on the mesh's scale or
 * the weights. Returns 0 for a (near) singular system -- a flat or
 * cylindrical neighbourhood, where the optimum is a line or a plane.
 */
#define MR_QUADRIC_DET_EPS 1e-6

static inline int mr_quadric_optimum(const mr_quadric *q, double x[3])
{
    const double c00 = q->a11 * q->a22 - q->a12 * q->a12;
    const double c01 = q->a02 * q->a12 - q->a01 * q->a22;
    const double c02 = q->a01 * q->a12 - q->a02 * q->a11;
    const double det = q->a00 * c00 + q->a01 * c01 + q->a02 * c02;
    const double diag = q->a00 * q->a11 * q->a22;
    if (!(fabs(det) > MR_QUADRIC_DET_EPS * diag) || !(diag > 0))
        return 0;
    const double c11 = q->a00 * q->a22 - q->a02 * q->a02;
    const double c12 = q->a01 * q->a02 - q->a00 * q->a12;
    const double c22 = q->a00 * q->a11 - q->a01 * q->a01;
    const double inv = -1.0 / det; /* x = -A^-1 b */
    x[0] = inv * (c00 * q->b0 + c01 * q->b1 + c02 * q->b2);
    x[1] = inv * (c01 * q->b0 + c11 * q->b1 + c12 * q->b2);
    x[2] = inv * (c02 * q->b0 + c12 * q->b1 + c22 * q->b2);
    return 1;
}

/*
 * The point of segment p0 + s (p1 - p0), s in [0, 1], minimising q (in q's
 * coordinates): Q along a line is a convex parabola, so its clamped vertex
 * is at least as good as either endpoint or the midpoint. Returns s.
 */
static inline double mr_quadric_segment_optimum(const mr_quadric *q, const double p0[3],
                                                const double p1[3], double x[3])
{
    const double d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    /* Q(p0 + s d) = s^2 dAd + 2 s (A p0 + b).d + Q(p0) */
    const double ad0 = q->a00 * d[0] + q->a01 * d[1] + q->a02 * d[2];
    const double ad1 = q->a01 * d[0] + q->a11 * d[1] + q->a12 * d[2];
    const double ad2 = q->a02 * d[0] + q->a12 * d[1] + q->a22 * d[2];
    const double dad = d[0] * ad0 + d[1] * ad1 + d[2] * ad2;
    const double g = p0[0] * ad0 + p0[1] * ad1 + p0[2] * ad2 + q->b0 * d[0] +
                     q->b1 * d[1] + q->b2 * d[2];
    double s = 0.5;
    if (dad > 0) {
        s = -g / dad;
        s = s < 0 ? 0 : s > 1 ? 1 : s;
    } else {
        s = g > 0 ? 0 : g < 0 ? 1 : 0.5;
    }
    x[0] = p0[0] + s * d[0];
    x[1] = p0[1] + s * d[1];
    x[2] = p0[2] + s * d[2];
    return s;
}

#endif /* MR_QUADRIC_H */
