/*
 * The concurrent-queue strategies (MR_STRATEGY_PPQ, _RPPQ, _FPPQ,
 * _MULTIQUEUE): the vertex queue of the greedy half-edge strategy
 * (greedy.c) on a concurrent priority queue, every thread running the
 * decimation kernel of the filter-priority-queue paper (section 3.3,
 * Fig. 5) at once: take a vertex from the top of the queue, lock the
 * vertices its collapse reads and writes, test it, collapse it, update the
 * neighbours' priorities, unlock. Half-edge collapses only.
 *
 * Priorities are greedy.c's: a vertex's key is its best half-edge collapse
 * (best[v], the packed key of heap.h, ties to the smaller id), a lower
 * bound when stale[v]; a vertex is checked when it reaches the top: stale,
 * it is re-keyed with its best collapse; invalid, with its best VALID one
 * or it leaves the queue until its neighbourhood changes; the update after
 * a collapse r -> k is greedy.c's update_around (it reads and writes only
 * k and the vertices of k's ring). The key itself is kept in key[v] too,
 * since a vertex may be out of the queue (taken by a thread) while a
 * neighbour's collapse compares with it.
 *
 * Locking protocol (per-vertex try-locks, vlock.h):
 *   - Ownership: best[v], stale[v], key[v], and every insert, re-key and
 *     removal of v in the queue happen only under v's lock. Pops take an
 *     element without it: the popping thread holds a "ticket" for v.
 *   - A ticket holder waits for v's lock (holding no other lock, so no
 *     cycle can form), then drops the ticket when v is removed, has no
 *     collapse (best NONE), or is back in the queue (a lock holder
 *     re-inserted it meanwhile: the queued copy is the one that counts;
 *     with v's lock held nothing but a pop can change that).
 *   - Holding v, it cleans v's list and locks v's closed 1-ring (every
 *     vertex of v's triangles): that freezes v's star (a collapse changes
 *     a triangle only when it holds the locks of all its vertices) and
 *     what the costs read (quadrics, flags, positions of the ring). For
 *     the collapse v -> w it also locks w's closed 1-ring: the validity
 *     test reads both ends' triangles and their vertices, the collapse
 *     writes both ends, their triangles and the opposite vertices' dead
 *     counts, and the update writes the vertices of k's new ring, which is
 *     inside the two rings. When v's best is invalid, its best valid
 *     collapse is looked for as greedy.c does; before each candidate w' is
 *     tested, w''s closed ring is locked too (a 2-ring vertex read beyond
 *     the locks never happens: it is locked or the attempt is abandoned).
 *   - Every lock past v's own is a try: on a failure the thread puts v
 *     back with its unchanged key, releases everything and pops again
 *     (from the next top node for RPPQ and FPPQ, another random pair for
 *     the MultiQueue; PPQ pops the root again, so it spins there).
 *   - Two collapses at once hold disjoint lock sets, so no end of one
 *     shares a triangle with an end of the other: that is the condition
 *     of collapse.h under which shared collapses (mr_collapse_apply_at)
 *     commute; the opposite vertices' dead[] counts they may share are
 *     atomic.
 *
 * Refs room: a collapse r -> k takes count[r] + count[k] - 1 entries from
 * an atomic cursor and zeroes the tail its merged list leaves. When the
 * room runs out the thread zeroes the part of its claim inside refs,
 * raises a safe-point request, releases its locks (keeping its ticket)
 * and goes to the safe point.
 *
 * Safe points: every loop iteration and every wait checks one shared flag;
 * a thread that sees it holds no lock and meets the others at an OpenMP
 * barrier; there the live counts are folded, refs is compacted by the
 * whole team (mr_collapse_compact) when asked, and the run ends when a
 * stop was asked. The decision to stop is read by every thread before the
 * last barrier of the safe point, so the team leaves together.
 *
 * Targets: a collapse reserves what it removes (vertices: 1 + ear tips;
 * triangles: those on the edge) from the remaining budget with a
 * compare-and-swap that succeeds only while the budget is positive: the
 * collapses made are exactly those the greedy rule (collapse while the
 * target is not reached) allows. A refusal asks for the stop.
 *
 * Termination (quiescence): `work` counts queued elements plus tickets,
 * never below the true number (raised before an insert, lowered after a
 * removal or when a ticket is dropped; a ticket put back into the queue
 * by its holder just changes form); only a ticket holder inserts. So
 * work == 0 means an empty queue and no ticket, which stays so: nothing
 * valid is left, and a thread seeing it asks for the stop. A vertex whose
 * collapse costs more than the error limit leaves the queue (parked) until
 * a neighbour's collapse re-keys it; on one thread with a strict pop that
 * ends the run, as the reference's break does.
 *
 * On one thread, PPQ (and RPPQ and FPPQ, whose first try is the root) pops
 * exactly what greedy.c's heap has at its top, and every step makes the
 * same decision: the output is greedy.c's half-edge output, byte for byte.
 */
