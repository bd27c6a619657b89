/*
 * Batched selection of collapses (MR_STRATEGY_BATCHED): the simplifier
 * works in passes instead of one collapse at a time from a heap.
 *
 * A pass gathers every live edge with its cost (the same costs, the same
 * planned collapse and the same validity test as the greedy strategy),
 * sorts the cheapest ones and applies them in order of cost, skipping an
 * edge when one of its ends was already the survivor of a collapse in this
 * pass: only the survivor's quadric and position change, so every other
 * edge's cost is still exact when its turn comes, and validity is tested
 * on the mesh as it is at that moment. The next pass re-evaluates
 * everything that changed.
 *
 * How far a pass goes decides how close the result is to the greedy one:
 * a pass takes edges up to the cost of the `goal`-th cheapest one (a
 * share of the collapses still needed) times a small factor -- edges
 * blocked by a neighbour's collapse would otherwise leave the pass short.
 * Costs and order are deterministic (ties keep gathering order, which is
 * by triangle), so the result is too.
 *
 * Why it is faster: no heap with mutable keys (a sift per neighbour edge
 * after every collapse), no re-evaluation of a neighbourhood that collapses
 * again before its edges reach the top, the gathering sweeps the mesh in
 * memory order, and costs and plans are computed for batches of edges in
 * one vectorised loop (mr_simplifier_plan_edges).
 */
#include "simplify_internal.h"

#include <math.h>

#define NONE MR_COLLAPSE_NONE

/* Share of the collapses still needed that one pass aims at, and the
 * slack on the cost of the goal-th cheapest edge. A pass cannot take two
 * collapses at one vertex, so it falls well short of its goal: aiming at
 * all of them (as meshoptimizer's passes do) takes 5 passes instead of 8
 * on a 1M-triangle scan to 10 %, 35 % fewer cost evaluations, with the
 * same error on the bunny and the armadillo at 10 % and 1 % (within the
 * noise of the Hausdorff distance; measured against 0.25 and 0.5). */
#define PASS_SHARE 1.0
#define PASS_SLACK 1.5f

/* Rounds of winner selection per pass: MAX_ROUNDS that apply more
 * collapses than they refuse, and at most MAX_ROUNDS_TOTAL in all. A
 * round whose winners are mostly invalid mainly clears them away, so that
 * the candidates they held back can win; near sharp creases and other
 * spots where the cheapest collapses are all refused, a pass needs many
 * such rounds (the fandisk stopped at 19 % for a 10 % target with 4). */
#define MAX_ROUNDS 4
#define MAX_ROUNDS_TOTAL 64

/* Histogram buckets over the top 16 bits of a key. */
#define HIST_BUCKETS 65536u

static inline uint32_t float_key(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return u; /* costs are >= 0: the bits order as the values */
}

