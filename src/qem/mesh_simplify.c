/*
 * mr_mesh_simplify: simplification that carries normals, texture
 * coordinates and colors.
 *
 * The geometry is simplified on the topology of the surface: attribute
 * vertices that are one surface point (mr_surface_points: at one position,
 * joined across the split by their triangles) are one geometric vertex,
 * so a UV seam or a hard edge is no boundary to the simplifier, while
 * parts that only touch stay apart. Each triangle
 * corner remembers its attribute vertex (its "wedge"). A geometric vertex
 * with two wedges is a seam vertex:
 *   - seam edges (whose two triangles use different wedges at both ends)
 *     get the perpendicular constraint quadrics that boundaries get;
 *   - a seam vertex only collapses along a seam edge into another seam
 *     vertex; each of its wedges then maps onto the survivor's wedge on the
 *     same side of the seam; a non-seam vertex may collapse into a seam
 *     vertex, whose position then stays (full collapses pin seam ends);
 *   - seam vertices with more than two wedges, other than two seam edges,
 *     or on an open boundary (seams meeting, corners) are locked;
 *   - where a seam turns sharply between straight runs, its vertex is a
 *     corner (MR_VF_CORNER), kept in place as a boundary's corners are;
 *   - when the run ends short of its targets with all this (and the
 *     corners released), the seam vertices off the open boundaries that
 *     no caller locked are freed for a last stage (attr_release): they
 *     may leave their seams onto other seam vertices, any vertex may go
 *     onto them, and the wedges that lose their place are priced by the
 *     attribute quadrics (meshoptimizer's permissive mode; only with
 *     weighted attributes, which price it); options.seams frees them from
 *     the start instead, or never (mr_seam_mode).
 * On a full collapse the survivor's wedges take the attributes
 * interpolated along the edge at the target's projection parameter
 * (normals renormalised). The output keeps the split: one output vertex
 * per surviving wedge.
 */
#include "attr_quadric.h"
#include "carried.h"
#include "entry.h"

#include "../core/omp_compat.h"

#include <math.h>

#define NONE MR_COLLAPSE_NONE

typedef struct attr_ctx {
    uint32_t *corner;   /* 3 * triangle_count: the wedge of each corner */
    float *normals, *texcoords, *colors; /* working copies, or NULL */
    double seam_weight;
    mr_attr_quadrics aq;  /* the weighted attributes' quadrics (channels 0:
                             none, every attribute interpolated) */
    bool lerp_normals, lerp_texcoords, lerp_colors; /* those interpolated */
    uint32_t *wedge;      /* with aq: a vertex's one wedge (no seam vertex's:
                             a vertex off the seams keeps its wedge) */
    uint8_t *loose;       /* per vertex: a seam vertex off the open
                             boundaries that no caller locked, which the
                             last stage frees (attr_release) */
    bool permissive;      /* that stage: loose vertices move off their
                             seams, every wedge priced */
} attr_ctx;


/* ---- wedges ------------------------------------------------------------------ */

static inline uint32_t wedge_at(const mr_simplifier *s, uint32_t t, uint32_t x)
{
    const attr_ctx *a = s->attr;
    const uint32_t *tri = s->m.tris + 3 * (size_t)t;
    const uint32_t k = tri[0] == x ? 0 : tri[1] == x ? 1 : 2;
    return a->corner[3 * (size_t)t + k];
}

/* The (one or two) triangles on edge (r, k), from r's list. */
static uint32_t edge_tris(const mr_simplifier *s, uint32_t r, uint32_t k, uint32_t et[2])
{
    const mr_collapse_mesh *m = &s->m;
    const uint32_t *list = mr_collapse_vertex_tris(m, r);
    uint32_t n = 0;
    for (uint32_t i = 0; i < m->count[r] && n < 2; i++) {
        const uint32_t t = list[i] / 3;
        const uint32_t *tri = m->tris + 3 * (size_t)t;
        if (tri[0] == k || tri[1] == k || tri[2] == k)
            et[n++] = t;
    }
    return n;
}

static bool seam_edge(const mr_simplifier *s, uint32_t a, uint32_t b, const uint32_t et[2])
{
    return wedge_at(s, et[0], a) != wedge_at(s, et[1], a) &&
           wedge_at(s, et[0], b) != wedge_at(s, et[1], b);
}

static bool attr_valid(const mr_simplifier *s, uint32_t r, uint32_t k)
{
    const attr_ctx *a = s->attr;
    if (a->permissive) {
        /* a loose vertex goes onto another seam vertex (which stays one);
         * any vertex may go onto a loose one */
        if (a->loose[r])
            return (s->m.flags[k] & MR_VF_SEAM) != 0;
        if (a->loose[k])
            return true;
    }
    uint32_t et[2];
    uint32_t n = edge_tris(s, r, k, et);
    if (n != 2)
        return !(s->m.flags[r] & MR_VF_SEAM) || n == 1;
    if (s->m.flags[r] & MR_VF_SEAM)
        return (s->m.flags[k] & MR_VF_SEAM) && seam_edge(s, r, k, et);
    /* r has one wedge: the survivor's must be the same on both sides. */
    return wedge_at(s, et[0], k) == wedge_at(s, et[1], k);
}