#include "../strategy.h"
#include "../vertex_queue.h"

#include "../../../core/omp_compat.h"
#include "fppq.h"
#include "multiqueue.h"
#include "ppq.h"
#include "vlock.h"

#include <math.h>
#include <stdatomic.h>

#define NONE MR_COLLAPSE_NONE

/* What the concurrent-queue strategies count, per thread and then summed
 * (mr_simplify_stats' profile fields). */
typedef struct mr_queued_profile {
    size_t pops, locks, lock_failures, checks, updates;
} mr_queued_profile;

/* Per thread, on cache lines of its own. */
typedef struct qthread {
    uint32_t *held;       /* the locks it holds */
    uint32_t nheld, cap;
    uint64_t rng;         /* MultiQueue */
    uint32_t first;       /* RPPQ, FPPQ: the top node tried first */
    mr_queued_profile p;
    size_t gone, deleted; /* removed since the last safe point */
    double worst;
    uint32_t ticket;      /* the vertex it took from the queue, or NONE */
    bool moved;           /* the ticket went back into the queue: it
                             counts there (work unchanged) */
    _Atomic size_t made;  /* collapses: read by the calling thread */
    char pad[64];
} qthread;

enum { STEP_DONE, STEP_RETRY, STEP_SYNC };

typedef struct mr_queued {
    int kind;                /* MR_STRATEGY_PPQ .. _MULTIQUEUE */
    mr_ppq ppq;              /* PPQ, RPPQ */
    mr_fppq fppq;
    mr_multiqueue mq;
    uint32_t top;            /* RPPQ: top nodes a pop may take */
    uint32_t *best;          /* per vertex: the other end of its collapse */
    float *key;              /* its key (a lower bound when stale) */
    uint8_t *stale;
    mr_vlock *lock;
    int threads;
    qthread *th;
    bool strict_one;         /* one thread, exact pops: stop at the limit */
    bool has_t;              /* a triangle target */
    double limit;
    char pad0[64];
    _Atomic int64_t work;    /* queued elements + tickets (upper bound) */
    char pad1[64];
    _Atomic size_t cursor;   /* refs' end, handed out */
    char pad2[64];
    _Atomic int64_t rem_v, rem_t; /* budget left to the targets */
    char pad3[64];
    _Atomic int sync, compact, stop; /* safe point asked, and why */
    size_t compactions;
} mr_queued;

/* ---- the queue: one interface over the four -------------------------------- */

static bool q_pop(mr_queued *qd, qthread *t, uint32_t *id)
{
    float key;
    switch (qd->kind) {
    case MR_STRATEGY_PPQ: return mr_ppq_pop(&qd->ppq, id, &key);
    case MR_STRATEGY_RPPQ: return mr_ppq_pop_relaxed(&qd->ppq, qd->top, t->first, id, &key);
    case MR_STRATEGY_FPPQ: return mr_fppq_pop_from(&qd->fppq, t->first, id, &key);
    default: return mr_multiqueue_pop(&qd->mq, &t->rng, id, &key);
    }
}