static inline float key_float(uint32_t u)
{
    float x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/*
 * Runs the block once for every live edge of triangle t, as (a, b) along
 * one of its half-edges: an inner edge from the half-edge that runs from
 * its smaller end (its other half-edge runs from the larger one), a
 * boundary edge from its only half-edge, whichever way it runs; an inner
 * edge between two boundary vertices never (its collapse would pinch the
 * surface: mr_collapse_valid refuses it, and as a candidate it would hold
 * back the edges around it -- the spokes of a fanned polygon cost nothing
 * and would block its rim). The
 * inner test is written without a branch (which end is the smaller is a
 * coin toss); `take` is false for the half-edges the block must ignore.
 */
#define FOR_EACH_TRIANGLE_EDGE(m, t, a, b, take, ...)                                   \
    do {                                                                               \
        const uint32_t *tri_ = (m)->tris + 3 * (size_t)(t);                            \
        for (int j_ = 0; j_ < 3; j_++) {                                               \
            const uint32_t a = tri_[j_], b = tri_[j_ == 2 ? 0 : j_ + 1];               \
            bool take = a < b;                                                         \
            if ((m)->flags[a] & (m)->flags[b] & MR_VF_BOUNDARY)                        \
                take = mr_collapse_edge_triangles((m), a, b) == 1;                     \
            __VA_ARGS__                                                                \
        }                                                                              \
    } while (0)

mr_status mr_simplifier_batched_init(mr_simplifier *s, mr_error *err)
{
    const mr_collapse_mesh *m = &s->m;
    /* Room for every edge, bounded without visiting them: with B edges
     * of one triangle, 3T >= B + 2 (E - B), so E <= (3T + B) / 2; and a
     * one-triangle edge has both ends flagged BOUNDARY or NONMANIFOLD,
     * each with at most two such edges per triangle. */
    size_t open = 0;
    for (size_t v = 0; v < m->vertex_count; v++)
        open += (m->flags[v] & (MR_VF_BOUNDARY | MR_VF_NONMANIFOLD)) ? 2 * (size_t)m->count[v] : 0;
    const size_t t3 = 3 * m->live_triangles;
    s->cand_cap = (t3 + (open < t3 ? open : t3)) / 2 + 1;
    s->m.lazy = true; /* only an edge's two ends read lists here */
    s->cand = mr_alloc_array(s->cand_cap, sizeof *s->cand);
    s->mark = mr_calloc_array(m->vertex_count, 1);
    s->hist = mr_alloc_array(HIST_BUCKETS, sizeof *s->hist);
    s->best64 = mr_alloc_array(m->vertex_count, sizeof *s->best64);
    if (s->best64) /* the rounds keep every entry at UINT64_MAX between uses */
        memset(s->best64, 0xFF, m->vertex_count * sizeof *s->best64);
    if (!s->cand || !s->mark || !s->hist || !s->best64)
        return mr_fail_nomem(err, NULL, s->cand_cap * sizeof *s->cand + m->vertex_count * 9);
    return MR_OK;
}

/* Collapses still needed to reach the targets. */
static size_t needed_collapses(const mr_simplifier *s, const mr_simplify_goal *g)
{
    const mr_collapse_mesh *m = &s->m;
    size_t needed = m->live_vertices > g->vertices ? m->live_vertices - g->vertices : 0;
    if (g->triangles) {
        const size_t t = m->live_triangles > g->triangles
                             ? (m->live_triangles - g->triangles + 1) / 2
                             : 0;
        needed = t < needed ? t : needed;
    }
    return needed;
}

/* Every live edge whose collapse may happen (cost finite and within the
 * limit), with its ends and cost, in triangle order. Returns how
 * many were written (at most s->cand_cap). */
static size_t gather(mr_simplifier *s, double limit)
{
    const mr_collapse_mesh *m = &s->m;
    mr_candidate *out = s->cand;
    const size_t cap = s->cand_cap;
    size_t n = 0;
    /* edges go through the cost kernel in batches, in gathering order */
    enum { B = 256 };
    uint32_t ea[B], eb[B];
    double cost[B];
    size_t nb = 0;
#define FLUSH()                                                                       \
    do {                                                                              \
        if (nb == 0)                                                                  \
            break;                                                                    \
        mr_simplifier_plan_edges(s, nb, ea, eb, cost, NULL, NULL, NULL);              \
        /* an infinite cost is a collapse that must not happen; every    \
         * candidate is stored, those allowed are kept (a mesh has no     \
         * more edges than at the start: cap is never reached) */         \
        const size_t room = cap - n < nb ? cap - n : nb;                              \
        for (size_t i = 0; i < room; i++) {                                           \
            out[n] = (mr_candidate){float_key((float)cost[i]), ea[i], eb[i]};         \
            n += (cost[i] <= limit) & (cost[i] < INFINITY);                           \
        }                                                                             \
        nb = 0;                                                                       \
    } while (0)
    /* Triangles 64 at a time: which are live is read without a branch
     * (collapses leave live and deleted ones interleaved), the live ones
     * are visited from the mask. */
    for (size_t t0 = 0; t0 < m->triangle_count; t0 += 64) {
        const size_t nt = m->triangle_count - t0 < 64 ? m->triangle_count - t0 : 64;
        uint64_t live = 0;
        for (size_t i = 0; i < nt; i++)
            live |= (uint64_t)(m->tris[3 * (t0 + i)] != NONE) << i;
        for (; live; live &= live - 1) {
            const size_t t = t0 + (size_t)__builtin_ctzll(live);
            FOR_EACH_TRIANGLE_EDGE(m, t, a, b, take, {
                /* stored always, kept when taken; the quadrics the
                 * batch's cost loop reads are fetched meanwhile */
                __builtin_prefetch(s->q + b);
                ea[nb] = a;
                eb[nb] = b;
                nb += take;
            });
            if (nb > B - 3)
                FLUSH();
        }
    }
    FLUSH();
#undef FLUSH
    return n;
}

/* The key below which at least `rank` + 1 of the n candidates lie, to the
 * resolution of the top 16 bits (1/128 relative). */
static uint32_t rank_key(const mr_simplifier *s, size_t n, size_t rank)
{
    uint32_t *hist = s->hist;
    memset(hist, 0, HIST_BUCKETS * sizeof *hist);
    for (size_t i = 0; i < n; i++)
        hist[s->cand[i].key >> 16]++;
    size_t acc = 0;
    for (uint32_t b = 0; b < HIST_BUCKETS; b++) {
        acc += hist[b];
        if (acc > rank)
            return b << 16 | 0xFFFFu;
    }
    return UINT32_MAX;
}

/* Candidates in order of cost; ties by their ends (an edge is one
 * candidate, so the order is total). */
static inline bool cand_less(const mr_candidate *x, const mr_candidate *y)
{
    if (x->key != y->key)
        return x->key < y->key;
    return x->a != y->a ? x->a < y->a : x->b < y->b;
}

static void sift_down(mr_candidate *a, size_t i, size_t n)
{
    const mr_candidate x = a[i];
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= n)
            break;
        if (c + 1 < n && cand_less(&a[c], &a[c + 1]))
            c++;
        if (!cand_less(&x, &a[c]))
            break;
        a[i] = a[c];
        i = c;
    }
    a[i] = x;
}

