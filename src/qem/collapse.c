/* The working mesh of the edge-collapse simplifiers: see collapse.h. */
#include "collapse.h"

#include "../mesh/adjacency.h"
#include "quadric.h"

#include <math.h>
#if defined(__SSE2__)
#include <emmintrin.h>

/* Bit i set where lane i of the eight ids (v0, v1) equals x. */
static inline unsigned lanes_equal(__m128i v0, __m128i v1, __m128i x)
{
    return (unsigned)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(v0, x))) |
           (unsigned)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(v1, x))) << 4;
}
#endif

/* Marks a list's first entry during compaction; corner ids stay below it
 * (3 * triangle_count <= LIST_TAG, checked at init). */
#define LIST_TAG 0x80000000u

static inline bool tri_has(const uint32_t *t, uint32_t x)
{
    return t[0] == x || t[1] == x || t[2] == x;
}

/* The vertex of triangle t after / before v. */
static inline uint32_t tri_next(const uint32_t *t, uint32_t v)
{
    return t[0] == v ? t[1] : t[1] == v ? t[2] : t[0];
}
static inline uint32_t tri_prev(const uint32_t *t, uint32_t v)
{
    return t[0] == v ? t[2] : t[1] == v ? t[0] : t[1];
}

uint32_t mr_collapse_edge_triangles(const mr_collapse_mesh *m, uint32_t v, uint32_t w)
{
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    uint32_t n = 0;
    for (uint32_t i = 0; i < m->count[v]; i++)
        n += tri_has(m->tris + (list[i] - list[i] % 3), w);
    return n;
}

/* ---- classification ------------------------------------------------------ */

/* The triangle of v's list other than `not` that holds w, or NONE. */
static uint32_t other_triangle(const mr_collapse_mesh *m, uint32_t v, uint32_t w, uint32_t not)
{
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    for (uint32_t i = 0; i < m->count[v]; i++)
        if (list[i] / 3 != not && tri_has(m->tris + (list[i] - list[i] % 3), w))
            return list[i] / 3;
    return MR_COLLAPSE_NONE;
}

/* Walk v's fan from t0 across the edge to the vertex after v (forward) or
 * before it, until a boundary edge or back at t0. Returns the number of
 * triangles stepped onto (t0 not counted) and whether it closed. */
static uint32_t walk_fan(const mr_collapse_mesh *m, uint32_t v, uint32_t t0, bool forward,
                         bool *closed)
{
    uint32_t t = t0, steps = 0;
    *closed = false;
    for (uint32_t guard = 0; guard <= m->count[v]; guard++) {
        const uint32_t *tri = m->tris + 3 * (size_t)t;
        uint32_t w = forward ? tri_next(tri, v) : tri_prev(tri, v);
        uint32_t s = other_triangle(m, v, w, t);
        if (s == MR_COLLAPSE_NONE)
            return steps;
        if (s == t0) {
            *closed = true;
            return steps;
        }
        t = s;
        steps++;
    }
    return steps;
}

/* Fans up to this many triangles are classified on local copies of their
 * edges (classify_small); larger ones by walking the lists. */
#define SMALL_FAN 64

/*
 * classify_vertex for a fan of n <= SMALL_FAN triangles, the same answer
 * from each triangle's edges at v, copied out once: triangle i runs
 * v -> nx[i] and pv[i] -> v. An edge is non-manifold (or inconsistently
 * oriented) when two triangles run it the same way: when two nx, or two
 * pv, are equal. Otherwise (v, w) is manifold when w is some nx and some
 * pv, a boundary edge when only one of them. The successor of triangle i
 * is the one whose pv is nx[i]; the fan is one when stepping to
 * successors (or back) from triangle 0 reaches all n.
 *
 * Only nx against pv is compared: two pv equal to an nx give it two
 * successors, two nx with one successor give that one two predecessors,
 * and once neither happens the triangles without a successor are as many
 * as those without a predecessor -- so two equal nx, or two equal pv,
 * that match nothing make two triangles without a successor, more than
 * one fan can have.
 */