static bool q_contains(const mr_queued *qd, uint32_t id)
{
    switch (qd->kind) {
    case MR_STRATEGY_FPPQ: return mr_ppq_contains(&qd->fppq.heap, id);
    case MR_STRATEGY_MULTIQUEUE:
        return atomic_load_explicit(&qd->mq.owner[id], memory_order_relaxed) != 0;
    default: return mr_ppq_contains(&qd->ppq, id);
    }
}

/* Set id's key, inserting it when absent: true when inserted. */
static bool q_set(mr_queued *qd, qthread *t, uint32_t id, float key)
{
    switch (qd->kind) {
    case MR_STRATEGY_FPPQ: return mr_fppq_update(&qd->fppq, id, key);
    case MR_STRATEGY_MULTIQUEUE: return mr_multiqueue_update(&qd->mq, id, key, &t->rng);
    default: return mr_ppq_update(&qd->ppq, id, key);
    }
}

static bool q_remove(mr_queued *qd, uint32_t id)
{
    switch (qd->kind) {
    case MR_STRATEGY_FPPQ: return mr_fppq_remove(&qd->fppq, id);
    case MR_STRATEGY_MULTIQUEUE: return mr_multiqueue_remove(&qd->mq, id);
    default: return mr_ppq_remove(&qd->ppq, id);
    }
}

/* v's key (v locked by the caller), in the queue; work raised before an
 * insert (v absent stays absent: only v's lock holder inserts it). */
static void set_key(mr_queued *qd, qthread *t, uint32_t v, float key)
{
    qd->key[v] = key;
    const bool present = q_contains(qd, v);
    if (!present && v == t->ticket)
        t->moved = true; /* the ticket becomes the queued element */
    else if (!present)
        atomic_fetch_add(&qd->work, 1);
    const bool inserted = q_set(qd, t, v, key);
    if (present && inserted) /* a pop took it meanwhile: its ticket counts
                                until we release v */
        atomic_fetch_add(&qd->work, 1);
    t->p.updates++;
}

static void drop_key(mr_queued *qd, qthread *t, uint32_t v)
{
    if (q_remove(qd, v))
        atomic_fetch_sub(&qd->work, 1);
    t->p.updates++;
}

/* ---- locks ----------------------------------------------------------------- */

static bool holds(const qthread *t, uint32_t v)
{
    for (uint32_t i = 0; i < t->nheld; i++)
        if (t->held[i] == v)
            return true;
    return false;
}

static bool note_held(qthread *t, uint32_t v)
{
    if (t->nheld == t->cap) {
        const uint32_t cap = t->cap ? 2 * t->cap : 256;
        uint32_t *h = realloc(t->held, cap * sizeof *h);
        if (!h)
            return false;
        t->held = h;
        t->cap = cap;
    }
    t->held[t->nheld++] = v;
    return true;
}

/* Take v's lock unless it is ours already; never waits. */
static bool grab(mr_queued *qd, qthread *t, uint32_t v)
{
    if (holds(t, v))
        return true;
    if (!mr_vlock_try(&qd->lock[v])) {
        t->p.lock_failures++;
        return false;
    }
    t->p.locks++;
    if (!note_held(t, v)) {
        mr_vlock_unlock(&qd->lock[v]);
        return false;
    }
    return true;
}

static void release_all(mr_queued *qd, qthread *t)
{
    for (uint32_t i = 0; i < t->nheld; i++)
        mr_vlock_unlock(&qd->lock[t->held[i]]);
    t->nheld = 0;
}

/* Lock v's closed 1-ring (v held): its list cleaned first. */
static bool grab_ring(mr_simplifier *s, mr_queued *qd, qthread *t, uint32_t v)
{
    mr_collapse_mesh *m = &s->m;
    mr_collapse_clean(m, v);
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    for (uint32_t i = 0, n = m->count[v]; i < n; i++) {
        const uint32_t *tri = m->tris + (list[i] - list[i] % 3);
        for (int c = 0; c < 3; c++)
            if (!grab(qd, t, tri[c]))
                return false;
    }
    return true;
}

/* ---- priorities: the vertex queue's rules (vertex_queue.h) ----------------- */