/* Heap sort of a[0..n) by cand_less, in place: the winners of a round are
 * sorted only when they are more than the target needs, and then no
 * second array of candidates is kept for it. */
static void sort_candidates(mr_candidate *a, size_t n)
{
    if (n < 2)
        return;
    for (size_t i = n / 2; i-- > 0;)
        sift_down(a, i, n);
    for (size_t e = n - 1; e > 0; e--) {
        const mr_candidate t = a[0];
        a[0] = a[e];
        a[e] = t;
        sift_down(a, 0, e);
    }
}

/* Apply the planned collapse r -> k (to target, at cost) if it is still
 * valid. */
static bool try_collapse(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3],
                         double cost, double limit, double *worst)
{
    mr_collapse_mesh *m = &s->m;
    if (!(cost <= limit && cost < INFINITY))
        return false;
    mr_collapse_clean(m, r);
    mr_collapse_clean(m, k);
    if (!mr_collapse_valid(m, r, k, target, &s->limits) ||
        (s->attr_valid && !s->attr_valid(s, r, k)))
        return false;
    mr_simplifier_collapse(s, r, k, target);
    s->mark[r] = s->mark[k] = 1;
    *worst = cost > *worst ? cost : *worst;
    return true;
}

/* How many turns ahead of a winner's validity test the three prefetch
 * stages of mr_collapse_prefetch run (~2 % on a 1M-triangle scan). */
#define PF0 6
#define PF1 4
#define PF2 2

/* Winners planned at once (one batch of the vector cost loop). */
#define PLAN_BATCH 64

