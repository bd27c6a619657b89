/*
 * Partitioned batches of collapses (MR_STRATEGY_PARTITIONED; issue 16,
 * the parallel-QEM report's "partitioned batch" with boundary-aware
 * handling, applied in parallel where the report committed sequentially).
 *
 * The live vertices are split into `partitions` slabs along the longest
 * axis of their bounding box, the slab planes at vertex-count quantiles (a
 * histogram of SLAB_BINS bins: balanced slabs, deterministic). A vertex
 * keeps its slab, even when a full collapse moves it across a plane, until
 * the next rebalance, which happens each time the live vertices halve
 * (counts only, never time).
 *
 * An edge (a, b) is interior when everything its collapse reads or writes
 * -- the closed 1-rings of a and b: collapse.h's read/write set -- lies in
 * one slab, i.e. when a and b are both "pure" (every vertex of every
 * triangle of theirs is in their own slab). A pure vertex's triangles hold
 * only vertices of its slab, and a collapse of two pure vertices touches
 * only those triangles and vertices (the survivor's new triangles are its
 * ends', the opposite vertices are in the slab), so collapses of
 * different slabs never touch the same vertex, triangle or list: they
 * commute, and slab p's outcome depends only on slab p's own work.
 *
 * A pass:
 *   1. gather, in fixed blocks of triangles in parallel (the triangles are
 *      in spatial order, setup.c): the vertices of triangles that span
 *      slabs are impure; every live edge once (batched.c's half-edge rule)
 *      with its cost from the vectorised planner, kept when its collapse
 *      may happen, counted per block and slab; after prefix sums, each
 *      block's edges to its slabs' lists: interior ones (both ends pure)
 *      to the slab's list, the others to its boundary list;
 *   2. a global cost threshold, as batched.c's: the goal-th cheapest key
 *      (goal = the collapses still needed) times PASS_SLACK, from a
 *      histogram of every slab's candidates (integer sums: the same on any
 *      number of threads); each slab keeps its candidates under it and
 *      sorts them by (cost, edge id) (a radix sort of the keys, ties by
 *      (smaller end, larger end));
 *   3. interior, per slab in parallel: the slab's candidates in that
 *      order, skipping an edge with an end that was already an end of a
 *      collapse in this pass (only the ends of a collapse change, so every
 *      other candidate's cost is still exact), testing validity
 *      (mr_simplifier_allowed) on the mesh as it stands, applying with
 *      mr_simplifier_collapse_at into the slab's room in refs (handed out
 *      by prefix sums of a bound; when the room runs out the slab pauses,
 *      refs is compacted between the steps and the paused slabs resume
 *      where they stopped -- a collapse's result does not depend on where
 *      its list is written);
 *   4. boundary: every slab's boundary candidates in one (cost, edge id)
 *      order; those
 *      whose ends are both unmarked and whose two closed 1-rings lie in one
 *      *shifted* slab (parts + 1 of them, planes at the quantiles
 *      (i - 1/2) / parts: each slab plane runs through the middle of one)
 *      are applied by the shifted slabs concurrently, exactly as in step 3;
 *      the rest (rings spanning a plane of both kinds: a few dozen a pass
 *      on a 1M-triangle scan) on the calling thread, in that order, up to
 *      the target.
 * Near the target each slab has a quota (its share, by candidate counts,
 * of the vertices and triangles still to go, less what one collapse can
 * remove: 3 vertices, 2 triangles), so the concurrent steps never
 * overshoot; once the collapses still needed are few (TAIL_PER_PARTITION
 * per slab) or a quota stopped a slab, the pass is a tail pass: all
 * candidates in one cost order on the calling thread, up to the target.
 *
 * Determinism: what each slab does depends only on the mesh, the slabs
 * (from positions and counts) and the constants; slabs run in any order on
 * any thread; every order is by (cost, edge id); the sequential steps are sequential; refs compaction
 * gives the same layout on any number of threads. So for a fixed
 * `partitions` the output is byte-identical at every thread count and in
 * the serial build. With one slab every edge is interior, there is no
 * boundary list, and a pass is the sequential sweep batched.c approximates
 * with its rounds.
 *
 * Not done (issue 16): the candidates are gathered anew each pass (as
 * batched.c's) rather than refreshed around the collapses only.
 */
#include "partitioned.h"

/* The edge id of a candidate: (smaller end, larger end). */
static inline uint64_t edge_id(const pcand *e)
{
    const uint32_t lo = e->a < e->b ? e->a : e->b, hi = e->a < e->b ? e->b : e->a;
    return (uint64_t)lo << 32 | hi;
}

static int by_edge(const void *x, const void *y)
{
    const uint64_t p = edge_id(x), q = edge_id(y);
    return (p > q) - (p < q);
}

/* Sort c[0..n) by (key, edge id), with scratch tmp[0..n): an LSD radix
 * sort of the keys (11 + 11 + 10 bits, a pass skipped when every key has
 * the same digit), then each run of equal keys by edge id (such runs are
 * short but for the many zero-cost edges of flat parts). The order then
 * comes from the mesh alone, not from where an edge was gathered. */
static void mr_part_sort(pcand *c, pcand *tmp, size_t n)
{
    static const unsigned shift[3] = {0, 11, 22}, bits[3] = {11, 11, 10};
    pcand *src = c, *dst = tmp;
    for (int pass = 0; pass < 3; pass++) {
        size_t cnt[2048];
        const uint32_t mask = (1u << bits[pass]) - 1;
        memset(cnt, 0, sizeof cnt);
        for (size_t i = 0; i < n; i++)
            cnt[(src[i].key >> shift[pass]) & mask]++;
        if (n == 0 || cnt[(src[0].key >> shift[pass]) & mask] == n)
            continue;
        size_t off = 0;
        for (uint32_t d = 0; d <= mask; d++) {
            const size_t k = cnt[d];
            cnt[d] = off;
            off += k;
        }
        for (size_t i = 0; i < n; i++)
            dst[cnt[(src[i].key >> shift[pass]) & mask]++] = src[i];
        pcand *t = src;
        src = dst;
        dst = t;
    }
    if (src != c)
        memcpy(c, src, n * sizeof *c);
    for (size_t i = 0; i < n;) {
        size_t j = i + 1;
        while (j < n && c[j].key == c[i].key)
            j++;
        if (j - i > 1)
            qsort(c + i, j - i, sizeof *c, by_edge);
        i = j;
    }
}