/* One thread's view for the rules' callbacks. */
typedef struct qctx {
    mr_simplifier *s;
    mr_queued *qd;
    qthread *t;
} qctx;

static float vq_key(void *q, uint32_t v) { return ((qctx *)q)->qd->key[v]; }
static void vq_set(void *q, uint32_t v, float key)
{
    qctx *c = q;
    set_key(c->qd, c->t, v, key);
}
static void vq_drop(void *q, uint32_t v)
{
    qctx *c = q;
    drop_key(c->qd, c->t, v);
}
/* A candidate's test reads its triangles: its closed ring locked first. */
static bool vq_prepare(void *q, uint32_t u, uint32_t w)
{
    qctx *c = q;
    (void)u;
    if (!grab_ring(c->s, c->qd, c->t, w))
        return false;
    c->t->p.checks++;
    return true;
}

static inline mr_vertex_queue vertex_queue(qctx *c)
{
    return (mr_vertex_queue){c->qd->best, c->qd->stale, c, vq_key, vq_set, vq_drop, vq_prepare};
}

/* ---- the kernel ------------------------------------------------------------- */

static inline void ask(mr_queued *qd, _Atomic int *why)
{
    atomic_store(why, 1);
    atomic_store(&qd->sync, 1);
}

/* Take what collapse r -> k removes from the budgets; false (nothing
 * taken) when a target is reached. */
static bool reserve(mr_queued *qd, int64_t dv, int64_t dt)
{
    int64_t cur = atomic_load(&qd->rem_v);
    do {
        if (cur <= 0)
            return false;
    } while (!atomic_compare_exchange_weak(&qd->rem_v, &cur, cur - dv));
    if (!qd->has_t)
        return true;
    cur = atomic_load(&qd->rem_t);
    do {
        if (cur <= 0) {
            atomic_fetch_add(&qd->rem_v, dv);
            return false;
        }
    } while (!atomic_compare_exchange_weak(&qd->rem_t, &cur, cur - dt));
    return true;
}

/* Vertices (1 + ear tips) and triangles collapse r -> k removes; r clean,
 * every vertex of r's triangles locked. */
static void removes(const mr_collapse_mesh *m, uint32_t r, uint32_t k, int64_t *dv, int64_t *dt)
{
    const uint32_t *list = mr_collapse_vertex_tris(m, r);
    *dv = 1;
    *dt = 0;
    for (uint32_t i = 0, n = m->count[r]; i < n; i++) {
        const uint32_t j = list[i] % 3, *tri = m->tris + (list[i] - j);
        const uint32_t a = tri[mr_local_next(j)], b = tri[mr_local_prev(j)];
        if (a != k && b != k)
            continue;
        const uint32_t x = a == k ? b : a;
        (*dt)++;
        *dv += m->count[x] - m->dead[x] == 1;
    }
}

/* Put u (locked) back with its key, release everything: another try. */
static int retry(mr_queued *qd, qthread *t, uint32_t u)
{
    set_key(qd, t, u, qd->key[u]); /* the ticket moves back */
    release_all(qd, t);
    return STEP_RETRY;
}

/* The ticket resolved: it counts no more, unless it went back into the
 * queue. */
static int done(mr_queued *qd, qthread *t)
{
    release_all(qd, t);
    if (!t->moved)
        atomic_fetch_sub(&qd->work, 1);
    return STEP_DONE;
}