static uint8_t classify_small(const mr_collapse_mesh *m, uint32_t v, uint32_t n)
{
    uint32_t nx[SMALL_FAN], pv[SMALL_FAN];
    int succ[SMALL_FAN], pred[SMALL_FAN];
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t j = list[i] % 3, *tri = m->tris + (list[i] - j);
        nx[i] = tri[mr_local_next(j)];
        pv[i] = tri[mr_local_prev(j)];
        pred[i] = -1;
    }
#if defined(__SSE2__)
    if (n <= 8) {
        /* The usual fan, eight lanes at a time; the free lanes hold a
         * copy of pv[0], which adds nothing new to match. */
        for (uint32_t i = n; i < 8; i++)
            pv[i] = pv[0];
        const __m128i pv0 = _mm_loadu_si128((const __m128i *)pv),
                      pv1 = _mm_loadu_si128((const __m128i *)(pv + 4));
        const unsigned lanes = (1u << n) - 1;
        for (uint32_t i = 0; i < n; i++) {
            const __m128i x = _mm_set1_epi32((int)nx[i]);
            const unsigned hit = lanes_equal(pv0, pv1, x) & lanes;
            if (hit & (hit - 1))
                return MR_VF_NONMANIFOLD | MR_VF_LOCKED;
            succ[i] = hit ? __builtin_ctz(hit) : -1;
        }
    } else
#endif
    for (uint32_t i = 0; i < n; i++) {
        int s = -1, hits = 0;
        for (uint32_t j = 0; j < n; j++) {
            const bool hit = pv[j] == nx[i];
            s = hit ? (int)j : s;
            hits += hit;
        }
        if (hits > 1)
            return MR_VF_NONMANIFOLD | MR_VF_LOCKED;
        succ[i] = s;
    }
    uint32_t open = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (succ[i] < 0) {
            open++;
            continue;
        }
        if (pred[succ[i]] >= 0)
            return MR_VF_NONMANIFOLD | MR_VF_LOCKED;
        pred[succ[i]] = (int)i;
    }
    if (open > 1)
        return MR_VF_NONMANIFOLD | MR_VF_LOCKED; /* more than two boundary edges */
    uint32_t seen = 1;
    bool closed = false;
    for (int t = succ[0]; t >= 0 && seen <= n; t = succ[t]) {
        if (t == 0) {
            closed = true;
            break;
        }
        seen++;
    }
    if (!closed)
        for (int t = pred[0]; t >= 0 && t != 0 && seen <= n; t = pred[t])
            seen++;
    if (seen != n)
        return MR_VF_NONMANIFOLD | MR_VF_LOCKED; /* several fans */
    return open ? MR_VF_BOUNDARY : 0;
}

/* MR_VF_BOUNDARY, MR_VF_NONMANIFOLD | MR_VF_LOCKED, or 0 for an inner
 * manifold vertex. */
static uint8_t classify_vertex(const mr_collapse_mesh *m, uint32_t v)
{
    const uint32_t n = m->count[v];
    if (n <= SMALL_FAN)
        return classify_small(m, v, n);
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    uint32_t boundary_edges = 0;
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        /* Edge v -> a of this triangle; each edge at v is seen once from
         * each side, so look at the forward ones and at the backward ones
         * that are boundary edges. */
        const uint32_t ends[2] = {tri_next(tri, v), tri_prev(tri, v)};
        for (int k = 0; k < 2; k++) {
            uint32_t w = ends[k];
            uint32_t c = mr_collapse_edge_triangles(m, v, w);
            if (c > 2)
                return MR_VF_NONMANIFOLD | MR_VF_LOCKED;
            if (c == 1) {
                boundary_edges++;
                continue;
            }
            /* Two triangles: they must run along the edge in opposite
             * directions (consistent orientation). */
            uint32_t s = other_triangle(m, v, w, list[i] / 3);
            const uint32_t *o = m->tris + 3 * (size_t)s;
            bool here_forward = k == 0;
            bool there_forward = tri_next(o, v) == w;
            if (here_forward == there_forward)
                return MR_VF_NONMANIFOLD | MR_VF_LOCKED;
        }
    }
    if (boundary_edges != 0 && boundary_edges != 2)
        return MR_VF_NONMANIFOLD | MR_VF_LOCKED;
    bool closed;
    uint32_t seen = 1 + walk_fan(m, v, list[0] / 3, true, &closed);
    if (!closed)
        seen += walk_fan(m, v, list[0] / 3, false, &closed);
    if (seen != n)
        return MR_VF_NONMANIFOLD | MR_VF_LOCKED; /* several fans */
    return boundary_edges ? MR_VF_BOUNDARY : 0;
}