static void lerp_attr(float *a, const float *b, int n, double t, bool normalise)
{
    double len = 0;
    for (int i = 0; i < n; i++) {
        a[i] = (float)((1 - t) * a[i] + t * b[i]);
        len += (double)a[i] * a[i];
    }
    if (normalise && len > 0) {
        len = sqrt(len);
        for (int i = 0; i < n; i++)
            a[i] = (float)(a[i] / len);
    }
}

/* The wedges of u other than those of its corners on edge (u, w)'s
 * triangles et[0..n): they go to w's wedge on et[0]'s side (attr_apply).
 * Up to `cap` distinct ones into out; their count. */
static uint32_t other_wedges(const mr_simplifier *s, uint32_t u, uint32_t w, const uint32_t *et,
                             uint32_t n, uint32_t *out, uint32_t cap)
{
    const attr_ctx *a = s->attr;
    const mr_collapse_mesh *m = &s->m;
    uint32_t on_edge[2] = {NONE, NONE};
    for (uint32_t j = 0; j < n; j++)
        on_edge[j] = wedge_at(s, et[j], u);
    const uint32_t *list = mr_collapse_vertex_tris(m, u);
    uint32_t found = 0;
    for (uint32_t i = 0; i < m->count[u] && found < cap; i++) {
        const uint32_t c = list[i];
        const uint32_t *tri = m->tris + (c - c % 3);
        if (tri[0] == NONE || tri[0] == w || tri[1] == w || tri[2] == w)
            continue;
        const uint32_t x = a->corner[c];
        bool seen = x == on_edge[0] || x == on_edge[1];
        for (uint32_t f = 0; f < found && !seen; f++)
            seen = out[f] == x;
        if (!seen)
            out[found++] = x;
    }
    return found;
}

#define MAX_OTHER_WEDGES 32

/* The attributes' part of a collapse of edge (u, w) (the core's
 * attr_cost): each wedge of u with w's on the same side of the edge; in
 * the permissive stage, u's other wedges too, with w's on et[0]'s side. */
static void attr_cost(const mr_simplifier *s, uint32_t u, uint32_t w, mr_quadric *q)
{
    const attr_ctx *a = s->attr;
    double o[3];
    mr_collapse_load(&s->m, w, o);
    if (!((s->m.flags[u] | s->m.flags[w]) & MR_VF_SEAM)) {
        mr_attr_pair_quadric(&a->aq, a->wedge[u], a->wedge[w], o, q);
        return;
    }
    uint32_t et[2];
    const uint32_t n = edge_tris(s, u, w, et);
    uint32_t pa = NONE, pb = NONE;
    for (uint32_t j = 0; j < n; j++) {
        const uint32_t fa = wedge_at(s, et[j], u), tb = wedge_at(s, et[j], w);
        if (fa == pa && tb == pb)
            break;
        mr_attr_pair_quadric(&a->aq, fa, tb, o, q);
        pa = fa;
        pb = tb;
    }
    if (a->permissive && n) {
        uint32_t other[MAX_OTHER_WEDGES];
        const uint32_t no = other_wedges(s, u, w, et, n, other, MAX_OTHER_WEDGES);
        const uint32_t t0 = wedge_at(s, et[0], w);
        for (uint32_t i = 0; i < no; i++)
            mr_attr_pair_quadric(&a->aq, other[i], t0, o, q);
    }
}

static void attr_prefetch(const mr_simplifier *s, uint32_t u, uint32_t w)
{
    const attr_ctx *a = s->attr;
    mr_attr_prefetch(&a->aq, a->wedge[u]);
    mr_attr_prefetch(&a->aq, a->wedge[w]);
}

