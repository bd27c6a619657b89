/*
 * Sequential greedy quadric-error simplification (Garland & Heckbert 1997),
 * with full-edge collapses to the quadric-optimal position or half-edge
 * collapses as in the filter-priority-queue paper (and OpenMesh's
 * decimater).
 *
 * The queue holds one entry per VERTEX: its cheapest collapse (best[v], the
 * other end, and its cost as the key). A collapse r -> s (r removed, s
 * kept) changes only the quadric and position of s, so afterwards:
 *   - s's candidates are all evaluated anew;
 *   - for every neighbour w of s only the edge (w, s) changed: when it beats
 *     w's cached best, it becomes w's best; when w's cached best pointed at
 *     r or s (whose cost changed) or w had no valid collapse, w's best is
 *     recomputed over all its edges.
 * Validity is checked lazily, when a vertex reaches the top: if its best
 * collapse is invalid there, its best VALID collapse is looked for and the
 * vertex goes back into the queue with that (higher) cost, or leaves the
 * queue until its neighbourhood changes.
 *
 * Geometry is normalised (centre of the referenced vertices' bounding box
 * at the origin, diagonal 1), so a cost is the squared RMS distance to the
 * planes the merged vertex stands for (quadric.h), relative to that
 * diagonal; max_error and stats.max_error are its square root, in world
 * units when error_absolute is set, else relative to the diagonal of the
 * bounding box of all the input's vertices (error_base, the one that
 * `meshreduce info` prints: unreferenced vertices may widen it).
 */
#include "simplify_internal.h"

#include <math.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#define NONE MR_COLLAPSE_NONE


void mr_simplify_options_default(mr_simplify_options *o)
{
    memset(o, 0, sizeof *o);
    o->collapse = MR_COLLAPSE_FULL;
    o->strategy = MR_STRATEGY_BATCHED;
    o->boundary_weight = 1.0;
    o->max_normal_turn = 60.0 * 3.14159265358979323846 / 180.0;
}

void mr_simplified_free(mr_simplified *r)
{
    if (!r)
        return;
    free(r->positions);
    free(r->indices);
    free(r->origin);
    memset(r, 0, sizeof *r);
}

/* ---- costs ---------------------------------------------------------------- */

static inline void load_quadric(const mr_simplifier *s, uint32_t v, mr_quadric *q)
{
    mr_quadric_load(q, &s->q[v]);
}

/*
 * The full collapse of an edge (u, w) with no pinned end: u's quadric moved
 * to w's origin and added to w's, the target x (relative to w) at the
 * optimum of the sum or, where the system is ill-conditioned or its optimum
 * lies far from the edge, at the best point of the edge; returns the cost.
 * Input k of the edge (FREE_*) is in[k * st], x[k] is x[k * xst]. Written
 * without branches (every quotient is computed, then selected), so that a
 * loop over edges vectorises (mr_simplifier_plan_edges); the scalar path
 * calls the same code, so both give the same bits.
 */
enum { FREE_QU = 0, FREE_QW = 11, FREE_PU = 22, FREE_PW = 25, FREE_INPUTS = 28 };

static inline __attribute__((always_inline)) double free_cost(const float *in, size_t st,
                                                              double *x, size_t xst,
                                                              const double box[3])
{
#define IN(k) ((double)in[(size_t)(k) * st])
    const double d0 = IN(FREE_PU) - IN(FREE_PW);
    const double d1 = IN(FREE_PU + 1) - IN(FREE_PW + 1);
    const double d2 = IN(FREE_PU + 2) - IN(FREE_PW + 2);
    const double k0 = -d0, k1 = -d1, k2 = -d2; /* u's origin seen from w */
    double a00 = IN(0), a01 = IN(1), a02 = IN(2), a11 = IN(3), a12 = IN(4), a22 = IN(5);
    double b0 = IN(6), b1 = IN(7), b2 = IN(8), c = IN(9), w = IN(10);
    /* shift u's quadric by k (mr_quadric_shift) */
    const double ad0 = a00 * k0 + a01 * k1 + a02 * k2;
    const double ad1 = a01 * k0 + a11 * k1 + a12 * k2;
    const double ad2 = a02 * k0 + a12 * k1 + a22 * k2;
    c += k0 * ad0 + k1 * ad1 + k2 * ad2 + 2 * (b0 * k0 + b1 * k1 + b2 * k2);
    b0 += ad0;
    b1 += ad1;
    b2 += ad2;
    /* add w's (mr_quadric_add) */
    a00 += IN(FREE_QW + 0); a01 += IN(FREE_QW + 1); a02 += IN(FREE_QW + 2);
    a11 += IN(FREE_QW + 3); a12 += IN(FREE_QW + 4); a22 += IN(FREE_QW + 5);
    b0 += IN(FREE_QW + 6); b1 += IN(FREE_QW + 7); b2 += IN(FREE_QW + 8);
    c += IN(FREE_QW + 9);
    w += IN(FREE_QW + 10);
#undef IN
    /* the optimum (mr_quadric_optimum) */
    const double c00 = a11 * a22 - a12 * a12;
    const double c01 = a02 * a12 - a01 * a22;
    const double c02 = a01 * a12 - a02 * a11;
    const double det = a00 * c00 + a01 * c01 + a02 * c02;
    const double diag = a00 * a11 * a22;
    const double c11 = a00 * a22 - a02 * a02;
    const double c12 = a01 * a02 - a00 * a12;
    const double c22 = a00 * a11 - a01 * a01;
    const double inv = -1.0 / det;
    const double o0 = inv * (c00 * b0 + c01 * b1 + c02 * b2);
    const double o1 = inv * (c01 * b0 + c11 * b1 + c12 * b2);
    const double o2 = inv * (c02 * b0 + c12 * b1 + c22 * b2);
    /* an optimum far from the edge comes from a barely conditioned system;
     * one outside the mesh's bounding box (box: its half extents, w at
     * IN(FREE_PW)) is no place for a vertex, and might leave the float
     * range of the input */
    const double len2 = d0 * d0 + d1 * d1 + d2 * d2;
    const double e0 = o0 - 0.5 * d0, e1 = o1 - 0.5 * d1, e2 = o2 - 0.5 * d2;
    const bool inside = (fabs(o0 + (double)in[(size_t)FREE_PW * st]) <= box[0]) &
                        (fabs(o1 + (double)in[(size_t)(FREE_PW + 1) * st]) <= box[1]) &
                        (fabs(o2 + (double)in[(size_t)(FREE_PW + 2) * st]) <= box[2]);
    const bool ok = (fabs(det) > MR_QUADRIC_DET_EPS * diag) & (diag > 0) &
                    (e0 * e0 + e1 * e1 + e2 * e2 <= 4 * len2) & inside;
    /* the best point of the edge from w (0) to u (d):
     * mr_quadric_segment_optimum */
    const double z = 0;
    const double sd0 = d0 - z, sd1 = d1 - z, sd2 = d2 - z;
    const double sa0 = a00 * sd0 + a01 * sd1 + a02 * sd2;
    const double sa1 = a01 * sd0 + a11 * sd1 + a12 * sd2;
    const double sa2 = a02 * sd0 + a12 * sd1 + a22 * sd2;
    const double dad = sd0 * sa0 + sd1 * sa1 + sd2 * sa2;
    const double g = z * sa0 + z * sa1 + z * sa2 + b0 * sd0 + b1 * sd1 + b2 * sd2;
    const double sq = -g / dad;
    const double s0 = sq < 0 ? 0 : sq;
    const double sc = s0 > 1 ? 1 : s0;
    const double sg0 = g < 0 ? 1 : 0.5;
    const double sg = g > 0 ? 0 : sg0;
    const double s = dad > 0 ? sc : sg;
    const double x0 = ok ? o0 : z + s * sd0;
    const double x1 = ok ? o1 : z + s * sd1;
    const double x2 = ok ? o2 : z + s * sd2;
    x[0] = x0;
    x[xst] = x1;
    x[2 * xst] = x2;
    /* its cost (mr_quadric_eval) */
    const double ax = a00 * x0 + a01 * x1 + a02 * x2;
    const double ay = a01 * x0 + a11 * x1 + a12 * x2;
    const double az = a02 * x0 + a12 * x1 + a22 * x2;
    const double q = x0 * ax + x1 * ay + x2 * az + 2 * (b0 * x0 + b1 * x1 + b2 * x2) + c;
    const double qn = q / w;
    const double err = w > 0 ? qn : 0;
    return err > 0 ? err : 0;
}

