/*
 * The attributes' quadrics (mr_mesh_simplify's collapse cost with
 * attributes): Hoppe's memory-efficient form (1999) of the quadric over
 * position and attributes, kept per wedge. Internal.
 *
 * On each triangle an attribute channel is a linear function of the
 * position, f(x) = g.x + d (g in the triangle's plane, f the corners'
 * values at the corners). A wedge sums, over its triangles (area-weighted,
 * as the geometric quadric): area * (f(x) - s)^2 for each weighted channel
 * -- the squared deviation of the wedge's value s from the surface's at a
 * position x. As a quadric in (x, s) it needs, besides a 3x3 quadric in x
 * (the sum of area * f^2 over channels), only each channel's area sums G
 * (a gradient) and D, and the area W: for any x the best s is
 * (G.x + D) / W, and with it the deviation is a quadric in x alone,
 * Q(x) - sum over channels of (G.x + D)^2 / W. Garland and Heckbert's
 * generalised quadric (1998) keeps the full (3 + n)^2 matrix instead:
 * 3 + n rows per vertex where this keeps 4 floats a channel, and it ties
 * the attributes of a seam's two sides to one vertex, where the wedges
 * keep them apart.
 *
 * A collapse merges each wedge of the removed end with the survivor's
 * wedge on the same side of the edge (mr_mesh_simplify's attr_apply): the
 * cost adds, for each merged pair, the pair's quadric in x at its best
 * values; the survivor's wedge takes those values at the target. Where the
 * survivor keeps wedges that merge with nothing, it does not move (full
 * collapses pin a seam vertex that a non-seam one joins), so their part
 * stays as it was.
 *
 * Storage, as the geometric quadrics': float, relative -- to the wedge's
 * position when the run began (its origin) and to its input values (its
 * frame): near the wedge both are small, so the float records keep their
 * differences. The arithmetic is in double.
 */
#ifndef MR_QEM_ATTR_QUADRIC_H
#define MR_QEM_ATTR_QUADRIC_H

#include "core/simplifier.h"

#define MR_ATTR_CHANNELS 9 /* normal 3, uv 2, color 4 */

typedef struct mr_attr_quadrics {
    unsigned channels;     /* weighted channels */
    unsigned stride;       /* floats per wedge: ATTR_HEAD + 4 * channels */
    float *rec;            /* per wedge (input vertex) */
    /* channel c: input values src[c][width[c] * v + comp[c]] times weight[c] */
    const float *src[MR_ATTR_CHANNELS];
    unsigned width[MR_ATTR_CHANNELS], comp[MR_ATTR_CHANNELS];
    double weight[MR_ATTR_CHANNELS];
    float *dst[MR_ATTR_CHANNELS]; /* the working values the channel writes */
    unsigned kind[MR_ATTR_CHANNELS]; /* 0 normal, 1 uv, 2 colour */
    bool has[3];           /* by kind: has a channel here (else interpolated) */
} mr_attr_quadrics;

/* The weighted channels of in, writing into the working copies normals,
 * texcoords, colors (each NULL where in has none), with the options'
 * weights made mesh-free: a normal's or colour's deviation times its
 * weight counts as that many mean edge lengths of the input, a UV
 * deviation as the distance it moves the texture on the surface
 * (sqrt(area / UV area); UVs without area are left out). s: the run as
 * set up, corner its corners' wedges. Returns the channel count (0: no
 * attribute in the cost). */
unsigned mr_attr_quadrics_channels(mr_attr_quadrics *aq, const mr_simplifier *s,
                                   const uint32_t *corner, const mr_mesh *in,
                                   const mr_simplify_options *o, float *normals,
                                   float *texcoords, float *colors);
/* Every wedge's record from the run's triangles (s->m, corner: the wedge
 * of each working corner; wedges are input vertices, vc of them). Each
 * geometric vertex builds its own wedges' records: on `threads` threads,
 * the same bits. */
mr_status mr_attr_quadrics_build(mr_attr_quadrics *aq, const mr_simplifier *s,
                                 const uint32_t *corner, size_t vc, mr_error *err);
void mr_attr_quadrics_free(mr_attr_quadrics *aq);

/* Add to q (relative to o, no weight) the merged pair (a, b)'s quadric in
 * the position at its best values (in b's frame). */
void mr_attr_pair_quadric(const mr_attr_quadrics *aq, uint32_t a, uint32_t b, const double o[3],
                          mr_quadric *q);
/* A hint: wedge w's record is read soon (w may be MR_COLLAPSE_NONE, a
 * vertex without a wedge: then nothing). */
static inline void mr_attr_prefetch(const mr_attr_quadrics *aq, uint32_t w)
{
    if (w == MR_COLLAPSE_NONE)
        return;
    const char *r = (const char *)(aq->rec + (size_t)aq->stride * w);
    for (unsigned b = 0; b < aq->stride * sizeof(float); b += 64)
        __builtin_prefetch(r + b);
    __builtin_prefetch(r + aq->stride * sizeof(float) - 1);
}
/* Merge wedge a's record into wedge b's. */
void mr_attr_merge(mr_attr_quadrics *aq, uint32_t a, uint32_t b);
/* Wedge b's values at position x (normalised): its quadric's best, into
 * the working copies (normals renormalised, colours clamped). */
void mr_attr_place(const mr_attr_quadrics *aq, uint32_t b, const double x[3]);

#endif
