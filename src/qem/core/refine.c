/*
 * The last step of MR_QUALITY_BEST: the simplified surface fitted to the
 * input's. Collapses place each survivor where its quadric is least, a
 * measure of the distance from the vertex to the planes it stands for;
 * the triangles between the vertices still cut through convex parts and
 * span concave ones (on the bunny at 10 %, 61 % of the input's surface
 * lies outside the output). Here both surfaces pull on the output's
 * vertices directly, as the symmetric RMS distance measures them:
 *
 *   input samples   the centroids of the input's triangles (every step-th
 *                   one beyond SAMPLES_PER_TRIANGLE per output triangle),
 *                   each weighted by its triangle's area; each finds its
 *                   nearest output triangle and point c there (barycentric
 *                   coordinates beta), with the residual r = n.(c - p)
 *                   along the output triangle's unit normal n;
 *   output samples  four points of each output triangle (fixed barycentric
 *                   coordinates), a quarter of its area each; each finds
 *                   its nearest input point q, with r = m.(p - q) along
 *                   that input triangle's unit normal m;
 *   vertex samples  each output vertex itself (beta 1), VERTEX_WEIGHT of a
 *                   third of its triangles' area, the same way: the tip of
 *                   a thin part, where the output lies farthest off the
 *                   input, is a vertex, and the four points inside its
 *                   triangles pull on it at most 2/3 as hard.
 * Moving vertex v by d moves a sample's point by beta_v d, so v's move is
 * the least-squares solution of sum w (beta_v n.d + r)^2 over the samples
 * it carries, with DAMPING times the trace added to the diagonal (samples
 * that pin only one direction leave the others as they are: flat parts
 * stay flat). All vertices move at once (Jacobi); a triangle that would
 * flip, turn by more than max_normal_turn in one sweep or lose its area
 * puts its vertices back, until none does. ITERATIONS sweeps. Boundary,
 * seam, locked and non-manifold vertices stay where the collapses left
 * them. Last, no two triangles that the collapses left apart may cross:
 * where a pair crosses after the sweeps and none of its vertices belongs
 * to a triangle that crossed another before them, its vertices go back to
 * where the collapses left them (mr_fit_untangle; measured on the nine
 * data meshes at 25/10/5/2/1 %, the sweeps had added crossings on the
 * nefertiti at 2 % and the homer at 5 %, 2 and 5 pairs, at RMS +0.1 % and
 * +1.0 % once put back; one check of the output costs about 1 us a
 * triangle on one thread). The fit reports its part of the progress
 * (s->fit_share) after the input's hierarchy and after each sweep, and
 * stops there when the callback asks.
 *
 * The first sweep finds each sample's nearest triangle in a hierarchy
 * (exact); the later ones walk from the last sweep's answer (walk_nearest:
 * a few point-triangle distances instead of a descent through the tree),
 * since a sweep moves the vertices by a fraction of an edge. A walk stops
 * at a local minimum, which is not always the nearest triangle (a sample
 * between two sheets of a thin part): measured on 8 data meshes at 25, 10
 * and 1 %, four walked sweeps after the first gave RMS distances 0-2 %
 * above four exact ones in 40-75 % of the time at 25 and 10 %; six sweeps
 * with walks (an odd count leaves the Jacobi steps' overshoot in place:
 * five measured worse than four) are within -1.5..+0.4 % of four exact
 * ones in about 60-75 % of their time.
 *
 * Measured on the bunny, the armadillo, the nefertiti and the homer at
 * 10 % and 1 % (with the volume-preserving placement): RMS distance 14-40
 * % lower than MR_QUALITY_DEFAULT's; the input samples alone also raised
 * the Hausdorff distance at the tips of thin parts (the armadillo's claws,
 * 1 %: 0.97 % of the diagonal to 2.35 %), which the output samples pull
 * back (1.81 % at damped steps, 2.18 % at full ones, whose RMS is lower).
 * With the memoryless collapses (cost.c) and the vertex samples, on the
 * same meshes at 25, 10 and 1 %: the largest one-sided distances were
 * output vertices beyond the tips (the armadillo's claw at 10 %: 0.47 %),
 * which the vertex samples at 0.1 bring to within Lindstrom-Turk's
 * Hausdorff distance in all 12 cases (0.25: RMS up to 5 % higher; 1: up
 * to 29 %).
 *
 * Deterministic: the samples, both hierarchies (their shape does not
 * depend on the thread count) and every query are per sample; each vertex
 * sums its samples in sample order (the input samples: every thread reads
 * them all and adds those of its own range of vertices, a stream of 32
 * bytes a sample instead of a sort by vertex and random reads; the output
 * samples by the output's triangles around the vertex); the flip checks
 * run in triangle order. The result is the same on any number of
 * threads. The hierarchy is geometry/distance.h's (below the simplifier,
 * shared with compare), the crossing test geometry/selfint.h's.
 */