/* Gathers free_cost's inputs for edge (u, w) into in[k * st]. */
static inline void free_cost_inputs(const mr_simplifier *s, uint32_t u, uint32_t w, float *in,
                                    size_t st)
{
    const float *qu = &s->q[u].a00, *qw = &s->q[w].a00;
    for (int k = 0; k < 11; k++) {
        in[(size_t)(FREE_QU + k) * st] = qu[k];
        in[(size_t)(FREE_QW + k) * st] = qw[k];
    }
    const float *pu = s->m.pos + 3 * (size_t)u, *pw = s->m.pos + 3 * (size_t)w;
    for (int k = 0; k < 3; k++) {
        in[(size_t)(FREE_PU + k) * st] = pu[k];
        in[(size_t)(FREE_PW + k) * st] = pw[k];
    }
}

/*
 * The collapse rules, one table for both kinds of collapse (as
 * meshoptimizer's kCanCollapse): may vertex u (flags fu) go to where w
 * (flags fw) is -- the half-edge collapse u -> w, or a full collapse that
 * keeps w in place?
 *   locked:           never;
 *   on a boundary:    only onto the boundary (a boundary vertex, locked or
 *                     not, or a non-manifold one, where boundaries may
 *                     meet; an inner edge between two boundary vertices is
 *                     refused by mr_collapse_valid), so it stays on its
 *                     polyline;
 *   on a seam (mr_mesh_simplify's attribute seams): only onto the seam;
 *   any other:        anywhere.
 * A full collapse moves both ends to the optimum when both may go onto
 * each other and neither is on a boundary or seam; to the best point of
 * the edge when both may and they share a boundary or seam (they stay on
 * it); onto the end that may not go when only one may; not at all when
 * neither may.
 */
static inline bool may_go_onto(uint8_t fu, uint8_t fw)
{
    if (fu & MR_VF_LOCKED)
        return false;
    if (fu & MR_VF_BOUNDARY) /* a non-manifold end may be where boundaries meet */
        return (fw & (MR_VF_BOUNDARY | MR_VF_NONMANIFOLD)) != 0;
    if (fu & MR_VF_SEAM)
        return (fw & MR_VF_SEAM) != 0;
    return true;
}

/* Flags that keep a full collapse off the free optimum. */
#define PINNING (MR_VF_LOCKED | MR_VF_BOUNDARY | MR_VF_SEAM)

/*
 * The full collapse of edge (u, w): the target relative to w's position
 * (x) and the cost, by the rules above.
 */
static double full_cost(const mr_simplifier *s, uint32_t u, uint32_t w, double x[3])
{
    const mr_collapse_mesh *m = &s->m;
    const uint8_t fu = m->flags[u], fw = m->flags[w];
    if (!((fu | fw) & PINNING)) {
        float in[FREE_INPUTS];
        free_cost_inputs(s, u, w, in, 1);
        return free_cost(in, 1, x, 1, s->box);
    }
    const bool gu = may_go_onto(fu, fw), gw = may_go_onto(fw, fu);
    if (!gu && !gw) {
        x[0] = x[1] = x[2] = 0; /* no collapse: w stays where it is */
        return INFINITY;
    }
    mr_quadric qu, qw;
    load_quadric(s, u, &qu);
    load_quadric(s, w, &qw);
    double pu[3], pw[3];
    mr_collapse_load(m, u, pu);
    mr_collapse_load(m, w, pw);
    const double d[3] = {pu[0] - pw[0], pu[1] - pw[1], pu[2] - pw[2]};
    /* qu measured from pw: qu(x'') = old qu(x'' + pw - pu) */
    const double back[3] = {-d[0], -d[1], -d[2]};
    mr_quadric_shift(&qu, back);
    mr_quadric_add(&qu, &qw);
    if (!gu) { /* w goes onto u */
        x[0] = d[0];
        x[1] = d[1];
        x[2] = d[2];
    } else if (!gw) { /* u goes onto w */
        x[0] = x[1] = x[2] = 0;
    } else {
        /* two ends on one boundary or seam: stay on its edge */
        const double zero[3] = {0, 0, 0};
        mr_quadric_segment_optimum(&qu, zero, d, x);
    }
    double err = mr_quadric_eval(&qu, x);
    err = qu.w > 0 ? err / qu.w : 0;
    return err > 0 ? err : 0;
}

/* The half-edge collapse u -> w: u moves onto w. */
static double half_cost(const mr_simplifier *s, uint32_t u, uint32_t w)
{
    const mr_collapse_mesh *m = &s->m;
    if (!may_go_onto(m->flags[u], m->flags[w]))
        return INFINITY;
    mr_quadric qu, qw;
    load_quadric(s, u, &qu);
    load_quadric(s, w, &qw);
    const double d[3] = {(double)m->pos[3 * w] - m->pos[3 * u],
                         (double)m->pos[3 * w + 1] - m->pos[3 * u + 1],
                         (double)m->pos[3 * w + 2] - m->pos[3 * u + 2]};
    const double wsum = qu.w + qw.w;
    double err = mr_quadric_eval(&qu, d) + qw.c;
    err = wsum > 0 ? err / wsum : 0;
    return err > 0 ? err : 0;
}

/* Cost of collapsing u along edge (u, w) for u's queue entry. */
static inline double edge_cost(const mr_simplifier *s, uint32_t u, uint32_t w)
{
    double x[3];
    return s->half ? half_cost(s, u, w) : full_cost(s, u, w, x);
}

/* ---- candidates ------------------------------------------------------------ */

/*
 * Calls visit(w) for every neighbour w of u: the vertex after u in each of
 * its triangles, which covers every inner edge once; plus the vertex before
 * u when both ends are on a boundary (a boundary edge is seen from one
 * side only). Some edges may be visited twice, which is harmless.
 */
#define FOR_EACH_NEIGHBOUR(s, u, w, ...)                                             \
    do {                                                                              \
        const mr_collapse_mesh *m_ = &(s)->m;                                         \
        const uint32_t *list_ = mr_collapse_vertex_tris(m_, (u));                     \
        const uint32_t n_ = m_->count[(u)];                                           \
        const bool ub_ = (m_->flags[(u)] & (MR_VF_BOUNDARY | MR_VF_SEAM)) != 0;       \
        for (uint32_t i_ = 0; i_ < n_; i_++) {                                        \
            const uint32_t k_ = list_[i_] % 3;                                        \
            const uint32_t *t_ = m_->tris + (list_[i_] - k_);                         \
            {                                                                         \
                const uint32_t w = t_[k_ == 2 ? 0 : k_ + 1];                          \
                __VA_ARGS__                                                           \
            }                                                                         \
            if (ub_) {                                                                \
                const uint32_t w = t_[k_ == 0 ? 2 : k_ - 1];                          \
                if (m_->flags[w] & (MR_VF_BOUNDARY | MR_VF_SEAM)) {                   \
                    __VA_ARGS__                                                       \
                }                                                                     \
            }                                                                         \
        }                                                                             \
    } while (0)

/* u's cheapest collapse (only valid ones when check_valid). Ties go to the
 * smaller neighbour id. */
static double best_collapse(mr_simplifier *s, uint32_t u, bool check_valid, uint32_t *best)
{
    double best_cost = INFINITY;
    uint32_t best_w = NONE;
    FOR_EACH_NEIGHBOUR(s, u, w, {
        double c = edge_cost(s, u, w);
        if (c < best_cost || (c == best_cost && c < INFINITY && w < best_w)) {
            if (!check_valid || mr_simplifier_valid(s, u, w, NULL)) {
                best_cost = c;
                best_w = w;
            }
        }
    });
    *best = best_w;
    return best_cost;
}

static void requeue(mr_simplifier *s, uint32_t u, bool check_valid)
{
    s->stale[u] = 0;
    uint32_t w;
    double c = best_collapse(s, u, check_valid, &w);
    s->best[u] = w;
    if (w == NONE)
        mr_heap_remove(&s->heap, u);
    else
        mr_heap_update(&s->heap, u, (float)c);
}

/* ---- one collapse ---------------------------------------------------------- */

/*
 * The collapse behind u's queue entry (u, w): which end goes (*r), which
 * stays (*k) and where it goes (target, normalised). For full collapses a
 * pinned end stays; else u goes.
 */
static double plan(const mr_simplifier *s, uint32_t u, uint32_t w, uint32_t *r, uint32_t *k,
                   double target[3])
{
    const mr_collapse_mesh *m = &s->m;
    if (s->half) {
        *r = u;
        *k = w;
        mr_collapse_load(m, w, target);
        return half_cost(s, u, w);
    }
    double x[3];
    double c = full_cost(s, u, w, x);
    double pw[3];
    mr_collapse_load(m, w, pw);
    target[0] = pw[0] + x[0];
    target[1] = pw[1] + x[1];
    target[2] = pw[2] + x[2];
    if (!may_go_onto(m->flags[u], m->flags[w]) && may_go_onto(m->flags[w], m->flags[u])) {
        *r = w;
        *k = u;
        mr_collapse_load(m, u, target); /* exactly u's position */
    } else {
        *r = u;
        *k = w;
    }
    return c;
}