static void attr_apply(const mr_simplifier *s, uint32_t r, uint32_t k, const double target[3])
{
    attr_ctx *a = s->attr;
    const mr_collapse_mesh *m = &s->m;
    uint32_t et[2];
    uint32_t n = edge_tris(s, r, k, et);
    uint32_t from[2], to[2];
    for (uint32_t j = 0; j < n; j++) {
        from[j] = wedge_at(s, et[j], r);
        to[j] = wedge_at(s, et[j], k);
    }
    /* The weighted attributes: each pair's quadrics merged, the survivor's
     * values at their best at the target (in the permissive stage, r's
     * other wedges' into to[0] too). */
    if (a->aq.channels) {
        if (a->permissive && n) {
            uint32_t other[MAX_OTHER_WEDGES];
            const uint32_t no = other_wedges(s, r, k, et, n, other, MAX_OTHER_WEDGES);
            for (uint32_t i = 0; i < no; i++)
                mr_attr_merge(&a->aq, other[i], to[0]);
        }
        for (uint32_t j = 0; j < n; j++) {
            if (j == 1 && from[1] == from[0] && to[1] == to[0])
                break;
            mr_attr_merge(&a->aq, from[j], to[j]);
            mr_attr_place(&a->aq, to[j], target);
        }
    }
    /* Interpolate the survivor's wedges at the target's place on the edge. */
    double pk[3], pr[3];
    mr_collapse_load(m, k, pk);
    mr_collapse_load(m, r, pr);
    const double d[3] = {pr[0] - pk[0], pr[1] - pk[1], pr[2] - pk[2]};
    const double len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    double t = len2 > 0 ? ((target[0] - pk[0]) * d[0] + (target[1] - pk[1]) * d[1] +
                           (target[2] - pk[2]) * d[2]) / len2
                        : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    if (t > 0) {
        for (uint32_t j = 0; j < n; j++) {
            if (j == 1 && to[1] == to[0])
                break;
            if (a->lerp_normals)
                lerp_attr(a->normals + 3 * (size_t)to[j], a->normals + 3 * (size_t)from[j],
                          3, t, true);
            if (a->lerp_texcoords)
                lerp_attr(a->texcoords + 2 * (size_t)to[j],
                          a->texcoords + 2 * (size_t)from[j], 2, t, false);
            if (a->lerp_colors)
                lerp_attr(a->colors + 4 * (size_t)to[j], a->colors + 4 * (size_t)from[j], 4,
                          t, false);
        }
    }
    /* r's corners take the survivor's wedge on their side. */
    const uint32_t *list = mr_collapse_vertex_tris(m, r);
    for (uint32_t i = 0; i < m->count[r]; i++) {
        const uint32_t c = list[i]; /* r's corner */
        const uint32_t *tri = m->tris + (c - c % 3);
        if (tri[0] == k || tri[1] == k || tri[2] == k)
            continue;
        const uint32_t w = a->corner[c];
        a->corner[c] = (n == 2 && w == from[1] && w != from[0]) ? to[1] : to[0];
    }
}

/* ---- seam setup ---------------------------------------------------------------- */

/* Flag seam vertices, lock the complex ones, add the seam edges'
 * constraint quadrics. Returns the number of seam vertices. Each vertex
 * writes only its own flags and quadric (and reads lists, triangles and
 * corners): the vertices run on every thread, with the same result. */
static size_t setup_seams(mr_simplifier *s)
{
    size_t seam_vertices = 0;
    mr_collapse_mesh *m = &s->m;
    attr_ctx *a = s->attr;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count;
#pragma omp parallel for schedule(dynamic, 4096) num_threads(s->plan.threads) \
    if (s->plan.threads > 1 && nv > 65536) reduction(+ : seam_vertices)
    for (ptrdiff_t vi = 0; vi < nv; vi++) {
        const uint32_t v = (uint32_t)vi;
        if (m->flags[v] & (MR_VF_REMOVED | MR_VF_NONMANIFOLD))
            continue;
        const uint32_t *list = mr_collapse_vertex_tris(m, v);
        uint32_t w0 = a->corner[list[0]], w1 = NONE;
        bool many = false;
        for (uint32_t i = 1; i < m->count[v]; i++) {
            uint32_t w = a->corner[list[i]];
            if (w == w0 || w == w1)
                continue;
            if (w1 == NONE)
                w1 = w;
            else
                many = true;
        }
        if (w1 == NONE)
            continue;
        /* free to leave its seam in the last stage: off the open
         * boundaries, and locked by no caller */
        a->loose[v] = !(m->flags[v] & (MR_VF_BOUNDARY | MR_VF_LOCKED));
        m->flags[v] |= MR_VF_SEAM;
        seam_vertices++;
        /* Count seam edges and add their constraint planes. */
        uint32_t seams = 0, loose = 0;
        mr_quadric q;
        mr_quadric_load(&q, &s->q[v]);
        double pv[3];
        mr_collapse_load(m, v, pv);
        for (uint32_t i = 0; i < m->count[v]; i++) {
            const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
            const uint32_t k = list[i] % 3;
            const uint32_t x = tri[(k + 1) % 3]; /* each inner edge once */
            uint32_t et[2];
            if (edge_tris(s, v, x, et) != 2)
                continue;
            bool at_v = wedge_at(s, et[0], v) != wedge_at(s, et[1], v);
            bool at_x = wedge_at(s, et[0], x) != wedge_at(s, et[1], x);
            if (at_v && at_x) {
                seams++;
                double p[3][3], n[3], b[3];
                for (int j = 0; j < 3; j++)
                    mr_collapse_load(m, tri[j], p[j]);
                mr_triangle_normal(p[0], p[1], p[2], n);
                mr_collapse_load(m, x, b);
                for (int j = 0; j < 3; j++)
                    b[j] -= pv[j];
                const double o[3] = {0, 0, 0};
                mr_quadric_add_edge_constraint(&q, o, b, n, a->seam_weight);
            } else if (at_v != at_x) {
                loose++; /* a seam that ends here in one wedge only */
            }
        }
        mr_quadric_store(&s->q[v], &q);
        if (many || seams != 2 || loose || (m->flags[v] & MR_VF_BOUNDARY))
            m->flags[v] |= MR_VF_LOCKED;
    }
    return seam_vertices;
}