/* Room for n entries in *buf (contents dropped). */
static bool mr_part_room(pcand **buf, size_t *cap, size_t n)
{
    if (n <= *cap && *buf)
        return true;
    free(*buf);
    *cap = n + n / 8 + 64;
    *buf = mr_alloc_array(*cap, sizeof **buf);
    if (!*buf)
        *cap = 0;
    return *buf != NULL;
}

/* ---- slabs ----------------------------------------------------------------- */

/* Slabs from the live vertices' current positions: the longest axis of
 * their bounding box, planes at vertex-count quantiles; then the live
 * vertices listed slab by slab (in id order). */
void mr_part_balance(mr_simplifier *s)
{
    mr_partitioned *pt = s->state;
    const mr_collapse_mesh *m = &s->m;
    const ptrdiff_t nv = (ptrdiff_t)m->vertex_count;
    const bool par = pt->threads > 1 && nv > 65536;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    float lo0 = INFINITY, lo1 = INFINITY, lo2 = INFINITY;
    float hi0 = -INFINITY, hi1 = -INFINITY, hi2 = -INFINITY;
#pragma omp parallel for schedule(static) num_threads(pt->threads) if (par) \
    reduction(min : lo0, lo1, lo2) reduction(max : hi0, hi1, hi2)
    for (ptrdiff_t v = 0; v < nv; v++) {
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        const float *p = m->pos + 3 * v;
        lo0 = p[0] < lo0 ? p[0] : lo0;
        lo1 = p[1] < lo1 ? p[1] : lo1;
        lo2 = p[2] < lo2 ? p[2] : lo2;
        hi0 = p[0] > hi0 ? p[0] : hi0;
        hi1 = p[1] > hi1 ? p[1] : hi1;
        hi2 = p[2] > hi2 ? p[2] : hi2;
    }
    lo[0] = lo0, lo[1] = lo1, lo[2] = lo2;
    hi[0] = hi0, hi[1] = hi1, hi[2] = hi2;
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if (hi[k] - lo[k] > hi[axis] - lo[axis])
            axis = k;
    const float a0 = lo[axis];
    const float ext = hi[axis] > lo[axis] ? hi[axis] - lo[axis] : 1.0f;
    const float scale = (float)SLAB_BINS / ext;
    uint32_t bins[SLAB_BINS];
    memset(bins, 0, sizeof bins);
    size_t live = 0;
    for (ptrdiff_t v = 0; v < nv; v++) {
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        float f = (m->pos[3 * v + axis] - a0) * scale;
        uint32_t b = f <= 0 ? 0 : f >= (float)(SLAB_BINS - 1) ? SLAB_BINS - 1 : (uint32_t)f;
        bins[b]++;
        live++;
    }
    /* a bin's slab: the share of live vertices before it; its shifted
     * slab: the same, half a slab on */
    uint16_t slab_of[SLAB_BINS], slab2_of[SLAB_BINS];
    size_t acc = 0;
    for (uint32_t b = 0; b < SLAB_BINS; b++) {
        const size_t q = live ? acc * pt->parts / live : 0;
        const size_t q2 = live ? (2 * acc * pt->parts + live) / (2 * live) : 0;
        slab_of[b] = (uint16_t)(q < pt->parts ? q : pt->parts - 1);
        slab2_of[b] = (uint16_t)(q2 < pt->parts ? q2 : pt->parts);
        acc += bins[b];
    }
#pragma omp parallel for schedule(static) num_threads(pt->threads) if (par)
    for (ptrdiff_t v = 0; v < nv; v++) {
        const float f = (m->pos[3 * v + axis] - a0) * scale;
        const uint32_t b = f <= 0                          ? 0
                           : f >= (float)(SLAB_BINS - 1) ? SLAB_BINS - 1
                                                           : (uint32_t)f;
        pt->part[v] = slab_of[b];
        pt->part2[v] = slab2_of[b];
    }
    pt->balanced_live = m->live_vertices;
}

/* ---- set-up ---------------------------------------------------------------- */

mr_status mr_part_start(mr_simplifier *s, mr_error *err)
{
    mr_collapse_mesh *m = &s->m;
    mr_partitioned *pt = mr_calloc_array(1, sizeof *pt);
    if (!pt)
        return mr_fail_nomem(err, NULL, sizeof *pt);
    s->state = pt;
    pt->threads = s->plan.threads > 0 ? s->plan.threads : 1;
    pt->parts = s->plan.partitions ? s->plan.partitions : MR_PARTITIONS_DEFAULT;
    m->lazy = true; /* only a collapse's two ends read its lists */
    mr_collapse_prepare(m);
    pt->part = mr_alloc_array(m->vertex_count + 1, sizeof *pt->part);
    pt->pure = mr_calloc_array(m->vertex_count + 1, 1);
    pt->mark = mr_calloc_array(m->vertex_count + 1, 1);
    pt->slab = mr_calloc_array(pt->parts, sizeof *pt->slab);
    pt->part2 = mr_alloc_array(m->vertex_count + 1, sizeof *pt->part2);
    pt->impure = mr_calloc_array(m->vertex_count + 1, sizeof *pt->impure);
    pt->nblocks = (m->triangle_count + BLOCK_TRIANGLES - 1) / BLOCK_TRIANGLES;
    pt->bcand = mr_alloc_array(pt->nblocks * 3 * BLOCK_TRIANGLES + 1, sizeof *pt->bcand);
    pt->bcount = mr_alloc_array(pt->nblocks * (2 * (size_t)pt->parts + 1) + 1,
                                sizeof *pt->bcount);
    pt->slab2 = mr_calloc_array((size_t)pt->parts + 1, sizeof *pt->slab2);
    pt->hist = mr_alloc_array((size_t)pt->threads * HIST_BUCKETS, sizeof *pt->hist);
    if (s->plan.strategy == MR_STRATEGY_PARTITIONED_BOUNDARY &&
        !(pt->claim = mr_calloc_array(m->vertex_count + 1, 1))) {
        mr_part_release(s);
        return mr_fail_nomem(err, NULL, m->vertex_count);
    }
    if (!pt->part || !pt->part2 || !pt->impure || !pt->bcand || !pt->bcount || !pt->slab2 ||
        !pt->pure || !pt->mark || !pt->slab || !pt->hist || !m->dead) {
        mr_part_release(s);
        return mr_fail_nomem(err, NULL, m->vertex_count * 12 + m->triangle_count * 36);
    }
    mr_part_balance(s);
    return MR_OK;
}