#include "simplifier.h"

#include "../../core/omp_compat.h"
#include "../../geometry/distance.h"
#include "../../geometry/selfint.h"

#include <math.h>

#define ITERATIONS 6
#define WALK_STEPS 8
#define DAMPING 0.05
#define SAMPLES_PER_TRIANGLE 16
#define OUT_SAMPLES 4 /* per output triangle */
/* The weight of a vertex's own sample, per unit of its share of the area
 * around it (a third of its triangles'). */
#define VERTEX_WEIGHT 0.1

/* The output samples' barycentric coordinates. */
static const double out_beta[OUT_SAMPLES][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3},
                                                {2.0 / 3, 1.0 / 6, 1.0 / 6},
                                                {1.0 / 6, 2.0 / 3, 1.0 / 6},
                                                {1.0 / 6, 1.0 / 6, 2.0 / 3}};

/* One sample's pull: unit direction, residual along it, weight (0: none),
 * and for an input sample its nearest output triangle and coordinates
 * (the first two; the third is 1 minus their sum). Floats: 32 bytes a
 * sample, of which there are a million and more on large inputs; the
 * normal equations are summed in doubles. */
typedef struct pull {
    float n[3], r, w;
    float beta[2];
    uint32_t tri; /* the nearest triangle, the next sweep's hint: input
                     samples, an index into the live triangles; output
                     samples, an input triangle */
} pull;

/* Input sample i's point: the centroid of its triangle tv (the same
 * doubles each sweep, from the input's float positions). */
static inline void sample_point(const float *ipos, const uint32_t *tv, double p[3])
{
    for (int k = 0; k < 3; k++)
        p[k] = ((double)ipos[3 * (size_t)tv[0] + (size_t)k] + ipos[3 * (size_t)tv[1] + (size_t)k] +
                ipos[3 * (size_t)tv[2] + (size_t)k]) /
               3;
}