/* One ticket: vertex u, taken from the queue. */
static int step(mr_simplifier *s, mr_queued *qd, qthread *t, uint32_t u)
{
    mr_collapse_mesh *m = &s->m;
    qctx ctx = {s, qd, t};
    const mr_vertex_queue vq = vertex_queue(&ctx);
    mr_spin sp = MR_SPIN_INIT;
    t->ticket = u;
    t->moved = false;
    while (!mr_vlock_try(&qd->lock[u])) {
        if (atomic_load_explicit(&qd->sync, memory_order_relaxed))
            return STEP_SYNC; /* the ticket kept */
        mr_spin_wait(&sp);
    }
    t->p.locks++;
    if (!note_held(t, u)) {
        mr_vlock_unlock(&qd->lock[u]);
        return STEP_SYNC; /* no memory for the list: wait and try again */
    }
    if ((m->flags[u] & MR_VF_REMOVED) || qd->best[u] == NONE || q_contains(qd, u))
        return done(qd, t);
    if (!grab_ring(s, qd, t, u))
        return retry(qd, t, u);
    if (qd->stale[u]) {
        mr_vq_requeue(s, &vq, u, false); /* u's ring only: never fails */
        return done(qd, t);
    }
    const uint32_t w = qd->best[u];
    uint32_t r, k;
    double target[3];
    const double cost = mr_simplifier_plan(s, u, w, &r, &k, target);
    if (cost > qd->limit) {
        /* parked: out of the queue until a neighbour's collapse re-keys it */
        if (qd->strict_one)
            ask(qd, &qd->stop);
        return done(qd, t);
    }
    if (!grab_ring(s, qd, t, w))
        return retry(qd, t, u);
    t->p.checks++;
    if (!mr_simplifier_allowed(s, r, k, target, cost, qd->limit)) {
        if (!mr_vq_requeue(s, &vq, u, true))
            return retry(qd, t, u);
        return done(qd, t);
    }
    const size_t need = (size_t)m->count[r] + m->count[k] - 1;
    const size_t at = atomic_fetch_add(&qd->cursor, need);
    if (at + need > m->refs_capacity) {
        for (size_t i = at; i < m->refs_capacity; i++)
            m->refs[i] = 0; /* no compaction tag may stay behind */
        ask(qd, &qd->compact);
        release_all(qd, t);
        return STEP_SYNC;
    }
    uint32_t *out = m->refs + at;
    int64_t dv, dt;
    removes(m, r, k, &dv, &dt);
    if (!reserve(qd, dv, dt)) {
        memset(out, 0, need * sizeof *out);
        ask(qd, &qd->stop);
        return done(qd, t);
    }
    size_t rm;
    t->deleted += mr_simplifier_collapse_at(s, r, k, target, out, &rm);
    t->gone += rm;
    for (size_t j = m->count[k]; j < need; j++)
        out[j] = 0;
    t->worst = cost > t->worst ? cost : t->worst;
    atomic_store_explicit(&t->made, atomic_load_explicit(&t->made, memory_order_relaxed) + 1,
                          memory_order_relaxed);
    mr_vq_update_around(s, &vq, r, k);
    t->first = 0;
    return done(qd, t);
}

/* All threads, holding no lock: fold the counts, compact when asked;
 * returns true when the run ends. */
static bool safe_point(mr_simplifier *s, mr_queued *qd)
{
    mr_collapse_mesh *m = &s->m;
#pragma omp barrier
#pragma omp single
    {
        for (int i = 0; i < qd->threads; i++) {
            m->live_vertices -= qd->th[i].gone;
            m->live_triangles -= qd->th[i].deleted;
            qd->th[i].gone = qd->th[i].deleted = 0;
        }
        const size_t end = atomic_load(&qd->cursor);
        m->refs_size = end < m->refs_capacity ? end : m->refs_capacity;
        qd->compactions += atomic_load(&qd->compact) != 0;
    }
    if (atomic_load(&qd->compact))
        mr_collapse_compact(m);
    const bool fin = atomic_load(&qd->stop) != 0;
#pragma omp barrier
#pragma omp single
    {
        atomic_store(&qd->cursor, m->refs_size);
        atomic_store(&qd->compact, 0);
        if (!fin)
            atomic_store(&qd->sync, 0);
    }
    return fin;
}