void mr_part_release(mr_simplifier *s)
{
    mr_partitioned *pt = s->state;
    if (!pt)
        return;
    for (unsigned p = 0; pt->slab && p < pt->parts; p++) {
        free(pt->slab[p].plan); /* buf and tmp: the arena's */
    }
    for (unsigned p = 0; pt->slab2 && p <= pt->parts; p++) {
        free(pt->slab2[p].buf); /* their tmp stays NULL */
        free(pt->slab2[p].plan);
    }
    free(pt->slab2);
    free(pt->arena_buf);
    free(pt->arena_tmp);
    free(pt->part2);
    free(pt->impure);
    free(pt->bcand);
    free(pt->bcount);
    free(pt->in2);
    free(pt->seq);
    free(pt->seq_tmp);
    free(pt->part);
    free(pt->pure);
    free(pt->mark);
    free(pt->slab);
    free(pt->hist);
    free(pt->claim);
    free(pt->bbatch.acc);
    free(pt->bplan);
    free(pt->bstate);
    free(pt);
    s->state = NULL;
}

/* ---- a pass ---------------------------------------------------------------- */

/* Triangles [t0, t1) of block blk. */
static inline void block_range(const mr_partitioned *pt, const mr_collapse_mesh *m, size_t blk,
                               size_t *t0, size_t *t1)
{
    (void)pt;
    *t0 = blk * BLOCK_TRIANGLES;
    *t1 = m->triangle_count - *t0 < BLOCK_TRIANGLES ? m->triangle_count : *t0 + BLOCK_TRIANGLES;
}

/* Gathering, first sweep over block blk: each vertex of a live triangle
 * that spans slabs is impure at this gathering (an idempotent store: a
 * vertex's triangles may lie in several blocks). */
static void block_impure(mr_partitioned *pt, const mr_collapse_mesh *m, size_t blk, bool par)
{
    size_t t0, t1;
    block_range(pt, m, blk, &t0, &t1);
    for (size_t t = t0; t < t1; t++) {
        const uint32_t *x = m->tris + 3 * t;
        if (x[0] == NONE)
            continue;
        const uint16_t p0 = pt->part[x[0]], p1 = pt->part[x[1]], p2 = pt->part[x[2]];
        if ((p0 == p1) & (p1 == p2))
            continue;
        for (int j = 0; j < 3; j++) {
            if (par)
                __atomic_store_n(&pt->impure[x[j]], pt->gen, __ATOMIC_RELAXED);
            else
                pt->impure[x[j]] = pt->gen;
        }
    }
}

/* Is v pure -- its closed 1-ring in its slab -- at this gathering? */
static inline bool is_pure(const mr_partitioned *pt, uint32_t v)
{
    return pt->impure[v] != pt->gen; /* read after the first sweep's barrier */
}

/* Gathering, second sweep over block blk: every live edge whose collapse
 * may happen, with its cost, in triangle order, to the block's part of
 * bcand, oriented so that a is the end whose slab takes it; counted per
 * slab, interior (both ends pure) and boundary. */
static void block_gather(mr_simplifier *s, size_t blk, double limit)
{
    mr_partitioned *pt = s->state;
    const mr_collapse_mesh *m = &s->m;
    size_t t0, t1;
    block_range(pt, m, blk, &t0, &t1);
    pcand *out = pt->bcand + blk * 3 * BLOCK_TRIANGLES;
    const size_t np = pt->parts;
    uint32_t *cnt = pt->bcount + pt->nblocks + blk * 2 * np;
    memset(cnt, 0, 2 * np * sizeof *cnt);
    uint32_t n = 0;
    uint32_t ea[GATHER_BATCH], eb[GATHER_BATCH];
    double cost[GATHER_BATCH];
    size_t nb = 0;
#define FLUSH()                                                                       \
    do {                                                                              \
        mr_simplifier_plan_edges(s, nb, ea, eb, cost, NULL, NULL, NULL);              \
        for (size_t f_ = 0; f_ < nb; f_++) {                                          \
            const uint32_t a_ = ea[f_], b_ = eb[f_];                                  \
            const bool in_ = is_pure(pt, a_) && is_pure(pt, b_);                      \
            out[n] = (pcand){mr_float_key((float)cost[f_]), a_, b_};                  \
            const bool keep_ = cost[f_] <= limit && cost[f_] < INFINITY;              \
            cnt[2 * pt->part[a_] + !in_] += keep_;                                    \
            n += keep_;                                                               \
        }                                                                             \
        nb = 0;                                                                       \
    } while (0)
    for (size_t c0 = t0; c0 < t1; c0 += 64) {
        const size_t nt = t1 - c0 < 64 ? t1 - c0 : 64;
        uint64_t live = 0;
        for (size_t i = 0; i < nt; i++)
            live |= (uint64_t)(m->tris[3 * (c0 + i)] != NONE) << i;
        for (; live; live &= live - 1) {
            const size_t t = c0 + (size_t)__builtin_ctzll(live);
            MR_FOR_EACH_TRIANGLE_EDGE(m, t, a, b, take, {
                if (take) {
                    __builtin_prefetch(s->q + b);
                    ea[nb] = a;
                    eb[nb] = b;
                    nb++;
                }
            });
            if (nb > GATHER_BATCH - 3)
                FLUSH();
        }
    }
    if (nb)
        FLUSH();
#undef FLUSH
    pt->bcount[blk] = n;
}

/* Gathering, last sweep over block blk: its candidates to their slabs'
 * lists, at the offsets the prefix sums gave. */
