/* The working mesh of the edge-collapse simplifiers: see collapse.h. */
#include "collapse.h"
#include "kernels.h"

#include "../../core/omp_compat.h"
#include "../../mesh/adjacency.h"
#include "quadric.h"

#include <assert.h>
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

/* Lists longer than this are cleaned of deleted triangles lazily (see
 * list_remove). */
#define LAZY_MIN 64

static inline bool tri_has(const uint32_t *t, uint32_t x)
{
    return t[0] == x || t[1] == x || t[2] == x;
}


uint32_t mr_collapse_edge_triangles(const mr_collapse_mesh *m, uint32_t v, uint32_t w)
{
    if (m->count[w] < m->count[v]) { /* both lists hold the edge's triangles */
        const uint32_t x = v;
        v = w;
        w = x;
    }
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    uint32_t n = 0;
    for (uint32_t i = 0; i < m->count[v]; i++)
        n += tri_has(m->tris + (list[i] - list[i] % 3), w);
    return n;
}

/* ---- classification ------------------------------------------------------ */

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

/* A fan of more than SMALL_FAN triangles: the same answer by sorting
 * (mr_fan_classify), O(n log n) at any valence. */
static uint8_t classify_large(const mr_collapse_mesh *m, uint32_t v, uint32_t n)
{
    mr_fan_entry *e = mr_alloc_array(n, sizeof *e);
    uint8_t *seen = mr_alloc_array(n, 1);
    int shape = -1;
    if (e && seen) {
        const uint32_t *list = mr_collapse_vertex_tris(m, v);
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t j = list[i] % 3, *tri = m->tris + (list[i] - j);
            e[i].next = tri[mr_local_next(j)];
            e[i].prev = tri[mr_local_prev(j)];
        }
        shape = mr_fan_classify(v, e, n, seen);
    }
    free(e);
    free(seen);
    /* (out of memory: locked, which is safe) */
    return shape < 0 ? MR_VF_NONMANIFOLD | MR_VF_LOCKED : shape ? MR_VF_BOUNDARY : 0;
}

/* MR_VF_BOUNDARY, MR_VF_NONMANIFOLD | MR_VF_LOCKED, or 0 for an inner
 * manifold vertex. */
static uint8_t classify_vertex(const mr_collapse_mesh *m, uint32_t v)
{
    const uint32_t n = m->count[v];
    return n <= SMALL_FAN ? classify_small(m, v, n) : classify_large(m, v, n);
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
    free(m->dead);
    free(m->seg);
    free(m->alive);
    memset(m, 0, sizeof *m);
}