/* One thread's loop. */
static void run_thread(mr_simplifier *s, mr_queued *qd, qthread *t, bool caller,
                       size_t planned)
{
    uint32_t ticket = NONE;
    mr_spin sp = MR_SPIN_INIT;
    size_t next_report = planned / 100 + 1, turns = 0;
    for (;;) {
        if (atomic_load_explicit(&qd->sync, memory_order_relaxed)) {
            if (safe_point(s, qd))
                break;
            continue;
        }
        if (ticket == NONE) {
            if (atomic_load(&qd->work) == 0) {
                ask(qd, &qd->stop); /* nothing queued, no ticket: quiescent */
                continue;
            }
            if (!q_pop(qd, t, &ticket)) {
                ticket = NONE;
                mr_spin_wait(&sp); /* the others hold what is left */
                continue;
            }
            t->p.pops++;
        }
        const int r = step(s, qd, t, ticket);
        if (r != STEP_SYNC)
            ticket = NONE;
        if (r == STEP_RETRY) {
            t->first++;
            mr_spin_wait(&sp);
        } else {
            sp.turns = 0;
        }
        if (caller && s->plan.progress && (++turns & 255) == 0) {
            size_t made = 0;
            for (int i = 0; i < qd->threads; i++)
                made += atomic_load_explicit(&qd->th[i].made, memory_order_relaxed);
            if (made >= next_report) {
                if (mr_simplifier_progress(s, planned ? (double)made / (double)planned : 1.0))
                    ask(qd, &qd->stop); /* every thread stops at the safe point */
                next_report = made + planned / 100 + 1;
            }
        }
    }
    (void)ticket; /* a ticket left at the stop dies with the queue */
}

/* ---- start, run, release ----------------------------------------------------- */

static void queued_free(mr_queued *qd)
{
    if (!qd)
        return;
    mr_ppq_free(&qd->ppq);
    mr_fppq_free(&qd->fppq);
    mr_multiqueue_free(&qd->mq);
    if (qd->th)
        for (int i = 0; i < qd->threads; i++)
            free(qd->th[i].held);
    free(qd->th);
    free(qd->best);
    free(qd->key);
    free(qd->stale);
    free(qd->lock);
    free(qd);
}

static void queued_release(mr_simplifier *s)
{
    queued_free(s->state);
    s->state = NULL;
}

static mr_status queued_start(mr_simplifier *s, mr_error *err)
{
    mr_collapse_mesh *m = &s->m;
    const size_t nv = m->vertex_count;
    mr_queued *qd = mr_calloc_array(1, sizeof *qd);
    if (!qd)
        return mr_fail_nomem(err, NULL, sizeof *qd);
    s->state = qd;
    qd->kind = s->plan.strategy;
    qd->threads = s->plan.threads > 0 ? s->plan.threads : 1;
    m->lazy = true; /* shared collapses count their opposite vertices' dead entries */
    mr_collapse_prepare(m);
    qd->best = mr_alloc_array(nv, sizeof *qd->best);
    qd->key = mr_alloc_array(nv, sizeof *qd->key);
    qd->stale = mr_calloc_array(nv, 1);
    qd->lock = mr_calloc_array(nv, sizeof *qd->lock);
    qd->th = mr_calloc_array((size_t)qd->threads, sizeof *qd->th);
    if (!qd->best || !qd->key || !qd->stale || !qd->lock || !qd->th || !m->dead) {
        queued_release(s);
        return mr_fail_nomem(err, NULL, nv * 14);
    }
    const unsigned levels =
        s->plan.filter_levels ? s->plan.filter_levels : mr_fppq_default_levels(qd->threads);
    mr_status st;
    switch (qd->kind) {
    case MR_STRATEGY_FPPQ: st = mr_fppq_init(&qd->fppq, nv, levels, err); break;
    case MR_STRATEGY_MULTIQUEUE:
        st = mr_multiqueue_init(&qd->mq, nv, qd->threads,
                                s->plan.multiqueue_factor ? s->plan.multiqueue_factor : 2, err);
        break;
    default: st = mr_ppq_init(&qd->ppq, nv, err); break;
    }
    if (st != MR_OK) {
        queued_release(s);
        return st;
    }
    qd->top = mr_fppq_top_nodes(levels);
    for (int i = 0; i < qd->threads; i++) {
        qd->th[i].rng = mr_multiqueue_seed(0x9e3779b97f4a7c15ull, i);
        qd->th[i].ticket = NONE;
    }
    /* Every vertex's best collapse (its ring only: any thread count gives
     * the same), then the queue, in id order. */
    const ptrdiff_t n = (ptrdiff_t)nv;
    uint32_t *ids = NULL;
    size_t count = 0;
    qctx ctx = {s, qd, NULL}; /* without validity tests no callback runs */
    const mr_vertex_queue vq = vertex_queue(&ctx);
#pragma omp parallel for schedule(dynamic, 4096) num_threads(qd->threads) \
    if (qd->threads > 1 && n > 65536)
    for (ptrdiff_t v = 0; v < n; v++) {
        qd->best[v] = NONE;
        qd->key[v] = INFINITY;
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        bool ok;
        const double c = mr_vq_best(s, &vq, (uint32_t)v, false, &qd->best[v], &ok);
        qd->key[v] = (float)c;
    }
    for (size_t v = 0; v < nv; v++)
        count += qd->best[v] != NONE;
    if (qd->kind == MR_STRATEGY_MULTIQUEUE) {
        for (size_t v = 0; v < nv; v++)
            if (qd->best[v] != NONE)
                mr_multiqueue_insert(&qd->mq, (uint32_t)v, qd->key[v], &qd->th[0].rng);
    } else {
        ids = mr_alloc_array(count ? count : 1, sizeof *ids);
        float *keys = mr_alloc_array(count ? count : 1, sizeof *keys);
        if (!ids || !keys) {
            free(ids);
            free(keys);
            queued_release(s);
            return mr_fail_nomem(err, NULL, count * 8);
        }
        size_t i = 0;
        for (size_t v = 0; v < nv; v++)
            if (qd->best[v] != NONE) {
                ids[i] = (uint32_t)v;
                keys[i++] = qd->key[v];
            }
        mr_ppq_build(qd->kind == MR_STRATEGY_FPPQ ? &qd->fppq.heap : &qd->ppq, ids, keys, count);
        free(ids);
        free(keys);
    }
    atomic_store(&qd->work, (int64_t)count);
    return MR_OK;
}

