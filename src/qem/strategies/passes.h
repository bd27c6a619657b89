/*
 * What the pass-based strategies share (batched.c, partitioned.c): which
 * edges a pass gathers, how many collapses are still needed, and cost keys.
 * Internal.
 */
#ifndef MR_QEM_PASSES_H
#define MR_QEM_PASSES_H

#include "strategy.h"

/* A cost as the bits of its float (costs are >= 0: the bits order as the
 * values), and back. */
static inline uint32_t mr_float_key(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static inline float mr_key_float(uint32_t u)
{
    float x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/* Collapses still needed to reach the targets. */
static inline size_t mr_needed_collapses(const mr_simplifier *s, const mr_simplify_goal *g)
{
    const mr_collapse_mesh *m = &s->m;
    size_t needed = m->live_vertices > g->vertices ? m->live_vertices - g->vertices : 0;
    if (g->triangles) {
        const size_t t = m->live_triangles > g->triangles
                             ? (m->live_triangles - g->triangles + 1) / 2
                             : 0;
        needed = t < needed ? t : needed;
    }
    return needed;
}

/*
 * Runs the block once for every live edge of triangle t, as (a, b) along
 * one of its half-edges: an inner edge from the half-edge that runs from
 * its smaller end (its other half-edge runs from the larger one), a
 * boundary edge from its only half-edge, whichever way it runs; an inner
 * edge between two boundary vertices never (its collapse would pinch the
 * surface: mr_collapse_valid refuses it, and as a candidate it would hold
 * back the edges around it -- the spokes of a fanned polygon cost nothing
 * and would block its rim). The inner test is written without a branch
 * (which end is the smaller is a coin toss); `take` is false for the
 * half-edges the block must ignore. Lists may hold deleted triangles
 * (mr_collapse_edge_triangles counts right on them).
 */
#define MR_FOR_EACH_TRIANGLE_EDGE(m, t, a, b, take, ...)                                \
    do {                                                                               \
        const uint32_t *tri_ = (m)->tris + 3 * (size_t)(t);                            \
        for (int j_ = 0; j_ < 3; j_++) {                                               \
            const uint32_t a = tri_[j_], b = tri_[j_ == 2 ? 0 : j_ + 1];               \
            bool take = a < b;                                                         \
            if ((m)->flags[a] & (m)->flags[b] & MR_VF_BOUNDARY)                        \
                take = mr_collapse_edge_triangles((m), a, b) == 1;                     \
            __VA_ARGS__                                                                \
        }                                                                              \
    } while (0)

#endif /* MR_QEM_PASSES_H */