bool mr_simplifier_valid(mr_simplifier *s, uint32_t u, uint32_t w, double *cost)
{
    uint32_t r, k;
    double target[3];
    double c = plan(s, u, w, &r, &k, target);
    if (cost)
        *cost = c;
    if (!(c < INFINITY))
        return false;
    if (!mr_collapse_valid(&s->m, r, k, target, &s->limits))
        return false;
    return !s->attr_valid || s->attr_valid(s, r, k);
}

/* Merge r's quadric into k's, both moved to the target's origin. */
static void merge_quadrics(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3])
{
    const mr_collapse_mesh *m = &s->m;
    mr_quadric qr, qk;
    load_quadric(s, r, &qr);
    load_quadric(s, k, &qk);
    /* Stored positions are floats: measure from the target as stored. */
    const double t[3] = {(float)target[0], (float)target[1], (float)target[2]};
    const double dr[3] = {t[0] - m->pos[3 * r], t[1] - m->pos[3 * r + 1],
                          t[2] - m->pos[3 * r + 2]};
    const double dk[3] = {t[0] - m->pos[3 * k], t[1] - m->pos[3 * k + 1],
                          t[2] - m->pos[3 * k + 2]};
    mr_quadric_shift(&qr, dr);
    mr_quadric_shift(&qk, dk);
    mr_quadric_add(&qk, &qr);
    mr_quadric_store(&s->q[k], &qk);
}

/* Refresh the queue around k after a collapse of r into it. */
static void update_around(mr_simplifier *s, uint32_t r, uint32_t k)
{
    mr_heap_remove(&s->heap, r);
    s->best[r] = NONE;
    double kbest = INFINITY;
    uint32_t kw = NONE;
    const mr_collapse_mesh *m = &s->m;
    FOR_EACH_NEIGHBOUR(s, k, w, {
        double x[3];
        double c, cw;
        if (s->half) {
            c = half_cost(s, k, w);
            cw = half_cost(s, w, k);
        } else {
            c = full_cost(s, k, w, x);
            cw = c;
        }
        if (c < kbest || (c == kbest && c < INFINITY && w < kw)) {
            kbest = c;
            kw = w;
        }
        /* w's other edges are unchanged, so its old key is a lower bound
         * of them: when the new edge (w, k) beats it, it is w's best;
         * when w's best was r or k and the new edge costs more, w keeps
         * its old key as a lower bound and is marked stale -- it is
         * recomputed only if it reaches the top of the queue, which most
         * never do before their neighbourhood changes again. */
        const uint32_t b = s->best[w];
        if (m->flags[w] & MR_VF_REMOVED) {
            /* nothing */
        } else if (b == NONE) {
            if (cw < INFINITY) {
                s->best[w] = k;
                s->stale[w] = 1;
                mr_heap_update(&s->heap, w, (float)cw);
            }
        } else {
            const float old = mr_heap_key(&s->heap, w);
            if ((float)cw < old || ((float)cw == old && k < b)) {
                s->best[w] = k;
                mr_heap_update(&s->heap, w, (float)cw);
            } else if (b == r || b == k) {
                s->stale[w] = 1;
            }
        }
    });
    s->best[k] = kw;
    if (kw == NONE)
        mr_heap_remove(&s->heap, k);
    else
        mr_heap_update(&s->heap, k, (float)kbest);
}


/* ---- full collapses: one queue entry per edge ------------------------------ */

/*
 * Full collapses queue EDGES. Ids are half-edges h = 3t + j, the edge from
 * corner j of triangle t to corner j + 1; an undirected edge is queued
 * under its representative, the smaller id of its two half-edges (its only
 * one on a boundary). Triangles are never renumbered -- a collapse u -> v
 * only relabels corners -- so a representative changes only where a
 * half-edge dies (a deleted triangle) or two edges merge (u's and v's edges
 * to an opposite vertex of the collapse), both around the survivor v;
 * there every edge is re-evaluated anyway (its cost changed), and the
 * non-representative half-edge leaves the queue. An edge found invalid at
 * the top leaves the queue and flags its ends BLOCKED; a collapse whose
 * ring holds a flagged vertex re-queues that vertex's edges.
 */
#define he_dst mr_collapse_he_dst

/* The half-edge b -> a opposite h = a -> b, or NONE (boundary); searched
 * in a's list. */
static uint32_t he_twin(const mr_collapse_mesh *m, uint32_t h)
{
    const uint32_t a = m->tris[h], b = he_dst(m, h), t = h / 3;
    if (m->count[b] < m->count[a]) {
        /* the shorter list: b's corner whose next vertex is a starts it */
        const uint32_t *lb = mr_collapse_vertex_tris(m, b);
        for (uint32_t i = 0, n = m->count[b]; i < n; i++) {
            const uint32_t j = lb[i] % 3, base = lb[i] - j;
            if (m->tris[base + mr_local_next(j)] == a && base != 3 * t)
                return lb[i];
        }
        return NONE;
    }
    const uint32_t *list = mr_collapse_vertex_tris(m, a);
    for (uint32_t i = 0, n = m->count[a]; i < n; i++) {
        const uint32_t j = list[i] % 3, base = list[i] - j, p = mr_local_prev(j);
        if (m->tris[base + p] == b && base != 3 * t)
            return base + p;
    }
    return NONE;
}

/* The full collapse of edge (a, b): a pinned end stays, else the end with
 * the larger id goes. Symmetric in a and b. */
static double plan_edge(const mr_simplifier *s, uint32_t a, uint32_t b, uint32_t *r,
                        uint32_t *k, double target[3])
{
    const mr_collapse_mesh *m = &s->m;
    /* the end that may not go stays; else the larger id goes */
    const bool ga = may_go_onto(m->flags[a], m->flags[b]),
               gb = may_go_onto(m->flags[b], m->flags[a]);
    uint32_t rr, kk;
    if (ga != gb) {
        kk = ga ? b : a;
        rr = ga ? a : b;
    } else {
        kk = a < b ? a : b;
        rr = a < b ? b : a;
    }
    double x[3];
    const double c = full_cost(s, rr, kk, x);
    target[0] = (double)m->pos[3 * kk] + x[0];
    target[1] = (double)m->pos[3 * kk + 1] + x[1];
    target[2] = (double)m->pos[3 * kk + 2] + x[2];
    *r = rr;
    *k = kk;
    return c;
}

double mr_simplifier_plan_edge(const mr_simplifier *s, uint32_t a, uint32_t b, uint32_t *r,
                               uint32_t *k, double target[3])
{
    if (!s->half)
        return plan_edge(s, a, b, r, k, target);
    const double ca = half_cost(s, a, b), cb = half_cost(s, b, a);
    const bool a_goes = ca < cb || (ca == cb && a > b); /* ties: the larger id goes */
    *r = a_goes ? a : b;
    *k = a_goes ? b : a;
    mr_collapse_load(&s->m, *k, target);
    return a_goes ? ca : cb;
}

/* Edges per batch of mr_simplifier_plan_edges' vector loop. */
#define COST_BATCH 64

/* The vector loop: costs of n <= COST_BATCH free edges whose inputs are in
 * in[k * COST_BATCH + i]. */
MR_VECTOR_CLONES static void free_costs(const float *in, size_t n, double *cost, double *x,
                                        const double box[3])
{
    const double bx[3] = {box[0], box[1], box[2]};
#pragma omp simd
    for (size_t i = 0; i < n; i++)
        cost[i] = free_cost(in + i, COST_BATCH, x + i, COST_BATCH, bx);
}

/*
 * free_cost's inputs of the edges (u[l], w[l]), l < n, into the batch's
 * rows in[k * COST_BATCH + l]: four edges at a time, each quadric (11
 * floats, read as 12) and position (3, read as 4) loaded as vectors and
 * transposed into four lanes of each row. The same floats as
 * free_cost_inputs, a third of the instructions.
 */