static size_t queued_run(mr_simplifier *s, double *max_error)
{
    mr_queued *qd = s->state;
    mr_collapse_mesh *m = &s->m;
    const mr_simplify_goal g = s->plan.goal;
    qd->limit = g.limit;
    qd->strict_one = qd->threads == 1 && qd->kind != MR_STRATEGY_MULTIQUEUE;
    qd->has_t = g.triangles != 0;
    atomic_store(&qd->rem_v, (int64_t)m->live_vertices - (int64_t)g.vertices);
    atomic_store(&qd->rem_t, qd->has_t ? (int64_t)m->live_triangles - (int64_t)g.triangles
                                       : INT64_MAX);
    atomic_store(&qd->cursor, m->refs_size);
    if (mr_simplifier_reached(s))
        atomic_store(&qd->work, 0); /* nothing to do */
    const int nt = qd->threads;
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
        const int me = omp_get_thread_num();
        run_thread(s, qd, &qd->th[me], me == 0, g.planned);
    }
    size_t made = 0;
    double worst = 0;
    mr_simplify_stats *p = &s->profile; /* added: a second stage adds to the first */
    for (int i = 0; i < nt; i++) {
        qthread *t = &qd->th[i];
        m->live_vertices -= t->gone;
        m->live_triangles -= t->deleted;
        made += atomic_load(&t->made);
        worst = t->worst > worst ? t->worst : worst;
        p->queue_pops += t->p.pops;
        p->lock_acquisitions += t->p.locks;
        p->lock_failures += t->p.lock_failures;
        p->topology_checks += t->p.checks;
        p->priority_updates += t->p.updates;
    }
    p->compactions += qd->compactions;
    const size_t end = atomic_load(&qd->cursor);
    m->refs_size = end < m->refs_capacity ? end : m->refs_capacity;
    queued_release(s);
    *max_error = sqrt(worst);
    return made;
}

const mr_strategy_ops mr_strategy_queued = {queued_start, queued_run, queued_release, true};
