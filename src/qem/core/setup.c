/*
 * The simplifier core's set-up, shared by every strategy: the options'
 * checks, the working mesh (collapse.h) and its per-vertex quadrics, the
 * targets a run aims at, and the release of it all.
 *
 * Geometry is normalised (centre of the referenced vertices' bounding box
 * at the origin, diagonal 1), so a cost is the squared RMS distance to the
 * planes the merged vertex stands for (quadric.h), relative to that
 * diagonal; max_error and stats.max_error are its square root, in world
 * units when error_absolute is set, else relative to the diagonal of the
 * bounding box of all the input's vertices (error_base, the one that
 * `meshreduce info` prints: unreferenced vertices may widen it).
 */
#include "simplifier.h"
#include "kernels.h"

#include "../../core/omp_compat.h"
#include "../../mesh/adjacency.h"

#include <math.h>

/* ---- setup ----------------------------------------------------------------- */

/* Triangles of one vertex that inner_quadric takes at once, and the
 * length of its rows (room for three lanes of padding). */
#define INNER_FAN MR_PLANE_FAN
#define INNER_ROW MR_PLANE_ROW

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
    s->plan.kernels->plane_terms(in, (n + 3) & ~3u, t);
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

/* Is (v, x) an open boundary's edge: one triangle, and not a chunk's cut
 * (mr_vertex_marks)? */