static void pack_inputs(const mr_simplifier *s, const uint32_t *u, const uint32_t *w, size_t n,
                        float *in)
{
    size_t l = 0;
#if defined(__SSE2__)
    const float *q = &s->q[0].a00, *pos = s->m.pos;
    const size_t qs = sizeof *s->q / sizeof(float);
    for (; l + 4 <= n; l += 4) {
        for (int end = 0; end < 2; end++) {
            const uint32_t *id = end ? w + l : u + l;
            float *row = in + (size_t)(end ? FREE_QW : FREE_QU) * COST_BATCH + l;
            const float *r0 = q + qs * id[0], *r1 = q + qs * id[1], *r2 = q + qs * id[2],
                        *r3 = q + qs * id[3];
            for (int part = 0; part < 3; part++) {
                __m128 x0 = _mm_loadu_ps(r0 + 4 * part), x1 = _mm_loadu_ps(r1 + 4 * part),
                       x2 = _mm_loadu_ps(r2 + 4 * part), x3 = _mm_loadu_ps(r3 + 4 * part);
                _MM_TRANSPOSE4_PS(x0, x1, x2, x3);
                float *o = row + (size_t)(4 * part) * COST_BATCH;
                _mm_storeu_ps(o, x0);
                _mm_storeu_ps(o + COST_BATCH, x1);
                _mm_storeu_ps(o + 2 * COST_BATCH, x2);
                if (part < 2) /* the 12th float is the next record's */
                    _mm_storeu_ps(o + 3 * COST_BATCH, x3);
            }
            const float *p0 = pos + 3 * (size_t)id[0], *p1 = pos + 3 * (size_t)id[1],
                        *p2 = pos + 3 * (size_t)id[2], *p3 = pos + 3 * (size_t)id[3];
            __m128 x0 = _mm_loadu_ps(p0), x1 = _mm_loadu_ps(p1), x2 = _mm_loadu_ps(p2),
                   x3 = _mm_loadu_ps(p3);
            _MM_TRANSPOSE4_PS(x0, x1, x2, x3);
            (void)x3;
            float *o = in + (size_t)(end ? FREE_PW : FREE_PU) * COST_BATCH + l;
            _mm_storeu_ps(o, x0);
            _mm_storeu_ps(o + COST_BATCH, x1);
            _mm_storeu_ps(o + 2 * COST_BATCH, x2);
        }
    }
#endif
    for (; l < n; l++)
        free_cost_inputs(s, u[l], w[l], in + l, COST_BATCH);
}

/* Edge i of mr_simplifier_plan_edges through the one-edge path. */
static void plan_one(const mr_simplifier *s, uint32_t a, uint32_t b, size_t i, double *cost,
                     uint32_t *r, uint32_t *k, double *target)
{
    uint32_t rr, kk;
    double t[3];
    cost[i] = mr_simplifier_plan_edge(s, a, b, &rr, &kk, t);
    if (r) {
        r[i] = rr;
        k[i] = kk;
        memcpy(target + 3 * i, t, sizeof t);
    }
}

void mr_simplifier_plan_edges(const mr_simplifier *s, size_t n, const uint32_t *a,
                              const uint32_t *b, double *cost, uint32_t *r, uint32_t *k,
                              double *target)
{
    const mr_collapse_mesh *m = &s->m;
    if (s->half) {
        for (size_t i = 0; i < n; i++)
            plan_one(s, a[i], b[i], i, cost, r, k, target);
        return;
    }
    const uint8_t pin = PINNING;
    float in[FREE_INPUTS * COST_BATCH];
    double out[COST_BATCH], x[3 * COST_BATCH];
    uint32_t lane[COST_BATCH], lk[COST_BATCH], lr[COST_BATCH];
    for (size_t i0 = 0; i0 < n; i0 += COST_BATCH) {
        const size_t i1 = n - i0 < COST_BATCH ? n : i0 + COST_BATCH;
        uint8_t any = 0;
        for (size_t i = i0; i < i1; i++)
            any |= m->flags[a[i]] | m->flags[b[i]];
        if (!(any & pin)) {
            /* the usual batch: no pinned end, every edge in its own lane */
            const size_t nl = i1 - i0;
            for (size_t l = 0; l < nl; l++) {
                const uint32_t ea = a[i0 + l], eb = b[i0 + l];
                lr[l] = ea < eb ? eb : ea;
                lk[l] = ea < eb ? ea : eb;
            }
            pack_inputs(s, lr, lk, nl, in);
            free_costs(in, nl, cost + i0, x, s->box);
            if (r) {
                for (size_t l = 0; l < nl; l++) {
                    const size_t i = i0 + l;
                    const uint32_t kk = lk[l];
                    r[i] = lr[l];
                    k[i] = kk;
                    target[3 * i] = (double)m->pos[3 * (size_t)kk] + x[l];
                    target[3 * i + 1] = (double)m->pos[3 * (size_t)kk + 1] + x[COST_BATCH + l];
                    target[3 * i + 2] =
                        (double)m->pos[3 * (size_t)kk + 2] + x[2 * COST_BATCH + l];
                }
            }
            continue;
        }
        size_t nl = 0;
        for (size_t i = i0; i < i1; i++) {
            const uint32_t ea = a[i], eb = b[i];
            if ((m->flags[ea] | m->flags[eb]) & pin) {
                plan_one(s, ea, eb, i, cost, r, k, target);
                continue;
            }
            /* plan_edge: the larger id goes */
            lr[nl] = ea < eb ? eb : ea;
            lk[nl] = ea < eb ? ea : eb;
            lane[nl++] = (uint32_t)(i - i0);
        }
        pack_inputs(s, lr, lk, nl, in);
        free_costs(in, nl, out, x, s->box);
        for (size_t l = 0; l < nl; l++) {
            const size_t i = i0 + lane[l];
            cost[i] = out[l];
            if (r) {
                /* as plan_edge: the kept end's position plus x */
                const uint32_t kk = lk[l];
                r[i] = lr[l];
                k[i] = kk;
                target[3 * i] = (double)m->pos[3 * (size_t)kk] + x[l];
                target[3 * i + 1] = (double)m->pos[3 * (size_t)kk + 1] + x[COST_BATCH + l];
                target[3 * i + 2] = (double)m->pos[3 * (size_t)kk + 2] + x[2 * COST_BATCH + l];
            }
        }
    }
}

void mr_simplifier_collapse(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3])
{
    if (s->attr_apply)
        s->attr_apply(s, r, k, target);
    merge_quadrics(s, r, k, target);
    mr_collapse_reserve(&s->m, r, k);
    mr_collapse_apply(&s->m, r, k, target);
}

/* Queue, re-key or drop the edge of half-edge h, whose twin is tw. */
static void edge_enqueue(mr_simplifier *s, uint32_t h, uint32_t tw)
{
    uint32_t rep = h;
    if (tw != NONE) {
        rep = tw < h ? tw : h;
        mr_heap_remove(&s->heap, tw < h ? h : tw);
    }
    uint32_t r, k;
    double target[3];
    const double c = plan_edge(s, s->m.tris[h], he_dst(&s->m, h), &r, &k, target);
    if (c < INFINITY)
        mr_heap_update(&s->heap, rep, (float)c);
    else
        mr_heap_remove(&s->heap, rep);
}

static int u64_cmp(const void *pa, const void *pb)
{
    const uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return a < b ? -1 : a > b;
}

/* In keys sorted as (key << 32 | index), the last index with this key
 * other than `skip` (as the pairwise scan finds the last), or NONE. */
static uint32_t find_keyed(const uint64_t *keys, uint32_t n, uint32_t key, uint32_t skip)
{
    uint32_t lo = 0, hi = n;
    const uint64_t want = (uint64_t)key << 32;
    while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (keys[mid] < want)
            lo = mid + 1;
        else
            hi = mid;
    }
    uint32_t found = NONE;
    for (uint32_t i = lo; i < n && keys[i] >> 32 == key; i++)
        if ((uint32_t)keys[i] != skip)
            found = (uint32_t)keys[i];
    return found;
}

/* Every edge at k anew: each inner edge is k's outgoing half-edge in one
 * triangle and incoming in another; a boundary edge has one of them. */