mr_status mr_collapse_mesh_init(mr_collapse_mesh *m, const float *positions, size_t stride,
                                size_t vertex_count, const uint32_t *indices,
                                size_t triangle_count, const uint32_t *order,
                                const double centre[3], double scale, int threads,
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
    m->threads = threads > 1 ? threads : 1;
    m->level = omp_get_level();
    m->seg = mr_alloc_array(3 * ((size_t)m->threads + 1), sizeof *m->seg);
    m->alive = mr_alloc_array((tc + 63) / 64 + 1, sizeof *m->alive);
    if (!m->start || !m->count || !m->pos || !m->tris || !m->flags || !m->seg || !m->alive) {
        mr_collapse_mesh_free(m);
        return mr_fail_nomem(err, NULL, vc * 21 + tc * 12);
    }
    const bool par = threads > 1 && tc > 65536;
    size_t live_tris = 0;
    const ptrdiff_t ntri = (ptrdiff_t)tc;
#pragma omp parallel for schedule(static) reduction(+ : live_tris) num_threads(threads) if (par)
    for (ptrdiff_t t = 0; t < ntri; t++) {
        const uint32_t *src = indices + 3 * (order ? (size_t)order[t] : (size_t)t);
        uint32_t *dst = m->tris + 3 * t;
        const bool bad = mr_triangle_is_degenerate(src);
        for (int k = 0; k < 3; k++)
            dst[k] = bad ? MR_COLLAPSE_NONE : src[k];
        live_tris += !bad;
    }
    m->live_triangles = live_tris;

    /* Lists of corner ids, in triangle order, with room to grow. Live
     * lists never take more than `total` (3 per live triangle) entries,
     * and a merged list no more than one per live triangle (a triangle has
     * at most one corner at each end; those on the edge, at both, die): so
     * after a compaction there is always room for it, at any valence. */
    const size_t total = 3 * live_tris;
    const size_t capacity = total + total / 3 + 64;
    m->refs = mr_alloc_array(capacity, sizeof *m->refs);
    if (!m->refs) {
        mr_collapse_mesh_free(m);
        return mr_fail_nomem(err, NULL, capacity * sizeof *m->refs);
    }
    m->refs_capacity = capacity;
    m->refs_size = total;
    /* Each thread counts and fills the lists of its own run of vertices,
     * sweeping every triangle in order: the same lists on any number of
     * threads, and no two threads write one vertex's. */
    size_t live_vertices = 0;
    size_t *own_total = m->seg;
#pragma omp parallel num_threads(threads) reduction(+ : live_vertices) if (par)
    {
        const int me = omp_get_thread_num(), team = omp_get_num_threads();
        const size_t v0 = vc * (size_t)me / (size_t)team;
        const size_t v1 = vc * (size_t)(me + 1) / (size_t)team;
        const uint32_t lo = (uint32_t)v0, span = (uint32_t)(v1 - v0);
        memset(m->count + v0, 0, (v1 - v0) * sizeof *m->count);
        for (size_t t = 0; t < tc; t++) {
            const uint32_t *tri = m->tris + 3 * t;
            if (tri[0] == MR_COLLAPSE_NONE)
                continue;
            for (int k = 0; k < 3; k++)
                if (tri[k] - lo < span)
                    m->count[tri[k]]++;
        }
        size_t own = 0;
        for (size_t v = v0; v < v1; v++) {
            own += m->count[v];
            live_vertices += m->count[v] > 0;
        }
        own_total[me] = own;
#pragma omp barrier
        size_t at = 0;
        for (int t = 0; t < me; t++)
            at += own_total[t];
        for (size_t v = v0; v < v1; v++) {
            m->start[v] = (uint32_t)at;
            at += m->count[v];
            m->count[v] = 0;
        }
        for (size_t t = 0; t < tc; t++) {
            const uint32_t *tri = m->tris + 3 * t;
            if (tri[0] == MR_COLLAPSE_NONE)
                continue;
            for (uint32_t k = 0; k < 3; k++)
                if (tri[k] - lo < span)
                    m->refs[m->start[tri[k]] + m->count[tri[k]]++] = 3 * (uint32_t)t + k;
        }
    }
    m->live_vertices = live_vertices;
    /* Positions and the classification: each vertex on its own (the same
     * result on any number of threads). */
    const ptrdiff_t nv = (ptrdiff_t)vc;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && nv > 65536)
    for (ptrdiff_t v = 0; v < nv; v++) {
        float p[3];
        memcpy(p, (const char *)positions + (size_t)v * stride, sizeof p);
        for (int k = 0; k < 3; k++)
            m->pos[3 * v + k] = (float)((p[k] - centre[k]) * scale);
    }
#pragma omp parallel for schedule(dynamic, 4096) num_threads(threads) \
    if (threads > 1 && nv > 65536)
    for (ptrdiff_t v = 0; v < nv; v++)
        m->flags[v] = m->count[v] ? classify_vertex(m, (uint32_t)v) : MR_VF_REMOVED;
    return MR_OK;
}

/* ---- validity -------------------------------------------------------------- */

/* fan_ok's rows: room for the fans of two vertices of the largest degree
 * the stack arrays take. */
#define RING (2 * MR_COLLAPSE_MAX_DEGREE)
_Static_assert(RING == MR_FAN_ROW, "fan rows");

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

static int u32_cmp(const void *pa, const void *pb)
{
    const uint32_t a = *(const uint32_t *)pa, b = *(const uint32_t *)pb;
    return a < b ? -1 : a > b;
}

/* Does a sorted array of n ids share one with a sorted array of k? */
static bool sorted_meet(const uint32_t *a, size_t n, const uint32_t *b, size_t k)
{
    for (size_t i = 0, j = 0; i < n && j < k;) {
        if (a[i] == b[j])
            return true;
        if (a[i] < b[j])
            i++;
        else
            j++;
    }
    return false;
}