/* ---- setup ---------------------------------------------------------------- */

void mr_collapse_mesh_free(mr_collapse_mesh *m)
{
    if (!m)
        return;
    free(m->pos);
    free(m->tris);
    free(m->start);
    free(m->count);
    free(m->refs);
    free(m->flags);
    memset(m, 0, sizeof *m);
}

mr_status mr_collapse_mesh_init(mr_collapse_mesh *m, const float *positions, size_t stride,
                                size_t vertex_count, const uint32_t *indices,
                                size_t triangle_count, const double centre[3], double scale,
                                mr_error *err)
{
    memset(m, 0, sizeof *m);
    const size_t vc = vertex_count, tc = triangle_count;
    if (vc >= LIST_TAG || tc > LIST_TAG / 3)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu vertices, %zu triangles exceed the simplifier's limits", vc,
                             tc);
    if (stride == 0)
        stride = 3 * sizeof(float);

    /* The triangle array, with degenerate input triangles marked dead,
     * and each vertex's count of live triangles (in start[v + 1]). */
    m->vertex_count = vc;
    m->triangle_count = tc;
    m->start = mr_calloc_array(vc + 1, sizeof *m->start);
    m->count = mr_alloc_array(vc, sizeof *m->count);
    /* one float of padding: the batch planner reads positions as 4 */
    m->pos = mr_alloc_array(3 * vc + 1, sizeof *m->pos);
    m->tris = mr_alloc_array(3 * tc, sizeof *m->tris);
    m->flags = mr_calloc_array(vc, sizeof *m->flags);
    if (!m->start || !m->count || !m->pos || !m->tris || !m->flags) {
        mr_collapse_mesh_free(m);
        return mr_fail_nomem(err, NULL, vc * 21 + tc * 12);
    }
    size_t live_tris = 0;
    for (size_t t = 0; t < tc; t++) {
        const uint32_t *src = indices + 3 * t;
        uint32_t *dst = m->tris + 3 * t;
        if (mr_triangle_is_degenerate(src)) {
            dst[0] = dst[1] = dst[2] = MR_COLLAPSE_NONE;
            continue;
        }
        for (int k = 0; k < 3; k++) {
            dst[k] = src[k];
            m->start[src[k] + 1]++;
        }
        live_tris++;
    }
    m->live_triangles = live_tris;

    /* Lists of corner ids, in triangle order, with room to grow. */
    size_t total = 0, live_vertices = 0;
    for (size_t v = 0; v < vc; v++) {
        const uint32_t c = m->start[v + 1];
        m->start[v] = (uint32_t)total;
        m->count[v] = 0;
        total += c;
        live_vertices += c > 0;
    }
    /* Live lists never take more than `total` entries, so after a
     * compaction there is always room for the merged list of two vertices
     * of MR_COLLAPSE_MAX_DEGREE triangles each. */
    const size_t capacity = total + total / 4 + 2 * MR_COLLAPSE_MAX_DEGREE + 64;
    m->refs = mr_alloc_array(capacity, sizeof *m->refs);
    if (!m->refs) {
        mr_collapse_mesh_free(m);
        return mr_fail_nomem(err, NULL, capacity * sizeof *m->refs);
    }
    m->refs_capacity = capacity;
    m->refs_size = total;
    for (size_t t = 0; t < tc; t++) {
        const uint32_t *tri = m->tris + 3 * t;
        if (tri[0] == MR_COLLAPSE_NONE)
            continue;
        for (uint32_t k = 0; k < 3; k++)
            m->refs[m->start[tri[k]] + m->count[tri[k]]++] = 3 * (uint32_t)t + k;
    }
    for (size_t v = 0; v < vc; v++) {
        float p[3];
        memcpy(p, (const char *)positions + v * stride, sizeof p);
        for (int k = 0; k < 3; k++)
            m->pos[3 * v + k] = (float)((p[k] - centre[k]) * scale);
    }
    m->live_vertices = live_vertices;

    for (size_t v = 0; v < vc; v++)
        m->flags[v] = m->count[v] ? classify_vertex(m, (uint32_t)v) : MR_VF_REMOVED;
    return MR_OK;
}

