/*
 * The attributes' quadrics: see attr_quadric.h.
 *
 * A wedge's record: the quadric in x (mr_quadricf: a00 .. c, and W in its
 * weight), the wedge's origin (3), then per channel G (3), D and the
 * wedge's frame (its input value, weighted).
 */
#include "attr_quadric.h"

#include "../core/omp_compat.h"

#include <math.h>

enum { ATTR_Q = 0, ATTR_ORIGIN = 11, ATTR_HEAD = 14, ATTR_CH = 5 };

/* A record in double: the quadric (its w is W), the origin, G and D. */
typedef struct attr_rec {
    mr_quadric q;
    double o[3];
    double g[MR_ATTR_CHANNELS][3], d[MR_ATTR_CHANNELS];
} attr_rec;

/* Add channel comp of src (width floats a vertex) unless its value is the
 * same at every referenced vertex (an opaque colour's alpha, a flat
 * colour's channel): its deviation is 0 wherever the vertices go, and the
 * interpolation (attr_apply) keeps it. */
static void add_channel(mr_attr_quadrics *aq, const mr_mesh *in, const float *src,
                        unsigned width, unsigned comp, double weight, float *dst, unsigned kind)
{
    const float v0 = src[(size_t)width * in->indices[0] + comp];
    size_t i = 1;
    while (i < 3 * in->triangle_count && src[(size_t)width * in->indices[i] + comp] == v0)
        i++;
    if (i == 3 * in->triangle_count)
        return;
    const unsigned c = aq->channels++;
    aq->src[c] = src;
    aq->width[c] = width;
    aq->comp[c] = comp;
    aq->weight[c] = weight;
    aq->dst[c] = dst;
    aq->kind[c] = kind;
}

/*
 * The scales that make the options' weights mesh-free (serial sums over
 * the run's triangles, in their order: the same at any thread count):
 *   - *edge: the mean edge length (normalised): a normal's or a colour's
 *     deviation of 1 at weight 1 counts as that distance;
 *   - *uv: the surface's length per unit of texture coordinates,
 *     sqrt(area / UV area): a UV deviation counts as the distance it moves
 *     the texture on the surface (0 where the UVs have no area).
 */
static void mesh_scales(const mr_simplifier *s, const uint32_t *corner, const float *uv,
                        double *edge, double *uvscale)
{
    const mr_collapse_mesh *m = &s->m;
    double len = 0, area = 0, uvarea = 0;
    size_t n = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *tri = m->tris + 3 * t;
        if (tri[0] == MR_COLLAPSE_NONE)
            continue;
        double p[3][3];
        for (int j = 0; j < 3; j++)
            mr_collapse_load(m, tri[j], p[j]);
        double e[3][3];
        for (int j = 0; j < 3; j++) {
            for (int k = 0; k < 3; k++)
                e[j][k] = p[(j + 1) % 3][k] - p[j][k];
            len += sqrt(e[j][0] * e[j][0] + e[j][1] * e[j][1] + e[j][2] * e[j][2]);
        }
        n += 3;
        if (!uv)
            continue;
        const double c[3] = {e[0][1] * e[2][2] - e[0][2] * e[2][1],
                             e[0][2] * e[2][0] - e[0][0] * e[2][2],
                             e[0][0] * e[2][1] - e[0][1] * e[2][0]};
        area += 0.5 * sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        const float *a = uv + 2 * (size_t)corner[3 * t], *b = uv + 2 * (size_t)corner[3 * t + 1],
                    *d = uv + 2 * (size_t)corner[3 * t + 2];
        uvarea += 0.5 * fabs(((double)b[0] - a[0]) * ((double)d[1] - a[1]) -
                             ((double)b[1] - a[1]) * ((double)d[0] - a[0]));
    }
    *edge = n ? len / (double)n : 0;
    *uvscale = uvarea > 0 && area > 0 ? sqrt(area / uvarea) : 0;
}

unsigned mr_attr_quadrics_channels(mr_attr_quadrics *aq, const mr_simplifier *s,
                                   const uint32_t *corner, const mr_mesh *in,
                                   const mr_simplify_options *o, float *normals,
                                   float *texcoords, float *colors)
{
    memset(aq, 0, sizeof *aq);
    if (!o || !((in->normals && o->normal_weight > 0) || (in->texcoords && o->uv_weight > 0) ||
                (in->colors && o->color_weight > 0)))
        return 0;
    double edge, uvscale;
    mesh_scales(s, corner, in->texcoords && o->uv_weight > 0 ? in->texcoords : NULL, &edge,
                &uvscale);
    if (!(edge > 0))
        return 0;
    if (in->normals && o->normal_weight > 0)
        for (unsigned k = 0; k < 3; k++)
            add_channel(aq, in, in->normals, 3, k, o->normal_weight * edge, normals, 0);
    if (in->texcoords && o->uv_weight > 0 && uvscale > 0)
        for (unsigned k = 0; k < 2; k++)
            add_channel(aq, in, in->texcoords, 2, k, o->uv_weight * uvscale, texcoords, 1);
    if (in->colors && o->color_weight > 0)
        for (unsigned k = 0; k < 4; k++)
            add_channel(aq, in, in->colors, 4, k, o->color_weight * edge, colors, 2);
    aq->stride = ATTR_HEAD + ATTR_CH * aq->channels;
    /* an attribute with no channel left is interpolated (attr_apply) */
    for (unsigned c = 0; c < aq->channels; c++)
        aq->has[aq->kind[c]] = true;
    return aq->channels;
}