static bool open_edge(const mr_simplifier *s, uint32_t v, uint32_t x)
{
    return mr_collapse_edge_triangles(&s->m, v, x) == 1 && !(s->cut && s->cut[v] && s->cut[x]);
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
            if (!open_edge(s, v, ends[e]))
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

/* The quadric of v carried from the runs before (mr_vertex_marks): theirs,
 * scaled to this run's normalised lengths (factor r: their unit in this
 * run's), and the constraint planes of v's open edges that those runs took
 * for a cut (both ends were cut there) and this one does not. */
static void carried_quadric(mr_simplifier *s, uint32_t v, const mr_vertex_marks *marks,
                            double r, double boundary_weight)
{
    const mr_collapse_mesh *m = &s->m;
    mr_quadric q;
    mr_quadric_load(&q, &marks->quadrics[v]);
    const double r2 = r * r;
    q.a00 *= r2, q.a01 *= r2, q.a02 *= r2, q.a11 *= r2, q.a12 *= r2, q.a22 *= r2;
    q.b0 *= r2 * r, q.b1 *= r2 * r, q.b2 *= r2 * r;
    q.c *= r2 * r2;
    q.w *= r2;
    if ((m->flags[v] & MR_VF_BOUNDARY) && boundary_weight > 0 && marks->was_cut[v]) {
        const uint32_t *list = mr_collapse_vertex_tris(m, v);
        double pv[3];
        mr_collapse_load(m, v, pv);
        for (uint32_t i = 0; i < m->count[v]; i++) {
            const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
            const uint32_t k = list[i] % 3;
            const uint32_t ends[2] = {tri[(k + 1) % 3], tri[(k + 2) % 3]};
            for (int e = 0; e < 2; e++) {
                if (!marks->was_cut[ends[e]] || !open_edge(s, v, ends[e]))
                    continue;
                double p[3][3], n[3], b[3];
                for (int j = 0; j < 3; j++)
                    mr_collapse_load(m, tri[j], p[j]);
                if (!(mr_triangle_normal(p[0], p[1], p[2], n) > 0))
                    continue;
                mr_collapse_load(m, ends[e], b);
                b[0] -= pv[0];
                b[1] -= pv[1];
                b[2] -= pv[2];
                const double o[3] = {0, 0, 0};
                mr_quadric_add_edge_constraint(&q, o, b, n, boundary_weight);
            }
        }
    }
    mr_quadric_store(&s->q[v], &q);
}

void mr_simplifier_release_quadrics(mr_simplifier *s)
{
    free(s->q);
    s->q = NULL;
}

void mr_simplifier_free(mr_simplifier *s)
{
    mr_collapse_mesh_free(&s->m);
    mr_simplifier_release_quadrics(s);
    free(s->order);
    memset(s, 0, sizeof *s);
}

static bool is_finite(double x) { return x == x && x - x == 0; }

/* The low 10 bits of x spread to every third bit. */
static inline uint32_t spread3(uint32_t x)
{
    x &= 0x3FFu;
    x = (x | x << 16) & 0x030000FFu;
    x = (x | x << 8) & 0x0300F00Fu;
    x = (x | x << 4) & 0x030C30C3u;
    x = (x | x << 2) & 0x09249249u;
    return x;
}

/*
 * Whether the input's triangle order keeps the triangles of most vertices
 * within one group of blocks of batched.c's first level: at most 1 in 20
 * of every 8th referenced vertex has triangles 2^MR_BATCH_FIRST_SHIFT
 * blocks apart or more. A scan or grid written row by row passes (1.2 %
 * of the generated 1M-triangle scan's vertices); the data meshes'
 * orders, 4 to 94 %, and a shuffled file do not. Each thread tracks the
 * sampled vertices of its own range, sweeping every triangle.
 */
static bool order_is_coherent(const uint32_t *indices, size_t tc, size_t vc, int threads)
{
    const size_t ns = (vc + 7) / 8;
    uint32_t *lo = mr_alloc_array(ns, sizeof *lo), *hi = mr_alloc_array(ns, sizeof *hi);
    if (!lo || !hi) {
        free(lo);
        free(hi);
        return true; /* no memory to tell: keep the input's order */
    }
    size_t used = 0, spread = 0;
#pragma omp parallel num_threads(threads) reduction(+ : used, spread) \
    if (threads > 1 && tc > 65536)
    {
        const int me = omp_get_thread_num(), team = omp_get_num_threads();
        const size_t s0 = ns * (size_t)me / (size_t)team, s1 = ns * (size_t)(me + 1) / (size_t)team;
        for (size_t i = s0; i < s1; i++) {
            lo[i] = UINT32_MAX;
            hi[i] = 0;
        }
        for (size_t c = 0; c < 3 * tc; c++) {
            const uint32_t v = indices[c];
            const size_t i = v >> 3;
            if ((v & 7) == 0 && i - s0 < s1 - s0) {
                const uint32_t b = (uint32_t)(c / (3 * MR_BATCH_BLOCK_TRIANGLES));
                lo[i] = b < lo[i] ? b : lo[i];
                hi[i] = b > hi[i] ? b : hi[i];
            }
        }
        for (size_t i = s0; i < s1; i++) {
            used += lo[i] != UINT32_MAX;
            spread += lo[i] != UINT32_MAX && hi[i] - lo[i] >= (1u << MR_BATCH_FIRST_SHIFT);
        }
    }
    free(lo);
    free(hi);
    return 20 * spread <= used;
}

/*
 * The order the batched strategy works the triangles in, when the input's
 * is not coherent (order_is_coherent): by the Morton
 * code of each centroid in a 1024^3 grid over the referenced vertices'
 * bounding box, ties in input order (a stable sort). Its blocks of
 * triangles are then compact patches whatever order the input came in --
 * a triangle soup, a shuffled or interleaved file -- so that a collapse's
 * triangles lie near each other in memory and most of a round's winners
 * fall in one group of blocks (batched.c); in the input's order nearly
 * every collapse of a shuffled scan spans the groups and runs on one
 * thread. An order that is coherent already is kept: the vertex ids
 * usually follow it, and the per-vertex arrays are then read in step
 * (Morton-ordered triangles over a row-by-row scan's vertices read them
 * out of step, and ran slower). The same on any number
 * of threads. *order: triangle_count input triangle ids.
 */
static mr_status spatial_order(const float *positions, size_t stride, const uint32_t *indices,
                               size_t tc, const float lo[3], const float hi[3], int threads,
                               uint32_t **order, mr_error *err)
{
    uint32_t *key = mr_alloc_array(tc, sizeof *key);
    uint32_t *id = mr_alloc_array(tc, sizeof *id);
    if (!key || !id) {
        free(key);
        free(id);
        return mr_fail_nomem(err, NULL, tc * 8);
    }
    float scale[3];
    for (int k = 0; k < 3; k++)
        scale[k] = hi[k] > lo[k] ? 1023.0f / (3.0f * (hi[k] - lo[k])) : 0.0f;
    const ptrdiff_t n = (ptrdiff_t)tc;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && n > 65536)
    for (ptrdiff_t t = 0; t < n; t++) {
        uint32_t code = 0;
        for (int k = 0; k < 3; k++) {
            float sum = 0;
            for (int j = 0; j < 3; j++) {
                float p;
                memcpy(&p, (const char *)positions + (size_t)indices[3 * t + j] * stride +
                               (size_t)k * sizeof p,
                       sizeof p);
                sum += p - lo[k];
            }
            const float q = sum * scale[k]; /* the centroid, in [0, 1023] */
            const uint32_t c = q > 0 ? (q < 1023.0f ? (uint32_t)q : 1023u) : 0u;
            code |= spread3(c) << k;
        }
        key[t] = code;
        id[t] = (uint32_t)t;
    }
    const mr_status st = mr_radix_sort_u32(key, id, tc, 30, threads, err);
    free(key);
    if (st != MR_OK) {
        free(id);
        return st;
    }
    *order = id;
    return MR_OK;
}