static void block_scatter(mr_partitioned *pt, size_t blk)
{
    const size_t np = pt->parts;
    uint32_t *off = pt->bcount + pt->nblocks + blk * 2 * np;
    const pcand *c = pt->bcand + blk * 3 * BLOCK_TRIANGLES;
    for (uint32_t i = 0, n = pt->bcount[blk]; i < n; i++) {
        const pcand e = c[i];
        const bool in = is_pure(pt, e.a) && is_pure(pt, e.b);
        const uint16_t p = pt->part[e.a];
        pslab *sl = &pt->slab[p];
        if (in)
            sl->buf[off[2 * p]++] = e;
        else
            sl->buf[off[2 * p + 1]++] = e;
    }
}

/*
 * Step 1: every slab's candidates, interior ones in buf[0..nin), the
 * others in buf[c1 - nbd .. c1), each in triangle order (fixed blocks of
 * triangles, whatever the threads). Three sweeps over the triangle
 * blocks: which vertices are impure (a triangle of theirs spans slabs);
 * the edges with their costs, counted per block and slab; after prefix
 * sums over the blocks, each block's candidates to its slabs' lists.
 * Lists are only read (no cleaning). Returns the candidates' number, or 0
 * when out of memory.
 */
static size_t mr_part_gather(mr_simplifier *s, double limit)
{
    mr_partitioned *pt = s->state;
    const mr_collapse_mesh *m = &s->m;
    const ptrdiff_t nb = (ptrdiff_t)pt->nblocks;
    const size_t np = pt->parts;
    const bool par = pt->threads > 1 && m->live_triangles > 65536;
    pt->gen++;
#pragma omp parallel num_threads(pt->threads) if (par)
    {
#pragma omp for schedule(static)
        for (ptrdiff_t i = 0; i < nb; i++)
            block_impure(pt, m, (size_t)i, par);
#pragma omp for schedule(dynamic, 4)
        for (ptrdiff_t i = 0; i < nb; i++)
            block_gather(s, (size_t)i, limit);
    }
    /* per slab: interior candidates block by block from 0, then the
     * boundary ones; each slab's lists a slice of the arena (contents
     * dropped: sliced again every pass) */
    size_t total = 0, need = 0;
    for (size_t p = 0; p < np; p++) {
        pslab *sl = &pt->slab[p];
        size_t ni = 0, nbd = 0;
        for (size_t i = 0; i < pt->nblocks; i++) {
            const uint32_t *cnt = pt->bcount + pt->nblocks + i * 2 * np + 2 * p;
            ni += cnt[0];
            nbd += cnt[1];
        }
        sl->nin = ni;
        sl->gathered = ni;
        sl->nbd = nbd;
        sl->c1 = ni + nbd;
        total += ni + nbd;
        need += sl->c1 + 1;
    }
    if (need > pt->arena_cap) {
        free(pt->arena_buf);
        free(pt->arena_tmp);
        pt->arena_cap = need + need / 8;
        pt->arena_buf = mr_alloc_array(pt->arena_cap, sizeof *pt->arena_buf);
        pt->arena_tmp = mr_alloc_array(pt->arena_cap, sizeof *pt->arena_tmp);
        if (!pt->arena_buf || !pt->arena_tmp) {
            pt->arena_cap = 0;
            return 0;
        }
    }
    for (size_t p = 0, off = 0; p < np; p++) {
        pslab *sl = &pt->slab[p];
        sl->buf = pt->arena_buf + off;
        sl->tmp = pt->arena_tmp + off;
        off += sl->c1 + 1; /* + 1: never an empty arena */
        const size_t ni = sl->nin;
        uint32_t oi = 0, ob = (uint32_t)ni;
        for (size_t i = 0; i < pt->nblocks; i++) {
            uint32_t *cnt = pt->bcount + pt->nblocks + i * 2 * np + 2 * p;
            const uint32_t ci = cnt[0], cb = cnt[1];
            cnt[0] = oi;
            cnt[1] = ob;
            oi += ci;
            ob += cb;
        }
    }
#pragma omp parallel for schedule(static) num_threads(pt->threads) if (par)
    for (ptrdiff_t i = 0; i < nb; i++)
        block_scatter(pt, (size_t)i);
    return total;
}

/* The key below which at least rank + 1 of the n candidates lie, to the
 * resolution of the top 16 bits (as batched.c's rank_key). */
static uint32_t mr_part_rank_key(mr_simplifier *s, size_t n, size_t rank)
{
    mr_partitioned *pt = s->state;
    const int nt = n > 65536 ? pt->threads : 1;
    const ptrdiff_t np = (ptrdiff_t)pt->parts;
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
        const int me = omp_get_thread_num(), team = omp_get_num_threads();
        uint32_t *hist = pt->hist + (size_t)me * HIST_BUCKETS;
        memset(hist, 0, HIST_BUCKETS * sizeof *hist);
#pragma omp for schedule(dynamic, 1)
        for (ptrdiff_t p = 0; p < np; p++) {
            const pslab *sl = &pt->slab[p];
            for (size_t i = 0; i < sl->nin; i++)
                hist[sl->buf[i].key >> 16]++;
            for (size_t i = sl->c1 - sl->nbd; i < sl->c1; i++)
                hist[sl->buf[i].key >> 16]++;
        }
        /* (the implicit barrier of the loop) the sum of the threads'
         * histograms, bucket ranges split */
#pragma omp for schedule(static)
        for (ptrdiff_t k = 0; k < (ptrdiff_t)HIST_BUCKETS; k++) {
            uint32_t sum = 0;
            for (int t = 0; t < team; t++)
                sum += pt->hist[(size_t)t * HIST_BUCKETS + (size_t)k];
            pt->hist[k] = sum;
        }
    }
    size_t acc = 0;
    for (uint32_t b = 0; b < HIST_BUCKETS; b++) {
        acc += pt->hist[b];
        if (acc > rank)
            return b << 16 | 0xFFFFu;
    }
    return UINT32_MAX;
}

/* Plan slab sl's candidates buf[0..nin) (the vector planner, in batches:
 * called while no collapse runs -- the planner reads a float past each
 * quadric record, which may be another slab's vertex's). A plan stays
 * exact while neither end has moved. Returns false when out of memory. */