static void edge_update_around(mr_simplifier *s, uint32_t k)
{
    const mr_collapse_mesh *m = &s->m;
    const uint32_t *list = mr_collapse_vertex_tris(m, k);
    const uint32_t n = m->count[k];
    if (n <= 2 * MR_COLLAPSE_MAX_DEGREE) {
        /* The corners of k and its next and previous vertices, gathered
         * once: the twin search below is then a scan of two small arrays. */
        uint32_t cj[2 * MR_COLLAPSE_MAX_DEGREE], nx[2 * MR_COLLAPSE_MAX_DEGREE],
            pv[2 * MR_COLLAPSE_MAX_DEGREE];
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t j = list[i] % 3;
            const uint32_t *tri = m->tris + (list[i] - j);
            cj[i] = j;
            nx[i] = tri[mr_local_next(j)];
            pv[i] = tri[mr_local_prev(j)];
        }
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t x = nx[i], p = pv[i], j = cj[i];
            uint32_t tw_out = NONE;
            bool in_twinned = false;
            for (uint32_t i2 = 0; i2 < n; i2++) {
                if (i2 == i)
                    continue;
                if (pv[i2] == x)
                    tw_out = list[i2] - cj[i2] + (cj[i2] == 0 ? 2 : cj[i2] - 1);
                if (nx[i2] == p)
                    in_twinned = true;
            }
            const uint32_t base = list[i] - j;
            edge_enqueue(s, base + j, tw_out);
            if (!in_twinned)
                edge_enqueue(s, base + mr_local_prev(j), NONE);
        }
        return;
    }
    /* A large fan: the same twins by sorting k's triangles by the vertex
     * before k and by the one after it (O(n log n) instead of every
     * pair). */
    uint64_t *byprev = mr_alloc_array(2 * (size_t)n, sizeof *byprev);
    if (!byprev) {
        /* no memory: the edges at k requeued without their twins, which
         * only queues an inner edge from both sides */
        for (uint32_t i = 0; i < n; i++)
            edge_enqueue(s, list[i], NONE);
        return;
    }
    uint64_t *bynext = byprev + n;
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t j = list[i] % 3, *tri = m->tris + (list[i] - j);
        byprev[i] = (uint64_t)tri[mr_local_prev(j)] << 32 | i;
        bynext[i] = (uint64_t)tri[mr_local_next(j)] << 32 | i;
    }
    qsort(byprev, n, sizeof *byprev, u64_cmp);
    qsort(bynext, n, sizeof *bynext, u64_cmp);
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t j = list[i] % 3, t = list[i] / 3;
        const uint32_t *tri = m->tris + 3 * (size_t)t;
        const uint32_t jn = mr_local_next(j), jp = mr_local_prev(j);
        const uint32_t x = tri[jn], p = tri[jp];
        /* k -> x is twinned by the triangle whose vertex before k is x
         * (its half-edge x -> k, from the corner before k's); p -> k by
         * one whose vertex after k is p */
        uint32_t tw_out = NONE;
        const uint32_t i2 = find_keyed(byprev, n, x, i);
        if (i2 != NONE) {
            const uint32_t j2 = list[i2] % 3;
            tw_out = list[i2] - j2 + mr_local_prev(j2);
        }
        edge_enqueue(s, 3 * t + j, tw_out);
        if (find_keyed(bynext, n, p, i) == NONE)
            edge_enqueue(s, 3 * t + jp, NONE);
    }
    free(byprev);
}

/* Re-queue the edges of a BLOCKED vertex x that are out of the queue
 * (those at k were just re-evaluated). */
static void edge_requeue_vertex(mr_simplifier *s, uint32_t x, uint32_t k)
{
    const mr_collapse_mesh *m = &s->m;
    const uint32_t *list = mr_collapse_vertex_tris(m, x);
    for (uint32_t i = 0, n = m->count[x]; i < n; i++) {
        const uint32_t j = list[i] % 3, t = list[i] / 3;
        const uint32_t *tri = m->tris + 3 * (size_t)t;
        const uint32_t jn = mr_local_next(j), jp = mr_local_prev(j);
        if (tri[jn] != k) {
            const uint32_t h = 3 * t + j, tw = he_twin(m, h);
            const uint32_t rep = tw != NONE && tw < h ? tw : h;
            if (!mr_heap_contains(&s->heap, rep))
                edge_enqueue(s, h, tw);
        }
        if (tri[jp] != k) {
            const uint32_t h = 3 * t + jp;
            if (!mr_heap_contains(&s->heap, h) && he_twin(m, h) == NONE)
                edge_enqueue(s, h, NONE);
        }
    }
}

static void edge_unblock_ring(mr_simplifier *s, uint32_t k)
{
    mr_collapse_mesh *m = &s->m;
    m->flags[k] &= (uint8_t)~MR_VF_BLOCKED;
    const uint32_t *list = mr_collapse_vertex_tris(m, k);
    for (uint32_t i = 0, n = m->count[k]; i < n; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        for (int c = 0; c < 3; c++) {
            const uint32_t x = tri[c];
            if (m->flags[x] & MR_VF_BLOCKED) {
                m->flags[x] &= (uint8_t)~MR_VF_BLOCKED;
                edge_requeue_vertex(s, x, k);
            }
        }
    }
}

/* The queue of edges: the representatives are found first (a bit each),
 * so the heap's items are sized to the edge count; built in O(n). */
static mr_status edge_fill_queue(mr_simplifier *s, mr_error *err)
{
    const mr_collapse_mesh *m = &s->m;
    const size_t nh = 3 * m->triangle_count;
    /* The bits live in the free end of refs when it has room (it is
     * unused until the first collapse), so they add nothing to the peak. */
    const size_t words = nh / 64 + 1;
    uint64_t *rep = NULL, *own = NULL;
    if ((m->refs_capacity - m->refs_size) * sizeof *m->refs >= words * sizeof *rep + 8) {
        uintptr_t a = (uintptr_t)(m->refs + m->refs_size);
        a = (a + 7) & ~(uintptr_t)7;
        rep = (uint64_t *)a;
        memset(rep, 0, words * sizeof *rep);
    } else {
        rep = own = mr_calloc_array(words, sizeof *rep);
        if (!rep)
            return mr_fail_nomem(err, NULL, nh / 8);
    }
    size_t edges = 0;
    for (size_t h = 0; h < nh; h++) {
        if (m->tris[h - h % 3] == NONE)
            continue;
        const uint32_t tw = he_twin(m, (uint32_t)h);
        if (tw == NONE || tw > h) {
            rep[h / 64] |= 1ull << (h % 64);
            edges++;
        }
    }
    mr_status st = mr_heap_init_sized(&s->heap, nh, edges, err);
    if (st != MR_OK) {
        free(own);
        return st;
    }
    for (size_t h = 0; h < nh; h++) {
        if (!(rep[h / 64] >> (h % 64) & 1))
            continue;
        uint32_t r, k;
        double target[3];
        const double c = plan_edge(s, m->tris[h], he_dst(m, (uint32_t)h), &r, &k, target);
        if (c < INFINITY)
            mr_heap_append(&s->heap, (uint32_t)h, (float)c);
    }
    free(own);
    mr_heap_heapify(&s->heap);
    return MR_OK;
}

/* ---- setup ----------------------------------------------------------------- */

/* Triangles of one vertex that inner_quadric takes at once, and the
 * length of its rows (room for three lanes of padding). */
#define INNER_FAN 32
#define INNER_ROW (INNER_FAN + 4)

/* Each triangle's area-weighted plane term c c^T / (2 |c|) (6 entries)
 * and area |c| / 2 for the cross products c of the edges (u, w) in
 * in[k * INNER_ROW + i] (u: k = 0..2, w: 3..5); zero for a triangle
 * without area. The same expressions as initial_quadric's scalar loop,
 * so the same bits. */
MR_VECTOR_CLONES static void plane_terms(double *in, size_t n, double *out)
{
#pragma omp simd
    for (size_t i = 0; i < n; i++) {
        const double u0 = in[i], u1 = in[INNER_ROW + i], u2 = in[2 * INNER_ROW + i];
        const double w0 = in[3 * INNER_ROW + i], w1 = in[4 * INNER_ROW + i],
                     w2 = in[5 * INNER_ROW + i];
        const double c0 = u1 * w2 - u2 * w1, c1 = u2 * w0 - u0 * w2, c2 = u0 * w1 - u1 * w0;
        const double len = sqrt(c0 * c0 + c1 * c1 + c2 * c2);
        const bool area = len > 0;
        const double f = 0.5 / (area ? len : 1.0);
        out[i] = area ? f * c0 * c0 : 0;
        out[INNER_ROW + i] = area ? f * c0 * c1 : 0;
        out[2 * INNER_ROW + i] = area ? f * c0 * c2 : 0;
        out[3 * INNER_ROW + i] = area ? f * c1 * c1 : 0;
        out[4 * INNER_ROW + i] = area ? f * c1 * c2 : 0;
        out[5 * INNER_ROW + i] = area ? f * c2 * c2 : 0;
        out[6 * INNER_ROW + i] = area ? 0.5 * len : 0;
    }
}

/* initial_quadric of a vertex with no constraint planes and at most
 * INNER_FAN triangles: the plane terms computed in one vector loop, then
 * summed in list order as the scalar loop does (adding a zero for a
 * triangle without area changes no bit: the sums start at +0). */
static void inner_quadric(mr_simplifier *s, uint32_t v)
{
    const mr_collapse_mesh *m = &s->m;
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    const uint32_t n = m->count[v];
    double in[6 * INNER_ROW], t[7 * INNER_ROW];
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        const float *p0 = m->pos + 3 * (size_t)tri[0], *p1 = m->pos + 3 * (size_t)tri[1],
                    *p2 = m->pos + 3 * (size_t)tri[2];
        for (int k = 0; k < 3; k++) {
            const double o = p0[k];
            in[k * INNER_ROW + i] = (double)p1[k] - o;
            in[(3 + k) * INNER_ROW + i] = (double)p2[k] - o;
        }
    }
    /* whole vectors only: padding lanes have no area */
    for (int k = 0; k < 6; k++) {
        double *row = in + k * INNER_ROW + n;
        row[0] = row[1] = row[2] = 0;
    }
    plane_terms(in, (n + 3) & ~3u, t);
    mr_quadric q;
    mr_quadric_zero(&q);
    for (uint32_t i = 0; i < n; i++) {
        q.a00 += t[i];
        q.a01 += t[INNER_ROW + i];
        q.a02 += t[2 * INNER_ROW + i];
        q.a11 += t[3 * INNER_ROW + i];
        q.a12 += t[4 * INNER_ROW + i];
        q.a22 += t[5 * INNER_ROW + i];
        q.w += t[6 * INNER_ROW + i];
    }
    mr_quadric_store(&s->q[v], &q);
}