/* ---- validity -------------------------------------------------------------- */

/*
 * Condition (2) for n triangles (o, a, b) of the fans, o the vertex that
 * moves to t: in[k * RING + i] holds, for triangle i, the coordinates of
 * o (k = 0..2), a (3..5) and b (6..8). Each normal may turn by an angle
 * whose cosine is at least min_cos (never flip) and the area may not
 * collapse (ratio 1e-6). Unnormalised normals (twice the area): the tests
 * are the unit normals' cos > min_cos and the area ratio, squared, without
 * a square root or a division; a degenerate normal is 0 and fails. A
 * branch-free loop, vectorised.
 */
#define RING (2 * MR_COLLAPSE_MAX_DEGREE)

MR_VECTOR_CLONES static bool fan_ok(const double *in, size_t n, const double t[3],
                                    double min_cos)
{
    const double mc2 = min_cos * min_cos;
    int bad = 0;
#pragma omp simd reduction(| : bad)
    for (size_t i = 0; i < n; i++) {
        const double ox = in[i], oy = in[RING + i], oz = in[2 * RING + i];
        const double ax = in[3 * RING + i], ay = in[4 * RING + i], az = in[5 * RING + i];
        const double bx = in[6 * RING + i], by = in[7 * RING + i], bz = in[8 * RING + i];
        const double u0 = ax - ox, u1 = ay - oy, u2 = az - oz;
        const double v0 = bx - ox, v1 = by - oy, v2 = bz - oz;
        const double n00 = u1 * v2 - u2 * v1, n01 = u2 * v0 - u0 * v2, n02 = u0 * v1 - u1 * v0;
        const double s0 = ax - t[0], s1 = ay - t[1], s2 = az - t[2];
        const double w0 = bx - t[0], w1 = by - t[1], w2 = bz - t[2];
        const double n10 = s1 * w2 - s2 * w1, n11 = s2 * w0 - s0 * w2, n12 = s0 * w1 - s1 * w0;
        const double d = n00 * n10 + n01 * n11 + n02 * n12;
        const double l0 = n00 * n00 + n01 * n01 + n02 * n02;
        const double l1 = n10 * n10 + n11 * n11 + n12 * n12;
        bad |= !((d > 0) & (d * d > mc2 * l0 * l1) & (l1 > 1e-12 * l0));
    }
    return !bad;
}

/* Appends triangle (o, a, b) to fan_ok's input. */
static inline void fan_add(const mr_collapse_mesh *m, double *in, size_t i, uint32_t o,
                           uint32_t a, uint32_t b)
{
    const float *po = m->pos + 3 * (size_t)o, *pa = m->pos + 3 * (size_t)a,
                *pb = m->pos + 3 * (size_t)b;
    for (int k = 0; k < 3; k++) {
        in[k * RING + i] = po[k];
        in[(3 + k) * RING + i] = pa[k];
        in[(6 + k) * RING + i] = pb[k];
    }
}

/* Corner id e = 3t + j: its triangle's vertices, and the vertices after and
 * before corner j. */
#define CORNER_TRI(m, e) ((m)->tris + ((e) - (e) % 3))
static inline uint32_t corner_next(const uint32_t *tri, uint32_t j)
{
    return tri[mr_local_next(j)];
}
static inline uint32_t corner_prev(const uint32_t *tri, uint32_t j)
{
    return tri[mr_local_prev(j)];
}