static bool slab_plan(const mr_simplifier *s, pslab *sl)
{
    if (sl->nin > sl->pcap || !sl->plan) {
        free(sl->plan);
        sl->pcap = sl->nin + sl->nin / 8 + 64;
        sl->plan = mr_alloc_array(sl->pcap, sizeof *sl->plan);
        if (!sl->plan) {
            sl->pcap = 0;
            return false;
        }
    }
    uint32_t pa[PLAN_BATCH], pb[PLAN_BATCH], pr[PLAN_BATCH], pk[PLAN_BATCH];
    double pc[PLAN_BATCH], pt3[3 * PLAN_BATCH];
    for (size_t i0 = 0; i0 < sl->nin; i0 += PLAN_BATCH) {
        const size_t n = sl->nin - i0 < PLAN_BATCH ? sl->nin - i0 : PLAN_BATCH;
        for (size_t j = 0; j < n; j++) {
            pa[j] = sl->buf[i0 + j].a;
            pb[j] = sl->buf[i0 + j].b;
        }
        mr_simplifier_plan_edges(s, n, pa, pb, pc, pr, pk, pt3);
        for (size_t j = 0; j < n; j++) {
            pplan *x = &sl->plan[i0 + j];
            memcpy(x->target, pt3 + 3 * j, sizeof x->target);
            x->cost = pc[j];
            x->r = pr[j];
            x->k = pk[j];
        }
    }
    return true;
}

/* Add to sl->demand the list lengths of the ends of its interior
 * candidates, each vertex once (the refs room its collapses may take). */
static void add_demand(mr_partitioned *pt, const mr_collapse_mesh *m, pslab *sl)
{
    const pcand *c = sl->buf;
    for (size_t i = 0; i < sl->nin; i++) {
        const uint32_t e[2] = {c[i].a, c[i].b};
        for (int j = 0; j < 2; j++) {
            if (!(pt->pure[e[j]] & SEEN)) {
                pt->pure[e[j]] |= SEEN;
                sl->demand += m->count[e[j]];
            }
        }
    }
    for (size_t i = 0; i < sl->nin; i++) {
        pt->pure[c[i].a] &= (uint8_t)~SEEN;
        pt->pure[c[i].b] &= (uint8_t)~SEEN;
    }
}

/* Slab p keeps its candidates with keys up to lim, interior ones sorted
 * (unless `tail`: all go to the global order), and bounds the refs room
 * its collapses can take: the list lengths of the distinct ends (each
 * vertex is an end once a pass, and its list does not grow before).
 * Returns false when out of memory. */
static bool mr_part_select(mr_simplifier *s, unsigned p, uint32_t lim, bool tail)
{
    mr_partitioned *pt = s->state;
    const mr_collapse_mesh *m = &s->m;
    pslab *sl = &pt->slab[p];
    pcand *c = sl->buf;
    size_t k = 0;
    for (size_t i = 0; i < sl->nin; i++) {
        c[k] = c[i];
        k += c[i].key <= lim;
    }
    sl->nin = k;
    k = 0;
    for (size_t i = 0; i < sl->nbd; i++) {
        c[sl->c1 - 1 - k] = c[sl->c1 - 1 - i];
        k += c[sl->c1 - 1 - i].key <= lim;
    }
    sl->nbd = k;
    sl->next = 0;
    sl->keep = 0;
    sl->demand = 0;
    if (tail)
        return true;
    mr_part_sort(c, sl->tmp, sl->nin); /* tmp holds c1 >= nin */
    if (!slab_plan(s, sl))
        return false;
    add_demand(pt, m, sl);
    return true;
}

/* Slab p's interior collapses (step 3) from sl->next on, in its room;
 * pauses when the room is spent, stops at its quota. */
static void slab_apply(mr_simplifier *s, pslab *sl, double limit)
{
    mr_partitioned *pt = s->state;
    mr_collapse_mesh *m = &s->m;
    pcand *c = sl->buf;
    size_t at = sl->room0;
    sl->paused = false;
    for (; sl->next < sl->nin; sl->next++) {
        if (sl->gone + 3 > sl->qv || sl->deleted + 2 > sl->qt) {
            sl->quota_hit = true;
            sl->next = sl->nin;
            break;
        }
        /* the lists, triangles and quadrics of the candidates a few
         * turns ahead, in stages (the sorted order jumps about the slab) */
        static const size_t ahead[3] = {PF0, PF1, PF2};
        for (int st = 0; st < 3; st++) {
            if (sl->next + ahead[st] < sl->nin) {
                const pcand y = c[sl->next + ahead[st]];
                mr_collapse_prefetch(m, y.a, st);
                mr_collapse_prefetch(m, y.b, st);
                if (st == 1) {
                    __builtin_prefetch(s->q + y.a);
                    __builtin_prefetch(s->q + y.b);
                    __builtin_prefetch(pt->mark + y.a);
                    __builtin_prefetch(pt->mark + y.b);
                }
            }
        }
        const pcand e = c[sl->next];
        if (pt->mark[e.a] | pt->mark[e.b])
            continue;
        if (pt->claim && !mr_claim_free(m, pt->claim, e.a, e.b)) {
            sl->deferred++;
            sl->plan[sl->keep] = sl->plan[sl->next]; /* to the next round */
            c[sl->keep++] = e;
            continue;
        }
        const pplan *x = &sl->plan[sl->next];
        const uint32_t r = x->r, k = x->k;
        double target[3] = {x->target[0], x->target[1], x->target[2]}, cost = x->cost;
        mr_collapse_clean(m, r);
        mr_collapse_clean(m, k);
        /* on a copy: a paused slab plans again from x */
        mr_simplifier_place(s, r, k, target, &cost);
        if (!mr_simplifier_allowed(s, r, k, target, cost, limit)) {
            sl->refused++;
            continue;
        }
        const size_t need = (size_t)m->count[r] + m->count[k] - 1;
        if (at + need > sl->room1) {
            sl->paused = true; /* resumes here */
            break;
        }
        uint32_t *out = m->refs + at;
        size_t rm;
        if (pt->claim)
            mr_claim_take(m, pt->claim, r, k);
        sl->deleted += mr_simplifier_collapse_at(s, r, k, target, out, &rm);
        sl->gone += rm;
        for (size_t q = m->count[k]; q < need; q++)
            out[q] = 0; /* no compaction tag may stay behind */
        at += need;
        sl->demand -= sl->demand < need + 1 ? sl->demand : need + 1;
        pt->mark[r] = pt->mark[k] = 1;
        sl->made++;
        sl->worst = cost > sl->worst ? cost : sl->worst;
    }
    for (size_t q = at; q < sl->room1; q++)
        m->refs[q] = 0; /* the room left unused */
}