/* ---- corners ---------------------------------------------------------------- */

/* A polyline turns sharply at a vertex when the directions of its two
 * edges there differ by at least MR_CORNER_SHARP degrees, and runs
 * straight on when they differ by at most MR_CORNER_STRAIGHT. */
#define MR_CORNER_SHARP 40.0
#define MR_CORNER_STRAIGHT 20.0

/* v's two neighbours along a polyline (the x with on_line(s, v, x)) into
 * nb; false unless there are exactly two. */
static bool line_neighbours(const mr_simplifier *s, uint32_t v, mr_line_edge on_line,
                            uint32_t nb[2])
{
    const mr_collapse_mesh *m = &s->m;
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    uint32_t n = 0;
    for (uint32_t i = 0; i < m->count[v]; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        const uint32_t k = list[i] % 3;
        for (int side = 1; side <= 2; side++) {
            const uint32_t x = tri[(k + (uint32_t)side) % 3];
            if ((n > 0 && nb[0] == x) || (n > 1 && nb[1] == x) || !on_line(s, v, x))
                continue;
            if (n == 2)
                return false;
            nb[n++] = x;
        }
    }
    return n == 2;
}

/* The turn of the polyline at v, from neighbour nb[0] through v to nb[1]:
 * the cosine of the angle between its two edges' directions (1: straight
 * on) into *cosine, and on which side it turns, seen along the normal of
 * v's fan, into *side (+1 or -1). False when an edge has no length. */