/*
 * mr_collapse_valid where u or v has more than MR_COLLAPSE_MAX_DEGREE
 * triangles: the same rules on heap arrays, the link condition by sorting
 * both neighbourhoods (O(n log n) instead of O(nu nv)), the normal test
 * in blocks of RING triangles. The flag and lock tests are done.
 */
static bool valid_large(const mr_collapse_mesh *m, uint32_t u, uint32_t v, const double t[3],
                        bool v_stays, const mr_collapse_limits *limits)
{
    const uint8_t fu = m->flags[u], fv = m->flags[v];
    const uint32_t nu = m->count[u], nv = m->count[v];
    const uint32_t *lu = mr_collapse_vertex_tris(m, u), *lv = mr_collapse_vertex_tris(m, v);
    const bool inner = !((fu | fv) & (MR_VF_BOUNDARY | MR_VF_NONMANIFOLD));
    /* u's off-edge triangles (a, b), then v's (x, y), then the two
     * neighbour sets to sort */
    uint32_t *buf = mr_alloc_array(4 * ((size_t)nu + nv), sizeof *buf);
    double *fan = mr_alloc_array(9 * RING, sizeof *fan);
    bool ok = false;
    if (!buf || !fan)
        goto done; /* out of memory: refused, which is safe */
    uint32_t *ua = buf, *ub = buf + nu, *vx = buf + 2 * (size_t)nu, *vy = vx + nv;
    uint32_t opp[2] = {MR_COLLAPSE_NONE, MR_COLLAPSE_NONE}, ne = 0, no = 0, nw = 0;
    for (uint32_t i = 0; i < nu; i++) {
        const uint32_t e = lu[i], j = e % 3, *tri = CORNER_TRI(m, e);
        const uint32_t a = corner_next(tri, j), b = corner_prev(tri, j);
        if (a == v || b == v) {
            if (ne < 2)
                opp[ne] = a == v ? b : a;
            ne++;
        } else {
            ua[no] = a;
            ub[no++] = b;
        }
    }
    if (ne == 0 || ne > 2 || (ne == 2 && opp[0] == opp[1]))
        goto done;
    if (ne == 2 && (fu & MR_VF_BOUNDARY) && (fv & MR_VF_BOUNDARY))
        goto done;
    if (nu == ne && nv == ne)
        goto done;
    for (uint32_t i = 0; i < nv; i++) {
        const uint32_t e = lv[i], j = e % 3, *tri = CORNER_TRI(m, e);
        const uint32_t a = corner_next(tri, j), b = corner_prev(tri, j);
        if (a != u && b != u) {
            vx[nw] = a;
            vy[nw++] = b;
        }
    }
    /* (1) the link condition: no neighbour of u but the opposite
     * vertices is a neighbour of v. When one end has a short list, each
     * of its neighbours is looked up in the mesh (the shorter of its and
     * the other end's lists); else both neighbourhoods are sorted. */
    if (no <= MR_COLLAPSE_MAX_DEGREE || nw <= MR_COLLAPSE_MAX_DEGREE) {
        const bool from_u = no <= nw;
        const uint32_t *xs = from_u ? ua : vx, *ys = from_u ? ub : vy;
        const uint32_t other = from_u ? v : u, nn = from_u ? no : nw;
        for (uint32_t i = 0; i < nn; i++)
            for (int side = 0; side < 2; side++) {
                const uint32_t x = side ? ys[i] : xs[i];
                if (x != opp[0] && x != opp[1] && mr_collapse_edge_triangles(m, x, other))
                    goto done;
            }
    } else {
        uint32_t *su = buf + 2 * ((size_t)nu + nv), *sv = su + 2 * (size_t)nu;
        size_t kn = 0, kv = 0;
        for (uint32_t i = 0; i < no; i++) {
            su[kn++] = ua[i];
            if (!inner)
                su[kn++] = ub[i];
        }
        for (uint32_t i = 0; i < nw; i++) {
            if (vx[i] != opp[0] && vx[i] != opp[1])
                sv[kv++] = vx[i];
            if (!inner && vy[i] != opp[0] && vy[i] != opp[1])
                sv[kv++] = vy[i];
        }
        qsort(su, kn, sizeof *su, u32_cmp);
        qsort(sv, kv, sizeof *sv, u32_cmp);
        if (sorted_meet(su, kn, sv, kv))
            goto done;
    }
    /* (3) no duplicate triangle over both opposite vertices */
    for (uint32_t i = 0; i < no && ne == 2; i++) {
        const uint32_t a = ua[i], b = ub[i];
        if ((a == opp[0] && b == opp[1]) || (a == opp[1] && b == opp[0]))
            for (uint32_t j = 0; j < nv; j++) {
                const uint32_t *o = CORNER_TRI(m, lv[j]);
                if (tri_has(o, a) && tri_has(o, b))
                    goto done;
            }
    }
    /* (2) the normals, RING triangles at a time */
    const size_t total = (size_t)no + (v_stays ? 0 : nw);
    for (size_t i0 = 0; i0 < total; i0 += RING) {
        const size_t nf = total - i0 < RING ? total - i0 : RING;
        for (size_t i = 0; i < nf; i++) {
            const size_t k = i0 + i;
            if (k < no)
                fan_add(m, fan, i, u, ua[k], ub[k]);
            else
                fan_add(m, fan, i, v, vx[k - no], vy[k - no]);
        }
        const size_t nf4 = (nf + 3) & ~(size_t)3;
        for (size_t i = nf; i < nf4; i++)
            for (int k = 0; k < 9; k++)
                fan[k * RING + i] = fan[k * RING];
        if (!limits->kernels->fan_ok(fan, nf4, t, limits->min_cos_turn))
            goto done;
    }
    ok = true;
done:
    free(buf);
    free(fan);
    return ok;
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
    const uint8_t pinned = MR_VF_LOCKED | MR_VF_CORNER;
    if ((fu & pinned && !u_stays) || (fv & pinned && !v_stays))
        return false;
    if (limits->half_edge) {
        const uint8_t keep = MR_VF_BOUNDARY | MR_VF_SEAM;
        if ((fu & keep) & ~(fv & keep))
            return false;
    }
    assert(!mr_collapse_dirty(m, u) && !mr_collapse_dirty(m, v)); /* mr_collapse_clean first */
    const uint32_t nu = m->count[u], nv = m->count[v];
    if (nu > MR_COLLAPSE_MAX_DEGREE || nv > MR_COLLAPSE_MAX_DEGREE)
        return valid_large(m, u, v, t, v_stays, limits);
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
    return limits->kernels->fan_ok(fan, nf4, t, limits->min_cos_turn);
}