/* Normal (twice the area) of triangle (a, b, c) and its squared length. */
static void normal_of(const float *a, const float *b, const float *c, double n[3], double *len2)
{
    const double u[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    const double v[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    *len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
}

static void tri_normal(const float *pos, const uint32_t *tri, double n[3], double *len2)
{
    normal_of(pos + 3 * (size_t)tri[0], pos + 3 * (size_t)tri[1], pos + 3 * (size_t)tri[2], n,
              len2);
}

/* Would triangle tri flip, turn by more than the collapses' limit (cosine
 * min_cos) or lose its area from positions p0 to p1? */
static bool turns_bad(const float *p0, const float *p1, const uint32_t *tri, double min_cos)
{
    double n0[3], n1[3], l0, l1;
    tri_normal(p0, tri, n0, &l0);
    tri_normal(p1, tri, n1, &l1);
    const double d = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
    return !(d > 0) || !(d * d > min_cos * min_cos * l0 * l1) || !(l1 > 1e-12 * l0);
}

/* Lists of (triangle, corner) by vertex, in triangle order: start[v] ..
 * start[v + 1) of list, each entry 3 * triangle + corner. A counting
 * sort: the order is the triangles', whatever the threads. */
static void by_vertex(size_t vc, size_t items, const uint32_t *tris, uint32_t *start,
                      uint32_t *list)
{
    memset(start, 0, (vc + 1) * sizeof *start);
    for (size_t i = 0; i < items; i++) {
        const uint32_t *tv = tris + 3 * i;
        for (int j = 0; j < 3; j++)
            start[tv[j] + 1]++;
    }
    for (size_t v = 0; v < vc; v++)
        start[v + 1] += start[v];
    for (size_t i = 0; i < items; i++) {
        const uint32_t *tv = tris + 3 * i;
        for (uint32_t j = 0; j < 3; j++)
            list[start[tv[j]]++] = 3 * (uint32_t)i + j;
    }
    for (size_t v = vc; v > 0; v--)
        start[v] = start[v - 1];
    start[0] = 0;
}

/* Add sample pull p, carried with coordinate beta, to the normal
 * equations (a: 6 entries of the symmetric matrix, b: 3). */
static inline void add_pull(const pull *p, double beta, double a[6], double b[3])
{
    const double w = p->w, n0 = p->n[0], n1 = p->n[1], n2 = p->n[2];
    const double f = w * beta * beta, g = -w * beta * p->r;
    a[0] += f * n0 * n0;
    a[1] += f * n0 * n1;
    a[2] += f * n0 * n2;
    a[3] += f * n1 * n1;
    a[4] += f * n1 * n2;
    a[5] += f * n2 * n2;
    b[0] += g * n0;
    b[1] += g * n1;
    b[2] += g * n2;
}

/* Squared distance from p to triangle t of (pos, tris), its closest point
 * c, and the corners that point leans on: bit j set when c's barycentric
 * coordinate j is clearly above zero (7: inside; on an edge, its two ends;
 * at a corner, that corner; 0 for a sliver, whose coordinates say
 * nothing). */
static double tri_dist_region(const float *pos, const uint32_t *tris, uint32_t t,
                              const double p[3], double c[3], unsigned *region)
{
    const uint32_t *tv = tris + 3 * (size_t)t;
    double a[3], b[3], cc[3];
    for (int k = 0; k < 3; k++) {
        a[k] = pos[3 * (size_t)tv[0] + k];
        b[k] = pos[3 * (size_t)tv[1] + k];
        cc[k] = pos[3 * (size_t)tv[2] + k];
    }
    const double d = mr_point_triangle_dist2(p, a, b, cc, c);
    double bb, bc;
    if (!(mr_edge_coords(a, b, cc, c, 1e-14, &bb, &bc) > 0)) {
        *region = 0;
        return d;
    }
    const double eps = 1e-6;
    *region = (1 - bb - bc > eps ? 1u : 0u) | (bb > eps ? 2u : 0u) | (bc > eps ? 4u : 0u);
    return d;
}

/*
 * The nearest triangle to p near triangle `from` of (pos, tris), by a
 * walk: while the closest point lies on an edge or a corner of the current
 * triangle, the triangles around those corners (lists by vertex, as
 * by_vertex builds them) are tried and the nearest taken, at most
 * WALK_STEPS times; a point inside a triangle is a local minimum. Sets c;
 * returns the triangle. The order of the tries is fixed, ties keep the
 * earlier one: the same answer on any thread.
 */
static uint32_t walk_nearest(const float *pos, const uint32_t *tris, const uint32_t *start,
                             const uint32_t *list, uint32_t from, const double p[3], double c[3])
{
    unsigned region;
    double best = tri_dist_region(pos, tris, from, p, c, &region);
    uint32_t cur = from;
    for (int step = 0; step < WALK_STEPS && region != 7; step++) {
        uint32_t next = cur;
        unsigned next_region = region;
        const uint32_t *cv = tris + 3 * (size_t)cur;
        for (int j = 0; j < 3; j++) {
            if (region && !(region & (1u << j)))
                continue;
            for (uint32_t e = start[cv[j]]; e < start[cv[j] + 1]; e++) {
                const uint32_t t = list[e] / 3;
                if (t == cur)
                    continue;
                double q[3];
                unsigned r;
                const double d = tri_dist_region(pos, tris, t, p, q, &r);
                if (d < best) {
                    best = d;
                    next = t;
                    next_region = r;
                    memcpy(c, q, sizeof q);
                }
            }
        }
        if (next == cur)
            break;
        cur = next;
        region = next_region;
    }
    return cur;
}

/* The input as the output's samples see it: positions, triangles, their
 * lists by vertex, the hierarchy. */
typedef struct input_surface {
    const float *pos;
    const uint32_t *tris, *start, *list;
    const mr_tri_bvh *bvh;
} input_surface;

/* Output point p's pull towards the input: its nearest input triangle (in
 * the hierarchy when exact, else by a walk from o->tri) and the residual
 * along that triangle's normal, with weight w (none for a degenerate
 * triangle or no weight). */
static void input_pull(const input_surface *in, bool exact, const double p[3], double w,
                       pull *o)
{
    double q[3], mn[3], ml2;
    uint32_t itri;
    if (exact)
        mr_tri_bvh_nearest(in->bvh, p, o->tri, &itri, q);
    else
        itri = walk_nearest(in->pos, in->tris, in->start, in->list, o->tri, p, q);
    tri_normal(in->pos, in->tris + 3 * (size_t)itri, mn, &ml2);
    o->tri = itri;
    o->w = 0;
    if (!(ml2 > 0) || !(w > 0))
        return;
    const double ml = sqrt(ml2);
    double n[3];
    for (int z = 0; z < 3; z++) {
        n[z] = mn[z] / ml;
        o->n[z] = (float)n[z];
    }
    o->r = (float)(n[0] * (p[0] - q[0]) + n[1] * (p[1] - q[1]) + n[2] * (p[2] - q[2]));
    o->w = (float)w;
}

/* mr_fit_untangle's marks per vertex. */
enum { BACK = 1, TANGLED = 2 };

/* Vertex x back where it was before the fit, marked BACK: false when it
 * is there already. */
static bool put_vertex_back(float *pos, const float *before, uint8_t *back, size_t x)
{
    if (memcmp(pos + 3 * x, before + 3 * x, 3 * sizeof *pos) == 0)
        return false;
    memcpy(pos + 3 * x, before + 3 * x, 3 * sizeof *pos);
    back[x] |= BACK;
    return true;
}

mr_status mr_fit_untangle(float *pos, const float *before, size_t vc, const uint32_t *live,
                          size_t nlive, double min_cos, int threads, size_t *put_back,
                          mr_error *err)
{
    *put_back = 0;
    uint8_t *back = calloc(vc ? vc : 1, 1); /* BACK, TANGLED */
    if (!back)
        return mr_fail_nomem(err, "simplify: surface fit", vc);
    mr_status st = MR_OK;
    bool have_before = false;
    for (;;) {
        uint32_t *pairs = NULL;
        size_t np = 0, marked = 0;
        st = mr_self_intersection_pairs(pos, live, nlive, threads, &pairs, &np, err);
        if (st != MR_OK)
            break;
        if (np > 0 && !have_before) {
            /* the vertices of the triangles that met before the fit */
            uint32_t *was = NULL;
            size_t nw = 0;
            st = mr_self_intersection_pairs(before, live, nlive, threads, &was, &nw, err);
            if (st != MR_OK) {
                free(pairs);
                break;
            }
            for (size_t i = 0; i < 2 * nw; i++)
                for (int k = 0; k < 3; k++)
                    back[live[3 * (size_t)was[i] + (size_t)k]] |= TANGLED;
            free(was);
            have_before = true;
        }
        for (size_t i = 0; i < np; i++) {
            const uint32_t *ta = live + 3 * (size_t)pairs[2 * i],
                           *tb = live + 3 * (size_t)pairs[2 * i + 1];
            bool tangled = false;
            for (int k = 0; k < 3; k++)
                tangled |= ((back[ta[k]] | back[tb[k]]) & TANGLED) != 0;
            if (tangled)
                continue; /* where the collapses' surface met itself already */
            for (int k = 0; k < 6; k++)
                marked += put_vertex_back(pos, before, back, k < 3 ? ta[k] : tb[k - 3]);
        }
        free(pairs);
        if (marked == 0)
            break;
        /* a triangle that a vertex put back flips or turns (from before
         * the fit) puts back its other vertices too, until none does */
        for (bool again = true; again;) {
            again = false;
            for (size_t t = 0; t < nlive; t++) {
                const uint32_t *tv = live + 3 * t;
                if (!((back[tv[0]] | back[tv[1]] | back[tv[2]]) & BACK) ||
                    !turns_bad(before, pos, tv, min_cos))
                    continue;
                for (int j = 0; j < 3; j++)
                    if (put_vertex_back(pos, before, back, tv[j])) {
                        marked++;
                        again = true;
                    }
            }
        }
        *put_back += marked;
    }
    free(back);
    return st;
}

/* Report the fit's step k of ITERATIONS + 1 (the input's hierarchy, then
 * the sweeps): true when the progress callback asked to stop. */
static bool fit_report(mr_simplifier *s, int k)
{
    return mr_simplifier_report(s, 1 - s->fit_share + s->fit_share * k / (ITERATIONS + 1));
}

mr_status mr_simplifier_refine(mr_simplifier *s, const float *positions, size_t stride,
                               const uint32_t *indices, size_t triangle_count, mr_error *err)
{
    mr_collapse_mesh *m = &s->m;
    if (stride == 0)
        stride = 3 * sizeof(float);
    /* the working mesh has the input's vertices, so its count is the
     * input's too */
    const size_t vc = m->vertex_count, ivc = vc;
    size_t nlive = 0;
    for (size_t t = 0; t < m->triangle_count; t++)
        nlive += m->tris[3 * t] != MR_COLLAPSE_NONE;
    if (nlive == 0 || triangle_count == 0) {
        fit_report(s, ITERATIONS + 1);
        return MR_OK;
    }
    const size_t step = triangle_count > SAMPLES_PER_TRIANGLE * nlive
                            ? triangle_count / (SAMPLES_PER_TRIANGLE * nlive)
                            : 1;
    const size_t ns = (triangle_count + step - 1) / step, no = OUT_SAMPLES * nlive;
    if (3 * ns > UINT32_MAX || 3 * nlive > UINT32_MAX || 3 * triangle_count > UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "simplify: too many triangles for the surface fit");
    /* The input's hierarchy first, then the samples' arrays: its build's
     * scratch and the samples never take memory at once. */
    uint32_t *live = mr_alloc_array(3 * nlive, sizeof *live);
    uint32_t *tstart = mr_alloc_array(vc + 1, sizeof *tstart);
    uint32_t *tlist = mr_alloc_array(3 * nlive, sizeof *tlist);
    uint32_t *istart = mr_alloc_array(ivc + 1, sizeof *istart);
    uint32_t *ilist = mr_alloc_array(3 * triangle_count, sizeof *ilist);
    float *ipos = mr_alloc_array(3 * ivc, sizeof *ipos);
    float *sarea = NULL; /* the input samples' areas */
    pull *in_pull = NULL, *out_pull = NULL, *v_pull = NULL;
    uint32_t *vidx = NULL, *vout = NULL;
    double *acc = NULL; /* per output vertex: its input samples' normal equations */
    float *next = NULL;
    float *before = NULL; /* the output vertices' positions from the collapses, in vout order */
    uint8_t *moved = NULL;
    mr_tri_bvh ibvh;
    bool have_ibvh = false;
    mr_status st = MR_OK;
    if (!live || !tstart || !tlist || !istart || !ilist || !ipos) {
        st = mr_fail_nomem(err, "simplify: surface fit",
                           4 * (3 * nlive + 3 * triangle_count + 2 * vc) + 12 * ivc);
        goto done;
    }
    for (size_t t = 0, k = 0; t < m->triangle_count; t++)
        if (m->tris[3 * t] != MR_COLLAPSE_NONE)
            memcpy(live + 3 * k++, m->tris + 3 * t, 3 * sizeof *live);
    by_vertex(vc, nlive, live, tstart, tlist); /* the output's triangles stay */
    by_vertex(ivc, triangle_count, indices, istart, ilist);

    /* the input in normalised coordinates, its hierarchy */
    const ptrdiff_t niv = (ptrdiff_t)ivc, nsi = (ptrdiff_t)ns;
    const bool par = s->plan.threads > 1;
#pragma omp parallel for schedule(static) num_threads(s->plan.threads) if (par && niv > 65536)
    for (ptrdiff_t v = 0; v < niv; v++) {
        float f[3];
        memcpy(f, (const char *)positions + (size_t)v * stride, sizeof f);
        for (int k = 0; k < 3; k++)
            ipos[3 * v + k] = (float)(((double)f[k] - s->centre[k]) * s->scale);
    }
    st = mr_tri_bvh_build(&ibvh, ipos, indices, triangle_count, s->plan.threads, err);
    if (st != MR_OK)
        goto done;
    have_ibvh = true;
    if (fit_report(s, 1))
        goto done; /* cancelled: the caller fails */
    const input_surface in = {ipos, indices, istart, ilist, &ibvh};

    /* the samples: the input's, the output's triangles' and vertices' (the
     * output's vertices are those with triangles, in id order) */
    size_t nout = 0;
    for (size_t v = 0; v < vc; v++)
        nout += tstart[v] < tstart[v + 1];
    sarea = mr_alloc_array(ns, sizeof *sarea);
    in_pull = mr_alloc_array(ns, sizeof *in_pull);
    out_pull = mr_alloc_array(no, sizeof *out_pull);
    v_pull = mr_alloc_array(nout, sizeof *v_pull);
    vout = mr_alloc_array(nout, sizeof *vout);
    vidx = mr_alloc_array(vc, sizeof *vidx);
    acc = mr_alloc_array(9 * nout, sizeof *acc);
    next = mr_alloc_array(3 * vc, sizeof *next);
    before = mr_alloc_array(3 * nout, sizeof *before);
    moved = mr_alloc_array(vc, 1);
    if (!sarea || !in_pull || !out_pull || !v_pull || !vout || !vidx || !acc || !next ||
        !before || !moved) {
        st = mr_fail_nomem(err, "simplify: surface fit",
                           ns * (sizeof *sarea + sizeof *in_pull) + no * sizeof *out_pull +
                               nout * (sizeof *v_pull + 16 + 9 * sizeof *acc) + 17 * vc);
        goto done;
    }
    for (size_t i = 0; i < no; i++)
        out_pull[i].tri = MR_NO_HINT;
    for (size_t v = 0, i = 0; v < vc; v++) {
        vidx[v] = tstart[v] < tstart[v + 1] ? (uint32_t)i : UINT32_MAX;
        if (tstart[v] < tstart[v + 1])
            vout[i++] = (uint32_t)v;
    }
    for (size_t i = 0; i < nout; i++)
        memcpy(before + 3 * i, m->pos + 3 * (size_t)vout[i], 3 * sizeof *before);
    for (size_t i = 0; i < nout; i++)
        v_pull[i].tri = MR_NO_HINT;
#pragma omp parallel for schedule(static) num_threads(s->plan.threads) if (par && nsi > 65536)
    for (ptrdiff_t i = 0; i < nsi; i++) {
        double n[3], l2;
        tri_normal(ipos, indices + 3 * (size_t)i * step, n, &l2);
        sarea[i] = (float)(0.5 * sqrt(l2));
        in_pull[i].tri = UINT32_MAX;
    }

    const uint8_t stay =
        MR_VF_BOUNDARY | MR_VF_LOCKED | MR_VF_NONMANIFOLD | MR_VF_SEAM | MR_VF_REMOVED;
    for (int it = 0; it < ITERATIONS; it++) {
        mr_tri_bvh obvh;
        if (it == 0) { /* later sweeps walk */
            st = mr_tri_bvh_build(&obvh, m->pos, live, nlive, s->plan.threads, err);
            if (st != MR_OK)
                goto done;
        }
        /* the input's samples against the output */
#pragma omp parallel for schedule(dynamic, 1024) num_threads(s->plan.threads) if (par && nsi > 4096)
        for (ptrdiff_t i = 0; i < nsi; i++) {
            pull *h = &in_pull[i];
            double p[3];
            sample_point(ipos, indices + 3 * (size_t)i * step, p);
            uint32_t tri;
            double c[3], n[3], l2;
            if (it == 0)
                mr_tri_bvh_nearest(&obvh, p, h->tri, &tri, c);
            else
                tri = walk_nearest(m->pos, live, tstart, tlist, h->tri, p, c);
            const uint32_t *tv = live + 3 * (size_t)tri;
            const float *a = m->pos + 3 * (size_t)tv[0], *b = m->pos + 3 * (size_t)tv[1],
                        *cc = m->pos + 3 * (size_t)tv[2];
            normal_of(a, b, cc, n, &l2);
            h->tri = tri;
            const double da[3] = {a[0], a[1], a[2]}, db[3] = {b[0], b[1], b[2]},
                         dc[3] = {cc[0], cc[1], cc[2]};
            double bb = 0, bc = 0;
            if (!(l2 > 0) || !(mr_edge_coords(da, db, dc, c, 0, &bb, &bc) > 0) || !(sarea[i] > 0)) {
                h->w = 0; /* no pull */
                continue;
            }
            const double l = sqrt(l2);
            h->beta[0] = (float)(1 - bb - bc);
            h->beta[1] = (float)bb;
            for (int k = 0; k < 3; k++) {
                n[k] /= l;
                h->n[k] = (float)n[k];
            }
            h->r = (float)(n[0] * (c[0] - p[0]) + n[1] * (c[1] - p[1]) + n[2] * (c[2] - p[2]));
            h->w = sarea[i];
        }
        if (it == 0)
            mr_tri_bvh_free(&obvh);
        /* the output's samples against the input */
        const ptrdiff_t nl = (ptrdiff_t)nlive;
#pragma omp parallel for schedule(dynamic, 256) num_threads(s->plan.threads) if (par && nl > 1024)
        for (ptrdiff_t t = 0; t < nl; t++) {
            const uint32_t *tv = live + 3 * t;
            const float *a = m->pos + 3 * (size_t)tv[0], *b = m->pos + 3 * (size_t)tv[1],
                        *c = m->pos + 3 * (size_t)tv[2];
            double n[3], l2;
            normal_of(a, b, c, n, &l2);
            const double area = 0.5 * sqrt(l2);
            for (int k = 0; k < OUT_SAMPLES; k++) {
                const double *be = out_beta[k];
                const double p[3] = {be[0] * a[0] + be[1] * b[0] + be[2] * c[0],
                                     be[0] * a[1] + be[1] * b[1] + be[2] * c[1],
                                     be[0] * a[2] + be[1] * b[2] + be[2] * c[2]};
                input_pull(&in, it == 0, p, area / OUT_SAMPLES,
                           &out_pull[OUT_SAMPLES * (size_t)t + (size_t)k]);
            }
        }
        /* the output's vertices against the input */
        const ptrdiff_t nvo = (ptrdiff_t)nout;
#pragma omp parallel for schedule(dynamic, 1024) num_threads(s->plan.threads) if (par && nvo > 4096)
        for (ptrdiff_t i = 0; i < nvo; i++) {
            const uint32_t v = vout[i];
            pull *o = &v_pull[i];
            o->w = 0;
            if (m->flags[v] & stay)
                continue;
            double area = 0;
            for (uint32_t e = tstart[v]; e < tstart[v + 1]; e++) {
                double n[3], l2;
                tri_normal(m->pos, live + 3 * (size_t)(tlist[e] / 3), n, &l2);
                area += 0.5 * sqrt(l2);
            }
            const double p[3] = {m->pos[3 * v], m->pos[3 * v + 1], m->pos[3 * v + 2]};
            input_pull(&in, it == 0, p, VERTEX_WEIGHT * area / 3, o);
        }
        /* the input samples' pulls added to their triangle's corners, in
         * sample order: each thread scans them all and adds to its own
         * range of output vertices, so every vertex sums its samples in
         * the same order on any number of threads */
        memset(acc, 0, 9 * nout * sizeof *acc);
#pragma omp parallel num_threads(s->plan.threads) if (par && nsi > 65536)
        {
            const size_t nth = (size_t)omp_get_num_threads(), th = (size_t)omp_get_thread_num();
            const uint32_t lo = (uint32_t)(nout * th / nth),
                           span = (uint32_t)(nout * (th + 1) / nth) - lo;
            for (size_t i = 0; i < ns; i++) {
                const pull *h = &in_pull[i];
                if (!(h->w > 0))
                    continue;
                const uint32_t *tv = live + 3 * (size_t)h->tri;
                const double beta[3] = {h->beta[0], h->beta[1], 1.0 - h->beta[0] - h->beta[1]};
                for (int j = 0; j < 3; j++) {
                    const uint32_t x = vidx[tv[j]];
                    if (x - lo < span)
                        add_pull(h, beta[j], acc + 9 * (size_t)x, acc + 9 * (size_t)x + 6);
                }
            }
        }
        /* each vertex's least-squares move */
#pragma omp parallel for schedule(static) num_threads(s->plan.threads) if (par && nvo > 16384)
        for (ptrdiff_t i = 0; i < nvo; i++) {
            const size_t v = vout[i];
            memcpy(next + 3 * v, m->pos + 3 * v, 3 * sizeof *next);
            moved[v] = 0;
            if (m->flags[v] & stay)
                continue;
            double a[6], b[3];
            memcpy(a, acc + 9 * (size_t)i, sizeof a);
            memcpy(b, acc + 9 * (size_t)i + 6, sizeof b);
            for (uint32_t e = tstart[v]; e < tstart[v + 1]; e++)
                for (int k = 0; k < OUT_SAMPLES; k++) {
                    const pull *o = &out_pull[OUT_SAMPLES * (size_t)(tlist[e] / 3) + (size_t)k];
                    if (o->w > 0)
                        add_pull(o, out_beta[k][tlist[e] % 3], a, b);
                }
            if (v_pull[i].w > 0)
                add_pull(&v_pull[i], 1.0, a, b);
            const double tr = a[0] + a[3] + a[5];
            if (!(tr > 0))
                continue;
            const double a00 = a[0] + DAMPING * tr, a01 = a[1], a02 = a[2],
                         a11 = a[3] + DAMPING * tr, a12 = a[4], a22 = a[5] + DAMPING * tr;
            const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22,
                         c02 = a01 * a12 - a02 * a11, c11 = a00 * a22 - a02 * a02,
                         c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
            const double det = a00 * c00 + a01 * c01 + a02 * c02;
            if (!(det > 0))
                continue;
            const double d[3] = {(c00 * b[0] + c01 * b[1] + c02 * b[2]) / det,
                                 (c01 * b[0] + c11 * b[1] + c12 * b[2]) / det,
                                 (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det};
            float x[3];
            bool inside = true;
            for (int k = 0; k < 3; k++) {
                x[k] = (float)(m->pos[3 * v + k] + d[k]);
                inside &= fabs((double)x[k]) <= s->box[k];
            }
            if (!inside)
                continue;
            memcpy(next + 3 * v, x, sizeof x);
            moved[v] = memcmp(x, m->pos + 3 * v, sizeof x) != 0;
        }
        /* no triangle flips or loses its area: put its vertices back, in
         * triangle order, until none does */
        for (bool again = true; again;) {
            again = false;
            for (size_t t = 0; t < nlive; t++) {
                const uint32_t *tv = live + 3 * t;
                if (!(moved[tv[0]] | moved[tv[1]] | moved[tv[2]]) ||
                    !turns_bad(m->pos, next, tv, s->limits.min_cos_turn))
                    continue;
                for (int j = 0; j < 3; j++) {
                    memcpy(next + 3 * (size_t)tv[j], m->pos + 3 * (size_t)tv[j],
                           3 * sizeof *next);
                    moved[tv[j]] = 0;
                }
                again = true;
            }
        }
        for (size_t i = 0; i < nout; i++) {
            const size_t v = vout[i];
            if (moved[v])
                memcpy(m->pos + 3 * v, next + 3 * v, 3 * sizeof *next);
        }
        if (it + 1 < ITERATIONS && fit_report(s, it + 2))
            goto done; /* cancelled */
    }
    /* no pair of triangles that the collapses left apart meets after the
     * fit: the collapses' positions by vertex id (in next, free now) */
    for (size_t i = 0; i < nout; i++)
        memcpy(next + 3 * (size_t)vout[i], before + 3 * i, 3 * sizeof *next);
    size_t put_back;
    st = mr_fit_untangle(m->pos, next, vc, live, nlive, s->limits.min_cos_turn, s->plan.threads,
                         &put_back, err);
    if (st != MR_OK)
        goto done;
    for (size_t i = 0; i < nout; i++) {
        const size_t v = vout[i];
        if (memcmp(m->pos + 3 * v, next + 3 * v, 3 * sizeof *next) != 0)
            m->flags[v] |= MR_VF_MOVED;
    }
    fit_report(s, ITERATIONS + 1); /* the last: a stop here fails the call */
done:
    if (have_ibvh)
        mr_tri_bvh_free(&ibvh);
    free(live);
    free(sarea);
    free(in_pull);
    free(out_pull);
    free(v_pull);
    free(vout);
    free(vidx);
    free(acc);
    free(tstart);
    free(tlist);
    free(istart);
    free(ilist);
    free(ipos);
    free(next);
    free(before);
    free(moved);
    return st;
}