size_t mr_simplifier_run_batched(mr_simplifier *s, const mr_simplify_options *o,
                                 double *max_error)
{
    mr_collapse_mesh *m = &s->m;
    mr_simplify_goal g;
    mr_simplifier_targets(s, o, &g);
    size_t next_report = g.planned / 100 + 1, done = 0;
    double worst = 0;
    double share = PASS_SHARE;
    bool finished = false;
    uint64_t *best = s->best64;

    while (!finished) {
        if (mr_simplifier_reached(s, &g))
            break;
        size_t n = gather(s, g.limit);
        if (n == 0)
            break;

        /* This pass's candidates: up to the goal-th cheapest cost, with
         * slack, in gathering order. */
        mr_candidate *cand = s->cand;
        const double goal = ceil(share * (double)needed_collapses(s, &g));
        size_t nsel = n;
        if (goal < (double)n) {
            const uint32_t kth = rank_key(s, n, (size_t)goal);
            const uint32_t lim = float_key(key_float(kth) * PASS_SLACK);
            nsel = 0;
            for (size_t i = 0; i < n; i++) {
                cand[nsel] = cand[i];
                nsel += cand[i].key <= lim;
            }
        }
        const bool partial = nsel < n;

        /* Rounds: a candidate cheaper (ties: earlier) than every other
         * candidate at its two ends collapses; its ends are then marked,
         * which retires the candidates around them, and the next round
         * looks again among the rest. Iterated, this takes the same edges
         * as taking them in order of cost, skipping those at a marked end;
         * but the collapses of a round run in gathering (triangle) order,
         * so they walk the mesh in memory order. A candidate whose ends
         * are both unmarked is still an edge of the mesh with its cost:
         * only the ends of a collapse move, and the triangles it deletes
         * hold both of them. */
        memset(s->mark, 0, m->vertex_count);
        size_t pass_done = 0;
        for (int round = 0, productive = 0;
             round < MAX_ROUNDS_TOTAL && productive < MAX_ROUNDS && nsel && !finished;
             round++) {
            /* best[v]: the least (key, index) among v's candidates; every
             * entry is UINT64_MAX between rounds */
            size_t live = 0;
            for (size_t i = 0; i < nsel; i++) {
                const mr_candidate c = cand[i];
                const bool retired = s->mark[c.a] | s->mark[c.b];
                const uint64_t id = ((uint64_t)c.key << 32 | live) | -(uint64_t)retired;
                best[c.a] = id < best[c.a] ? id : best[c.a];
                best[c.b] = id < best[c.b] ? id : best[c.b];
                cand[live] = c;
                live += !retired;
            }
            nsel = live;
            /* The winners, moved to the front (the rest keep their order
             * behind them). Winners share no end, and a collapse changes
             * only its own ends and the triangles on its edge, so each
             * winner's cost is still exact when it is applied. */
            size_t wins = 0;
            for (size_t i = 0; i < nsel; i++) {
                const mr_candidate c = cand[i], w = cand[wins];
                const uint64_t id = (uint64_t)c.key << 32 | i;
                const bool win = (best[c.a] == id) & (best[c.b] == id);
                /* select by mask: a conditional move of the records */
                const uint32_t mk = -(uint32_t)win;
                cand[i] = (mr_candidate){(w.key & mk) | (c.key & ~mk), (w.a & mk) | (c.a & ~mk),
                                         (w.b & mk) | (c.b & ~mk)};
                cand[wins] = (mr_candidate){(c.key & mk) | (w.key & ~mk),
                                            (c.a & mk) | (w.a & ~mk), (c.b & mk) | (w.b & ~mk)};
                wins += win;
            }
            for (size_t i = 0; i < nsel; i++)
                best[cand[i].a] = best[cand[i].b] = UINT64_MAX;
            if (wins == 0)
                break;
            /* When the winners are more than the target needs, the
             * cheapest go first. */
            if (wins > needed_collapses(s, &g))
                sort_candidates(cand, wins);
            /* Winners share no end and a collapse changes only its own
             * ends, so a batch of them is planned before any of the batch
             * is applied; validity is tested as each one's turn comes. */
            size_t round_done = 0;
            for (size_t i0 = 0; i0 < wins && !finished; i0 += PLAN_BATCH) {
                const size_t nc = wins - i0 < PLAN_BATCH ? wins - i0 : PLAN_BATCH;
                uint32_t pa[PLAN_BATCH], pb[PLAN_BATCH], pr[PLAN_BATCH], pk[PLAN_BATCH];
                double pc[PLAN_BATCH], pt[3 * PLAN_BATCH];
                for (size_t j = 0; j < nc; j++) {
                    pa[j] = cand[i0 + j].a;
                    pb[j] = cand[i0 + j].b;
                }
                mr_simplifier_plan_edges(s, nc, pa, pb, pc, pr, pk, pt);
                for (size_t j = 0; j < nc; j++) {
                    static const int ahead[3] = {PF0, PF1, PF2};
                    for (int st = 0; st < 3; st++) {
                        if (j + ahead[st] < nc) {
                            mr_collapse_prefetch(m, pr[j + ahead[st]], st);
                            mr_collapse_prefetch(m, pk[j + ahead[st]], st);
                        }
                    }
                    if (!try_collapse(s, pr[j], pk[j], pt + 3 * j, pc[j], g.limit, &worst)) {
                        /* Out of the pass: mark nothing, so that the other
                         * candidates at its ends can win the next round. */
                        continue;
                    }
                    done++;
                    round_done++;
                    if (mr_simplifier_reached(s, &g)) {
                        finished = true;
                        break;
                    }
                    if (o->progress && done >= next_report) {
                        o->progress(g.planned ? (double)done / (double)g.planned : 1.0,
                                    o->progress_user);
                        next_report += g.planned / 100 + 1;
                    }
                }
            }
            pass_done += round_done;
            productive += round_done > wins - round_done;
            /* The winners leave the candidates (those that failed
             * validity too): the rest follow them. */
            cand += wins;
            nsel -= wins;
        }
        if (pass_done == 0) {
            if (!partial)
                break; /* nothing valid is left */
            share *= 4; /* the cheapest are all invalid: look further */
        } else {
            share = PASS_SHARE;
        }
    }
    if (o->progress)
        o->progress(1.0, o->progress_user);
    const double e = sqrt(worst);
    *max_error = mr_simplifier_error(s, o, e);
    return done;
}