/* The last stage (the core's attr_release), when the run ends short of
 * its targets with the seams kept: the loose seam vertices are freed --
 * they may move off their seams, the wedges that lose their place priced
 * by the attributes' quadrics -- as meshoptimizer's permissive mode frees
 * its seam and complex vertices. Without weighted attributes nothing
 * would price that: no stage. */
static bool attr_release(mr_simplifier *s)
{
    attr_ctx *a = s->attr;
    mr_collapse_mesh *m = &s->m;
    if (a->permissive || !a->aq.channels)
        return false;
    size_t freed = 0;
    for (size_t v = 0; v < m->vertex_count; v++)
        if (a->loose[v] && !(m->flags[v] & MR_VF_REMOVED)) {
            m->flags[v] &= (uint8_t)~MR_VF_LOCKED;
            freed++;
        }
    a->permissive = freed > 0;
    return a->permissive;
}

/* Whether the seams go free from the start (mr_seam_mode): asked, or
 * (auto) where the seam vertices they lock that the last stage would free
 * are a tenth of the surface points or more. */
static bool free_from_start(const mr_simplifier *s, mr_seam_mode mode)
{
    if (mode == MR_SEAMS_FREE)
        return true;
    if (mode != MR_SEAMS_AUTO)
        return false;
    const attr_ctx *a = s->attr;
    const mr_collapse_mesh *m = &s->m;
    size_t live = 0, held = 0;
    for (size_t v = 0; v < m->vertex_count; v++)
        if (!(m->flags[v] & MR_VF_REMOVED)) {
            live++;
            held += a->loose[v] && (m->flags[v] & MR_VF_LOCKED);
        }
    return 10 * held >= live && held > 0;
}

/* A seam's edge (mr_simplifier_mark_corners' polyline). */
static bool seam_line_edge(const mr_simplifier *s, uint32_t v, uint32_t x)
{
    uint32_t et[2];
    return edge_tris(s, v, x, et) == 2 && seam_edge(s, v, x, et);
}

/* ---- the call ---------------------------------------------------------------------- */

/* The wedge of v's first corner (NONE for a vertex without triangles). */
static inline uint32_t first_wedge(const mr_collapse_mesh *m, const uint32_t *corner, uint32_t v)
{
    return !(m->flags[v] & MR_VF_REMOVED) && m->count[v] > 0
               ? corner[mr_collapse_vertex_tris(m, v)[0]]
               : NONE;
}

/* The attributes' part in the cost, where o weighs one that the mesh has:
 * their quadrics (attr_quadric.h), each vertex's wedge for the seamless
 * edges' pairs, and the hooks. Nothing to do without weights. */
static mr_status attr_cost_setup(mr_simplifier *s, attr_ctx *a, const mr_mesh *in,
                                 const mr_simplify_options *o, int nth, mr_error *err)
{
    const size_t vc = in->vertex_count;
    if (!mr_attr_quadrics_channels(&a->aq, s, a->corner, in, o, a->normals, a->texcoords,
                                   a->colors))
        return MR_OK;
    mr_status st = mr_attr_quadrics_build(&a->aq, s, a->corner, vc, err);
    if (st != MR_OK)
        return st;
    a->wedge = mr_alloc_array(vc ? vc : 1, sizeof *a->wedge);
    if (!a->wedge)
        return mr_fail_nomem(err, NULL, vc * sizeof *a->wedge);
    const mr_collapse_mesh *m = &s->m;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count;
#pragma omp parallel for schedule(static) num_threads(nth) if (nth > 1 && nv > 65536)
    for (ptrdiff_t v = 0; v < nv; v++)
        a->wedge[v] = first_wedge(m, a->corner, (uint32_t)v);
    s->attr_cost = attr_cost;
    s->attr_prefetch = attr_prefetch;
    return MR_OK;
}

static void free_ctx(attr_ctx *a)
{
    free(a->corner);
    free(a->normals);
    free(a->texcoords);
    free(a->colors);
    mr_attr_quadrics_free(&a->aq);
    free(a->wedge);
    free(a->loose);
}