static bool line_turn(const mr_simplifier *s, uint32_t v, const uint32_t nb[2], double *cosine,
                      int *side)
{
    const mr_collapse_mesh *m = &s->m;
    double pv[3], pa[3], pb[3];
    mr_collapse_load(m, v, pv);
    mr_collapse_load(m, nb[0], pa);
    mr_collapse_load(m, nb[1], pb);
    const double e1[3] = {pv[0] - pa[0], pv[1] - pa[1], pv[2] - pa[2]};
    const double e2[3] = {pb[0] - pv[0], pb[1] - pv[1], pb[2] - pv[2]};
    const double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    const double l2 = sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
    if (!(l1 > 0) || !(l2 > 0))
        return false;
    *cosine = (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / (l1 * l2);
    double n[3] = {0, 0, 0};
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    for (uint32_t i = 0; i < m->count[v]; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        double p[3][3], c[3];
        for (int j = 0; j < 3; j++)
            mr_collapse_load(m, tri[j], p[j]);
        mr_triangle_normal(p[0], p[1], p[2], c);
        n[0] += c[0];
        n[1] += c[1];
        n[2] += c[2];
    }
    const double x[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    *side = x[0] * n[0] + x[1] * n[1] + x[2] * n[2] < 0 ? -1 : 1;
    return true;
}

/* One vertex along a polyline: cur's turn (*cosine, *side) and the
 * vertex after it coming from prev (*next). False where the line ends at
 * cur (a junction, a line's end, an edge without length). */
static bool line_step(const mr_simplifier *s, uint32_t prev, uint32_t cur, mr_line_edge on_line,
                      uint32_t *next, double *cosine, int *side)
{
    uint32_t nb[2];
    if (!line_neighbours(s, cur, on_line, nb) || (nb[0] != prev && nb[1] != prev))
        return false;
    const uint32_t order[2] = {prev, nb[0] == prev ? nb[1] : nb[0]};
    *next = order[1];
    return line_turn(s, cur, order, cosine, side);
}

/* Does the run from v through x (on v's side `side`) bear a corner at v?
 * Yes when it goes on straight for a while (CORNER_RUN vertices), ends
 * the line, or ends turning to v's side again (a tile's next corner);
 * no when it ends turning back within those few vertices -- a staircase
 * of grid cells, a scan's ragged hole. The first vertex may also turn
 * sharply to v's side with a straight run beyond it: the two corners of a
 * strip one triangle wide. */
#define CORNER_RUN 3
static bool run_bears_corner(const mr_simplifier *s, uint32_t v, uint32_t x, int side,
                             mr_line_edge on_line, double sharp, double straight)
{
    uint32_t prev = v, cur = x, next;
    double c;
    int sd;
    if (!line_step(s, prev, cur, on_line, &next, &c, &sd))
        return true; /* the line ends at x */
    if (c < straight) {
        if (c > sharp || sd != side)
            return false; /* a bend, or back the other way at once */
        prev = cur; /* the pair's other corner: its run beyond */
        cur = next;
        if (!line_step(s, prev, cur, on_line, &next, &c, &sd))
            return true;
        if (c < straight)
            return false;
    }
    for (int n = 1; n < CORNER_RUN; n++) {
        prev = cur;
        cur = next;
        if (!line_step(s, prev, cur, on_line, &next, &c, &sd))
            return true;
        if (c < straight)
            return sd == side;
    }
    return true;
}

/*
 * Is v a corner of its polyline: a sharp turn between two runs that bear
 * it (run_bears_corner)? A ragged line turns at every vertex or every few
 * vertices, back and forth, and has no corners: its vertices simplify as
 * any boundary's.
 */
static bool is_corner(const mr_simplifier *s, uint32_t v, mr_line_edge on_line)
{
    const double deg = 3.14159265358979323846 / 180;
    const double sharp = cos(MR_CORNER_SHARP * deg), straight = cos(MR_CORNER_STRAIGHT * deg);
    uint32_t nb[2];
    double c;
    int side;
    if (!line_neighbours(s, v, on_line, nb) || !line_turn(s, v, nb, &c, &side) || c > sharp)
        return false;
    /* walked from v, the run to nb[1] goes the way v's turn was taken,
     * the run to nb[0] against it: its turns to v's side read opposite */
    return run_bears_corner(s, v, nb[0], -side, on_line, sharp, straight) &&
           run_bears_corner(s, v, nb[1], side, on_line, sharp, straight);
}

size_t mr_simplifier_mark_corners(mr_simplifier *s, uint8_t line, mr_line_edge on_line)
{
    mr_collapse_mesh *m = &s->m;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count;
    const uint8_t skip = MR_VF_LOCKED | MR_VF_NONMANIFOLD | MR_VF_REMOVED;
    size_t on = 0;
    for (ptrdiff_t v = 0; v < nv; v++)
        on += (m->flags[v] & (line | skip)) == line;
    if (on == 0)
        return 0;
    uint8_t *mark = mr_calloc_array(m->vertex_count, 1);
    if (!mark)
        return 0; /* no memory: no corners kept, the run as without them */
    /* Each vertex decides from the mesh alone into its own mark, then the
     * marks become flags: the same on any number of threads. */
    const int nthreads = s->plan.threads;
#pragma omp parallel for schedule(dynamic, 4096) num_threads(nthreads) \
    if (nthreads > 1 && on > 65536)
    for (ptrdiff_t v = 0; v < nv; v++)
        if ((m->flags[v] & (line | skip)) == line)
            mark[v] = is_corner(s, (uint32_t)v, on_line);
    size_t corners = 0;
    for (ptrdiff_t v = 0; v < nv; v++)
        if (mark[v]) {
            m->flags[v] |= MR_VF_CORNER;
            corners++;
        }
    free(mark);
    s->corners += corners;
    return corners;
}

void mr_simplifier_release_corners(mr_simplifier *s)
{
    mr_collapse_mesh *m = &s->m;
    for (size_t v = 0; v < m->vertex_count; v++)
        m->flags[v] &= (uint8_t)~MR_VF_CORNER;
    s->corners = 0;
}

/* An open boundary's edge: one triangle, no chunk's cut. */
static bool boundary_edge(const mr_simplifier *s, uint32_t v, uint32_t x)
{
    return open_edge(s, v, x);
}

mr_status mr_simplify_check_options(const mr_simplify_options *o, size_t input_triangles,
                                    mr_error *err)
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
    const double aw[3] = {o->normal_weight, o->uv_weight, o->color_weight};
    static const char *const aname[3] = {"normal", "uv", "color"};
    for (int i = 0; i < 3; i++)
        if (!is_finite(aw[i]) || aw[i] < 0)
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                                 "simplify: %s weight %g must be finite and >= 0", aname[i],
                                 aw[i]);
    if (!is_finite(o->max_normal_turn) || o->max_normal_turn <= 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: max normal turn %g must be a positive angle (radians)",
                             o->max_normal_turn);
    if (o->collapse != MR_COLLAPSE_FULL && o->collapse != MR_COLLAPSE_HALF)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: unknown collapse kind %d", (int)o->collapse);
    if (o->quality != MR_QUALITY_DEFAULT && o->quality != MR_QUALITY_BEST)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: unknown quality %d", (int)o->quality);
    if (o->quality == MR_QUALITY_BEST && o->collapse != MR_COLLAPSE_FULL)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: the best quality moves the output's vertices off the "
                             "input's; half-edge collapse keeps them: use MR_COLLAPSE_FULL "
                             "(--collapse full)");
    if (o->target_ratio == 0 && o->target_vertices == 0 && o->target_triangles == 0 &&
        o->max_error == 0 && !o->until_error)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: no target: set a target ratio, vertex or triangle "
                             "count, a max error, or until_error");
    if (o->target_triangles > input_triangles)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: target of %zu triangles exceeds the input's %zu",
                             o->target_triangles, input_triangles);
    return MR_OK;
}

