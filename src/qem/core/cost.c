/*
 * The simplifier core's costs and collapse plans, shared by every strategy:
 * what a collapse costs, which end goes and where the survivor goes, and
 * whether it may happen; then the collapse itself (quadrics and mesh).
 *
 * The collapse rules are one table (may_go_onto) for both kinds of
 * collapse. A free edge (no pinned end) has a branch-free cost kernel
 * (free_cost) that the scalar path and the vector loop over a batch of
 * edges (mr_simplifier_plan_edges, the batched strategy's) share, so both
 * give the same bits. The strategies only choose which collapses run when:
 * every one of them is tested by mr_simplifier_allowed and applied by
 * mr_simplifier_collapse.
 */
#include "simplifier.h"
#include "kernels.h"

#include <math.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

/* ---- costs ---------------------------------------------------------------- */

static inline void load_quadric(const mr_simplifier *s, uint32_t v, mr_quadric *q)
{
    mr_quadric_load(q, &s->q[v]);
}

/* Gathers free_cost's inputs for edge (u, w) of the quadrics q and
 * positions pos into in[k * st]. */
static inline void free_cost_inputs_at(const mr_quadricf *q, const float *pos, uint32_t u,
                                       uint32_t w, float *in, size_t st)
{
    const float *qu = &q[u].a00, *qw = &q[w].a00;
    for (int k = 0; k < 11; k++) {
        in[(size_t)(FREE_QU + k) * st] = qu[k];
        in[(size_t)(FREE_QW + k) * st] = qw[k];
    }
    const float *pu = pos + 3 * (size_t)u, *pw = pos + 3 * (size_t)w;
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
 *   a corner:         never (where a boundary or seam turns, a tile's or
 *                     a decal's corner: mr_simplifier_mark_corners; kept
 *                     in place while the target can be reached without
 *                     moving it, then released: mr_simplify_run, the
 *                     entry's);
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
    if (fu & (MR_VF_LOCKED | MR_VF_CORNER))
        return false;
    if (fu & MR_VF_BOUNDARY) /* a non-manifold end may be where boundaries meet */
        return (fw & (MR_VF_BOUNDARY | MR_VF_NONMANIFOLD)) != 0;
    if (fu & MR_VF_SEAM)
        return (fw & MR_VF_SEAM) != 0;
    return true;
}

/* Flags that keep a full collapse off the free optimum. */
#define PINNING (MR_VF_LOCKED | MR_VF_BOUNDARY | MR_VF_SEAM | MR_VF_CORNER)

/*
 * mr_free_cost's placement for a merged quadric q (relative to w's
 * position pw; u at d from it): its optimum where the system is well
 * conditioned, near the edge and inside the box, else the best point of
 * the edge. Returns q at x. The free edges with attributes come here
 * (their quadric has the attributes' part that the vector kernel's
 * inputs lack).
 */
static double free_optimum(const mr_quadric *q, const double d[3], const double pw[3],
                           const double box[3], double x[3])
{
    double o[3];
    bool ok = mr_quadric_optimum(q, o) != 0;
    if (ok) {
        const double len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        const double e0 = o[0] - 0.5 * d[0], e1 = o[1] - 0.5 * d[1], e2 = o[2] - 0.5 * d[2];
        ok = e0 * e0 + e1 * e1 + e2 * e2 <= 4 * len2;
        for (int i = 0; i < 3; i++)
            ok &= fabs(o[i] + pw[i]) <= box[i];
    }
    if (ok) {
        memcpy(x, o, sizeof o);
    } else {
        const double zero[3] = {0, 0, 0};
        mr_quadric_segment_optimum(q, zero, d, x);
    }
    return mr_quadric_eval(q, x);
}

/*
 * The full collapse of edge (u, w): the target relative to w's position
 * (x) and the cost, by the rules above.
 */
static double full_cost(const mr_simplifier *s, uint32_t u, uint32_t w, double x[3])
{
    const mr_collapse_mesh *m = &s->m;
    const uint8_t fu = m->flags[u], fw = m->flags[w];
    if (!((fu | fw) & PINNING) && !s->attr_cost) {
        float in[FREE_INPUTS];
        free_cost_inputs_at(s->q, s->m.pos, u, w, in, 1);
        return mr_free_cost(in, 1, x, 1, s->box);
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
    if (s->attr_cost)
        s->attr_cost(s, u, w, &qu);
    if (!((fu | fw) & PINNING)) { /* with attributes: free_optimum */
        double err = free_optimum(&qu, d, pw, s->box, x);
        err = qu.w > 0 ? err / qu.w : 0;
        return err > 0 ? err : 0;
    }
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
    if (s->attr_cost) { /* the attributes' part, at w */
        mr_quadric qa;
        mr_quadric_zero(&qa);
        s->attr_cost(s, u, w, &qa);
        err += qa.c;
    }
    err = wsum > 0 ? err / wsum : 0;
    return err > 0 ? err : 0;
}

/* The two kernels for the strategies' own loops (greedy.c); calls within
 * this file stay static, to be inlined. */
double mr_simplifier_full_cost(const mr_simplifier *s, uint32_t u, uint32_t w, double x[3])
{
    return full_cost(s, u, w, x);
}

double mr_simplifier_half_cost(const mr_simplifier *s, uint32_t u, uint32_t w)
{
    return half_cost(s, u, w);
}

/* ---- one collapse ---------------------------------------------------------- */

/*
 * The collapse behind u's queue entry (u, w): which end goes (*r), which
 * stays (*k) and where it goes (target, normalised). For full collapses a
 * pinned end stays; else u goes.
 */
double mr_simplifier_plan(const mr_simplifier *s, uint32_t u, uint32_t w, uint32_t *r,
                          uint32_t *k, double target[3])
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

static double memoryless_plan(const mr_simplifier *s, uint32_t r, uint32_t k, double target[3],
                              double gh_cost);

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
    return s->memoryless ? memoryless_plan(s, rr, kk, target, c) : c;
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

/* ---- many edges at once --------------------------------------------------- */

#define COST_BATCH MR_COST_BATCH

/*
 * free_cost's inputs of the edges (u[l], w[l]), l < n, into the batch's
 * rows in[k * COST_BATCH + l]: four edges at a time, each quadric (11
 * floats, read as 12) and position (3, read as 4) loaded as vectors and
 * transposed into four lanes of each row. The same floats as
 * free_cost_inputs_at, a third of the instructions.
 */
void mr_cost_pack_inputs(const mr_quadricf *quadrics, const float *pos, const uint32_t *u,
                         const uint32_t *w, size_t n, float *in)
{
    size_t l = 0;
#if defined(__SSE2__)
    const float *q = &quadrics[0].a00;
    const size_t qs = sizeof *quadrics / sizeof(float);
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
        free_cost_inputs_at(quadrics, pos, u[l], w[l], in + l, COST_BATCH);
}

/* How many edges ahead mr_simplifier_plan_edges hints the attributes'
 * records (s->attr_prefetch). */
#define ATTR_AHEAD 4

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
    if (s->half || s->attr_cost) { /* attributes: no vector kernel */
        for (size_t i = 0; i < n; i++) {
            if (s->attr_prefetch && i + ATTR_AHEAD < n)
                s->attr_prefetch(s, a[i + ATTR_AHEAD], b[i + ATTR_AHEAD]);
            plan_one(s, a[i], b[i], i, cost, r, k, target);
        }
        return;
    }
    const uint8_t pin = PINNING;
    const mr_kernels *kern = s->plan.kernels;
    float in[FREE_INPUTS * COST_BATCH];
    double out[COST_BATCH], x[3 * COST_BATCH];
    uint32_t lane[COST_BATCH], lk[COST_BATCH], lr[COST_BATCH];
    for (size_t i0 = 0; i0 < n; i0 += COST_BATCH) {
        const size_t i1 = n - i0 < COST_BATCH ? n : i0 + COST_BATCH;
        /* the free edges in lanes (plan_edge: the larger id goes), the
         * pinned ones through the one-edge path */
        size_t nl = 0;
        for (size_t i = i0; i < i1; i++) {
            const uint32_t ea = a[i], eb = b[i];
            if ((m->flags[ea] | m->flags[eb]) & pin) {
                plan_one(s, ea, eb, i, cost, r, k, target);
                continue;
            }
            lr[nl] = ea < eb ? eb : ea;
            lk[nl] = ea < eb ? ea : eb;
            lane[nl++] = (uint32_t)(i - i0);
        }
        mr_cost_pack_inputs(s->q, s->m.pos, lr, lk, nl, in);
        kern->free_costs(in, nl, out, x, s->box);
        if (!r && !s->memoryless) {
            for (size_t l = 0; l < nl; l++)
                cost[i0 + lane[l]] = out[l];
            continue;
        }
        for (size_t l = 0; l < nl; l++) {
            const size_t i = i0 + lane[l];
            /* as plan_edge: the kept end's position plus x, then the
             * memoryless plan from there */
            const uint32_t kk = lk[l];
            double t[3] = {(double)m->pos[3 * (size_t)kk] + x[l],
                           (double)m->pos[3 * (size_t)kk + 1] + x[COST_BATCH + l],
                           (double)m->pos[3 * (size_t)kk + 2] + x[2 * COST_BATCH + l]};
            cost[i] = s->memoryless ? memoryless_plan(s, lr[l], kk, t, out[l]) : out[l];
            if (r) {
                r[i] = lr[l];
                k[i] = kk;
                memcpy(target + 3 * i, t, sizeof t);
            }
        }
    }
}

/* ---- volume-preserving placement ------------------------------------------ */

/* The farthest the volume constraint moves a target, in lengths of the
 * edge: farther moves come from directions the quadric hardly constrains
 * and raised the Hausdorff distance (the armadillo at 1 %: 0.97 % of the
 * diagonal without the constraint, 2.57 % with no limit, 1.11 % at a
 * quarter). */
#define VOLUME_REACH 0.25

/*
 * The fan sums of a collapse of r into k, relative to o (k's position):
 * the volume's linear change g.(x - o) - h (triangles around both ends,
 * those on the edge once, in h only); and, when A is not NULL, the
 * memoryless objective sum ((x - w).n)^2 over the triangles that stay
 * (w their moving corner, n = (a - w) x (b - w) twice their area along
 * their normal: the volume each sweeps, times 6) as x'^T A x' - 2 bv.x' +
 * cc, x' = x - o, and its rows' sum of |n|^2 in *nn. Skips deleted
 * triangles (a dirty list's). The sums are the kernels' (kernels.c:
 * fan_sums_default; the AVX2 path's are the same bits, 1.41x faster in
 * cache by bench_kernels).
 */
static void fan_sums(const mr_simplifier *s, uint32_t r, uint32_t k, const double o[3],
                     double g[3], double *h, double A[6], double bv[3], double *cc, double *nn)
{
    const mr_collapse_mesh *m = &s->m;
    const mr_fan_input in = {m->pos, m->tris, mr_collapse_vertex_tris(m, r),
                             mr_collapse_vertex_tris(m, k), m->count[r], m->count[k], r, k};
    double sum[MR_FAN_SUMS] = {0};
    s->plan.kernels->fan_sums(&in, o, A != NULL, sum); /* kernels.c */
    memcpy(g, sum + MR_FAN_G, 3 * sizeof *g);
    *h = sum[MR_FAN_H];
    if (!A)
        return;
    memcpy(A, sum + MR_FAN_A, 6 * sizeof *A);
    memcpy(bv, sum + MR_FAN_B, 3 * sizeof *bv);
    *cc = sum[MR_FAN_C];
    *nn = A[0] + A[3] + A[5];
}

/* The least-cost point of the merged quadric on the volume's plane
 * g.(x - o) = h, from the target (the quadric's optimum): see
 * keep_volume. */
static void volume_move(const mr_simplifier *s, uint32_t r, uint32_t k, const double o[3],
                        const double g[3], double h, double target[3], double *cost)
{
    const mr_collapse_mesh *m = &s->m;
    mr_quadric qr, qk;
    load_quadric(s, r, &qr);
    load_quadric(s, k, &qk);
    const double a00 = qr.a00 + qk.a00, a01 = qr.a01 + qk.a01, a02 = qr.a02 + qk.a02,
                 a11 = qr.a11 + qk.a11, a12 = qr.a12 + qk.a12, a22 = qr.a22 + qk.a22;
    const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22,
                 c02 = a01 * a12 - a02 * a11, c11 = a00 * a22 - a02 * a02,
                 c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
    const double det = a00 * c00 + a01 * c01 + a02 * c02, diag = a00 * a11 * a22;
    if (!(fabs(det) > MR_QUADRIC_DET_EPS * diag) || !(diag > 0))
        return;
    /* y = A^-1 g */
    const double y[3] = {(c00 * g[0] + c01 * g[1] + c02 * g[2]) / det,
                         (c01 * g[0] + c11 * g[1] + c12 * g[2]) / det,
                         (c02 * g[0] + c12 * g[1] + c22 * g[2]) / det};
    const double gy = g[0] * y[0] + g[1] * y[1] + g[2] * y[2];
    if (!(gy > 0))
        return;
    const double t[3] = {target[0] - o[0], target[1] - o[1], target[2] - o[2]};
    const double miss = h - (g[0] * t[0] + g[1] * t[1] + g[2] * t[2]);
    const double lam = miss / gy;
    /* no move past VOLUME_REACH edge lengths */
    const double el2 = (m->pos[3 * r] - o[0]) * (m->pos[3 * r] - o[0]) +
                       (m->pos[3 * r + 1] - o[1]) * (m->pos[3 * r + 1] - o[1]) +
                       (m->pos[3 * r + 2] - o[2]) * (m->pos[3 * r + 2] - o[2]);
    const double mv2 = lam * lam * (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    if (mv2 > VOLUME_REACH * VOLUME_REACH * el2)
        return;
    double x[3];
    for (int i = 0; i < 3; i++) {
        x[i] = target[i] + lam * y[i];
        if (!(fabs(x[i]) <= s->box[i]))
            return; /* outside the box: no place for a vertex */
    }
    const double w = qr.w + qk.w;
    memcpy(target, x, sizeof x);
    if (cost && w > 0)
        *cost += miss * lam / w;
}

/*
 * Move a free full collapse's target to the point that keeps the volume the
 * surface encloses (Lindstrom and Turk's first constraint): the volume a
 * collapse of r into k at x changes by g.(x - o) - h for the triangles
 * around both ends (o: k's position), a linear function of x, so the
 * least-cost point on the plane g.(x - o) = h is the quadric's optimum x*
 * moved by A^-1 g (h - g.(x* - o)) / (g.A^-1 g), and its cost grows by
 * (h - g.(x* - o))^2 / (g.A^-1 g) over the weight. Reads r's and k's
 * (clean) lists, their triangles and positions: what the validity test
 * reads next. Leaves the target alone for a pinned end, an ill-conditioned
 * quadric, or a fan whose g vanishes (a flat or closed-up neighbourhood),
 * and in the memoryless mode (its plans keep the volume).
 */
static void keep_volume(const mr_simplifier *s, uint32_t r, uint32_t k, double target[3],
                        double *cost)
{
    const mr_collapse_mesh *m = &s->m;
    if ((m->flags[r] | m->flags[k]) & PINNING || s->half || s->memoryless)
        return;
    const double o[3] = {m->pos[3 * k], m->pos[3 * k + 1], m->pos[3 * k + 2]};
    double g[3] = {0, 0, 0}, h = 0;
    fan_sums(s, r, k, o, g, &h, NULL, NULL, NULL, NULL);
    volume_move(s, r, k, o, g, h, target, cost);
}

void mr_simplifier_place(const mr_simplifier *s, uint32_t r, uint32_t k, double target[3],
                         double *cost)
{
    if (s->keep_volume)
        keep_volume(s, r, k, target, cost);
}

/* ---- memoryless placement and cost (MR_QUALITY_BEST) ------------------------ */

/* The weight of the collapse's merged quadric (the distance to the input's
 * planes) beside the swept volumes in the placement, relative to their
 * scales: a little keeps a sequence of collapses from drifting off the
 * input (Hausdorff distance) where the volumes alone leave a direction
 * free. */
#define MEMORY_WEIGHT 0.1
/* The farthest the memoryless target may lie from the quadric's, in edge
 * lengths: a bound where the swept volumes leave a direction nearly free.
 * On the bunny, the armadillo, the nefertiti and the homer at 25, 10 and
 * 1 %, the worst RMS distance against CGAL's Lindstrom-Turk was 0.991x
 * with it, 1.015x without, 1.08-1.16x with a quarter or half an edge. */
#define MEMORYLESS_REACH 1.0
/* The cost of a collapse with a pinned end (boundary, seam, locked), in
 * the swept volumes' unit: its quadric cost (which holds the boundary)
 * times its edge length^4 and fan size -- about what a free collapse's
 * swept volumes come to at the same distance -- times this. */
#define PINNED_WEIGHT 16.0

/*
 * Lindstrom and Turk's memoryless collapse (1998), for the edge strategies
 * of MR_QUALITY_BEST: the survivor goes where the volumes the triangles
 * sweep, sum ((x - w).n)^2 (fan_sums), are least on the plane that keeps
 * the enclosed volume, plus MEMORY_WEIGHT of the merged quadric; the cost
 * is that sum at that point -- measured on the current surface, not the
 * input's planes, and weighted by area squared, so the collapses spread
 * over the surface as Lindstrom-Turk's do (the RMS distance follows).
 * target holds the quadric's plan (gh_cost: its cost) and becomes the
 * memoryless one; an ill-conditioned system (a flat fan) keeps the
 * quadric's target moved onto the volume's plane. Returns the cost in
 * units of memoryless_scale, or MR_MEMORYLESS_OVER past the error bound
 * (the merged quadric's mean squared distance at the final target).
 */
static double memoryless_plan(const mr_simplifier *s, uint32_t r, uint32_t k, double target[3],
                              double gh_cost)
{
    const mr_collapse_mesh *m = &s->m;
    const float *pr = m->pos + 3 * (size_t)r, *pk = m->pos + 3 * (size_t)k;
    if (!(gh_cost < INFINITY))
        return gh_cost;
    if ((m->flags[r] | m->flags[k]) & PINNING) {
        if (gh_cost > s->memoryless_limit)
            return MR_MEMORYLESS_OVER;
        const double el2 = (pr[0] - pk[0]) * (pr[0] - pk[0]) + (pr[1] - pk[1]) * (pr[1] - pk[1]) +
                           (pr[2] - pk[2]) * (pr[2] - pk[2]);
        return PINNED_WEIGHT * gh_cost * el2 * el2 * (double)(m->count[r] + m->count[k]) *
               s->memoryless_scale;
    }
    const double o[3] = {pk[0], pk[1], pk[2]};
    double g[3] = {0, 0, 0}, h = 0, A[6] = {0, 0, 0, 0, 0, 0}, bv[3] = {0, 0, 0}, cc = 0, nn = 0;
    fan_sums(s, r, k, o, g, &h, A, bv, &cc, &nn);
    /* the merged quadric, relative to o */
    mr_quadric q, qr;
    load_quadric(s, r, &qr);
    load_quadric(s, k, &q);
    const double d[3] = {o[0] - pr[0], o[1] - pr[1], o[2] - pr[2]};
    mr_quadric_shift(&qr, d);
    mr_quadric_add(&q, &qr);
    double M[6] = {A[0], A[1], A[2], A[3], A[4], A[5]}, b[3] = {bv[0], bv[1], bv[2]};
    if (q.w > 0) {
        const double f = MEMORY_WEIGHT * nn / q.w;
        M[0] += f * q.a00;
        M[1] += f * q.a01;
        M[2] += f * q.a02;
        M[3] += f * q.a11;
        M[4] += f * q.a12;
        M[5] += f * q.a22;
        b[0] -= f * q.b0;
        b[1] -= f * q.b1;
        b[2] -= f * q.b2;
    }
    const double c00 = M[3] * M[5] - M[4] * M[4], c01 = M[2] * M[4] - M[1] * M[5],
                 c02 = M[1] * M[4] - M[2] * M[3], c11 = M[0] * M[5] - M[2] * M[2],
                 c12 = M[1] * M[2] - M[0] * M[4], c22 = M[0] * M[3] - M[1] * M[1];
    const double det = M[0] * c00 + M[1] * c01 + M[2] * c02, tr = M[0] + M[3] + M[5];
    bool placed = false;
    if (det > 1e-6 * tr * tr * tr) {
        double x[3] = {(c00 * b[0] + c01 * b[1] + c02 * b[2]) / det,
                       (c01 * b[0] + c11 * b[1] + c12 * b[2]) / det,
                       (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det};
        const double y[3] = {(c00 * g[0] + c01 * g[1] + c02 * g[2]) / det,
                             (c01 * g[0] + c11 * g[1] + c12 * g[2]) / det,
                             (c02 * g[0] + c12 * g[1] + c22 * g[2]) / det};
        const double gy = g[0] * y[0] + g[1] * y[1] + g[2] * y[2];
        if (gy > 0) { /* onto the volume's plane */
            const double lam = (h - (g[0] * x[0] + g[1] * x[1] + g[2] * x[2])) / gy;
            for (int i = 0; i < 3; i++)
                x[i] += lam * y[i];
        }
        double t[3];
        bool inside = true;
        for (int i = 0; i < 3; i++) {
            t[i] = o[i] + x[i];
            inside &= fabs(t[i]) <= s->box[i];
        }
        /* no farther from the quadric's target than MEMORYLESS_REACH edge
         * lengths */
        const double el2 = (pr[0] - pk[0]) * (pr[0] - pk[0]) + (pr[1] - pk[1]) * (pr[1] - pk[1]) +
                           (pr[2] - pk[2]) * (pr[2] - pk[2]);
        const double dv2 = (t[0] - target[0]) * (t[0] - target[0]) +
                           (t[1] - target[1]) * (t[1] - target[1]) +
                           (t[2] - target[2]) * (t[2] - target[2]);
        if (inside && dv2 <= MEMORYLESS_REACH * MEMORYLESS_REACH * el2) {
            memcpy(target, t, sizeof t);
            placed = true;
        }
    }
    if (!placed)
        volume_move(s, r, k, o, g, h, target, NULL);
    const double x[3] = {target[0] - o[0], target[1] - o[1], target[2] - o[2]};
    if (q.w > 0 && mr_quadric_eval(&q, x) / q.w > s->memoryless_limit)
        return MR_MEMORYLESS_OVER;
    const double ax = A[0] * x[0] + A[1] * x[1] + A[2] * x[2];
    const double ay = A[1] * x[0] + A[3] * x[1] + A[4] * x[2];
    const double az = A[2] * x[0] + A[4] * x[1] + A[5] * x[2];
    const double swept = x[0] * ax + x[1] * ay + x[2] * az -
                         2 * (bv[0] * x[0] + bv[1] * x[1] + bv[2] * x[2]) + cc;
    double cost = (swept > 0 ? swept : 0) * s->memoryless_scale;
    if (s->attr_cost && q.w > 0) {
        /* the attributes' mean squared deviation at the target, for each
         * triangle of the fans (a triangle's swept term is about its
         * squared distance, in these units) */
        mr_quadric qa;
        mr_quadric_zero(&qa);
        s->attr_cost(s, r, k, &qa);
        const double e = mr_quadric_eval(&qa, x) / q.w;
        cost += (e > 0 ? e : 0) * (double)(m->count[r] + m->count[k]);
    }
    return cost;
}

double mr_simplifier_vertex_error(const mr_simplifier *s)
{
    const mr_collapse_mesh *m = &s->m;
    double worst = 0;
    for (size_t v = 0; v < m->vertex_count; v++) {
        if (m->flags[v] & MR_VF_REMOVED || !(s->q[v].w > 0))
            continue;
        const double e = (double)s->q[v].c / s->q[v].w; /* Q at the vertex itself */
        worst = e > worst ? e : worst;
    }
    return sqrt(worst);
}

/* ---- validity and the collapse -------------------------------------------- */

/* A collapse r -> k into a chunk's cut vertex k (mr_vertex_marks): may
 * it happen without seeing k's edges in the other chunks? Only when r has
 * no cut neighbour but k and the edge's opposite vertices (which are k's
 * neighbours here already): any other could be joined to k elsewhere. */
static bool cut_collapse_ok(const mr_simplifier *s, uint32_t r, uint32_t k)
{
    const mr_collapse_mesh *m = &s->m;
    const uint32_t *list = mr_collapse_vertex_tris(m, r);
    uint32_t opp[2] = {k, k};
    unsigned n = 0;
    for (uint32_t i = 0; i < m->count[r]; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        if (tri[0] == MR_COLLAPSE_NONE || (tri[0] != k && tri[1] != k && tri[2] != k))
            continue;
        const uint32_t j = list[i] % 3, a = tri[(j + 1) % 3], b = tri[(j + 2) % 3];
        if (n < 2)
            opp[n++] = a == k ? b : a;
    }
    for (uint32_t i = 0; i < m->count[r]; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        if (tri[0] == MR_COLLAPSE_NONE)
            continue;
        const uint32_t j = list[i] % 3;
        for (uint32_t e = 1; e <= 2; e++) {
            const uint32_t x = tri[(j + e) % 3];
            if (x != k && x != opp[0] && x != opp[1] && s->cut[x])
                return false;
        }
    }
    return true;
}

bool mr_simplifier_allowed(const mr_simplifier *s, uint32_t r, uint32_t k, const double target[3],
                           double cost, double limit)
{
    if (!(cost <= limit && cost < INFINITY))
        return false;
    if (!mr_collapse_valid(&s->m, r, k, target, &s->limits))
        return false;
    if (s->cut && s->cut[k] && !cut_collapse_ok(s, r, k))
        return false;
    return !s->attr_valid || s->attr_valid(s, r, k);
}

bool mr_simplifier_valid(const mr_simplifier *s, uint32_t u, uint32_t w, double *cost)
{
    uint32_t r, k;
    double target[3];
    double c = mr_simplifier_plan(s, u, w, &r, &k, target);
    if (cost)
        *cost = c;
    return mr_simplifier_allowed(s, r, k, target, c, INFINITY);
}

/* Merge r's quadric into k's, both moved to the target's origin. */
static void merge_quadrics(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3])
{
    const mr_collapse_mesh *m = &s->m;
    /* Stored positions are floats: measure from the target as stored. */
    const double t[3] = {(float)target[0], (float)target[1], (float)target[2]};
    const double dr[3] = {t[0] - m->pos[3 * r], t[1] - m->pos[3 * r + 1],
                          t[2] - m->pos[3 * r + 2]};
    const double dk[3] = {t[0] - m->pos[3 * k], t[1] - m->pos[3 * k + 1],
                          t[2] - m->pos[3 * k + 2]};
    s->plan.kernels->merge(&s->q[k], &s->q[r], dk, dr);
}

unsigned mr_simplifier_collapse_at(mr_simplifier *s, uint32_t r, uint32_t k,
                                   const double target[3], uint32_t *out, size_t *removed)
{
    if (s->attr_apply)
        s->attr_apply(s, r, k, target);
    merge_quadrics(s, r, k, target);
    return mr_collapse_apply_at(&s->m, r, k, target, out, removed, true);
}

void mr_simplifier_collapse(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3])
{
    if (s->attr_apply)
        s->attr_apply(s, r, k, target);
    merge_quadrics(s, r, k, target);
    mr_collapse_reserve(&s->m, r, k);
    mr_collapse_apply(&s->m, r, k, target);
}