static float *dup_floats(const float *src, size_t n)
{
    if (!src)
        return NULL;
    float *d = mr_alloc_array(n, sizeof *d);
    if (d)
        memcpy(d, src, n * sizeof *d);
    return d;
}

/* The chunk's marks by geometric vertex (mr_mesh_chunk_marks): a wedge's
 * cut, lock and carried quadric go to its surface point. */
typedef struct geo_marks {
    uint8_t *cut, *was;
    mr_quadricf *q;
} geo_marks;

static void geo_marks_free(geo_marks *g)
{
    free(g->cut);
    free(g->was);
    free(g->q);
    memset(g, 0, sizeof *g);
}

static mr_status geo_marks_make(const mr_mesh_chunk_marks *cm, const uint32_t *geo, size_t vc,
                                uint8_t *lock, geo_marks *g, mr_error *err)
{
    memset(g, 0, sizeof *g);
    g->cut = mr_calloc_array(vc ? vc : 1, 1);
    g->was = cm->quadrics ? mr_calloc_array(vc ? vc : 1, 1) : NULL;
    g->q = cm->quadrics ? mr_calloc_array(vc ? vc : 1, sizeof *g->q) : NULL;
    if (!g->cut || (cm->quadrics && (!g->was || !g->q))) {
        geo_marks_free(g);
        return mr_fail_nomem(err, NULL, vc * (2 + sizeof *g->q));
    }
    for (size_t v = 0; v < vc; v++) {
        const uint32_t p = geo[v];
        g->cut[p] |= cm->cut[v] != 0;
        if (cm->cut[v] || (cm->locked && cm->locked[v]))
            lock[p] = MR_VF_LOCKED;
        if (cm->quadrics) {
            g->was[p] |= cm->was_cut[v] != 0;
            mr_quadric a, b;
            mr_quadric_load(&a, &g->q[p]);
            mr_quadric_load(&b, &cm->quadrics[v]);
            mr_quadric_add(&a, &b);
            mr_quadric_store(&g->q[p], &a);
        }
    }
    return MR_OK;
}

/* A chunk's output quadrics (mr_mesh_chunk_marks): each geometric
 * vertex's on its first output vertex. */
static mr_status chunk_quadrics_out(const mr_simplifier *s, const mr_mesh_chunk_marks *cm,
                                    const float *run_pos, const uint32_t *gof, const mr_mesh *out,
                                    mr_error *err)
{
    const size_t nv = out->vertex_count;
    mr_quadricf *q = mr_calloc_array(nv ? nv : 1, sizeof *q);
    uint8_t *seen = mr_calloc_array(s->m.vertex_count ? s->m.vertex_count : 1, 1);
    if (!q || !seen) {
        free(q);
        free(seen);
        return mr_fail_nomem(err, NULL, nv * sizeof *q);
    }
    for (size_t i = 0; i < nv; i++) {
        if (seen[gof[i]])
            continue;
        seen[gof[i]] = 1;
        mr_simplifier_quadric_out(s, gof[i], run_pos, out->positions + 3 * i, cm->unit, &q[i]);
    }
    free(seen);
    *cm->quadrics_out = q;
    return MR_OK;
}