/* Initial quadric of v, relative to v's position: the planes of its
 * triangles (all through v) and the constraint planes of its boundary
 * edges. */
static void initial_quadric(mr_simplifier *s, uint32_t v, double boundary_weight)
{
    const mr_collapse_mesh *m = &s->m;
    const bool border = (m->flags[v] & MR_VF_BOUNDARY) && boundary_weight > 0;
    if (!border && m->count[v] <= INNER_FAN) {
        inner_quadric(s, v);
        return;
    }
    mr_quadric q;
    mr_quadric_zero(&q);
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    double pv[3];
    mr_collapse_load(m, v, pv);
    for (uint32_t i = 0; i < m->count[v]; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        double p[3][3];
        for (int k = 0; k < 3; k++)
            mr_collapse_load(m, tri[k], p[k]);
        /* area * n n^T for the unit normal n = c / |c| and area |c| / 2 of
         * the cross product c: c c^T / (2 |c|), one division */
        const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
        const double w[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
        const double c[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                             u[0] * w[1] - u[1] * w[0]};
        const double len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        if (!(len > 0))
            continue; /* no area, no normal: nothing to add */
        const double f = 0.5 / len;
        q.a00 += f * c[0] * c[0];
        q.a01 += f * c[0] * c[1];
        q.a02 += f * c[0] * c[2];
        q.a11 += f * c[1] * c[1];
        q.a12 += f * c[1] * c[2];
        q.a22 += f * c[2] * c[2];
        q.w += 0.5 * len;
        if (!border)
            continue;
        const double n[3] = {c[0] / len, c[1] / len, c[2] / len};
        const uint32_t k = list[i] % 3;
        const uint32_t ends[2] = {tri[(k + 1) % 3], tri[(k + 2) % 3]};
        for (int e = 0; e < 2; e++) {
            if (mr_collapse_edge_triangles(m, v, ends[e]) != 1)
                continue;
            const double o[3] = {0, 0, 0};
            double b[3];
            mr_collapse_load(m, ends[e], b);
            b[0] -= pv[0];
            b[1] -= pv[1];
            b[2] -= pv[2];
            mr_quadric_add_edge_constraint(&q, o, b, n, boundary_weight);
        }
    }
    mr_quadric_store(&s->q[v], &q);
}

void mr_simplifier_free(mr_simplifier *s)
{
    mr_collapse_mesh_free(&s->m);
    mr_heap_free(&s->heap);
    free(s->q);
    free(s->best);
    free(s->stale);
    free(s->cand);
    free(s->mark);
    free(s->hist);
    free(s->best64);
    memset(s, 0, sizeof *s);
}

static bool is_finite(double x) { return x == x && x - x == 0; }

mr_status mr_simplify_check_options(const mr_simplify_options *o, size_t input_vertices,
                                    size_t input_triangles, mr_error *err)
{
    if (!o)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: options are required (a target must be set)");
    if (!is_finite(o->target_ratio) || o->target_ratio < 0 || o->target_ratio > 1)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: target ratio %g is not in (0, 1]", o->target_ratio);
    if (!is_finite(o->max_error) || o->max_error < 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: max error %g must be a finite distance >= 0",
                             o->max_error);
    if (!is_finite(o->boundary_weight) || o->boundary_weight < 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: boundary weight %g must be finite and >= 0",
                             o->boundary_weight);
    if (!is_finite(o->max_normal_turn) || o->max_normal_turn <= 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: max normal turn %g must be a positive angle (radians)",
                             o->max_normal_turn);
    if (o->collapse != MR_COLLAPSE_FULL && o->collapse != MR_COLLAPSE_HALF)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: unknown collapse kind %d", (int)o->collapse);
    if (o->strategy != MR_STRATEGY_GREEDY && o->strategy != MR_STRATEGY_BATCHED)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: unknown strategy %d", (int)o->strategy);
    if (o->target_ratio == 0 && o->target_vertices == 0 && o->target_triangles == 0 &&
        o->max_error == 0 && !o->until_error)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: no target: set a target ratio, vertex or triangle "
                             "count, a max error, or until_error");
    if (o->target_triangles > input_triangles)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: target of %zu triangles exceeds the input's %zu",
                             o->target_triangles, input_triangles);
    if (o->target_vertices > input_vertices)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: target of %zu vertices exceeds the input's %zu "
                             "referenced vertices",
                             o->target_vertices, input_vertices);
    return MR_OK;
}

mr_status mr_simplifier_init(mr_simplifier *s, const float *positions, size_t stride,
                             size_t vertex_count, const uint32_t *indices,
                             size_t triangle_count, const mr_simplify_options *o,
                             const uint8_t *extra_flags, mr_error *err)
{
    memset(s, 0, sizeof *s);
    if (!positions && vertex_count)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "simplify: positions are NULL");
    if (!indices && triangle_count)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "simplify: indices are NULL");
    if (stride == 0)
        stride = 3 * sizeof(float);
    if (stride < 3 * sizeof(float))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: stride %zu is below 12 bytes", stride);
    if (triangle_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL, "simplify: the mesh has no triangles");
    mr_status st = mr_check_indices(indices, triangle_count, vertex_count, err);
    if (st != MR_OK)
        return st;

    /* Bounding box of the referenced vertices: each vertex once. */
    uint8_t *used = mr_calloc_array(vertex_count, 1);
    if (!used)
        return mr_fail_nomem(err, NULL, vertex_count);
    for (size_t i = 0; i < 3 * triangle_count; i++)
        used[indices[i]] = 1;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    /* every finite vertex's box too: the base of relative errors, as
     * `meshreduce info` and mr_stats give it */
    double alo[3] = {INFINITY, INFINITY, INFINITY}, ahi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < vertex_count; v++) {
        float p[3];
        memcpy(p, (const char *)positions + v * stride, sizeof p);
        for (int k = 0; k < 3 && is_finite(p[0]) && is_finite(p[1]) && is_finite(p[2]); k++) {
            alo[k] = p[k] < alo[k] ? p[k] : alo[k];
            ahi[k] = p[k] > ahi[k] ? p[k] : ahi[k];
        }
        if (!used[v])
            continue;
        if (!is_finite(p[0]) || !is_finite(p[1]) || !is_finite(p[2])) {
            free(used);
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                                 "simplify: vertex %zu has a non-finite coordinate", v);
        }
        for (int k = 0; k < 3; k++) {
            lo[k] = p[k] < lo[k] ? p[k] : lo[k];
            hi[k] = p[k] > hi[k] ? p[k] : hi[k];
        }
    }
    free(used);
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    if (!(diag > 0))
        diag = 1; /* every vertex at one point */
    for (int k = 0; k < 3; k++)
        s->centre[k] = 0.5 * (lo[k] + hi[k]);
    s->diagonal = diag;
    s->scale = 1.0 / diag;
    const double ad = sqrt((ahi[0] - alo[0]) * (ahi[0] - alo[0]) +
                           (ahi[1] - alo[1]) * (ahi[1] - alo[1]) +
                           (ahi[2] - alo[2]) * (ahi[2] - alo[2]));
    s->error_base = ad > 0 ? ad : diag;
    for (int k = 0; k < 3; k++) {
        s->lo[k] = (float)lo[k];
        s->hi[k] = (float)hi[k];
        /* a millionth of the diagonal of slack: a flat mesh's optimum
         * may round off its plane */
        s->box[k] = 0.5 * (hi[k] - lo[k]) * s->scale + 1e-6;
    }

    st = mr_collapse_mesh_init(&s->m, positions, stride, vertex_count, indices, triangle_count,
                               s->centre, s->scale, err);
    if (st != MR_OK)
        return st;
    mr_collapse_mesh *m = &s->m;
    s->input_vertices = m->live_vertices;
    if (m->live_triangles == 0) {
        mr_simplifier_free(s);
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL,
                             "every one of its %zu triangles uses a vertex twice: no surface "
                             "to simplify",
                             triangle_count);
    }
    st = mr_simplify_check_options(o, m->live_vertices, triangle_count, err);
    if (st != MR_OK) {
        mr_simplifier_free(s);
        return st;
    }
    s->half = o->collapse == MR_COLLAPSE_HALF;
    s->batched = o->strategy == MR_STRATEGY_BATCHED;
    s->limits.half_edge = s->half;
    double c = cos(o->max_normal_turn);
    s->limits.min_cos_turn = c > 0 ? c : 0;
    for (size_t v = 0; v < vertex_count; v++) {
        s->blocked_vertices += (m->flags[v] & MR_VF_NONMANIFOLD) != 0;
        if (o->lock_border && (m->flags[v] & MR_VF_BOUNDARY))
            m->flags[v] |= MR_VF_LOCKED;
        if (o->vertex_lock && o->vertex_lock[v])
            m->flags[v] |= MR_VF_LOCKED;
        if (extra_flags)
            m->flags[v] |= extra_flags[v];
    }

    /* one record of padding: the batch planner reads 12 floats of each */
    s->q = mr_alloc_array(vertex_count + 1, sizeof *s->q);
    if (!s->q) {
        mr_simplifier_free(s);
        return mr_fail_nomem(err, NULL, vertex_count * sizeof *s->q);
    }
    if (s->half && !s->batched) { /* full collapses queue edges: see edge_fill_queue */
        s->best = mr_alloc_array(vertex_count, sizeof *s->best);
        s->stale = mr_calloc_array(vertex_count, 1);
        if (!s->best || !s->stale) {
            mr_simplifier_free(s);
            return mr_fail_nomem(err, NULL, vertex_count * 5);
        }
        /* 32-bit positions: this heap is small next to the rest (one id
         * per vertex), and they are the faster to update. */
        st = mr_heap_init_width(&s->heap, vertex_count, vertex_count, 4, err);
        if (st != MR_OK) {
            mr_simplifier_free(s);
            return st;
        }
    }
    /* A gather over each vertex's own triangles, writing only its own
     * quadric: the same result on any number of threads. */
    const int nthreads = mr_thread_count(o->threads);
    const ptrdiff_t nv = (ptrdiff_t)vertex_count;
