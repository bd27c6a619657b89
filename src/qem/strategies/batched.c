/*
 * Batched selection of collapses (MR_STRATEGY_BATCHED, the default): the
 * simplifier works in passes instead of one collapse at a time from a
 * heap, and runs every phase on all threads with the same result on any
 * number of them.
 *
 * A pass gathers every live edge with its cost (the same costs, the same
 * planned collapse and the same validity test as the greedy strategy),
 * keeps the cheapest ones and applies them in order of cost, skipping an
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
 *
 * Rounds within a pass: a candidate cheaper than every other candidate at
 * its two ends wins (find_winners); winners share no end. They are taken
 * in chunks of a fixed size (run_chunk): winners whose two ends lie in
 * one group of triangle blocks touch nothing of another group's, so the
 * groups run concurrently, each in order (apply_levels); winners spanning
 * groups follow with wider groups, the last few on one thread; a chunk in
 * which the target may be reached goes in priority order, in steps short
 * of it. Every order and tie
 * comes from the mesh (costs, then vertex ids), never from a thread's
 * timing or the thread count; the layout of the candidates (blocks of
 * BLOCK_TRIANGLES triangles), the chunk size and the levels of groups are
 * constants. So the output is
 * byte-identical at every thread count, and in a build without OpenMP.
 *
 * Why it is fast: no heap with mutable keys (a sift per neighbour edge
 * after every collapse), no re-evaluation of a neighbourhood that collapses
 * again before its edges reach the top, the gathering sweeps the mesh in
 * memory order, costs and plans are computed for batches of edges in one
 * vectorised loop (mr_simplifier_plan_edges), and all of it is spread
 * over the threads.
 */
#include "passes.h"

#include "../../core/omp_compat.h"

#include <assert.h>
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

/* Live triangles from which a gather runs on every thread, and winners
 * from which their plans do: below, starting the team costs more than
 * the edges' quadric costs. The memoryless plans (MR_QUALITY_BEST) read
 * both ends' fans and cost about ten times as much each. */
#define GATHER_PAR 65536
#define GATHER_PAR_MEMORYLESS 4096
#define PLAN_PAR 2048
#define PLAN_PAR_MEMORYLESS 256

/* Histogram buckets over the top 16 bits of a key. */
#define HIST_BUCKETS 65536u

/* An edge (a, b) of a pass and the bits of its (float) cost. */
typedef struct mr_candidate {
    uint32_t key, a, b;
} mr_candidate;

/* A round's winner: where its candidate is, its plan and its fate. */
typedef struct mr_winner {
    uint32_t at;      /* candidate index */
    uint32_t r, k;    /* r goes, k stays */
    uint8_t state;    /* W_* */
    size_t slot;      /* where its merged list goes in refs */
    uint32_t slots;   /* and the room it has there */
    uint32_t group;   /* its group of blocks at this level, or NONE */
    double target[3];
    double cost;
} mr_winner;

/* A winner is invalid (past the error bound, or refused when its turn
 * came) or valid (planned). */
enum { W_INVALID = 0, W_VALID = 1 };

/* Triangles per gathering block: a pass's candidates lie in blocks, one
 * per run of this many triangles, each with its own live count, so that
 * the blocks are gathered, filtered and compacted independently (in
 * parallel) while the order stays that of one sequential sweep. A
 * constant: the layout must not depend on the thread count. */
#define BLOCK_TRIANGLES MR_BATCH_BLOCK_TRIANGLES

typedef struct mr_batched {
    mr_candidate *cand;  /* cand_cap */
    size_t cand_cap;
    size_t nblocks;
    size_t *boff;        /* per block: its first candidate slot */
    uint32_t *bn;        /* per block: live candidates (from boff) */
    uint32_t *bw;        /* per block: winners, then their offset */
    uint8_t *mark;       /* per vertex: an end of a collapse of this pass */
    uint64_t *best;      /* per vertex: winner selection; UINT64_MAX
                            between uses */
    uint32_t *home_lo, *home_hi; /* per vertex: the range of blocks its
                                    triangles lie in (apply_levels) */
    uint32_t *gcount;    /* per group of blocks: its winners' end */
    uint32_t *hist;      /* HIST_BUCKETS per thread */
    uint32_t *wid;       /* a round's winners: candidate indices */
    size_t wid_cap;
    mr_winner *win;      /* WIN_CHUNK: a chunk's winners */
    uint32_t *cur, *next, *grouped, *order; /* WIN_CHUNK each: winner indices */
    uint32_t *tcount;    /* per thread and group: winners, then offsets */
    size_t *tslots;      /* per thread and group: refs room, then offsets */
    size_t tgroups;      /* groups each thread's rows have room for */
    size_t *tspan;       /* per thread: winners spanning groups, then offset */
    size_t *trun;        /* threads + 1: find_winners' runs of blocks */
    int threads;
} mr_batched;

/* The sign bit of a key (costs are >= 0) marks a round's winner between
 * two sweeps; a key of all ones (a NaN, never a cost) a winner found
 * invalid, which leaves the candidates at the next sweep. */
#define WIN_BIT 0x80000000u
#define DEAD_KEY 0xFFFFFFFFu