static mr_status mesh_simplify(const mr_mesh *in, const mr_simplify_options *options,
                               const mr_mesh_chunk_marks *cm, mr_mesh *out, uint32_t **origin,
                               mr_simplify_stats *stats, mr_error *err)
{
    if (origin)
        *origin = NULL;
    if (!in || !out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "simplify: NULL mesh");
    if (in->triangle_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL, "simplify: the mesh has no triangles");
    const double t0 = mr_now_seconds();
    const size_t vc = in->vertex_count, tc = in->triangle_count;
    mr_status st = mr_check_indices(in->indices, tc, vc, err);
    if (st != MR_OK)
        return st;
    attr_ctx a;
    memset(&a, 0, sizeof a);
    uint32_t *geo = mr_alloc_array(vc, sizeof *geo);
    uint32_t *gidx = mr_alloc_array(3 * tc, sizeof *gidx);
    a.corner = mr_alloc_array(3 * tc, sizeof *a.corner);
    a.normals = dup_floats(in->normals, 3 * vc);
    a.texcoords = dup_floats(in->texcoords, 2 * vc);
    a.colors = dup_floats(in->colors, 4 * vc);
    if (!geo || !gidx || !a.corner || (in->normals && !a.normals) ||
        (in->texcoords && !a.texcoords) || (in->colors && !a.colors)) {
        free(geo);
        free(gidx);
        free_ctx(&a);
        return mr_fail_nomem(err, NULL, vc * 40 + tc * 24);
    }
    st = mr_surface_points(in->positions, vc, in->indices, tc, geo, NULL, err);
    if (st != MR_OK) {
        free(geo);
        free(gidx);
        free_ctx(&a);
        return st;
    }
    const int nth = mr_thread_count(options ? options->threads : 0);
    const bool par = nth > 1 && tc > 65536;
    const ptrdiff_t ncorners = (ptrdiff_t)(3 * tc), nvc = (ptrdiff_t)vc, ntc = (ptrdiff_t)tc;
#pragma omp parallel for schedule(static) num_threads(nth) if (par)
    for (ptrdiff_t c = 0; c < ncorners; c++) {
        gidx[c] = geo[in->indices[c]];
        a.corner[c] = in->indices[c];
    }
    a.seam_weight = options ? options->boundary_weight : 0;

    /* A vertex lock on any wedge locks the geometric vertex. */
    mr_simplify_options o;
    mr_simplify_options_default(&o); /* read below even without options */
    if (options)
        o = *options;
    uint8_t *lock = NULL;
    geo_marks gm = {0};
    if ((options && options->vertex_lock) || cm) {
        lock = mr_calloc_array(vc, 1);
        if (!lock) {
            free(geo);
            free(gidx);
            free_ctx(&a);
            return mr_fail_nomem(err, NULL, vc);
        }
        if (options && options->vertex_lock)
            for (size_t v = 0; v < vc; v++)
                if (options->vertex_lock[v])
                    lock[geo[v]] = MR_VF_LOCKED;
        o.vertex_lock = NULL;
        if (cm && (st = geo_marks_make(cm, geo, vc, lock, &gm, err)) != MR_OK) {
            free(lock);
            free(geo);
            free(gidx);
            free_ctx(&a);
            return st;
        }
    }
    mr_simplifier s;
    const mr_vertex_marks marks = {.flags = lock,
                                   .cut = gm.cut,
                                   .quadrics = gm.q,
                                   .was_cut = gm.was,
                                   .unit = cm ? cm->unit : 0};
    st = mr_simplify_setup(&s, in->positions, 0, vc, gidx, tc, options ? &o : NULL, &marks, err);
    free(lock);
    /* the set-up took the quadrics; the cut stays with the run */
    free(gm.q);
    free(gm.was);
    gm.q = NULL;
    gm.was = NULL;
    if (st != MR_OK || o.quality != MR_QUALITY_BEST) {
        free(gidx); /* else the last step's samples come from it */
        gidx = NULL;
    }
    if (st != MR_OK) {
        free(geo);
        free_ctx(&a);
        geo_marks_free(&gm);
        return st;
    }
    if (s.order) {
        /* the corners in the working order of the triangles */
        uint32_t *corner = mr_alloc_array(3 * tc, sizeof *corner);
        if (!corner) {
            mr_simplify_discard(&s);
            free(geo);
            free(gidx);
            free_ctx(&a);
        geo_marks_free(&gm);
            return mr_fail_nomem(err, NULL, 3 * tc * sizeof *corner);
        }
#pragma omp parallel for schedule(static) num_threads(nth) if (par)
        for (ptrdiff_t t = 0; t < ntc; t++)
            memcpy(corner + 3 * t, a.corner + 3 * (size_t)s.order[t], 3 * sizeof *corner);
        free(a.corner);
        a.corner = corner;
        free(s.order);
        s.order = NULL;
    }
    a.loose = mr_calloc_array(vc ? vc : 1, 1);
    if (!a.loose) {
        mr_simplify_discard(&s);
        free(geo);
        free(gidx);
        free_ctx(&a);
        geo_marks_free(&gm);
        return mr_fail_nomem(err, NULL, vc);
    }
    s.attr = &a;
    /* Without seams every geometric vertex has one wedge: the attribute
     * rules cannot refuse a collapse, and without attributes the only
     * work of attr_apply -- giving moved corners the survivor's wedge --
     * is done at output from each vertex's one wedge. */
    const bool has_attributes = a.normals || a.texcoords || a.colors;
    const bool has_seams = setup_seams(&s) > 0;
    if (has_seams)
        mr_simplifier_mark_corners(&s, MR_VF_SEAM, seam_line_edge);
    s.attr_valid = has_seams ? attr_valid : NULL;
    s.attr_apply = has_seams || has_attributes ? attr_apply : NULL;
    s.attr_release = has_seams && o.seams != MR_SEAMS_KEEP ? attr_release : NULL;
    /* The weighted attributes in the cost (their quadrics from the
     * triangles as set up: before any collapse). */
    st = attr_cost_setup(&s, &a, in, &o, nth, err);
    a.lerp_normals = a.normals && !a.aq.has[0];
    a.lerp_texcoords = a.texcoords && !a.aq.has[1];
    a.lerp_colors = a.colors && !a.aq.has[2];
    if (!s.attr_apply) {
        /* wedge of each geometric vertex, kept in geo (no longer needed) */
        const mr_collapse_mesh *m0 = &s.m;
#pragma omp parallel for schedule(static) num_threads(nth) if (par)
        for (ptrdiff_t v = 0; v < nvc; v++) {
            const uint32_t w = first_wedge(m0, a.corner, (uint32_t)v);
            if (w != NONE)
                geo[v] = w;
        }
    }
    if (st == MR_OK && s.attr_release && free_from_start(&s, o.seams))
        s.attr_release(&s); /* the seams free from the start */
    if (st == MR_OK)
        st = mr_simplifier_fill_queue(&s, err);
    if (st != MR_OK) {
        mr_simplify_discard(&s);
        free(geo);
        free(gidx);
        free_ctx(&a);
        geo_marks_free(&gm);
        return st;
    }
    const double t1 = mr_now_seconds();
    double max_error;
    size_t collapses = mr_simplify_run(&s, &max_error);
    mr_attr_quadrics_free(&a.aq); /* the run's alone */
    free(a.wedge);
    a.wedge = NULL;
    s.attr_cost = NULL;
    s.attr_prefetch = NULL;
    s.attr_release = NULL;
    float *before = NULL; /* a chunk's: where the collapses left the vertices */
    if (o.quality == MR_QUALITY_BEST && !s.cancelled) {
        if (cm) {
            /* the quadrics stay for the output's */
            mr_simplify_strategy(&s)->release(&s);
            before = mr_alloc_array(3 * vc, sizeof *before);
            if (before)
                memcpy(before, s.m.pos, 12 * vc);
            else
                st = mr_fail_nomem(err, NULL, 12 * vc);
        } else {
            mr_simplify_release_run(&s);
        }
        if (st == MR_OK)
            st = mr_simplifier_refine(&s, in->positions, 0, gidx, tc, err);
        free(gidx);
        gidx = NULL;
        if (st != MR_OK) {
            mr_simplify_discard(&s);
            free(geo);
            free(before);
            free_ctx(&a);
            geo_marks_free(&gm);
            return st;
        }
    }
    const double t2 = mr_now_seconds();
    if (s.cancelled) {
        mr_simplify_discard(&s);
        free(geo);
        free(before);
        free_ctx(&a);
        geo_marks_free(&gm);
        return mr_simplifier_cancelled(err);
    }

    /* Output: one vertex per surviving wedge, in input order. */
    const mr_collapse_mesh *m = &s.m;
    if (!s.attr_apply) {
#pragma omp parallel for schedule(static) num_threads(nth) if (par)
        for (ptrdiff_t c = 0; c < ncorners; c++)
            if (m->tris[c - c % 3] != NONE)
                a.corner[c] = geo[m->tris[c]];
    }
    uint32_t *remap = geo; /* reused: wedge -> output vertex */
#pragma omp parallel for schedule(static) num_threads(nth) if (par)
    for (ptrdiff_t v = 0; v < nvc; v++)
        remap[v] = NONE;
    size_t nt = 0;
    for (size_t t = 0; t < tc; t++) {
        if (m->tris[3 * t] == NONE)
            continue;
        nt++;
        for (int k = 0; k < 3; k++)
            remap[a.corner[3 * t + k]] = 0;
    }
    size_t nv = 0;
    for (size_t v = 0; v < vc; v++)
        if (remap[v] != NONE)
            remap[v] = (uint32_t)nv++;
    mr_mesh_init(out);
    st = mr_mesh_alloc(out, nv, nt, mr_mesh_attributes(in) & MR_ATTR_BASIC, err);
    uint32_t *org = NULL;
    if (st == MR_OK && origin) {
        org = mr_alloc_array(nv, sizeof *org);
        if (!org) {
            mr_mesh_free(out);
            st = mr_fail_nomem(err, NULL, nv * 4);
        }
    }
    /* a chunk's: each output vertex's geometric vertex, for its quadric */
    uint32_t *gof = NULL;
    if (st == MR_OK && cm) {
        gof = mr_alloc_array(nv ? nv : 1, sizeof *gof);
        if (!gof) {
            mr_mesh_free(out);
            free(org);
            org = NULL;
            st = mr_fail_nomem(err, NULL, nv * 4);
        }
    }
    if (st == MR_OK) {
        size_t t2i = 0;
        for (size_t t = 0; t < tc; t++) {
            const uint32_t *tri = m->tris + 3 * t;
            if (tri[0] == NONE)
                continue;
            for (int k = 0; k < 3; k++) {
                const uint32_t w = a.corner[3 * t + k], o_ = remap[w];
                out->indices[3 * t2i + k] = o_;
                /* position of the corner's geometric vertex */
                const uint32_t g = tri[k];
                float *p = out->positions + 3 * (size_t)o_;
                if (m->flags[g] & MR_VF_MOVED)
                    mr_simplifier_position(&s, g, p);
                else
                    memcpy(p, in->positions + 3 * (size_t)w, 3 * sizeof(float));
                if (a.normals)
                    memcpy(out->normals + 3 * (size_t)o_, a.normals + 3 * (size_t)w, 12);
                if (a.texcoords)
                    memcpy(out->texcoords + 2 * (size_t)o_, a.texcoords + 2 * (size_t)w, 8);
                if (a.colors)
                    memcpy(out->colors + 4 * (size_t)o_, a.colors + 4 * (size_t)w, 16);
                if (org)
                    org[o_] = w;
                if (gof)
                    gof[o_] = g;
            }
            t2i++;
        }
    }
    if (st == MR_OK && cm)
        st = chunk_quadrics_out(&s, cm, before ? before : s.m.pos, gof, out, err);
    free(gof);
    free(before);
    const size_t input_vertices = s.input_vertices, blocked = s.blocked_vertices;
    const size_t output_points = s.m.live_vertices;
    const mr_simplify_stop stop = s.stop;
    const size_t pruned = s.pruned;
    const mr_simplify_stats profile = s.profile; /* the strategy's counts */
    mr_simplify_discard(&s);
    free(geo);
    free_ctx(&a);
    geo_marks_free(&gm);
    if (st != MR_OK) {
        free(org);
        if (cm)
            mr_mesh_free(out);
        return st;
    }
    if (origin)
        *origin = org;
    if (stats) {
        *stats = profile;
        stats->input_vertices = input_vertices;
        stats->locked_vertices = blocked;
        stats->input_triangles = tc;
        stats->output_vertices = nv;
        stats->output_points = output_points;
        stats->output_triangles = nt;
        stats->stop = stop;
        stats->target_reached = stop <= MR_STOP_MAX_ERROR || (options && options->until_error);
        stats->pruned_parts = pruned;
        stats->collapses = collapses;
        stats->max_error = max_error;
        stats->seconds_setup = t1 - t0;
        stats->seconds_collapse = t2 - t1;
        stats->seconds_output = mr_now_seconds() - t2;
    }
    return MR_OK;
}

