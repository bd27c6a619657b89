/*
 * Sequential greedy quadric-error simplification (Garland & Heckbert 1997)
 * (MR_STRATEGY_GREEDY): always the single cheapest collapse, from a heap --
 * the reference the other strategies are measured against. Full-edge
 * collapses (to the quadric-optimal position) queue edges; half-edge
 * collapses, as in the filter-priority-queue paper (and OpenMesh's
 * decimater), queue vertices. Its state (mr_greedy: the heap, and the
 * vertex queue's best and stale) is its own (s->state), from greedy_start
 * to the end of greedy_run; costs, plans, validity and the collapse are
 * the core's (core/cost.c).
 *
 * The vertex queue holds one entry per VERTEX, its cheapest collapse; its
 * rules (the updates after a collapse, lazy validity at the top) are
 * vertex_queue.h's, shared with the concurrent-queue strategies
 * (parallel/queued.c).
 *
 * The edge queue is described where it starts, below.
 */
#include "strategy.h"

#include "heap.h"
#include "vertex_queue.h"

#include <math.h>

#define NONE MR_COLLAPSE_NONE

typedef struct mr_greedy {
    mr_heap heap;   /* vertices (half collapses) or edges (full ones) */
    uint32_t *best; /* half: per vertex, other end of its queued collapse */
    uint8_t *stale; /* half: per vertex, key is only a lower bound */
} mr_greedy;

/* ---- half collapses: the vertex queue's rules (vertex_queue.h) on the heap */

static float heap_key(void *q, uint32_t v) { return mr_heap_key(q, v); }
static void heap_set(void *q, uint32_t v, float key) { mr_heap_update(q, v, key); }
static void heap_drop(void *q, uint32_t v) { mr_heap_remove(q, v); }

static inline mr_vertex_queue vertex_queue(mr_greedy *gr)
{
    return (mr_vertex_queue){gr->best, gr->stale, &gr->heap, heap_key, heap_set, heap_drop, NULL};
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

/* Queue, re-key or drop the edge of half-edge h, whose twin is tw. */
static void edge_enqueue(mr_simplifier *s, mr_greedy *gr, uint32_t h, uint32_t tw)
{
    uint32_t rep = h;
    if (tw != NONE) {
        rep = tw < h ? tw : h;
        mr_heap_remove(&gr->heap, tw < h ? h : tw);
    }
    uint32_t r, k;
    double target[3];
    const double c = mr_simplifier_plan_edge(s, s->m.tris[h], he_dst(&s->m, h), &r, &k, target);
    if (c < INFINITY)
        mr_heap_update(&gr->heap, rep, (float)c);
    else
        mr_heap_remove(&gr->heap, rep);
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
static void edge_update_around(mr_simplifier *s, mr_greedy *gr, uint32_t k)
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
            edge_enqueue(s, gr, base + j, tw_out);
            if (!in_twinned)
                edge_enqueue(s, gr, base + mr_local_prev(j), NONE);
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
            edge_enqueue(s, gr, list[i], NONE);
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
        edge_enqueue(s, gr, 3 * t + j, tw_out);
        if (find_keyed(bynext, n, p, i) == NONE)
            edge_enqueue(s, gr, 3 * t + jp, NONE);
    }
    free(byprev);
}

/* Re-queue the edges of a BLOCKED vertex x that are out of the queue
 * (those at k were just re-evaluated). */
static void edge_requeue_vertex(mr_simplifier *s, mr_greedy *gr, uint32_t x, uint32_t k)
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
            if (!mr_heap_contains(&gr->heap, rep))
                edge_enqueue(s, gr, h, tw);
        }
        if (tri[jp] != k) {
            const uint32_t h = 3 * t + jp;
            if (!mr_heap_contains(&gr->heap, h) && he_twin(m, h) == NONE)
                edge_enqueue(s, gr, h, NONE);
        }
    }
}

static void edge_unblock_ring(mr_simplifier *s, mr_greedy *gr, uint32_t k)
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
                edge_requeue_vertex(s, gr, x, k);
            }
        }
    }
}

/* The queue of edges: the representatives are found first (a bit each),
 * so the heap's items are sized to the edge count; built in O(n). */
static mr_status edge_fill_queue(mr_simplifier *s, mr_greedy *gr, mr_error *err)
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
    mr_status st = mr_heap_init_sized(&gr->heap, nh, edges, err);
    if (st != MR_OK) {
        free(own);
        return st;
    }
    for (size_t h = 0; h < nh; h++) {
        if (!(rep[h / 64] >> (h % 64) & 1))
            continue;
        uint32_t r, k;
        double target[3];
        const double c = mr_simplifier_plan_edge(s, m->tris[h], he_dst(m, (uint32_t)h), &r, &k,
                                                 target);
        if (c < INFINITY)
            mr_heap_append(&gr->heap, (uint32_t)h, (float)c);
    }
    free(own);
    mr_heap_heapify(&gr->heap);
    return MR_OK;
}