static inline void min_u64(uint64_t *p, uint64_t v, bool par)
{
    if (!par) {
        *p = v < *p ? v : *p;
        return;
    }
    uint64_t cur = __atomic_load_n(p, __ATOMIC_RELAXED);
    while (v < cur &&
           !__atomic_compare_exchange_n(p, &cur, v, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
    }
}

static inline uint64_t load_u64(const uint64_t *p, bool par)
{
    return par ? __atomic_load_n(p, __ATOMIC_RELAXED) : *p;
}


static inline void store_u64(uint64_t *p, uint64_t v, bool par)
{
    if (par)
        __atomic_store_n(p, v, __ATOMIC_RELAXED);
    else
        *p = v;
}

static void batched_release(mr_simplifier *s);

static mr_status batched_start(mr_simplifier *s, mr_error *err)
{
    const mr_collapse_mesh *m = &s->m;
    mr_batched *b = mr_calloc_array(1, sizeof *b);
    if (!b)
        return mr_fail_nomem(err, NULL, sizeof *b);
    s->state = b;
    b->threads = s->plan.threads > 0 ? s->plan.threads : 1;
    /* Room for every edge, bounded without visiting them: with B edges
     * of one triangle, 3T >= B + 2 (E - B), so E <= (3T + B) / 2; and a
     * one-triangle edge has both ends flagged BOUNDARY or NONMANIFOLD,
     * each with at most two such edges per triangle. */
    size_t open = 0;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count;
#pragma omp parallel for schedule(static) reduction(+ : open) num_threads(b->threads) \
    if (b->threads > 1 && nv > 65536)
    for (ptrdiff_t v = 0; v < nv; v++)
        open += (m->flags[v] & (MR_VF_BOUNDARY | MR_VF_NONMANIFOLD)) ? 2 * (size_t)m->count[v] : 0;
    const size_t t3 = 3 * m->live_triangles;
    b->cand_cap = (t3 + (open < t3 ? open : t3)) / 2 + 1;
    s->m.lazy = true; /* only an edge's two ends read lists here */
    mr_collapse_prepare(&s->m);
    b->nblocks = (m->triangle_count + BLOCK_TRIANGLES - 1) / BLOCK_TRIANGLES;
    b->cand = mr_alloc_array(b->cand_cap, sizeof *b->cand);
    b->boff = mr_alloc_array(b->nblocks + 1, sizeof *b->boff);
    b->bn = mr_alloc_array(b->nblocks + 1, sizeof *b->bn);
    b->bw = mr_alloc_array(b->nblocks + 1, sizeof *b->bw);
    b->mark = mr_calloc_array(m->vertex_count, 1);
    b->hist = mr_alloc_array((size_t)b->threads * HIST_BUCKETS, sizeof *b->hist);
    b->best = mr_alloc_array(m->vertex_count, sizeof *b->best);
    b->home_lo = mr_alloc_array(m->vertex_count, sizeof *b->home_lo);
    b->home_hi = mr_alloc_array(m->vertex_count, sizeof *b->home_hi);
    b->gcount = mr_alloc_array(b->nblocks + 2, sizeof *b->gcount);
    b->trun = mr_alloc_array((size_t)b->threads + 1, sizeof *b->trun);
    if (b->best) /* every entry is UINT64_MAX between uses */
        memset(b->best, 0xFF, m->vertex_count * sizeof *b->best);
    if (!b->cand || !b->boff || !b->bn || !b->bw || !b->mark || !b->hist || !b->best ||
        !b->home_lo || !b->home_hi || !b->gcount || !b->trun ||
        (s->m.lazy && !s->m.dead)) {
        const size_t bytes = b->cand_cap * sizeof *b->cand + m->vertex_count * 17;
        batched_release(s);
        return mr_fail_nomem(err, NULL, bytes);
    }
    return MR_OK;
}

static void batched_release(mr_simplifier *s)
{
    mr_batched *b = s->state;
    if (!b)
        return;
    free(b->cand);
    free(b->boff);
    free(b->bn);
    free(b->bw);
    free(b->mark);
    free(b->hist);
    free(b->best);
    free(b->home_lo);
    free(b->home_hi);
    free(b->gcount);
    free(b->win);
    free(b->cur);
    free(b->next);
    free(b->grouped);
    free(b->order);
    free(b->tcount);
    free(b->tslots);
    free(b->tspan);
    free(b->trun);
    free(b->wid);
    free(b);
    s->state = NULL;
}

/* Edges block `blk` takes (MR_FOR_EACH_TRIANGLE_EDGE), without their
 * costs: how many, and when out is not NULL the edges themselves, in
 * triangle order, from out. */
static uint32_t block_edges(const mr_collapse_mesh *m, size_t blk, mr_candidate *out)
{
    const size_t t0 = blk * BLOCK_TRIANGLES;
    const size_t t1 = m->triangle_count - t0 < BLOCK_TRIANGLES ? m->triangle_count
                                                                : t0 + BLOCK_TRIANGLES;
    uint32_t n = 0;
    for (size_t t = t0; t < t1; t++) {
        if (m->tris[3 * t] == NONE)
            continue;
        MR_FOR_EACH_TRIANGLE_EDGE(m, t, a, b, take, {
            if (take && out) /* never past the block's last edge: the next block's */
                out[n] = (mr_candidate){0, a, b};
            n += take;
        });
    }
    return n;
}

/* Block blk's edges whose collapse may happen (cost finite and within the
 * limit), with their ends and cost, in triangle order, from out; returns
 * how many. */
static uint32_t gather_block(const mr_simplifier *s, size_t blk, double limit,
                             mr_candidate *out)
{
    const mr_collapse_mesh *m = &s->m;
    const size_t t0 = blk * BLOCK_TRIANGLES;
    const size_t t1 = m->triangle_count - t0 < BLOCK_TRIANGLES ? m->triangle_count
                                                                : t0 + BLOCK_TRIANGLES;
    uint32_t n = 0;
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
         * candidate is stored, those allowed are kept */                 \
        for (size_t i = 0; i < nb; i++) {                                             \
            out[n] = (mr_candidate){mr_float_key((float)cost[i]), ea[i], eb[i]};      \
            n += (cost[i] <= limit) & (cost[i] < INFINITY);                           \
        }                                                                             \
        nb = 0;                                                                       \
    } while (0)
    /* Triangles 64 at a time: which are live is read without a branch
     * (collapses leave live and deleted ones interleaved), the live ones
     * are visited from the mask. */
    for (size_t c0 = t0; c0 < t1; c0 += 64) {
        const size_t nt = t1 - c0 < 64 ? t1 - c0 : 64;
        uint64_t live = 0;
        for (size_t i = 0; i < nt; i++)
            live |= (uint64_t)(m->tris[3 * (c0 + i)] != NONE) << i;
        for (; live; live &= live - 1) {
            const size_t t = c0 + (size_t)__builtin_ctzll(live);
            MR_FOR_EACH_TRIANGLE_EDGE(m, t, a, b, take, {
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

/* Edges planned together in a memoryless gather (the unit of its work
 * sharing). */
#define KEY_CHUNK 256

/* The memoryless plans' keys of candidates [i0, i0 + n) (n <= KEY_CHUNK):
 * their cost's, or DEAD_KEY when the collapse may not happen. */
static void key_chunk(const mr_simplifier *s, mr_candidate *c, size_t n, double limit)
{
    uint32_t ea[KEY_CHUNK], eb[KEY_CHUNK];
    double cost[KEY_CHUNK];
    if (n == 0 || n > KEY_CHUNK)
        return;
    for (size_t i = 0; i < n; i++) {
        ea[i] = c[i].a;
        eb[i] = c[i].b;
    }
    mr_simplifier_plan_edges(s, n, ea, eb, cost, NULL, NULL, NULL);
    for (size_t i = 0; i < n; i++)
        c[i].key = cost[i] <= limit && cost[i] < INFINITY ? mr_float_key((float)cost[i])
                                                          : DEAD_KEY;
}

/* Every live edge whose collapse may happen, block by block (bn[], from
 * boff[]); returns how many. The quadric costs are computed block by
 * block; the memoryless plans, ten times dearer each, in equal chunks of
 * all the edges (a small mesh has few blocks, and its blocks unequal
 * work), then each block keeps its allowed ones. */
static size_t gather(mr_simplifier *s, double limit)
{
    mr_batched *bt = s->state;
    const mr_collapse_mesh *m = &s->m;
    const ptrdiff_t nb = (ptrdiff_t)bt->nblocks;
    const bool par = bt->threads > 1 &&
                     m->live_triangles > (s->memoryless ? GATHER_PAR_MEMORYLESS : GATHER_PAR);
#pragma omp parallel for schedule(static) num_threads(bt->threads) if (par)
    for (ptrdiff_t i = 0; i < nb; i++)
        bt->bn[i] = block_edges(m, (size_t)i, NULL);
    size_t off = 0;
    for (size_t i = 0; i < bt->nblocks; i++) {
        bt->boff[i] = off;
        off += bt->bn[i];
    }
    if (off > bt->cand_cap) /* never: a mesh has no more edges than at the start */
        return 0;
    size_t total = 0;
    if (!s->memoryless) {
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : total) num_threads(bt->threads) \
    if (par)
        for (ptrdiff_t i = 0; i < nb; i++) {
            bt->bn[i] = gather_block(s, (size_t)i, limit, bt->cand + bt->boff[i]);
            total += bt->bn[i];
        }
        return total;
    }
    const ptrdiff_t nc = (ptrdiff_t)off;
#pragma omp parallel num_threads(bt->threads) if (par)
    {
#pragma omp for schedule(static)
        for (ptrdiff_t i = 0; i < nb; i++)
            block_edges(m, (size_t)i, bt->cand + bt->boff[i]);
#pragma omp for schedule(dynamic, 1)
        for (ptrdiff_t i0 = 0; i0 < nc; i0 += KEY_CHUNK)
            key_chunk(s, bt->cand + i0, nc - i0 < KEY_CHUNK ? (size_t)(nc - i0) : KEY_CHUNK,
                      limit);
#pragma omp for schedule(static) reduction(+ : total)
        for (ptrdiff_t i = 0; i < nb; i++) {
            mr_candidate *c = bt->cand + bt->boff[i];
            uint32_t k = 0;
            for (uint32_t j = 0, e = bt->bn[i]; j < e; j++) {
                c[k] = c[j];
                k += c[j].key != DEAD_KEY;
            }
            bt->bn[i] = k;
            total += k;
        }
    }
    return total;
}

/* Candidates up to which rank_key finds its bucket in two passes over
 * them with two histograms of 256 (the top byte of the keys, then the next
 * within the top byte's bucket) instead of one of HIST_BUCKETS: the same
 * bucket, without clearing and scanning 65,536 counters each pass (the
 * homer, 12,000 triangles, to 10 % with the default: 0.0055 -> 0.0049 s). */
#define RANK_SMALL 65536

/* rank_key for a small pass: the same bucket from the two histograms. */
static uint32_t rank_key_small(const mr_batched *bt, size_t rank)
{
    uint32_t top[256] = {0}, next[256] = {0};
    for (size_t i = 0; i < bt->nblocks; i++) {
        const mr_candidate *c = bt->cand + bt->boff[i];
        for (uint32_t j = 0, e = bt->bn[i]; j < e; j++)
            top[c[j].key >> 24]++;
    }
    size_t acc = 0;
    uint32_t t = 0;
    for (; t < 256 && acc + top[t] <= rank; t++)
        acc += top[t];
    if (t == 256)
        return UINT32_MAX;
    for (size_t i = 0; i < bt->nblocks; i++) {
        const mr_candidate *c = bt->cand + bt->boff[i];
        for (uint32_t j = 0, e = bt->bn[i]; j < e; j++)
            next[(c[j].key >> 16) & 0xFFu] += c[j].key >> 24 == t;
    }
    uint32_t u = 0;
    for (; u < 255 && acc + next[u] <= rank; u++)
        acc += next[u];
    return (t << 8 | u) << 16 | 0xFFFFu;
}

/* The key below which at least `rank` + 1 of the n candidates lie, to the
 * resolution of the top 16 bits (1/128 relative). */
static uint32_t rank_key(const mr_simplifier *s, size_t n, size_t rank)
{
    mr_batched *bt = s->state;
    const ptrdiff_t nb = (ptrdiff_t)bt->nblocks;
    if (n <= RANK_SMALL)
        return rank_key_small(bt, rank);
    const int nt = bt->threads;
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
        const int me = omp_get_thread_num(), team = omp_get_num_threads();
        uint32_t *hist = bt->hist + (size_t)me * HIST_BUCKETS;
        memset(hist, 0, HIST_BUCKETS * sizeof *hist);
        for (ptrdiff_t i = me; i < nb; i += team) {
            const mr_candidate *c = bt->cand + bt->boff[i];
            for (uint32_t j = 0, e = bt->bn[i]; j < e; j++)
                hist[c[j].key >> 16]++;
        }
#pragma omp barrier
        /* the sum of the threads' histograms, bucket ranges split */
#pragma omp for schedule(static)
        for (ptrdiff_t k = 0; k < (ptrdiff_t)HIST_BUCKETS; k++) {
            uint32_t sum = 0;
            for (int t = 0; t < team; t++)
                sum += bt->hist[(size_t)t * HIST_BUCKETS + (size_t)k];
            bt->hist[k] = sum;
        }
    }
    const uint32_t *hist = bt->hist;
    size_t acc = 0;
    for (uint32_t b = 0; b < HIST_BUCKETS; b++) {
        acc += hist[b];
        if (acc > rank)
            return b << 16 | 0xFFFFu;
    }
    return UINT32_MAX;
}

/* A winner's priority (lower first): cost, then its smaller end (winners
 * share no end, so no two have one priority). A tie goes by the mesh, not
 * by where the edge lies in the candidates: two copies of a part (a
 * double-sided sheet) reduce alike. */
static inline uint64_t prio_of(const mr_batched *bt, uint32_t at)
{
    const mr_candidate c = bt->cand[at];
    return (uint64_t)c.key << 32 | (c.a < c.b ? c.a : c.b);
}

/* The priority of element e of an id array: a candidate index, or with
 * w, an index into the winner records w. */
static inline uint64_t id_prio(const mr_batched *bt, const mr_winner *w, uint32_t e)
{
    return prio_of(bt, w ? w[e].at : e);
}

static void sift(const mr_batched *bt, const mr_winner *w, uint32_t *a, size_t j, size_t n)
{
    const uint32_t held = a[j];
    const uint64_t px = id_prio(bt, w, held);
    for (;;) {
        size_t c = 2 * j + 1;
        if (c >= n)
            break;
        uint64_t pc = id_prio(bt, w, a[c]);
        if (c + 1 < n) {
            const uint64_t pd = id_prio(bt, w, a[c + 1]);
            if (pc < pd) {
                c++;
                pc = pd;
            }
        }
        if (px >= pc)
            break;
        a[j] = a[c];
        j = c;
    }
    a[j] = held;
}

/* Heap sort of n ids by priority, in place (a round's winners, as
 * candidate indices, when they are more than the target needs; a chunk's,
 * as indices into w, when the target falls inside it). Priorities are
 * distinct, so the order is total. */
static void sort_by_prio(const mr_batched *bt, const mr_winner *w, uint32_t *a, size_t n)
{
    if (n < 2)
        return;
    for (size_t i = n / 2; i-- > 0;)
        sift(bt, w, a, i, n);
    for (size_t e = n - 1; e > 0; e--) {
        const uint32_t top = a[0];
        a[0] = a[e];
        a[e] = top;
        sift(bt, w, a, 0, e);
    }
}

/* Winners planned at once (one batch of the vector cost loop). */
#define PLAN_BATCH 64

/* How many winners ahead the three prefetch stages of
 * mr_collapse_prefetch run. */
#define PF0 6
#define PF1 4
#define PF2 2

/* Plan winners w[0..n): which end goes, where to, at what cost; those
 * within the error bound are candidates to commit (tested then). */
static void plan_winners(const mr_simplifier *s, mr_winner *w, size_t n, double limit)
{
    const mr_candidate *cand = ((const mr_batched *)s->state)->cand;
    uint32_t pa[PLAN_BATCH], pb[PLAN_BATCH], pr[PLAN_BATCH], pk[PLAN_BATCH];
    double pc[PLAN_BATCH], pt[3 * PLAN_BATCH];
    for (size_t i0 = 0; i0 < n; i0 += PLAN_BATCH) {
        const size_t nc = n - i0 < PLAN_BATCH ? n - i0 : PLAN_BATCH;
        for (size_t j = 0; j < nc; j++) {
            pa[j] = cand[w[i0 + j].at].a;
            pb[j] = cand[w[i0 + j].at].b;
        }
        mr_simplifier_plan_edges(s, nc, pa, pb, pc, pr, pk, pt);
        for (size_t j = 0; j < nc; j++) {
            mr_winner *x = &w[i0 + j];
            x->r = pr[j];
            x->k = pk[j];
            memcpy(x->target, pt + 3 * j, sizeof x->target);
            x->cost = pc[j];
            x->state = pc[j] <= limit && pc[j] < INFINITY ? W_VALID : W_INVALID;
        }
    }
}

/* Levels of grouping in apply_levels: groups of 2^FIRST_SHIFT blocks at
 * the first, LEVEL_SHIFT bits wider at each next (constants: what runs
 * together must not depend on the thread count; these keep the error at
 * 1 % on the bunny and the armadillo within 2 % of the sequential
 * sweep's). */
#define FIRST_SHIFT MR_BATCH_FIRST_SHIFT
#define LEVEL_SHIFT 3

/* The block ranges are found anew every this many passes (between, the
 * collapses keep them a bound: see apply_levels). */
#define HOME_EVERY 2

/* Winners planned and applied together: a round's winners go through
 * run_chunk in chunks of this many, each on the mesh the chunks before it
 * left (a constant, as BLOCK_TRIANGLES). */
#define WIN_CHUNK 8192

/* Apply winner x now if it is still allowed: concurrently, its merged
 * list at out (x->slots of room) and what it removes added to *gone and
 * *deleted; or, when out is NULL, on one thread at the end of refs, the
 * mesh's counts updated. */
static bool apply_winner(mr_simplifier *s, mr_winner *x, double limit, uint32_t *out,
                         size_t *gone, size_t *deleted)
{
    mr_batched *bt = s->state;
    mr_collapse_mesh *m = &s->m;
    mr_collapse_clean(m, x->r); /* its ends: no one else reads their lists */
    mr_collapse_clean(m, x->k);
    mr_simplifier_place(s, x->r, x->k, x->target, &x->cost);
    if (!mr_simplifier_allowed(s, x->r, x->k, x->target, x->cost, limit)) {
        bt->cand[x->at].key = DEAD_KEY; /* leaves the candidates */
        x->state = W_INVALID;
        for (uint32_t j = 0; out && j < x->slots; j++)
            out[j] = 0; /* its room stays unused: no tag may be found there */
        return false;
    }
    if (out) {
        size_t rm;
        *deleted += mr_simplifier_collapse_at(s, x->r, x->k, x->target, out, &rm);
        *gone += rm;
        for (uint32_t j = m->count[x->k]; j < x->slots; j++)
            out[j] = 0; /* no compaction tag may stay behind */
    } else {
        mr_simplifier_collapse(s, x->r, x->k, x->target); /* counts itself */
    }
    bt->mark[x->r] = bt->mark[x->k] = 1;
    /* the survivor holds both ends' triangles */
    bt->home_lo[x->k] = bt->home_lo[x->r] < bt->home_lo[x->k] ? bt->home_lo[x->r] : bt->home_lo[x->k];
    bt->home_hi[x->k] = bt->home_hi[x->r] > bt->home_hi[x->k] ? bt->home_hi[x->r] : bt->home_hi[x->k];
    return true;
}

/* The group of blocks winner x lies in at a level (blocks >> shift), or
 * NONE when its ends' block ranges span groups. */
static inline uint32_t winner_group(const mr_batched *bt, const mr_winner *x, unsigned shift)
{
    const uint32_t grp = bt->home_lo[x->r] >> shift;
    const bool one = (bt->home_hi[x->r] >> shift == grp) & (bt->home_lo[x->k] >> shift == grp) &
                     (bt->home_hi[x->k] >> shift == grp);
    return one ? grp : NONE;
}

/* What a set of applied winners did. */
typedef struct mr_applied {
    size_t made, bad;
    double worst;
} mr_applied;

/* Apply winner x (concurrently, at its slot, when `at`), and count it. */
static inline void apply_counted(mr_simplifier *s, mr_winner *x, double limit, bool at,
                                 size_t *gone, size_t *deleted, size_t *made, size_t *bad,
                                 double *worst)
{
    if (apply_winner(s, x, limit, at ? s->m.refs + x->slot : NULL, gone, deleted)) {
        (*made)++;
        *worst = x->cost > *worst ? x->cost : *worst;
    } else {
        (*bad)++;
    }
}

/*
 * Apply the winners w[idx[0..n)], in that order, the same on any number
 * of threads. Winners share no end; each is tested on the mesh as it
 * stands when its turn comes. Every vertex knows the range of triangle
 * blocks its triangles lie in (home_lo and home_hi, in blocks of
 * BLOCK_TRIANGLES; a collapse widens the survivor's range to both ends',
 * and a vertex that loses triangles keeps its range, which stays a
 * bound). A winner whose two ends lie in one group of blocks (at a level:
 * blocks >> shift) reads and writes only triangles of that group
 * and their vertices; the one thing two winners of different groups may
 * share is an opposite vertex, whose list the concurrent collapse leaves
 * alone (mr_collapse_apply_at, shared: the entry is only counted dead).
 * So two such winners commute -- no end of one shares a triangle with an
 * end of the other -- and the groups run concurrently, each testing
 * (mr_simplifier_allowed) and applying its winners in order on the mesh
 * as the collapses before them left it. Winners that span groups go on to
 * the next level, with groups LEVEL_SHIFT bits wider; those left when one
 * group would hold every block follow in order on one thread.
 *
 * Each level: every thread takes a fixed share of the winners and counts,
 * per group, its winners and the refs room they need; prefix sums over
 * (group, thread) give each winner its place among its group's -- the
 * winners' order within a group, whatever the shares -- and its room in
 * refs, in the same order: both ends' counts less one (a collapse only
 * shrinks the lists of the vertices it does not own; a valid one deletes
 * at least one triangle, which is in both lists; the merge writes at most
 * one entry past its end).
 */
static void apply_levels(mr_simplifier *s, mr_winner *w, const uint32_t *idx, size_t n,
                         const mr_simplify_goal *g, mr_applied *res)
{
    mr_batched *bt = s->state;
    mr_collapse_mesh *m = &s->m;
    const int nt = bt->threads;
    const bool par = nt > 1 && n >= 2048;
    uint32_t *cur = bt->cur, *next = bt->next, *gend = bt->gcount;
    const uint32_t *grouped = bt->grouped;
    if (idx != cur)
        memcpy(cur, idx, n * sizeof *cur);
    size_t ncur = n, ngroups = 0, room = 0, base = 0, gone = 0, deleted = 0;
    size_t made = 0, bad = 0;
    double wmax = res->worst;
    unsigned shift = FIRST_SHIFT;
    bool stop = (bt->nblocks - 1) >> shift == 0 || n == 0, compact = false;
#pragma omp parallel num_threads(nt) if (par)
    {
        const int me = omp_get_thread_num(), team = omp_get_num_threads();
        uint32_t *cnt = bt->tcount + (size_t)me * bt->tgroups;
        size_t *room_of = bt->tslots + (size_t)me * bt->tgroups;
        while (!stop) {
            /* this thread's share of the winners: their groups, counted */
            const size_t i0 = ncur * (size_t)me / (size_t)team;
            const size_t i1 = ncur * (size_t)(me + 1) / (size_t)team;
            const size_t ng = ((bt->nblocks - 1) >> shift) + 1;
            memset(cnt, 0, ng * sizeof *cnt);
            memset(room_of, 0, ng * sizeof *room_of);
            size_t span = 0;
            for (size_t i = i0; i < i1; i++) {
                mr_winner *x = &w[cur[i]];
                x->group = winner_group(bt, x, shift);
                x->slots = m->count[x->r] + m->count[x->k] - 1;
                if (x->group != NONE) {
                    cnt[x->group]++;
                    room_of[x->group] += x->slots;
                } else {
                    span++;
                }
            }
            bt->tspan[me] = span;
#pragma omp barrier
#pragma omp single
            {
                /* group by group, thread by thread: where each thread's
                 * winners of a group go, and their room; then the
                 * spanning ones, thread by thread */
                size_t at = 0, r = 0;
                for (size_t q = 0; q < ng; q++) {
                    for (int t = 0; t < team; t++) {
                        const size_t row = (size_t)t * bt->tgroups + q;
                        const uint32_t c = bt->tcount[row];
                        const size_t sl = bt->tslots[row];
                        bt->tcount[row] = (uint32_t)at;
                        bt->tslots[row] = r;
                        at += c;
                        r += sl;
                    }
                    gend[q] = (uint32_t)at;
                }
                size_t sp = 0;
                for (int t = 0; t < team; t++) {
                    const size_t c = bt->tspan[t];
                    bt->tspan[t] = sp;
                    sp += c;
                }
                ngroups = ng;
                room = r;
                compact = m->refs_size + room > m->refs_capacity;
            }
            if (compact) /* on the whole team */
                mr_collapse_compact(m);
#pragma omp single
            {
                stop = m->refs_size + room > m->refs_capacity; /* never, after a compaction */
                base = m->refs_size;
                if (!stop)
                    m->refs_size += room;
                gone = deleted = 0;
            }
            if (stop)
                break;
            /* the same share again: each winner to its place */
            size_t sp = bt->tspan[me];
            for (size_t i = i0; i < i1; i++) {
                const uint32_t id = cur[i];
                mr_winner *x = &w[id];
                if (x->group == NONE) {
                    next[sp++] = id;
                    continue;
                }
                bt->grouped[cnt[x->group]++] = id;
                x->slot = base + room_of[x->group];
                room_of[x->group] += x->slots;
            }
#pragma omp barrier
#pragma omp for schedule(dynamic, 1) reduction(+ : gone, deleted, bad, made) \
    reduction(max : wmax)
            for (ptrdiff_t q = 0; q < (ptrdiff_t)ngroups; q++) {
                const size_t j1 = gend[q], j0 = q ? gend[q - 1] : 0;
                for (size_t j = j0; j < j1; j++) {
                    mr_winner *x = &w[grouped[j]];
                    static const int ahead[3] = {PF0, PF1, PF2};
                    for (int st = 0; st < 3; st++) {
                        if (j + (size_t)ahead[st] < j1) {
                            const mr_winner *y = &w[grouped[j + (size_t)ahead[st]]];
                            mr_collapse_prefetch(m, y->r, st);
                            mr_collapse_prefetch(m, y->k, st);
                        }
                    }
                    if (j + PF1 < j1) { /* and the quadrics the collapse merges */
                        const mr_winner *y = &w[grouped[j + PF1]];
                        __builtin_prefetch(s->q + y->r);
                        __builtin_prefetch(s->q + y->k);
                    }
                    apply_counted(s, x, g->limit, true, &gone, &deleted, &made, &bad, &wmax);
                }
            }
#pragma omp single
            {
                m->live_vertices -= gone;
                m->live_triangles -= deleted;
                ncur -= gend[ngroups - 1];
                uint32_t *t = cur;
                cur = next;
                next = t;
                shift += LEVEL_SHIFT; /* the next level: wider groups */
                stop = ncur == 0 || (bt->nblocks - 1) >> shift == 0;
            }
        }
    }
    /* the rest, on one thread, in order (also those a full refs stopped) */
    for (size_t i = 0; i < ncur; i++)
        apply_counted(s, &w[cur[i]], g->limit, false, NULL, NULL, &made, &bad, &wmax);
    res->made += made;
    res->bad += bad;
    res->worst = wmax;
}

/* Winners a chunk applies in several steps with groups at least, when
 * the target may be reached inside it (below, one by one). */
#define MIN_GROUPED 64

/*
 * One chunk of a round's winners, the same on any number of threads:
 * planned (on all threads), then applied in chunk order (apply_levels).
 * A chunk in which the target may be reached -- by the bounds of what a
 * collapse removes: a vertex and two ears, two triangles -- is applied in
 * priority order instead, in steps: each step the longest run of the next
 * winners whose bounds cannot reach the target (apply_levels), while such
 * a run holds MIN_GROUPED of them; the last ones one by one, up to the
 * target. Returns the collapses made; *invalid counts the winners found
 * invalid.
 */
static size_t run_chunk(mr_simplifier *s, mr_winner *w, size_t n, const mr_simplify_goal *g,
                        bool sorted, double *worst, size_t *invalid)
{
    mr_batched *bt = s->state;
    mr_collapse_mesh *m = &s->m;
    const int nt = bt->threads;
    const size_t pmin = s->memoryless ? PLAN_PAR_MEMORYLESS : PLAN_PAR;
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt) if (nt > 1 && n >= pmin)
    for (ptrdiff_t i0 = 0; i0 < (ptrdiff_t)n; i0 += PLAN_BATCH) {
        const size_t c = n - (size_t)i0 < PLAN_BATCH ? n - (size_t)i0 : PLAN_BATCH;
        plan_winners(s, w + i0, c, g->limit);
    }
    size_t valid = 0;
    for (size_t i = 0; i < n; i++)
        valid += w[i].state != W_INVALID;
    const bool whole = 3 * valid + g->vertices >= m->live_vertices ||
                       (g->triangles && 2 * valid + g->triangles >= m->live_triangles);
    mr_applied res = {0, 0, *worst};
    uint32_t *idx = bt->cur;
    if (!whole) {
        size_t k = 0;
        for (size_t i = 0; i < n; i++)
            if (w[i].state != W_INVALID)
                idx[k++] = (uint32_t)i;
        apply_levels(s, w, idx, k, g, &res);
    } else {
        /* the valid winners in priority order (a sorted round's chunks
         * are in it already) */
        uint32_t *ord = bt->order;
        size_t nv = 0;
        for (size_t i = 0; i < n; i++)
            if (w[i].state != W_INVALID)
                ord[nv++] = (uint32_t)i;
        if (!sorted)
            sort_by_prio(bt, w, ord, nv);
        size_t i = 0;
        while (i < nv && !mr_simplifier_reached(s)) {
            /* the next winners whose bounds stay short of the target */
            const size_t lv = m->live_vertices - g->vertices;
            const size_t lt = g->triangles ? m->live_triangles - g->triangles : SIZE_MAX;
            size_t k = nv - i;
            k = 3 * k < lv ? k : (lv - 1) / 3;
            k = 2 * k < lt ? k : (lt - 1) / 2;
            if (k < MIN_GROUPED)
                break;
            apply_levels(s, w, ord + i, k, g, &res);
            i += k;
        }
        for (; i < nv && !mr_simplifier_reached(s); i++)
            apply_counted(s, &w[ord[i]], g->limit, false, NULL, NULL, &res.made, &res.bad,
                          &res.worst);
    }
    *worst = res.worst;
    *invalid = res.bad;
    return res.made;
}

/* Each vertex's range of triangle blocks, from its list (deleted entries
 * count too: the range is a bound). */
static void home_ranges(mr_simplifier *s)
{
    mr_batched *bt = s->state;
    const mr_collapse_mesh *m = &s->m;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count;
#pragma omp parallel for schedule(static) num_threads(bt->threads) \
    if (bt->threads > 1 && nv > 65536)
    for (ptrdiff_t v = 0; v < nv; v++) {
        const uint32_t *l = mr_collapse_vertex_tris(m, (uint32_t)v);
        uint32_t lo = UINT32_MAX, hi = 0;
        for (uint32_t i = 0, c = m->count[v]; i < c; i++) {
            const uint32_t b = l[i] / (3 * BLOCK_TRIANGLES);
            lo = b < lo ? b : lo;
            hi = b > hi ? b : hi;
        }
        bt->home_lo[v] = lo;
        bt->home_hi[v] = hi;
    }
}

/*
 * The sweeps of a round over the candidates, block by block: retire those
 * at a marked end (and the winners found invalid) and note at each vertex
 * the least of its candidates, by cost and then by the other end's id;
 * then mark the winners (the least at both ends) and count them per
 * block; then list them in block order and clear the per-vertex minima.
 * Every order here comes from the mesh, none from the candidates' places:
 * two copies of a part (a double-sided sheet) reduce alike. The cheapest
 * candidate, ties to the smallest (smaller end, larger end), always wins.
 *
 * Each thread sweeps its own run of blocks (runs of about equal candidate
 * counts). A vertex's live candidates lie in the blocks of its triangles
 * (an unmarked candidate is still an edge of the triangle it was gathered
 * from), so a vertex whose block range (home_lo, home_hi: a bound) lies
 * in one thread's run is that thread's alone, and its minimum is kept
 * with plain loads and stores; only the others need atomics. A minimum
 * does not depend on the order it is taken in: the same winners on any
 * number of threads. Returns the winner count.
 */
static size_t find_winners(mr_simplifier *s)
{
    mr_batched *bt = s->state;
    const size_t nb = bt->nblocks;
    size_t live_total = 0;
    for (size_t i = 0; i < nb; i++)
        live_total += bt->bn[i];
    const bool par = bt->threads > 1 && live_total > 65536;
    uint64_t *best = bt->best;
    const uint8_t *mark = bt->mark;
    const uint32_t *lo = bt->home_lo, *hi = bt->home_hi;
    /* each thread's run of blocks, [run[t], run[t + 1]), by candidate
     * counts (before the first sweep changes them) */
    const int team = par ? bt->threads : 1;
    size_t *run = bt->trun;
    {
        size_t acc = 0, b = 0;
        for (int t = 0; t < team; t++) {
            const size_t want = live_total * (size_t)t / (size_t)team;
            for (; b < nb && acc < want; b++)
                acc += bt->bn[b];
            run[t] = b;
        }
        run[team] = nb;
    }
#pragma omp parallel num_threads(team) if (par)
    {
        const int me = omp_get_thread_num();
        const size_t b0 = run[me], b1 = run[me + 1];
        const uint32_t own0 = (uint32_t)b0, own1 = (uint32_t)b1;
#define SHARED(v) (par && (lo[v] < own0 || hi[v] >= own1))
        for (size_t i = b0; i < b1; i++) {
            mr_candidate *cand = bt->cand + bt->boff[i];
            uint32_t live = 0;
            for (uint32_t j = 0, n = bt->bn[i]; j < n; j++) {
                const mr_candidate c = cand[j];
                const bool retired = (mark[c.a] | mark[c.b]) || c.key == DEAD_KEY;
                cand[live] = c;
                if (!retired) {
                    min_u64(&best[c.a], (uint64_t)c.key << 32 | c.b, SHARED(c.a));
                    min_u64(&best[c.b], (uint64_t)c.key << 32 | c.a, SHARED(c.b));
                }
                live += !retired;
            }
            bt->bn[i] = live;
        }
#pragma omp barrier
        for (size_t i = b0; i < b1; i++) {
            mr_candidate *cand = bt->cand + bt->boff[i];
            uint32_t wins = 0;
            for (uint32_t j = 0, n = bt->bn[i]; j < n; j++) {
                const mr_candidate c = cand[j];
                const uint64_t k = (uint64_t)c.key << 32;
                /* both tests, no branch between them */
                const bool win = (unsigned)(load_u64(&best[c.a], SHARED(c.a)) == (k | c.b)) &
                                 (unsigned)(load_u64(&best[c.b], SHARED(c.b)) == (k | c.a));
                cand[j].key = c.key | (win ? WIN_BIT : 0);
                wins += win;
            }
            bt->bw[i] = wins;
        }
#pragma omp barrier
#pragma omp single
        {
            size_t off = 0;
            for (size_t i = 0; i < nb; i++) {
                const size_t w = bt->bw[i];
                bt->bw[i] = (uint32_t)off;
                off += w;
            }
            bt->bw[nb] = (uint32_t)off;
            if (off > bt->wid_cap) {
                free(bt->wid);
                bt->wid_cap = off + off / 4;
                bt->wid = mr_alloc_array(bt->wid_cap, sizeof *bt->wid);
                if (!bt->wid)
                    bt->wid_cap = 0;
            }
        }
        for (size_t i = b0; i < b1; i++) {
            mr_candidate *cand = bt->cand + bt->boff[i];
            const uint32_t base = (uint32_t)bt->boff[i];
            uint32_t at = bt->bw[i];
            for (uint32_t j = 0, n = bt->bn[i]; j < n; j++) {
                const mr_candidate c = cand[j];
                if (c.key & WIN_BIT) {
                    cand[j].key = c.key & ~WIN_BIT;
                    if (bt->wid)
                        bt->wid[at++] = base + j;
                }
                store_u64(&best[c.a], UINT64_MAX, SHARED(c.a));
                store_u64(&best[c.b], UINT64_MAX, SHARED(c.b));
            }
        }
#undef SHARED
    }
    return bt->wid ? bt->bw[nb] : 0; /* no memory: stop here */
}

static size_t batched_run(mr_simplifier *s, double *max_error)
{
    mr_batched *bt = s->state;
    mr_collapse_mesh *m = &s->m;
    const mr_simplify_goal g = s->plan.goal;
    size_t next_report = g.planned / 100 + 1, done = 0;
    double worst = 0;
    double share = PASS_SHARE;
    bool finished = false;
    if (!bt->win) {
        bt->win = mr_alloc_array(WIN_CHUNK, sizeof *bt->win);
        bt->cur = mr_alloc_array(WIN_CHUNK, sizeof *bt->cur);
        bt->next = mr_alloc_array(WIN_CHUNK, sizeof *bt->next);
        bt->grouped = mr_alloc_array(WIN_CHUNK, sizeof *bt->grouped);
        bt->order = mr_alloc_array(WIN_CHUNK, sizeof *bt->order);
        /* the most groups a level has: the first level's */
        bt->tgroups = ((bt->nblocks - 1) >> FIRST_SHIFT) + 1;
        const size_t rows = (size_t)bt->threads * bt->tgroups;
        bt->tcount = mr_alloc_array(rows, sizeof *bt->tcount);
        bt->tslots = mr_alloc_array(rows, sizeof *bt->tslots);
        bt->tspan = mr_alloc_array((size_t)bt->threads, sizeof *bt->tspan);
    }
    if (!bt->win || !bt->cur || !bt->next || !bt->grouped || !bt->order || !bt->tcount ||
        !bt->tslots ||
        !bt->tspan)
        finished = true; /* no memory: nothing collapses */

    for (unsigned pass = 0; !finished;) {
        if (mr_simplifier_reached(s))
            break;
        const size_t n = gather(s, g.limit);
        if (n == 0)
            break;

        /* This pass's candidates: up to the goal-th cheapest cost, with
         * slack, in gathering order. */
        const double goal = ceil(share * (double)mr_needed_collapses(s, &g));
        bool partial = false;
        if (goal < (double)n) {
            const uint32_t kth = rank_key(s, n, (size_t)goal);
            const uint32_t lim = mr_float_key(mr_key_float(kth) * PASS_SLACK);
            const ptrdiff_t nb = (ptrdiff_t)bt->nblocks;
            size_t kept = 0;
#pragma omp parallel for schedule(static) reduction(+ : kept) num_threads(bt->threads) \
    if (bt->threads > 1 && n > 65536)
            for (ptrdiff_t i = 0; i < nb; i++) {
                mr_candidate *cand = bt->cand + bt->boff[i];
                uint32_t k = 0;
                for (uint32_t j = 0, e = bt->bn[i]; j < e; j++) {
                    cand[k] = cand[j];
                    k += cand[j].key <= lim;
                }
                bt->bn[i] = k;
                kept += k;
            }
            partial = kept < n;
        }

        /* Rounds: a candidate cheaper (ties: by the other end's id) than
         * every other candidate at its two ends wins; a collapse marks its
         * ends, which retires the candidates around them, and the next
         * round looks again among the rest. A candidate whose ends are
         * both unmarked is still an edge of the mesh with its cost: only
         * the ends of a collapse move, and the triangles it deletes hold
         * both of them. */
        memset(bt->mark, 0, m->vertex_count);
        if (pass % HOME_EVERY == 0)
            home_ranges(s);
        pass++;
        size_t pass_done = 0;
        for (int round = 0, productive = 0;
             round < MAX_ROUNDS_TOTAL && productive < MAX_ROUNDS && !finished; round++) {
            size_t wins = find_winners(s);
            if (wins == 0)
                break;
            /* When the winners are more than the target needs, the
             * cheapest go first, and no more than twice the need are
             * tried (the rest stay candidates). */
            const size_t needed = mr_needed_collapses(s, &g);
            const bool sorted = wins > needed;
            if (sorted) {
                sort_by_prio(bt, NULL, bt->wid, wins);
                const size_t cap = 2 * needed + 64;
                wins = wins < cap ? wins : cap;
            }
            size_t round_done = 0, refused = 0;
            for (size_t c0 = 0; c0 < wins && !finished; c0 += WIN_CHUNK) {
                const size_t nc = wins - c0 < WIN_CHUNK ? wins - c0 : WIN_CHUNK;
                for (size_t i = 0; i < nc; i++)
                    bt->win[i].at = bt->wid[c0 + i];
                size_t invalid;
                const size_t made = run_chunk(s, bt->win, nc, &g, sorted, &worst, &invalid);
                round_done += made;
                refused += invalid;
                done += made;
                if (mr_simplifier_reached(s))
                    finished = true;
                if (s->plan.progress && done >= next_report) {
                    if (mr_simplifier_progress(
                            s, g.planned ? (double)done / (double)g.planned : 1.0))
                        finished = true;
                    next_report = done + g.planned / 100 + 1;
                }
            }
            pass_done += round_done;
            productive += round_done > refused;
            if (round_done == 0 && refused == 0)
                break; /* nothing happened (cannot: every winner is tried) */
        }
        if (pass_done == 0) {
            if (!partial)
                break; /* nothing valid is left */
            share *= 4; /* the cheapest are all invalid: look further */
        } else {
            share = PASS_SHARE;
        }
    }
    const double e = sqrt(worst);
    *max_error = e;
    return done;
}

const mr_strategy_ops mr_strategy_batched = {batched_start, batched_run, batched_release, false};