/* A mesh with materials, texture sets 1-3 or a skin: the run on its
 * weighed attributes (split by material), what it carries put back
 * (carried.c). Tangents are left out. */
static mr_status simplify_carried(const mr_mesh *in, const mr_simplify_options *options,
                                  mr_mesh *out, uint32_t **origin, mr_simplify_stats *stats,
                                  mr_error *err)
{
    if (origin)
        *origin = NULL;
    mr_mesh_init(out);
    mr_carried c;
    memset(&c, 0, sizeof c);
    mr_mesh run = *in; /* its weighed attributes only */
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        run.more_texcoords[k] = NULL;
    run.tangents = NULL;
    run.joints = NULL;
    run.weights = NULL;
    run.materials = NULL;
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    if (options)
        o = *options;
    mr_status st = MR_OK;
    if (in->materials) {
        if ((st = mr_check_indices(in->indices, in->triangle_count, in->vertex_count, err)) !=
                MR_OK ||
            (st = mr_carried_split(in, o.vertex_lock, &c, err)) != MR_OK)
            return st;
        run = c.split;
        o.vertex_lock = c.lock;
    }
    uint32_t *org = NULL;
    st = mesh_simplify(&run, &o, NULL, out, &org, stats, err);
    if (st == MR_OK && (st = mr_carried_finish(in, &c, out, org, err)) != MR_OK)
        mr_mesh_free(out);
    if (st == MR_OK && origin)
        *origin = org;
    else
        free(org);
    mr_carried_free(&c);
    return st;
}