void mr_attr_quadrics_free(mr_attr_quadrics *aq)
{
    free(aq->rec);
    aq->rec = NULL;
}

/* Wedge v's frame of channel c: its input value, weighted (in its record
 * from the start of the build). */
static inline double frame(const mr_attr_quadrics *aq, unsigned c, uint32_t v)
{
    return aq->rec[(size_t)aq->stride * v + ATTR_HEAD + ATTR_CH * c + 4];
}

/* Corner cv's triangle's part of its wedge's record (v at pv). */
static void add_corner(const mr_attr_quadrics *aq, const mr_collapse_mesh *m,
                       const uint32_t *corner, uint32_t cv, const double pv[3], attr_rec *acc)
{
    const uint32_t t = cv / 3;
    const uint32_t *tri = m->tris + 3 * (size_t)t;
    const uint32_t *wt = corner + 3 * (size_t)t;
    const uint32_t w = corner[cv];
    double p[3][3];
    for (int j = 0; j < 3; j++)
        mr_collapse_load(m, tri[j], p[j]);
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    const double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if (!(nn > 0))
        return; /* no area: nothing to add */
    const double area = 0.5 * sqrt(nn);
    /* g = ((s1 - s0) (e2 x n) + (s2 - s0) (n x e1)) / |n|^2: in the
     * triangle's plane, g.e1 = s1 - s0 and g.e2 = s2 - s0 */
    const double a[3] = {e2[1] * n[2] - e2[2] * n[1], e2[2] * n[0] - e2[0] * n[2],
                         e2[0] * n[1] - e2[1] * n[0]};
    const double b[3] = {n[1] * e1[2] - n[2] * e1[1], n[2] * e1[0] - n[0] * e1[2],
                         n[0] * e1[1] - n[1] * e1[0]};
    const double rel[3] = {pv[0] - p[0][0], pv[1] - p[0][1], pv[2] - p[0][2]};
    const double inn = 1 / nn;
    mr_quadric *q = &acc->q;
    for (unsigned c = 0; c < aq->channels; c++) {
        const double s0 = frame(aq, c, wt[0]), s1 = frame(aq, c, wt[1]),
                     s2 = frame(aq, c, wt[2]);
        const double d1 = (s1 - s0) * inn, d2 = (s2 - s0) * inn;
        const double g[3] = {d1 * a[0] + d2 * b[0], d1 * a[1] + d2 * b[1],
                             d1 * a[2] + d2 * b[2]};
        /* f at y = x - pv, relative to the wedge's value */
        const double d = s0 + g[0] * rel[0] + g[1] * rel[1] + g[2] * rel[2] - frame(aq, c, w);
        q->a00 += area * g[0] * g[0];
        q->a01 += area * g[0] * g[1];
        q->a02 += area * g[0] * g[2];
        q->a11 += area * g[1] * g[1];
        q->a12 += area * g[1] * g[2];
        q->a22 += area * g[2] * g[2];
        q->b0 += area * g[0] * d;
        q->b1 += area * g[1] * d;
        q->b2 += area * g[2] * d;
        q->c += area * d * d;
        acc->g[c][0] += area * g[0];
        acc->g[c][1] += area * g[1];
        acc->g[c][2] += area * g[2];
        acc->d[c] += area * d;
    }
    q->w += area;
}