/* ---- the run -------------------------------------------------------------- */

static void greedy_free(mr_simplifier *s)
{
    mr_greedy *gr = s->state;
    if (!gr)
        return;
    mr_heap_free(&gr->heap);
    free(gr->best);
    free(gr->stale);
    free(gr);
    s->state = NULL;
}

/* Fill the queue: for half collapses every vertex with its best collapse,
 * for full ones every edge. Pushed in id order, so the heap -- and
 * everything after -- is deterministic. On failure nothing of it is left
 * (the simplifier must still be freed). */
static mr_status greedy_start(mr_simplifier *s, mr_error *err)
{
    const size_t vertex_count = s->m.vertex_count;
    mr_greedy *gr = mr_calloc_array(1, sizeof *gr);
    if (!gr)
        return mr_fail_nomem(err, NULL, sizeof *gr);
    s->state = gr;
    mr_status st;
    if (!s->half) { /* full collapses queue edges: see edge_fill_queue */
        st = edge_fill_queue(s, gr, err);
        if (st != MR_OK)
            greedy_free(s);
        return st;
    }
    gr->best = mr_alloc_array(vertex_count, sizeof *gr->best);
    gr->stale = mr_calloc_array(vertex_count, 1);
    if (!gr->best || !gr->stale) {
        greedy_free(s);
        return mr_fail_nomem(err, NULL, vertex_count * 5);
    }
    /* 32-bit positions: this heap is small next to the rest (one id
     * per vertex), and they are the faster to update. */
    st = mr_heap_init_width(&gr->heap, vertex_count, vertex_count, 4, err);
    if (st != MR_OK) {
        greedy_free(s);
        return st;
    }
    const mr_vertex_queue vq = vertex_queue(gr);
    for (size_t v = 0; v < s->m.vertex_count; v++) {
        gr->best[v] = NONE;
        if (s->m.flags[v] & MR_VF_REMOVED)
            continue;
        uint32_t w;
        bool ok;
        double c = mr_vq_best(s, &vq, (uint32_t)v, false, &w, &ok);
        gr->best[v] = w;
        if (w != NONE)
            mr_heap_push(&gr->heap, (uint32_t)v, (float)c);
    }
    return MR_OK;
}

static size_t greedy_run(mr_simplifier *s, double *max_error)
{
    mr_greedy *gr = s->state;
    mr_collapse_mesh *m = &s->m;
    const size_t planned = s->plan.goal.planned;
    const double limit = s->plan.goal.limit;
    size_t next_report = planned / 100 + 1, done = 0;
    double worst = 0;
    const mr_vertex_queue vq = vertex_queue(gr);

    while (!mr_heap_empty(&gr->heap)) {
        if (mr_simplifier_reached(s))
            break;
        if (!s->half) {
            const uint32_t h = mr_heap_top(&gr->heap);
            const uint32_t a = m->tris[h], b = he_dst(m, h);
            uint32_t r, k;
            double target[3];
            double cost = mr_simplifier_plan_edge(s, a, b, &r, &k, target);
            if (cost > limit)
                break;
            mr_simplifier_place(s, r, k, target, &cost);
            if (!mr_simplifier_allowed(s, r, k, target, cost, limit)) {
                mr_heap_remove(&gr->heap, h);
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
                    mr_heap_remove(&gr->heap, 3 * dead[i] + c);
            edge_update_around(s, gr, k);
            edge_unblock_ring(s, gr, k);
            worst = cost > worst ? cost : worst;
            done++;
            if (s->plan.progress && done >= next_report) {
                if (mr_simplifier_progress(s, planned ? (double)done / (double)planned : 1.0))
                    break;
                next_report += planned / 100 + 1;
            }
            continue;
        }
        const uint32_t u = mr_heap_top(&gr->heap);
        if (gr->stale[u]) {
            mr_vq_requeue(s, &vq, u, false);
            continue;
        }
        const uint32_t w = gr->best[u];
        uint32_t r, k;
        double target[3];
        const double cost = mr_simplifier_plan(s, u, w, &r, &k, target);
        if (cost > limit)
            break;
        if (!mr_simplifier_allowed(s, r, k, target, cost, limit)) {
            mr_vq_requeue(s, &vq, u, true);
            continue;
        }
        mr_simplifier_collapse(s, r, k, target);
        mr_vq_update_around(s, &vq, r, k);
        worst = cost > worst ? cost : worst;
        done++;
        if (s->plan.progress && done >= next_report) {
            if (mr_simplifier_progress(s, planned ? (double)done / (double)planned : 1.0))
                break;
            next_report += planned / 100 + 1;
        }
    }
    /* The queue is done with: its memory goes before the output's. */
    greedy_free(s);
    *max_error = sqrt(worst);
    return done;
}

const mr_strategy_ops mr_strategy_greedy = {greedy_start, greedy_run, greedy_free, true};