#pragma omp parallel for schedule(static) num_threads(nthreads) if (nthreads > 1 && nv > 65536)
    for (ptrdiff_t v = 0; v < nv; v++)
        if (!(m->flags[v] & MR_VF_REMOVED))
            initial_quadric(s, (uint32_t)v, o->boundary_weight);
    return MR_OK;
}

/* Fill the queue: for half collapses every vertex with its best collapse,
 * for full ones every edge. Pushed in id order, so the heap -- and
 * everything after -- is deterministic. On failure the simplifier must
 * still be freed. */
mr_status mr_simplifier_fill_queue(mr_simplifier *s, mr_error *err)
{
    if (s->batched)
        return mr_simplifier_batched_init(s, err);
    if (!s->half)
        return edge_fill_queue(s, err);
    for (size_t v = 0; v < s->m.vertex_count; v++) {
        s->best[v] = NONE;
        if (s->m.flags[v] & MR_VF_REMOVED)
            continue;
        uint32_t w;
        double c = best_collapse(s, (uint32_t)v, false, &w);
        s->best[v] = w;
        if (w != NONE)
            mr_heap_push(&s->heap, (uint32_t)v, (float)c);
    }
    return MR_OK;
}

/* ---- the loop -------------------------------------------------------------- */

void mr_simplifier_targets(const mr_simplifier *s, const mr_simplify_options *o,
                           mr_simplify_goal *g)
{
    const mr_collapse_mesh *m = &s->m;
    size_t target_v = 0;
    if (o->target_ratio > 0)
        target_v = (size_t)floor(o->target_ratio * (double)s->input_vertices + 0.5);
    if (o->target_vertices > target_v)
        target_v = o->target_vertices;
    if (o->target_vertices && o->target_vertices < target_v)
        target_v = o->target_vertices;
    if (o->target_ratio > 0 && o->target_vertices) {
        size_t a = (size_t)floor(o->target_ratio * (double)s->input_vertices + 0.5);
        target_v = a > o->target_vertices ? a : o->target_vertices; /* first reached */
    }
    g->vertices = target_v;
    g->triangles = o->target_triangles;
    g->limit = INFINITY;
    if (o->max_error > 0) {
        const double rel = mr_simplifier_normalised(s, o, o->max_error);
        g->limit = rel * rel;
    }
    /* Progress: the share of the collapses the vertex target needs. */
    size_t planned = m->live_vertices > target_v ? m->live_vertices - target_v : 0;
    if (g->triangles && (m->live_triangles - g->triangles) / 2 < planned)
        planned = (m->live_triangles - g->triangles) / 2;
    g->planned = planned;
}

/*
 * Why the run stopped, when no count target was met, from the costs of
 * the edges left (no validity test: the strategies stop only once every
 * collapse within the bound has been found invalid): one within reach but
 * for the error bound means the bound stopped it; else one that may happen
 * at all means the validity tests refused the rest; else every edge has
 * locked (or two pinned) ends. One pass over the triangles, O(E), only
 * when a target is missed.
 */
static mr_simplify_stop stop_reason(const mr_simplifier *s, const mr_simplify_goal *g)
{
    if (mr_simplifier_reached(s, g))
        return MR_STOP_TARGET;
    const mr_collapse_mesh *m = &s->m;
    bool movable = false;
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *tri = m->tris + 3 * t;
        if (tri[0] == NONE)
            continue;
        for (int j = 0; j < 3; j++) {
            uint32_t r, k;
            double target[3];
            const double cost = mr_simplifier_plan_edge(s, tri[j], tri[(j + 1) % 3], &r, &k,
                                                        target);
            if (cost < INFINITY && cost > g->limit)
                return MR_STOP_MAX_ERROR;
            movable |= cost < INFINITY;
        }
    }
    return movable ? MR_STOP_REFUSED : MR_STOP_LOCKED;
}

const char *mr_simplify_stop_string(mr_simplify_stop stop)
{
    switch (stop) {
    case MR_STOP_TARGET: return "the target was reached";
    case MR_STOP_MAX_ERROR: return "every further collapse would exceed the error bound";
    case MR_STOP_LOCKED:
        return "every remaining vertex is locked (non-manifold or misoriented fans, "
               "locked borders or vertices, seam ends)";
    case MR_STOP_REFUSED:
        return "every remaining collapse is refused by the topology or normal tests (it "
               "would join two sides of the surface, remove a part's last triangles, or "
               "flip or turn a triangle past the normal limit)";
    }
    return "unknown";
}

static size_t run_greedy(mr_simplifier *s, const mr_simplify_options *o, double *max_error);

/*
 * Drop the connected parts whose bounding-box diagonal (normalised) is at
 * most `bound` -- removing them moves the surface by no more -- but never
 * the part with the most triangles. Returns the number of parts dropped.
 * A part is a set of live triangles joined through shared vertices.
 */
static size_t prune(mr_simplifier *s, double bound)
{
    mr_collapse_mesh *m = &s->m;
    const size_t vc = m->vertex_count, tc = m->triangle_count;
    uint32_t *parent = mr_alloc_array(vc, sizeof *parent);
    float *box = mr_alloc_array(vc, 6 * sizeof *box);
    uint32_t *tris = mr_calloc_array(vc, sizeof *tris);
    size_t dropped = 0;
    if (!parent || !box || !tris)
        goto done; /* out of memory: nothing pruned */
    mr_uf_init(parent, vc);
    for (size_t t = 0; t < tc; t++) {
        const uint32_t *tri = m->tris + 3 * t;
        if (tri[0] != NONE) {
            mr_uf_union(parent, tri[0], tri[1]);
            mr_uf_union(parent, tri[0], tri[2]);
        }
    }
    for (size_t v = 0; v < vc; v++) {
        float *b = box + 6 * v;
        b[0] = b[1] = b[2] = INFINITY;
        b[3] = b[4] = b[5] = -INFINITY;
    }
    for (size_t v = 0; v < vc; v++) {
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        float *b = box + 6 * (size_t)mr_uf_find(parent, (uint32_t)v);
        const float *p = m->pos + 3 * v;
        for (int k = 0; k < 3; k++) {
            b[k] = p[k] < b[k] ? p[k] : b[k];
            b[3 + k] = p[k] > b[3 + k] ? p[k] : b[3 + k];
        }
    }
    uint32_t largest = NONE;
    for (size_t t = 0; t < tc; t++)
        if (m->tris[3 * t] != NONE) {
            const uint32_t r = mr_uf_find(parent, m->tris[3 * t]);
            tris[r]++;
            largest = largest == NONE || tris[r] > tris[largest] ||
                              (tris[r] == tris[largest] && r < largest)
                          ? r
                          : largest;
        }
    /* tris[r] becomes the verdict: 1 = drop part r */
    for (size_t v = 0; v < vc; v++) {
        if (!tris[v])
            continue;
        const float *b = box + 6 * v;
        const double dx = (double)b[3] - b[0], dy = (double)b[4] - b[1], dz = (double)b[5] - b[2];
        tris[v] = v != largest && sqrt(dx * dx + dy * dy + dz * dz) <= bound;
        dropped += tris[v];
    }
    if (!dropped)
        goto done;
    for (size_t t = 0; t < tc; t++) {
        uint32_t *tri = m->tris + 3 * t;
        if (tri[0] != NONE && tris[mr_uf_find(parent, tri[0])]) {
            tri[0] = tri[1] = tri[2] = NONE;
            m->live_triangles--;
        }
    }
    for (size_t v = 0; v < vc; v++)
        if (!(m->flags[v] & MR_VF_REMOVED) && tris[mr_uf_find(parent, (uint32_t)v)]) {
            m->flags[v] = (uint8_t)((m->flags[v] & ~MR_VF_DIRTY) | MR_VF_REMOVED);
            if (m->dead)
                m->dead[v] = 0;
            m->count[v] = 0;
            m->live_vertices--;
        }
done:
    free(parent);
    free(box);
    free(tris);
    return dropped;
}