bool mr_collapse_valid(const mr_collapse_mesh *m, uint32_t u, uint32_t v,
                       const double target[3], const mr_collapse_limits *limits)
{
    const uint8_t fu = m->flags[u], fv = m->flags[v];
    if ((fu | fv) & MR_VF_REMOVED || u == v)
        return false;
    /* The target as it will be stored. */
    const double t[3] = {(float)target[0], (float)target[1], (float)target[2]};
    const bool u_stays = t[0] == m->pos[3 * u] && t[1] == m->pos[3 * u + 1] &&
                         t[2] == m->pos[3 * u + 2];
    const bool v_stays = t[0] == m->pos[3 * v] && t[1] == m->pos[3 * v + 1] &&
                         t[2] == m->pos[3 * v + 2];
    if ((fu & MR_VF_LOCKED && !u_stays) || (fv & MR_VF_LOCKED && !v_stays))
        return false;
    if (limits->half_edge) {
        const uint8_t keep = MR_VF_BOUNDARY | MR_VF_SEAM;
        if ((fu & keep) & ~(fv & keep))
            return false;
    }
    const uint32_t nu = m->count[u], nv = m->count[v];
    if (nu > MR_COLLAPSE_MAX_DEGREE || nv > MR_COLLAPSE_MAX_DEGREE)
        return false;
    const uint32_t *lu = mr_collapse_vertex_tris(m, u), *lv = mr_collapse_vertex_tris(m, v);

    /* u's triangles off the edge, as the neighbours across u's corner
     * (nua, nub: compacted, no branch on which ones they are); the
     * triangles on the edge and their opposite vertices. */
    uint32_t nua[MR_COLLAPSE_MAX_DEGREE], nub[MR_COLLAPSE_MAX_DEGREE];
    uint32_t opp[4], ne = 0, no = 0;
    for (uint32_t i = 0; i < nu; i++) {
        const uint32_t e = lu[i], j = e % 3;
        const uint32_t *tri = CORNER_TRI(m, e);
        const uint32_t a = corner_next(tri, j), b = corner_prev(tri, j);
        const bool on = (a == v) | (b == v);
        nua[no] = a;
        nub[no] = b;
        no += !on;
        opp[ne < 3 ? ne : 3] = a ^ ((a ^ b) & -(uint32_t)(a == v)); /* a == v ? b : a */
        ne += on;
    }
    if (ne == 0 || ne > 2 || (ne == 2 && opp[0] == opp[1]))
        return false; /* not an edge, or a non-manifold one */
    if (ne == 1)
        opp[1] = MR_COLLAPSE_NONE;
    /* A valid collapse takes the edge's triangles out of the opposite
     * vertices' lists (mr_collapse_apply): fetch their heads now. */
    for (uint32_t i = 0; i < ne; i++) {
        __builtin_prefetch(m->start + opp[i]);
        __builtin_prefetch(m->count + opp[i]);
    }
    /* (4) two boundary vertices joined through the inside would pinch the
     * surface; and the last triangles of a component must stay. */
    if (ne == 2 && (fu & MR_VF_BOUNDARY) && (fv & MR_VF_BOUNDARY))
        return false;
    if (nu == ne && nv == ne)
        return false;

    /* (1) the link condition: a neighbour of u other than the opposite
     * vertices must not be a neighbour of v. v's triangles on the edge
     * are left out: their vertices are u and the opposite ones, and
     * neither can match. */
    uint32_t nbn[MR_COLLAPSE_MAX_DEGREE + 8], nbp[MR_COLLAPSE_MAX_DEGREE + 8];
    uint32_t nw = 0;
    for (uint32_t i = 0; i < nv; i++) {
        const uint32_t e = lv[i], j = e % 3;
        const uint32_t *tri = CORNER_TRI(m, e);
        const uint32_t a = corner_next(tri, j), b = corner_prev(tri, j);
        nbn[nw] = a;
        nbp[nw] = b;
        nw += (a != u) & (b != u);
    }
    /* Around an inner manifold vertex every neighbour is the vertex after
     * it in exactly one triangle: then the vertices after u (in its
     * triangles off the edge; the one after u in an edge triangle is v or
     * an opposite vertex) and after v are all the neighbours. */
    const bool inner = !((fu | fv) & (MR_VF_BOUNDARY | MR_VF_NONMANIFOLD));
#if defined(__SSE2__)
    if (nw <= 8) {
        /* v's usual fan, eight lanes at a time; the free lanes hold an
         * opposite vertex, which matches nothing that counts. */
        for (uint32_t i = nw; i < 8; i++)
            nbn[i] = nbp[i] = opp[0];
        const __m128i n0 = _mm_loadu_si128((const __m128i *)nbn),
                      n1 = _mm_loadu_si128((const __m128i *)(nbn + 4)),
                      p0 = _mm_loadu_si128((const __m128i *)nbp),
                      p1 = _mm_loadu_si128((const __m128i *)(nbp + 4));
        const __m128i o0 = _mm_set1_epi32((int)opp[0]), o1 = _mm_set1_epi32((int)opp[1]);
        const unsigned keep_n = ~(lanes_equal(n0, n1, o0) | lanes_equal(n0, n1, o1)),
                       keep_p = ~(lanes_equal(p0, p1, o0) | lanes_equal(p0, p1, o1));
        unsigned hit = 0;
        for (uint32_t i = 0; i < no; i++) {
            const __m128i xa = _mm_set1_epi32((int)nua[i]);
            hit |= lanes_equal(n0, n1, xa) & keep_n;
            if (!inner) {
                const __m128i xb = _mm_set1_epi32((int)nub[i]);
                hit |= (lanes_equal(n0, n1, xb) & keep_n) |
                       ((lanes_equal(p0, p1, xa) | lanes_equal(p0, p1, xb)) & keep_p);
            }
        }
        if (hit)
            return false;
    } else
#endif
    for (uint32_t i = 0; i < no; i++) {
        const uint32_t a = nua[i], b = nub[i];
        for (uint32_t j = 0; j < nw; j++) {
            const uint32_t x = nbn[j], y = nbp[j];
            const bool x_counts = x != opp[0] && x != opp[1],
                       y_counts = y != opp[0] && y != opp[1];
            if (x_counts && (x == a || (!inner && x == b)))
                return false;
            if (!inner && y_counts && (y == a || y == b))
                return false;
        }
    }
    double fan[9 * RING];
    size_t nf = 0;
    for (uint32_t i = 0; i < no; i++) {
        const uint32_t a = nua[i], b = nub[i];
        /* (3) u's triangle (u, c, d) over both opposite vertices would
         * duplicate a triangle (v, c, d) of v: a tetrahedron-like pocket. */
        const bool pocket =
            (ne == 2) & (((a == opp[0]) & (b == opp[1])) | ((a == opp[1]) & (b == opp[0])));
        if (MR_UNLIKELY(pocket)) {
            for (uint32_t j = 0; j < nv; j++) {
                const uint32_t *o = CORNER_TRI(m, lv[j]);
                if (tri_has(o, a) && tri_has(o, b))
                    return false;
            }
        }
        /* (2) the triangle's normal under the move of u */
        fan_add(m, fan, nf++, u, a, b);
    }
    if (!v_stays)
        for (uint32_t i = 0; i < nw; i++)
            fan_add(m, fan, nf++, v, nbn[i], nbp[i]);
    for (uint32_t i = 0; i < ne; i++) /* and the lists */
        __builtin_prefetch(m->refs + m->start[opp[i]]);
    /* whole vectors only: the padding repeats the first triangle */
    const size_t nf4 = (nf + 3) & ~(size_t)3;
    for (size_t i = nf; i < nf4 && nf; i++)
        for (int k = 0; k < 9; k++)
            fan[k * RING + i] = fan[k * RING];
    return fan_ok(fan, nf4, t, limits->min_cos_turn);
}