/* ---- targets -------------------------------------------------------------- */

/* The plan's goal, from the options and the mesh as set up: once, before
 * the strategy starts. */
static void set_goal(mr_simplifier *s, const mr_simplify_options *o)
{
    mr_simplify_goal *g = &s->plan.goal;
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
        const double rel = s->plan.error_bound;
        /* memoryless plans test the bound themselves (MR_MEMORYLESS_OVER) */
        g->limit = s->memoryless ? 0.5 * MR_MEMORYLESS_OVER : rel * rel;
    }
    /* Progress: the share of the collapses the vertex target needs. */
    size_t planned = m->live_vertices > target_v ? m->live_vertices - target_v : 0;
    if (g->triangles && (m->live_triangles - g->triangles) / 2 < planned)
        planned = (m->live_triangles - g->triangles) / 2;
    g->planned = planned;
}

mr_status mr_simplifier_init(mr_simplifier *s, const float *positions, size_t stride,
                             size_t vertex_count, const uint32_t *indices,
                             size_t triangle_count, const mr_simplify_options *o,
                             const mr_simplify_plan *plan, const mr_vertex_marks *marks,
                             mr_error *err)
{
    memset(s, 0, sizeof *s);
    const uint8_t *extra_flags = marks ? marks->flags : NULL;
    if (marks && marks->quadrics && (!marks->was_cut || !(marks->unit > 0)))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: carried quadrics need was_cut and a unit > 0");
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

    s->plan = *plan;
    s->plan.threads = mr_thread_count(o ? o->threads : 0);
    if (s->plan.spatial_order &&
        !order_is_coherent(indices, triangle_count, vertex_count, s->plan.threads)) {
        st = spatial_order(positions, stride, indices, triangle_count, s->lo, s->hi, s->plan.threads,
                           &s->order, err);
        if (st != MR_OK)
            return st;
    }
    st = mr_collapse_mesh_init(&s->m, positions, stride, vertex_count, indices, triangle_count,
                               s->order, s->centre, s->scale, s->plan.threads, err);
    if (st != MR_OK) {
        mr_simplifier_free(s);
        return st;
    }
    mr_collapse_mesh *m = &s->m;
    s->input_vertices = m->live_vertices;
    if (m->live_triangles == 0) {
        mr_simplifier_free(s);
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL,
                             "every one of its %zu triangles uses a vertex twice: no surface "
                             "to simplify",
                             triangle_count);
    }
    st = mr_simplify_check_options(o, triangle_count, err);
    if (st == MR_OK && o->target_vertices > m->live_vertices)
        st = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                           "simplify: target of %zu vertices exceeds the input's %zu "
                           "referenced vertices",
                           o->target_vertices, m->live_vertices);
    if (st != MR_OK) {
        mr_simplifier_free(s);
        return st;
    }
    s->half = o->collapse == MR_COLLAPSE_HALF;
    s->keep_volume = o->quality == MR_QUALITY_BEST;
    /* the fit takes about as long as the collapses (the armadillo at 10 %,
     * the generated 1M scan) */
    s->fit_share = o->quality == MR_QUALITY_BEST ? 0.5 : 0;
    s->plan.error_absolute = o->error_absolute != 0;
    s->plan.until_error = o->until_error != 0;
    s->plan.prune = o->prune != 0;
    s->plan.error_bound = o->max_error > 0 ? mr_simplifier_normalised(s, o->max_error) : 0;
    s->plan.kernels = mr_kernels_get();
    s->plan.progress = o->progress;
    s->plan.progress_user = o->progress_user;
    /* the edge strategies plan through mr_simplifier_plan_edge; the
     * queued ones rank vertices by quadric cost (mr_simplifier_plan) */
    s->memoryless = s->keep_volume && !s->half && s->plan.edge_plans;
    s->memoryless_limit = INFINITY;
    s->memoryless_scale = 1;
    if (s->memoryless) {
        if (o->max_error > 0) {
            const double rel = s->plan.error_bound;
            s->memoryless_limit = rel * rel;
        }
        double area = 0;
        for (size_t t = 0; t < m->triangle_count; t++) {
            const uint32_t *tv = m->tris + 3 * t;
            if (tv[0] == MR_COLLAPSE_NONE)
                continue;
            const float *a = m->pos + 3 * (size_t)tv[0], *b = m->pos + 3 * (size_t)tv[1],
                        *c = m->pos + 3 * (size_t)tv[2];
            const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                                 u[0] * v[1] - u[1] * v[0]};
            area += sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        }
        const double mean = area / (double)m->live_triangles; /* twice the mean area */
        if (mean > 0)
            s->memoryless_scale = 1 / (mean * mean);
    }
    s->limits.half_edge = s->half;
    s->limits.kernels = s->plan.kernels;
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
    /* A gather over each vertex's own triangles, writing only its own
     * quadric: the same result on any number of threads. */
    const int nthreads = s->plan.threads;
    const ptrdiff_t nv = (ptrdiff_t)vertex_count;
    s->cut = marks ? marks->cut : NULL;
    const mr_quadricf *carried = marks ? marks->quadrics : NULL;
    const double r = carried ? marks->unit * s->scale : 0;
#pragma omp parallel for schedule(static) num_threads(nthreads) if (nthreads > 1 && nv > 65536)
    for (ptrdiff_t v = 0; v < nv; v++) {
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        if (carried)
            carried_quadric(s, (uint32_t)v, marks, r, o->boundary_weight);
        else
            initial_quadric(s, (uint32_t)v, o->boundary_weight);
    }
    mr_simplifier_mark_corners(s, MR_VF_BOUNDARY, boundary_edge);
    set_goal(s, o);
    return MR_OK;
}

