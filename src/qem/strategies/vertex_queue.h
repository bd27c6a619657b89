/*
 * The vertex queue of half-edge collapses: its priority rules, shared by
 * greedy.c (MR_STRATEGY_GREEDY with MR_COLLAPSE_HALF, on mr_heap) and
 * parallel/queued.c (the concurrent queues, under vertex locks). Internal.
 *
 * The queue holds one entry per VERTEX: its cheapest collapse (best[v],
 * the other end, and its cost as the key). A collapse r -> k (r removed,
 * k kept) changes only the quadric of k, so afterwards (update_around):
 *   - k's candidates are all evaluated anew;
 *   - for every neighbour w of k only the edge (w, k) changed: when it
 *     beats w's key, it becomes w's best; when w's best pointed at r or k
 *     (whose cost changed), w keeps its old key as a lower bound and is
 *     marked stale; a w without a collapse gets (w, k), stale.
 * Validity is checked lazily, when a vertex reaches the top (requeue): a
 * stale one is re-keyed with its best collapse; one whose best is invalid
 * with its best VALID collapse, or it leaves the queue until its
 * neighbourhood changes.
 *
 * What the rules read and write: requeue(u) reads u's list and the costs
 * of u's edges (quadrics, flags and positions of u's closed ring), and
 * with validity each tested candidate w's triangles (prepare, when set,
 * is called before each such test); it writes u's entry. update_around
 * writes the entries of k and of the vertices of k's ring, reading the
 * same vertices' quadrics, flags and positions. The queue is reached only
 * through the callbacks, each on one vertex's entry.
 */
#ifndef MR_VERTEX_QUEUE_H
#define MR_VERTEX_QUEUE_H

#include "strategy.h"

/*
 * Calls visit(w) for every neighbour w of u: the vertex after u in each of
 * its triangles, which covers every inner edge once; plus the vertex before
 * u when both ends are on a boundary (a boundary edge is seen from one
 * side only). Some edges may be visited twice, which is harmless.
 */
#define MR_FOR_EACH_NEIGHBOUR(s, u, w, ...)                                           \
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

typedef struct mr_vertex_queue {
    uint32_t *best;  /* per vertex: the other end of its queued collapse */
    uint8_t *stale;  /* per vertex: its key is only a lower bound */
    void *q;         /* the callbacks' own */
    float (*key)(void *q, uint32_t v);           /* v's key (v queued) */
    void (*set)(void *q, uint32_t v, float key); /* key v, inserting it */
    void (*drop)(void *q, uint32_t v);           /* v out of the queue */
    /* Before u -> w is tested for validity: false abandons the requeue
     * (nothing changed). NULL: always go on. */
    bool (*prepare)(void *q, uint32_t u, uint32_t w);
} mr_vertex_queue;

/* u's cheapest half-edge collapse (only valid ones when check_valid); ties
 * go to the smaller neighbour id. *ok false when prepare refused. */
static inline double mr_vq_best(mr_simplifier *s, const mr_vertex_queue *vq, uint32_t u,
                                bool check_valid, uint32_t *best, bool *ok)
{
    double best_cost = INFINITY;
    uint32_t best_w = MR_COLLAPSE_NONE;
    bool go = true;
    MR_FOR_EACH_NEIGHBOUR(s, u, w, {
        const double c = mr_simplifier_half_cost(s, u, w);
        if (go && (c < best_cost || (c == best_cost && c < INFINITY && w < best_w))) {
            if (check_valid && vq->prepare && !vq->prepare(vq->q, u, w))
                go = false;
            else if (!check_valid || mr_simplifier_valid(s, u, w, NULL)) {
                best_cost = c;
                best_w = w;
            }
        }
    });
    *ok = go;
    *best = best_w;
    return best_cost;
}

/* u at the top: re-keyed with its best (valid when check_valid) collapse,
 * or out of the queue without one. False, nothing changed, when prepare
 * refused. */
static inline bool mr_vq_requeue(mr_simplifier *s, const mr_vertex_queue *vq, uint32_t u,
                                 bool check_valid)
{
    uint32_t w;
    bool ok;
    const double c = mr_vq_best(s, vq, u, check_valid, &w, &ok);
    if (!ok)
        return false;
    vq->stale[u] = 0;
    vq->best[u] = w;
    if (w == MR_COLLAPSE_NONE)
        vq->drop(vq->q, u);
    else
        vq->set(vq->q, u, (float)c);
    return true;
}

/* The entries around k after the collapse r -> k. */
static inline void mr_vq_update_around(mr_simplifier *s, const mr_vertex_queue *vq,
                                       uint32_t r, uint32_t k)
{
    vq->drop(vq->q, r);
    vq->best[r] = MR_COLLAPSE_NONE;
    double kbest = INFINITY;
    uint32_t kw = MR_COLLAPSE_NONE;
    const mr_collapse_mesh *m = &s->m;
    MR_FOR_EACH_NEIGHBOUR(s, k, w, {
        const double c = mr_simplifier_half_cost(s, k, w);
        const double cw = mr_simplifier_half_cost(s, w, k);
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
        const uint32_t b = vq->best[w];
        if (m->flags[w] & MR_VF_REMOVED) {
            /* nothing */
        } else if (b == MR_COLLAPSE_NONE) {
            if (cw < INFINITY) {
                vq->best[w] = k;
                vq->stale[w] = 1;
                vq->set(vq->q, w, (float)cw);
            }
        } else {
            const float old = vq->key(vq->q, w);
            if ((float)cw < old || ((float)cw == old && k < b)) {
                vq->best[w] = k;
                vq->set(vq->q, w, (float)cw);
            } else if (b == r || b == k) {
                vq->stale[w] = 1;
            }
        }
    });
    vq->best[k] = kw;
    if (kw == MR_COLLAPSE_NONE)
        vq->drop(vq->q, k);
    else
        vq->set(vq->q, k, (float)kbest);
}

#endif /* MR_VERTEX_QUEUE_H */