/* ---- apply ------------------------------------------------------------------ */

/* Compact refs in place: every live list moves down, in the order the lists
 * lie in the array. The first entry of each live list is swapped for a tag
 * naming its vertex, so one forward scan finds the lists among the garbage;
 * the displaced entry waits in start[v]. */
static void compact_refs(mr_collapse_mesh *m)
{
    uint32_t *refs = m->refs;
    for (size_t v = 0; v < m->vertex_count; v++) {
        if (!m->count[v])
            continue;
        const uint32_t s = m->start[v];
        m->start[v] = refs[s];
        refs[s] = (uint32_t)v | LIST_TAG;
    }
    size_t w = 0;
    for (size_t r = 0; r < m->refs_size;) {
        const uint32_t x = refs[r];
        if (!(x & LIST_TAG)) {
            r++;
            continue;
        }
        const uint32_t v = x & ~LIST_TAG, n = m->count[v];
        refs[w] = m->start[v];
        memmove(refs + w + 1, refs + r + 1, (size_t)(n - 1) * sizeof *refs);
        m->start[v] = (uint32_t)w;
        w += n;
        r += n;
    }
    m->refs_size = w;
}

void mr_collapse_reserve(mr_collapse_mesh *m, uint32_t u, uint32_t v)
{
    if (m->refs_size + m->count[u] + m->count[v] > m->refs_capacity)
        compact_refs(m);
}