size_t mr_simplifier_run(mr_simplifier *s, const mr_simplify_options *o, double *max_error)
{
    size_t done = s->batched ? mr_simplifier_run_batched(s, o, max_error)
                             : run_greedy(s, o, max_error);
    mr_simplify_goal g;
    mr_simplifier_targets(s, o, &g);
    s->stop = stop_reason(s, &g);
    s->pruned = 0;
    if (o->prune) {
        /* the error bound, or the largest error the collapses made */
        const double e = o->max_error > 0 ? o->max_error : *max_error;
        s->pruned = prune(s, mr_simplifier_normalised(s, o, e));
    }
    return done;
}

static size_t run_greedy(mr_simplifier *s, const mr_simplify_options *o, double *max_error)
{
    mr_collapse_mesh *m = &s->m;
    mr_simplify_goal g;
    mr_simplifier_targets(s, o, &g);
    const size_t planned = g.planned;
    const double limit = g.limit;
    size_t next_report = planned / 100 + 1, done = 0;
    double worst = 0;

    while (!mr_heap_empty(&s->heap)) {
        if (mr_simplifier_reached(s, &g))
            break;
        if (!s->half) {
            const uint32_t h = mr_heap_top(&s->heap);
            const uint32_t a = m->tris[h], b = he_dst(m, h);
            uint32_t r, k;
            double target[3];
            const double cost = plan_edge(s, a, b, &r, &k, target);
            if (cost > limit)
                break;
            if (!mr_collapse_valid(m, r, k, target, &s->limits) ||
                (s->attr_valid && !s->attr_valid(s, r, k))) {
                mr_heap_remove(&s->heap, h);
                m->flags[a] |= MR_VF_BLOCKED;
                m->flags[b] |= MR_VF_BLOCKED;
                continue;
            }
            /* The triangles on the edge die with their half-edges. */
            uint32_t dead[2], nd = 0;
            const uint32_t *lr = mr_collapse_vertex_tris(m, r);
            for (uint32_t i = 0; i < m->count[r] && nd < 2; i++) {
                const uint32_t *tri = m->tris + (lr[i] - lr[i] % 3);
                if (tri[0] == k || tri[1] == k || tri[2] == k)
                    dead[nd++] = lr[i] / 3;
            }
            mr_simplifier_collapse(s, r, k, target);
            for (uint32_t i = 0; i < nd; i++)
                for (uint32_t c = 0; c < 3; c++)
                    mr_heap_remove(&s->heap, 3 * dead[i] + c);
            edge_update_around(s, k);
            edge_unblock_ring(s, k);
            worst = cost > worst ? cost : worst;
            done++;
            if (o->progress && done >= next_report) {
                o->progress(planned ? (double)done / (double)planned : 1.0, o->progress_user);
                next_report += planned / 100 + 1;
            }
            continue;
        }
        const uint32_t u = mr_heap_top(&s->heap);
        if (s->stale[u]) {
            requeue(s, u, false);
            continue;
        }
        const uint32_t w = s->best[u];
        uint32_t r, k;
        double target[3];
        const double cost = plan(s, u, w, &r, &k, target);
        if (cost > limit)
            break;
        if (!mr_collapse_valid(m, r, k, target, &s->limits) ||
            (s->attr_valid && !s->attr_valid(s, r, k))) {
            requeue(s, u, true);
            continue;
        }
        mr_simplifier_collapse(s, r, k, target);
        update_around(s, r, k);
        worst = cost > worst ? cost : worst;
        done++;
        if (o->progress && done >= next_report) {
            o->progress(planned ? (double)done / (double)planned : 1.0, o->progress_user);
            next_report += planned / 100 + 1;
        }
    }
    if (o->progress)
        o->progress(1.0, o->progress_user);
    double e = sqrt(worst);
    *max_error = mr_simplifier_error(s, o, e);
    return done;
}

/* ---- output ---------------------------------------------------------------- */

mr_status mr_simplifier_output(const mr_simplifier *s, const float *positions, size_t stride,
                               mr_simplified *out, mr_error *err)
{
    const mr_collapse_mesh *m = &s->m;
    if (stride == 0)
        stride = 3 * sizeof(float);
    const size_t vc = m->vertex_count, nv = m->live_vertices, nt = m->live_triangles;
    uint32_t *remap = mr_alloc_array(vc, sizeof *remap);
    out->positions = mr_alloc_array(3 * nv, sizeof *out->positions);
    out->indices = mr_alloc_array(3 * nt, sizeof *out->indices);
    out->origin = mr_alloc_array(nv, sizeof *out->origin);
    if (!remap || !out->positions || !out->indices || !out->origin) {
        free(remap);
        mr_simplified_free(out);
        return mr_fail_nomem(err, NULL, nv * 16 + nt * 12);
    }
    size_t n = 0;
    for (size_t v = 0; v < vc; v++) {
        remap[v] = NONE;
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        remap[v] = (uint32_t)n;
        out->origin[n] = (uint32_t)v;
        float *p = out->positions + 3 * n;
        if (m->flags[v] & MR_VF_MOVED)
            mr_simplifier_position(s, (uint32_t)v, p);
        else
            memcpy(p, (const char *)positions + v * stride, 3 * sizeof(float));
        n++;
    }
    size_t t = 0;
    for (size_t i = 0; i < m->triangle_count; i++) {
        const uint32_t *tri = m->tris + 3 * i;
        if (tri[0] == NONE)
            continue;
        for (int k = 0; k < 3; k++)
            out->indices[3 * t + k] = remap[tri[k]];
        t++;
    }
    free(remap);
    out->vertex_count = n;
    out->triangle_count = t;
    return MR_OK;
}

mr_status mr_simplify(const float *positions, size_t stride, size_t vertex_count,
                      const uint32_t *indices, size_t triangle_count,
                      const mr_simplify_options *options, mr_simplified *out, mr_error *err)
{
    if (!out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "simplify: no output");
    memset(out, 0, sizeof *out);
    const double t0 = mr_now_seconds();
    mr_simplifier s;
    mr_status st = mr_simplifier_init(&s, positions, stride, vertex_count, indices,
                                      triangle_count, options, NULL, err);
    if (st != MR_OK)
        return st;
    st = mr_simplifier_fill_queue(&s, err);
    if (st != MR_OK) {
        mr_simplifier_free(&s);
        return st;
    }
    const double t1 = mr_now_seconds();
    double max_error;
    size_t collapses = mr_simplifier_run(&s, options, &max_error);
    const double t2 = mr_now_seconds();
    /* Only the mesh is needed from here: release the rest before the
     * output is allocated (it would set the peak). */
    mr_heap_free(&s.heap);
    free(s.q);
    s.q = NULL;
    st = mr_simplifier_output(&s, positions, stride, out, err);
    const size_t input_vertices = s.input_vertices, blocked = s.blocked_vertices;
    const mr_simplify_stop stop = s.stop;
    const size_t pruned = s.pruned;
    mr_simplifier_free(&s);
    if (st != MR_OK)
        return st;
    const double t3 = mr_now_seconds();
    mr_simplify_stats *stats = &out->stats;
    stats->input_vertices = input_vertices;
    stats->locked_vertices = blocked;
    stats->input_triangles = triangle_count;
    stats->output_vertices = out->vertex_count;
    stats->output_points = out->vertex_count;
    stats->output_triangles = out->triangle_count;
    stats->stop = stop;
    stats->target_reached = stop <= MR_STOP_MAX_ERROR || options->until_error;
    stats->pruned_parts = pruned;
    stats->collapses = collapses;
    stats->max_error = max_error;
    stats->seconds_setup = t1 - t0;
    stats->seconds_collapse = t2 - t1;
    stats->seconds_output = t3 - t2;
    return MR_OK;
}