mr_status mr_attr_quadrics_build(mr_attr_quadrics *aq, const mr_simplifier *s,
                                 const uint32_t *corner, size_t vc, mr_error *err)
{
    aq->rec = mr_calloc_array(vc ? vc : 1, aq->stride * sizeof(float));
    if (!aq->rec)
        return mr_fail_nomem(err, NULL, vc * aq->stride * sizeof(float));
    const mr_collapse_mesh *m = &s->m;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count, nw = (ptrdiff_t)vc;
    const unsigned nch = aq->channels, st = aq->stride;
#pragma omp parallel for schedule(static) num_threads(s->plan.threads) \
    if (s->plan.threads > 1 && nw > 65536)
    for (ptrdiff_t w = 0; w < nw; w++)
        for (unsigned c = 0; c < nch; c++)
            aq->rec[(size_t)st * (size_t)w + ATTR_HEAD + ATTR_CH * c + 4] =
                (float)(aq->weight[c] *
                        (double)aq->src[c][(size_t)aq->width[c] * (size_t)w + aq->comp[c]]);
#pragma omp parallel for schedule(dynamic, 4096) num_threads(s->plan.threads) \
    if (s->plan.threads > 1 && nv > 65536)
    for (ptrdiff_t vi = 0; vi < nv; vi++) {
        const uint32_t v = (uint32_t)vi;
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        const uint32_t *list = mr_collapse_vertex_tris(m, v);
        double pv[3];
        mr_collapse_load(m, v, pv);
        /* each of v's wedges in turn (in the order its corners come),
         * summed in double over its corners */
        for (uint32_t first = 0; first < m->count[v]; first++) {
            const uint32_t w = corner[list[first]];
            bool seen = false;
            for (uint32_t i = 0; i < first && !seen; i++)
                seen = corner[list[i]] == w;
            if (seen)
                continue;
            attr_rec acc;
            memset(&acc, 0, sizeof acc);
            for (uint32_t i = first; i < m->count[v]; i++)
                if (corner[list[i]] == w)
                    add_corner(aq, m, corner, list[i], pv, &acc);
            float *r = aq->rec + (size_t)st * w;
            mr_quadric_store((mr_quadricf *)(r + ATTR_Q), &acc.q);
            for (int k = 0; k < 3; k++)
                r[ATTR_ORIGIN + k] = (float)pv[k];
            for (unsigned c = 0; c < nch; c++)
                for (int k = 0; k < 4; k++)
                    r[ATTR_HEAD + ATTR_CH * c + k] = (float)(k < 3 ? acc.g[c][k] : acc.d[c]);
        }
    }
    return MR_OK;
}

/* Wedge a's record in double, moved to origin o (q(y) = a's at y + o -
 * a's origin) and to wedge f's frame. */
static void load_rec(const mr_attr_quadrics *aq, uint32_t a, const double o[3], uint32_t f,
                     attr_rec *r)
{
    const float *src = aq->rec + (size_t)aq->stride * a;
    mr_quadric_load(&r->q, (const mr_quadricf *)(src + ATTR_Q));
    const double d[3] = {o[0] - src[ATTR_ORIGIN], o[1] - src[ATTR_ORIGIN + 1],
                         o[2] - src[ATTR_ORIGIN + 2]};
    memcpy(r->o, o, sizeof r->o);
    mr_quadric_shift(&r->q, d);
    for (unsigned c = 0; c < aq->channels; c++) {
        const float *gd = src + ATTR_HEAD + ATTR_CH * c;
        double *g = r->g[c];
        g[0] = gd[0];
        g[1] = gd[1];
        g[2] = gd[2];
        double D = gd[3] + g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
        if (f != a) {
            /* f's frame: values relative to f's input value */
            const double dl = frame(aq, c, a) - frame(aq, c, f);
            r->q.b0 += dl * g[0];
            r->q.b1 += dl * g[1];
            r->q.b2 += dl * g[2];
            r->q.c += 2 * dl * D + dl * dl * r->q.w;
            D += dl * r->q.w;
        }
        r->d[c] = D;
    }
}

static void add_rec(const mr_attr_quadrics *aq, attr_rec *r, const attr_rec *x)
{
    mr_quadric_add(&r->q, &x->q);
    for (unsigned c = 0; c < aq->channels; c++) {
        r->g[c][0] += x->g[c][0];
        r->g[c][1] += x->g[c][1];
        r->g[c][2] += x->g[c][2];
        r->d[c] += x->d[c];
    }
}

/* The pair's quadric at its best values, without the records in double:
 * b's moved to o; a's moved to o and to b's frame; summed; then each
 * channel's (G.x + D)^2 / W taken off. */