/* ---- apply ------------------------------------------------------------------ */

/*
 * Compaction in place by the calling team (see mr_collapse_compact): every
 * live list moves down, in the order the lists lie in the array, a dirty
 * list losing its deleted triangles on the way. The first entry of each
 * live list is swapped for a tag naming its vertex (the entry waits in
 * start[v]), so a forward scan finds the lists among the garbage. refs is
 * cut into one segment per thread at list heads; each thread slides its
 * segment's lists down to the segment's start; one thread then slides the
 * segments together, and every list's start moves by its segment's shift.
 * A list lies within one segment (segments begin at heads, lists do not
 * overlap), and garbage never holds a tag (the room a collapse leaves
 * unused is zeroed), so the lists keep their order: the layout of one
 * sequential sweep, on any team.
 */
static void compact_team(mr_collapse_mesh *m)
{
    uint32_t *refs = m->refs;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count;
#pragma omp for schedule(static)
    for (ptrdiff_t i = 0; i < nv; i++) {
        const uint32_t v = (uint32_t)i;
        if (!m->count[v])
            continue;
        const uint32_t s = m->start[v];
        m->start[v] = refs[s];
        refs[s] = v | LIST_TAG;
    }
    /* which triangles live, one bit each (a sweep in memory order: the
     * dirty lists' entries then read bits in cache, not triangles) */
    uint64_t *alive = m->alive;
    const ptrdiff_t nw = (ptrdiff_t)((m->triangle_count + 63) / 64);
#pragma omp for schedule(static)
    for (ptrdiff_t i = 0; i < nw; i++) {
        const size_t t0 = 64 * (size_t)i;
        const size_t nt = m->triangle_count - t0 < 64 ? m->triangle_count - t0 : 64;
        uint64_t bits = 0;
        for (size_t t = 0; t < nt; t++)
            bits |= (uint64_t)(m->tris[3 * (t0 + t)] != MR_COLLAPSE_NONE) << t;
        alive[i] = bits;
    }
    const int team = omp_get_num_threads(), me = omp_get_thread_num();
    const int nseg = team < m->threads ? team : m->threads;
    size_t *seg = m->seg, *live = seg + nseg + 1, *shift = live + nseg + 1;
    const size_t size = m->refs_size;
    if (me < nseg) {
        size_t p = me == 0 ? 0 : size / (size_t)nseg * (size_t)me;
        while (p < size && !(refs[p] & LIST_TAG))
            p++;
        seg[me] = p;
        if (me == nseg - 1)
            seg[nseg] = size;
    }
#pragma omp barrier
    if (me < nseg) {
        /* heads found a batch ahead, so that their vertices' counts and
         * starts (in vertex order, so scattered) are fetched meanwhile */
        enum { HEADS = 32 };
        uint32_t hv[HEADS];
        size_t hp[HEADS];
        const size_t end = seg[me + 1];
        size_t w = seg[me];
        for (size_t r = seg[me]; r < end;) {
            int nh = 0;
            for (; r < end && nh < HEADS; r++) {
                const uint32_t x = refs[r];
                if (x & LIST_TAG) {
                    const uint32_t v = x & ~LIST_TAG;
                    __builtin_prefetch(m->count + v);
                    __builtin_prefetch(m->start + v);
                    if (m->dead)
                        __builtin_prefetch(m->dead + v);
                    hv[nh] = v;
                    hp[nh++] = r;
                }
            }
            /* a list lies between its head and the next: the entries the
             * moves write are never heads (w <= the list's own place) */
            for (int h = 0; h < nh; h++) {
                const uint32_t v = hv[h], n = m->count[v];
                const size_t at = w, src = hp[h];
                refs[src] = m->start[v]; /* the first entry back */
                if (m->dead && m->dead[v]) {
                    /* exact lists: the room left is then as init sized it */
                    for (uint32_t k = 0; k < n; k++) {
                        const uint32_t c = refs[src + k], t = c / 3;
                        refs[w] = c;
                        w += (alive[t / 64] >> (t % 64)) & 1;
                    }
                    m->count[v] = (uint32_t)(w - at);
                    m->dead[v] = 0;
                } else {
                    for (uint32_t k = 0; k < n; k++)
                        refs[w + k] = refs[src + k];
                    w += n;
                }
                m->start[v] = (uint32_t)at;
            }
        }
        live[me] = w - seg[me];
    }
#pragma omp barrier
#pragma omp single
    {
        size_t d = 0;
        for (int t = 0; t < nseg; t++) {
            if (d != seg[t] && live[t])
                memmove(refs + d, refs + seg[t], live[t] * sizeof *refs);
            shift[t] = seg[t] - d;
            d += live[t];
        }
        m->refs_size = d;
    }
#pragma omp for schedule(static)
    for (ptrdiff_t v = 0; v < nv; v++) {
        if (!m->count[v])
            continue;
        /* the last segment starting at or before the list (an empty
         * segment shares its start with the next one) */
        const uint32_t s = m->start[v];
        int lo = 0, hi = nseg - 1;
        while (lo < hi) {
            const int mid = (lo + hi + 1) / 2;
            if (seg[mid] <= s)
                lo = mid;
            else
                hi = mid - 1;
        }
        m->start[v] = (uint32_t)(s - shift[lo]);
    }
}