/* Quotas of the slabs sl[0..ns) for a step whose candidates are `all`
 * in all (theirs and those after the step): each slab's share, by its
 * candidates, of what is left to the targets, when they could reach it;
 * and their counts reset. */
void mr_part_quotas(const mr_simplifier *s, const mr_simplify_goal *g, pslab *sl, size_t ns,
                       size_t all)
{
    const mr_collapse_mesh *m = &s->m;
    size_t nin = 0;
    for (size_t p = 0; p < ns; p++)
        nin += sl[p].nin;
    const size_t lv = m->live_vertices - g->vertices;
    const size_t lt = g->triangles ? m->live_triangles - g->triangles : SIZE_MAX;
    for (size_t p = 0; p < ns; p++) {
        sl[p].qv = 3 * nin < lv ? SIZE_MAX : (size_t)((unsigned __int128)lv * sl[p].nin / all);
        sl[p].qt = 2 * nin < lt ? SIZE_MAX : (size_t)((unsigned __int128)lt * sl[p].nin / all);
        sl[p].gone = sl[p].deleted = sl[p].made = sl[p].refused = 0;
        sl[p].worst = 0;
        sl[p].quota_hit = false;
    }
}

/* The slabs sl[0..ns) apply their candidates concurrently (steps 3 and
 * 4): room in refs handed out by prefix sums, compaction between steps
 * when a slab ran out. Returns the collapses made. */
size_t mr_part_apply_slabs(mr_simplifier *s, pslab *slabs, size_t ns, double limit, double *worst,
                          bool *quota_hit)
{
    mr_partitioned *pt = s->state;
    mr_collapse_mesh *m = &s->m;
    const ptrdiff_t np = (ptrdiff_t)ns;
    bool stuck = false;
    /* the slabs' counts so far in this pass (an earlier round's) */
    size_t gone = 0, deleted = 0, made = 0;
    for (size_t p = 0; p < ns; p++) {
        gone += slabs[p].gone;
        deleted += slabs[p].deleted;
        made += slabs[p].made;
    }
    gone = 0 - gone, deleted = 0 - deleted, made = 0 - made;
    for (;;) {
        size_t want = 0, active = 0, before = 0;
        for (size_t p = 0; p < ns; p++) {
            const pslab *sl = &slabs[p];
            before += sl->next + sl->made;
            if (sl->next < sl->nin) {
                want += sl->demand + 1;
                active++;
            }
        }
        if (active == 0)
            break;
        if (m->refs_size + want > m->refs_capacity)
            mr_collapse_compact(m);
        const size_t free_room = m->refs_capacity - m->refs_size;
        /* each active slab's room: its bound, scaled down to the free room
         * when they do not all fit (stuck: the first active slab takes it
         * all; a collapse needs less than the free room after compaction) */
        size_t at = m->refs_size;
        bool first_active = true;
        for (size_t p = 0; p < ns; p++) {
            pslab *sl = &slabs[p];
            size_t r = 0;
            if (sl->next < sl->nin) {
                const size_t d = sl->demand + 1;
                if (stuck)
                    r = first_active ? free_room : 0;
                else
                    r = want <= free_room
                            ? d
                            : (size_t)((unsigned __int128)d * free_room / want);
                first_active = false;
            }
            sl->room0 = at;
            sl->room1 = at + r;
            at += r;
        }
        m->refs_size = at;
#pragma omp parallel for schedule(dynamic, 1) num_threads(pt->threads) \
    if (pt->threads > 1 && np > 1 && active > 1)
        for (ptrdiff_t p = 0; p < np; p++) {
            pslab *sl = &slabs[p];
            if (sl->next < sl->nin)
                slab_apply(s, sl, limit);
        }
        size_t after = 0;
        for (size_t p = 0; p < ns; p++)
            after += slabs[p].next + slabs[p].made;
        if (after == before && stuck)
            break; /* cannot happen (see above): never loop */
        stuck = after == before;
    }
    for (size_t p = 0; p < ns; p++) {
        const pslab *sl = &slabs[p];
        gone += sl->gone;
        deleted += sl->deleted;
        made += sl->made;
        *worst = sl->worst > *worst ? sl->worst : *worst;
        *quota_hit |= sl->quota_hit;
    }
    m->live_vertices -= gone;
    m->live_triangles -= deleted;
    return made;
}

/* Does every live triangle of v lie in shifted slab q? (v's list may hold
 * deleted triangles: skipped.) */
static bool ring_in(const mr_collapse_mesh *m, const uint16_t *part2, uint32_t v, uint16_t q)
{
    const uint32_t *list = mr_collapse_vertex_tris(m, v);
    for (uint32_t j = 0, n = m->count[v]; j < n; j++) {
        const uint32_t *t = m->tris + (list[j] - list[j] % 3);
        if (t[0] == NONE)
            continue;
        if ((part2[t[0]] != q) | (part2[t[1]] != q) | (part2[t[2]] != q))
            return false;
    }
    return true;
}

/* Slab sl's refs room bound, from its candidates' distinct ends (as
 * slab_select's); counts are of the lists as they are (dirty ones are
 * cleaned before a collapse, which only shortens them). */
static bool slab_demand(const mr_simplifier *s, pslab *sl)
{
    mr_partitioned *pt = s->state;
    sl->demand = 0;
    sl->next = 0;
    sl->keep = 0;
    add_demand(pt, &s->m, sl);
    return slab_plan(s, sl);
}

void mr_part_next_round(mr_simplifier *s, pslab *sl)
{
    sl->nin = sl->keep;
    sl->keep = 0;
    sl->next = 0;
    sl->demand = 0;
    add_demand(s->state, &s->m, sl);
}