void mr_attr_pair_quadric(const mr_attr_quadrics *aq, uint32_t a, uint32_t b, const double o[3],
                          mr_quadric *q)
{
    const unsigned st = aq->stride;
    const float *rb = aq->rec + (size_t)st * b, *ra = aq->rec + (size_t)st * a;
    mr_quadric e, qa;
    mr_quadric_zero(&qa);
    mr_quadric_load(&e, (const mr_quadricf *)(rb + ATTR_Q));
    const double db[3] = {o[0] - rb[ATTR_ORIGIN], o[1] - rb[ATTR_ORIGIN + 1],
                          o[2] - rb[ATTR_ORIGIN + 2]};
    mr_quadric_shift(&e, db);
    const bool two = a != b;
    double da[3] = {0, 0, 0};
    if (two) {
        mr_quadric_load(&qa, (const mr_quadricf *)(ra + ATTR_Q));
        da[0] = o[0] - ra[ATTR_ORIGIN];
        da[1] = o[1] - ra[ATTR_ORIGIN + 1];
        da[2] = o[2] - ra[ATTR_ORIGIN + 2];
        mr_quadric_shift(&qa, da);
    }
    const double W = two ? e.w + qa.w : e.w;
    if (!(W > 0))
        return;
    const double inv = 1 / W;
    double s00 = 0, s01 = 0, s02 = 0, s11 = 0, s12 = 0, s22 = 0, t0 = 0, t1 = 0, t2 = 0, u = 0;
    for (unsigned c = 0; c < aq->channels; c++) {
        const float *gb = rb + ATTR_HEAD + ATTR_CH * c;
        double g0 = gb[0], g1 = gb[1], g2 = gb[2];
        double D = gb[3] + g0 * db[0] + g1 * db[1] + g2 * db[2];
        if (two) {
            const float *ga = ra + ATTR_HEAD + ATTR_CH * c;
            const double h0 = ga[0], h1 = ga[1], h2 = ga[2];
            double Da = ga[3] + h0 * da[0] + h1 * da[1] + h2 * da[2];
            const double dl = (double)ga[4] - gb[4]; /* to b's frame */
            qa.b0 += dl * h0;
            qa.b1 += dl * h1;
            qa.b2 += dl * h2;
            qa.c += 2 * dl * Da + dl * dl * qa.w;
            Da += dl * qa.w;
            g0 += h0;
            g1 += h1;
            g2 += h2;
            D += Da;
        }
        const double f0 = g0 * inv, f1 = g1 * inv, f2 = g2 * inv;
        s00 += f0 * g0;
        s01 += f0 * g1;
        s02 += f0 * g2;
        s11 += f1 * g1;
        s12 += f1 * g2;
        s22 += f2 * g2;
        t0 += f0 * D;
        t1 += f1 * D;
        t2 += f2 * D;
        u += D * D * inv;
    }
    if (two)
        mr_quadric_add(&e, &qa);
    q->a00 += e.a00 - s00;
    q->a01 += e.a01 - s01;
    q->a02 += e.a02 - s02;
    q->a11 += e.a11 - s11;
    q->a12 += e.a12 - s12;
    q->a22 += e.a22 - s22;
    q->b0 += e.b0 - t0;
    q->b1 += e.b1 - t1;
    q->b2 += e.b2 - t2;
    q->c += e.c - u;
}

void mr_attr_merge(mr_attr_quadrics *aq, uint32_t a, uint32_t b)
{
    float *dst = aq->rec + (size_t)aq->stride * b;
    const double o[3] = {dst[ATTR_ORIGIN], dst[ATTR_ORIGIN + 1], dst[ATTR_ORIGIN + 2]};
    attr_rec r, x;
    load_rec(aq, b, o, b, &r);
    load_rec(aq, a, o, b, &x);
    add_rec(aq, &r, &x);
    mr_quadric_store((mr_quadricf *)(dst + ATTR_Q), &r.q);
    for (unsigned c = 0; c < aq->channels; c++) {
        float *gd = dst + ATTR_HEAD + ATTR_CH * c;
        gd[0] = (float)r.g[c][0];
        gd[1] = (float)r.g[c][1];
        gd[2] = (float)r.g[c][2];
        gd[3] = (float)r.d[c];
    }
}

void mr_attr_place(const mr_attr_quadrics *aq, uint32_t b, const double x[3])
{
    const float *src = aq->rec + (size_t)aq->stride * b;
    const double W = src[ATTR_Q + 10];
    if (!(W > 0))
        return;
    const double y[3] = {x[0] - src[ATTR_ORIGIN], x[1] - src[ATTR_ORIGIN + 1],
                         x[2] - src[ATTR_ORIGIN + 2]};
    float *normal = NULL;
    for (unsigned c = 0; c < aq->channels; c++) {
        const float *gd = src + ATTR_HEAD + ATTR_CH * c;
        const double t = (gd[0] * y[0] + gd[1] * y[1] + gd[2] * y[2] + gd[3]) / W;
        double v = (frame(aq, c, b) + t) / aq->weight[c];
        if (aq->kind[c] == 2)
            v = v < 0 ? 0 : v > 1 ? 1 : v;
        float *dst = aq->dst[c] + (size_t)aq->width[c] * b;
        dst[aq->comp[c]] = (float)v;
        if (aq->kind[c] == 0)
            normal = dst;
    }
    if (normal) {
        const double len = sqrt((double)normal[0] * normal[0] + (double)normal[1] * normal[1] +
                                (double)normal[2] * normal[2]);
        if (len > 0)
            for (int k = 0; k < 3; k++)
                normal[k] = (float)(normal[k] / len);
    }
}