mr_status mr_mesh_simplify(const mr_mesh *in, const mr_simplify_options *options, mr_mesh *out,
                           uint32_t **origin, mr_simplify_stats *stats, mr_error *err)
{
    const int dynamic = mr_omp_fixed_teams(); /* teams as asked for */
    const bool carried = in && out && (mr_mesh_attributes(in) & ~MR_ATTR_BASIC);
    const mr_status st = carried ? simplify_carried(in, options, out, origin, stats, err)
                                 : mesh_simplify(in, options, NULL, out, origin, stats, err);
    mr_omp_restore_teams(dynamic);
    return st;
}

mr_status mr_mesh_simplify_chunk(const mr_mesh *in, const mr_simplify_options *options,
                                 const mr_mesh_chunk_marks *marks, mr_mesh *out,
                                 uint32_t **origin, mr_simplify_stats *stats, mr_error *err)
{
    if (!marks || !marks->cut || !marks->quadrics_out || !(marks->unit > 0) ||
        (marks->quadrics && !marks->was_cut))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: a chunk needs its cut, a unit > 0, and was_cut with "
                             "carried quadrics");
    *marks->quadrics_out = NULL;
    const int dynamic = mr_omp_fixed_teams();
    const mr_status st = mesh_simplify(in, options, marks, out, origin, stats, err);
    mr_omp_restore_teams(dynamic);
    return st;
}