void mr_collapse_compact(mr_collapse_mesh *m)
{
    /* called by every thread of one of the simplifier's own teams (not
     * merely inside the caller's parallel region, whose team is not ours) */
    if (omp_get_level() > m->level) {
        compact_team(m);
        return;
    }
#pragma omp parallel num_threads(m->threads) if (m->threads > 1 && m->vertex_count > 65536)
    compact_team(m);
}

void mr_collapse_prepare(mr_collapse_mesh *m)
{
    if (m->lazy && !m->dead)
        m->dead = mr_calloc_array(m->vertex_count, sizeof *m->dead);
}

void mr_collapse_reserve(mr_collapse_mesh *m, uint32_t u, uint32_t v)
{
    if (m->refs_size + m->count[u] + m->count[v] > m->refs_capacity)
        mr_collapse_compact(m);
}

void mr_collapse_clean(mr_collapse_mesh *m, uint32_t v)
{
    if (!mr_collapse_dirty(m, v))
        return;
    uint32_t *list = m->refs + m->start[v];
    uint32_t n = 0;
    for (uint32_t i = 0; i < m->count[v]; i++) {
        list[n] = list[i];
        n += m->tris[list[i] - list[i] % 3] != MR_COLLAPSE_NONE;
    }
    m->count[v] = n;
    m->dead[v] = 0;
}