/* Take corner id e out of its vertex c's list (order does not matter):
 * the whole list is looked at, without a branch on where e is. */
static void list_remove(mr_collapse_mesh *m, uint32_t c, uint32_t e)
{
    uint32_t *list = m->refs + m->start[c];
    const uint32_t n = m->count[c];
    uint32_t at = n;
    for (uint32_t i = 0; i < n; i++)
        at = list[i] == e ? i : at;
    if (at < n) {
        list[at] = list[n - 1];
        m->count[c] = n - 1;
    }
}

unsigned mr_collapse_apply(mr_collapse_mesh *m, uint32_t u, uint32_t v,
                           const double target[3])
{
    const uint32_t nu = m->count[u], nv = m->count[v];
    const uint32_t *lu = mr_collapse_vertex_tris(m, u), *lv = mr_collapse_vertex_tris(m, v);
    /* u's corners become v's; the triangles on the edge (one or two, as
     * the collapse is valid) are noted by their third corner and deleted
     * after the loop, which has no branch on which they are. */
    uint32_t dead[3];
    unsigned nd = 0;
    for (uint32_t i = 0; i < nu; i++) {
        const uint32_t e = lu[i], j = e % 3, base = e - j;
        uint32_t *tri = m->tris + base;
        const uint32_t jn = mr_local_next(j), jp = mr_local_prev(j);
        const bool on_n = tri[jn] == v, on = on_n | (tri[jp] == v);
        dead[nd] = base + (jn ^ ((jn ^ jp) & -(uint32_t)on_n)); /* on_n ? jp : jn */
        nd += on & (nd < 2);
        tri[j] = v;
    }
    for (unsigned d = 0; d < nd; d++) {
        const uint32_t ec = dead[d], base = ec - ec % 3, c = m->tris[ec];
        list_remove(m, c, ec);
        if (m->count[c] == 0) { /* an ear's tip: now unreferenced */
            m->flags[c] |= MR_VF_REMOVED;
            m->live_vertices--;
        }
        m->tris[base] = m->tris[base + 1] = m->tris[base + 2] = MR_COLLAPSE_NONE;
    }
    const unsigned deleted = nd;
    /* v's merged list, at the end of refs: v's surviving triangles, then
     * u's (their corners now hold v). */
    uint32_t *out = m->refs + m->refs_size;
    uint32_t n = 0;
    for (uint32_t i = 0; i < nv; i++) {
        out[n] = lv[i];
        n += m->tris[lv[i] - lv[i] % 3] != MR_COLLAPSE_NONE;
    }
    for (uint32_t i = 0; i < nu; i++) {
        out[n] = lu[i];
        n += m->tris[lu[i] - lu[i] % 3] != MR_COLLAPSE_NONE;
    }
    m->start[v] = (uint32_t)m->refs_size;
    m->count[v] = n;
    m->refs_size += n;
    m->count[u] = 0;

    float t[3] = {(float)target[0], (float)target[1], (float)target[2]};
    float *pv = m->pos + 3 * (size_t)v;
    if (t[0] != pv[0] || t[1] != pv[1] || t[2] != pv[2])
        m->flags[v] |= MR_VF_MOVED;
    pv[0] = t[0];
    pv[1] = t[1];
    pv[2] = t[2];
    m->flags[v] |= m->flags[u] & (MR_VF_BOUNDARY | MR_VF_SEAM);
    m->flags[u] |= MR_VF_REMOVED;
    m->live_vertices--;
    m->live_triangles -= deleted;
    return deleted;
}