/*
 * Step 4's concurrent part: of the boundary candidates seq[0..n) (sorted),
 * those still unmarked whose two ends' closed 1-rings lie in one shifted
 * slab -- the planes of `part` run through the middle of those -- are
 * applied by the shifted slabs concurrently, each in the sorted order (the
 * same reasoning as the interior step's, with part2). The rest stay in
 * seq, in order, for the calling thread; returns how many, and the
 * collapses made in *made. Returns SIZE_MAX when out of memory.
 */
static size_t shifted(mr_simplifier *s, size_t n, const mr_simplify_goal *g, double *worst,
                      bool *quota_hit, size_t *made)
{
    mr_partitioned *pt = s->state;
    const mr_collapse_mesh *m = &s->m;
    const size_t ns = (size_t)pt->parts + 1;
    *made = 0;
    if (n <= pt->in2_cap && pt->in2 == NULL)
        pt->in2_cap = 0;
    if (n > pt->in2_cap) {
        free(pt->in2);
        pt->in2_cap = n + n / 8 + 64;
        pt->in2 = mr_alloc_array(pt->in2_cap, 1);
        if (!pt->in2) {
            pt->in2_cap = 0;
            return SIZE_MAX;
        }
    }
    const pcand *c = pt->seq;
    uint8_t *in2 = pt->in2;
    const ptrdiff_t nn = (ptrdiff_t)n;
#pragma omp parallel for schedule(static) num_threads(pt->threads) \
    if (pt->threads > 1 && nn > 4096)
    for (ptrdiff_t i = 0; i < nn; i++) {
        const pcand e = c[i];
        if (pt->mark[e.a] | pt->mark[e.b]) {
            in2[i] = 2; /* dropped: an end moved this pass */
            continue;
        }
        const uint16_t q = pt->part2[e.a];
        in2[i] = ring_in(m, pt->part2, e.a, q) && ring_in(m, pt->part2, e.b, q);
    }
    /* the shifted slabs' lists, in the sorted order */
    for (size_t q = 0; q < ns; q++)
        pt->slab2[q].nin = 0;
    for (size_t i = 0; i < n; i++)
        pt->slab2[pt->part2[c[i].a]].nin += in2[i] == 1;
    for (size_t q = 0; q < ns; q++) {
        pslab *sl = &pt->slab2[q];
        if (!mr_part_room(&sl->buf, &sl->cap, sl->nin))
            return SIZE_MAX;
        sl->c1 = sl->nin;
        sl->nin = 0;
    }
    size_t rest = 0;
    for (size_t i = 0; i < n; i++) {
        if (in2[i] == 1) {
            pslab *sl = &pt->slab2[pt->part2[c[i].a]];
            sl->buf[sl->nin++] = c[i];
        } else if (in2[i] == 0) {
            pt->seq[rest++] = c[i];
        }
    }
    const ptrdiff_t nq = (ptrdiff_t)ns;
    bool ok = true;
#pragma omp parallel for schedule(dynamic, 1) num_threads(pt->threads) \
    if (pt->threads > 1 && n > 4096) reduction(&& : ok)
    for (ptrdiff_t q = 0; q < nq; q++)
        ok = slab_demand(s, &pt->slab2[q]) && ok;
    if (!ok)
        return SIZE_MAX;
    size_t nin = 0;
    for (size_t q = 0; q < ns; q++)
        nin += pt->slab2[q].nin;
    mr_part_quotas(s, g, pt->slab2, ns, nin + rest);
    *made = mr_part_apply_slabs(s, pt->slab2, ns, g->limit, worst, quota_hit);
    return rest;
}

/* Step 4's rest (or a tail pass): the candidates in seq[0..n), sorted,
 * one at a time on this thread, up to the target. Returns the collapses
 * made. */
size_t mr_part_sequential(mr_simplifier *s, size_t n, const mr_simplify_goal *g, double *worst)
{
    mr_partitioned *pt = s->state;
    mr_collapse_mesh *m = &s->m;
    size_t made = 0;
    for (size_t i = 0; i < n && !mr_simplifier_reached(s); i++) {
        const pcand e = pt->seq[i];
        if (pt->mark[e.a] | pt->mark[e.b])
            continue;
        mr_collapse_clean(m, e.a);
        mr_collapse_clean(m, e.b);
        uint32_t r, k;
        double target[3];
        double cost = mr_simplifier_plan_edge(s, e.a, e.b, &r, &k, target);
        mr_simplifier_place(s, r, k, target, &cost);
        if (!mr_simplifier_allowed(s, r, k, target, cost, g->limit))
            continue;
        mr_simplifier_collapse(s, r, k, target);
        pt->mark[r] = pt->mark[k] = 1;
        made++;
        *worst = cost > *worst ? cost : *worst;
    }
    return made;
}

/* Room for n merged candidates in seq. */
static bool mr_part_seq_room(mr_partitioned *pt, size_t n)
{
    return mr_part_room(&pt->seq, &pt->seq_cap, n) && mr_part_room(&pt->seq_tmp, &pt->seq_tmp_cap, n);
}

size_t mr_part_merge(mr_simplifier *s, bool tail)
{
    mr_partitioned *pt = s->state;
    size_t ns = 0;
    for (unsigned p = 0; p < pt->parts; p++)
        ns += pt->slab[p].nbd + (tail ? pt->slab[p].nin : 0);
    if (!mr_part_seq_room(pt, ns))
        return SIZE_MAX;
    size_t k = 0;
    for (unsigned p = 0; p < pt->parts; p++) {
        const pslab *sl = &pt->slab[p];
        if (tail) {
            memcpy(pt->seq + k, sl->buf, sl->nin * sizeof *pt->seq);
            k += sl->nin;
        }
        memcpy(pt->seq + k, sl->buf + sl->c1 - sl->nbd, sl->nbd * sizeof *pt->seq);
        k += sl->nbd;
    }
    mr_part_sort(pt->seq, pt->seq_tmp, k);
    return k;
}