/* Live triangles of c: its list less the dead entries a lazy removal left. */
static inline uint32_t live_count(const mr_collapse_mesh *m, uint32_t c)
{
    return m->count[c] - (m->dead ? m->dead[c] : 0);
}

/* Take corner id e out of its vertex c's list (order does not matter):
 * the whole list is looked at, without a branch on where e is. A long
 * list of a lazy mesh keeps the entry instead (its triangle is marked
 * dead by the caller), counted in dead[c], and is cleaned once half of it
 * is dead or before it is next read as an end of a collapse: a vertex of
 * valence n that loses its triangles one by one then costs O(n) in all,
 * not O(n) each time. */
static void list_remove(mr_collapse_mesh *m, uint32_t c, uint32_t e)
{
    if (m->lazy && m->count[c] > LAZY_MIN) {
        if (m->dead) {
            m->dead[c]++;
            return;
        }
        /* no memory for the counts: remove it now */
    }
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

unsigned mr_collapse_apply_at(mr_collapse_mesh *m, uint32_t u, uint32_t v,
                              const double target[3], uint32_t *out, size_t *removed,
                              bool shared)
{
    assert(!mr_collapse_dirty(m, u) && !mr_collapse_dirty(m, v)); /* mr_collapse_clean first */
    const uint32_t nu = m->count[u], nv = m->count[v];
    const uint32_t *lu = mr_collapse_vertex_tris(m, u), *lv = mr_collapse_vertex_tris(m, v);
    /* u's corners become v's; the triangles on the edge (one or two, as
     * the collapse is valid) are noted by their third corner and deleted
     * after the loop, which has no branch on which they are. */
    uint32_t dead[3];
    unsigned nd = 0;
    size_t gone = 1; /* u */
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
        m->tris[base] = m->tris[base + 1] = m->tris[base + 2] = MR_COLLAPSE_NONE;
        if (shared) {
            /* c may be the opposite vertex of another collapse running
             * now: its list is left as it is, the entry counted dead
             * (no one reads it meanwhile: c is an end of neither) */
            const uint32_t dc = __atomic_add_fetch(&m->dead[c], 1, __ATOMIC_RELAXED);
            if (dc == m->count[c]) { /* an ear's tip (never shared): now unreferenced */
                m->flags[c] |= MR_VF_REMOVED;
                gone++;
            }
            continue;
        }
        list_remove(m, c, ec);
        if (live_count(m, c) == 0) { /* an ear's tip: now unreferenced */
            mr_collapse_clean(m, c);
            m->flags[c] |= MR_VF_REMOVED;
            gone++;
        } else if (MR_UNLIKELY(mr_collapse_dirty(m, c)) && 2 * m->dead[c] > m->count[c]) {
            mr_collapse_clean(m, c);
        }
    }
    /* v's merged list at out: v's surviving triangles, then u's (their
     * corners now hold v). */
    uint32_t n = 0;
    for (uint32_t i = 0; i < nv; i++) {
        out[n] = lv[i];
        n += m->tris[lv[i] - lv[i] % 3] != MR_COLLAPSE_NONE;
    }
    for (uint32_t i = 0; i < nu; i++) {
        out[n] = lu[i];
        n += m->tris[lu[i] - lu[i] % 3] != MR_COLLAPSE_NONE;
    }
    m->start[v] = (uint32_t)(out - m->refs);
    m->count[v] = n;
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
    *removed = gone;
    return nd;
}

unsigned mr_collapse_apply(mr_collapse_mesh *m, uint32_t u, uint32_t v,
                           const double target[3])
{
    if (m->lazy && !m->dead)
        mr_collapse_prepare(m);
    size_t gone;
    const unsigned deleted =
        mr_collapse_apply_at(m, u, v, target, m->refs + m->refs_size, &gone, false);
    m->refs_size += m->count[v];
    m->live_vertices -= gone;
    m->live_triangles -= deleted;
    return deleted;
}