bool mr_part_begin(mr_simplifier *s, const mr_simplify_goal *g, double share, bool force_tail,
                   mr_part_pass *ps)
{
    mr_partitioned *pt = s->state;
    const ptrdiff_t np = (ptrdiff_t)pt->parts;
    const bool par = pt->threads > 1 && np > 1;
    ps->n = mr_part_gather(s, g->limit);
    if (ps->n == 0)
        return false;
    const size_t needed = mr_needed_collapses(s, g);
    ps->tail = force_tail || needed < (size_t)TAIL_PER_PARTITION * pt->parts;
    const double goal = ceil(share * (double)needed);
    uint32_t lim = UINT32_MAX;
    if (goal < (double)ps->n)
        lim = mr_float_key(mr_key_float(mr_part_rank_key(s, ps->n, (size_t)goal)) * PASS_SLACK);
    ps->nbd_all = 0;
    for (unsigned p = 0; p < pt->parts; p++)
        ps->nbd_all += pt->slab[p].nbd;
    bool ok = true;
#pragma omp parallel for schedule(dynamic, 1) num_threads(pt->threads) if (par) \
    reduction(&& : ok)
    for (ptrdiff_t p = 0; p < np; p++)
        ok = mr_part_select(s, (unsigned)p, lim, ps->tail) && ok;
    if (!ok)
        return false; /* no memory: stop here */
    ps->nin = ps->nbd = 0;
    for (unsigned p = 0; p < pt->parts; p++) {
        ps->nin += pt->slab[p].nin;
        ps->nbd += pt->slab[p].nbd;
    }
    memset(pt->mark, 0, s->m.vertex_count);
    return true;
}

static size_t partitioned_run(mr_simplifier *s, double *max_error)
{
    mr_partitioned *pt = s->state;
    mr_collapse_mesh *m = &s->m;
    mr_partition_profile *prof = &pt->profile;
    const mr_simplify_goal g = s->plan.goal;
    size_t next_report = g.planned / 100 + 1, done = 0;
    double worst = 0, share = 1.0;
    bool force_tail = false;
    memset(prof, 0, sizeof *prof);
    while (!mr_simplifier_reached(s)) {
        if (2 * m->live_vertices <= pt->balanced_live) {
            mr_part_balance(s);
            prof->rebalances++;
        }
        mr_part_pass ps;
        if (!mr_part_begin(s, &g, share, force_tail, &ps))
            break;
        prof->passes++;
        size_t pass_done = 0;
        bool quota_hit = false;
        if (!ps.tail) {
            mr_part_quotas(s, &g, pt->slab, pt->parts, ps.nin + ps.nbd);
            const size_t made =
                mr_part_apply_slabs(s, pt->slab, pt->parts, g.limit, &worst, &quota_hit);
            prof->interior += made;
            pass_done += made;
            done += made;
            if (mr_part_progress(s, &g, done, &next_report))
                break; /* cancelled */
        }
        /* the boundary candidates (a tail pass: all), one global order */
        size_t k = mr_part_merge(s, ps.tail);
        if (k == SIZE_MAX)
            break; /* no memory: stop here */
        if (!ps.tail && !mr_simplifier_reached(s)) {
            size_t made2;
            k = shifted(s, k, &g, &worst, &quota_hit, &made2);
            if (k == SIZE_MAX)
                break; /* no memory: stop here */
            prof->boundary += made2;
            pass_done += made2;
            done += made2;
        }
        const size_t made = mr_part_sequential(s, k, &g, &worst);
        if (ps.tail)
            prof->tail += made;
        else
            prof->boundary_seq += made;
        pass_done += made;
        done += made;
        if (mr_part_progress(s, &g, done, &next_report))
            break; /* cancelled */
        force_tail = quota_hit;
        if (!mr_part_next(pass_done, &ps, &share))
            break; /* nothing valid is left */
    }
    mr_part_add_profile(s, prof);
    *max_error = sqrt(worst);
    return done;
}

void mr_part_add_profile(mr_simplifier *s, const mr_partition_profile *p)
{
    mr_simplify_stats *stats = &s->profile;
    stats->partition_passes += p->passes;
    stats->interior_collapses += p->interior;
    stats->boundary_collapses += p->boundary + p->boundary_seq;
    stats->boundary_sequential += p->boundary_seq;
    stats->tail_collapses += p->tail;
    stats->rebalances += p->rebalances;
    stats->claim_conflicts += p->deferred;
    stats->rebalance_count += p->trigger[MR_TRIGGER_COUNT];
    stats->rebalance_imbalance += p->trigger[MR_TRIGGER_IMBALANCE];
    stats->rebalance_boundary += p->trigger[MR_TRIGGER_BOUNDARY];
    stats->rebalance_acceptance += p->trigger[MR_TRIGGER_ACCEPTANCE];
}

const mr_strategy_ops mr_strategy_partitioned = {mr_part_start, partitioned_run, mr_part_release,
                                             false};

unsigned mr_partitioned_slab(const mr_simplifier *s, uint32_t v, bool shifted_slabs)
{
    const mr_partitioned *pt = s->state;
    return shifted_slabs ? pt->part2[v] : pt->part[v];
}

bool mr_partitioned_shifted_interior(const mr_simplifier *s, uint32_t a, uint32_t b)
{
    const mr_partitioned *pt = s->state;
    const uint16_t q = pt->part2[a];
    return ring_in(&s->m, pt->part2, a, q) && ring_in(&s->m, pt->part2, b, q);
}

size_t mr_partitioned_edges(mr_simplifier *s, uint32_t *a, uint32_t *b, uint8_t *interior,
                            size_t cap)
{
    const mr_partitioned *pt = s->state;
    mr_part_gather(s, INFINITY);
    size_t n = 0;
    for (unsigned p = 0; p < pt->parts; p++) {
        const pslab *sl = &pt->slab[p];
        for (size_t i = 0; i < sl->c1; i++) {
            if (i >= sl->nin && i < sl->c1 - sl->nbd)
                continue;
            if (n < cap) {
                const uint32_t x = sl->buf[i].a, y = sl->buf[i].b;
                a[n] = x < y ? x : y;
                b[n] = x < y ? y : x;
                interior[n] = i < sl->nin;
            }
            n++;
        }
    }
    return n;
}
