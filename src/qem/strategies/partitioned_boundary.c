/*
 * The boundary-aware variant of the partitioned strategy
 * (MR_STRATEGY_PARTITIONED_BOUNDARY; issue 16 item 2, the parallel-QEM
 * report's "boundary-aware" refinement, with claims wide enough for the
 * collapses to be applied in parallel, where the report committed them one
 * by one).
 *
 * The slabs, the gathering of interior (both closed 1-rings in one slab)
 * and boundary candidates, the cost threshold and the (cost, edge id)
 * order are partitioned.c's. What differs is how a pass chooses and
 * applies its collapses:
 *   1. interior, per slab in parallel: a claim walk over the slab's sorted
 *      candidates, on the mesh as the pass found it. A candidate joins the
 *      slab's batch when it is valid (mr_simplifier_allowed) and free: its
 *      ends are neither ends of collapses already in the batch nor in their
 *      closed 1-rings, and no vertex of its own ends' closed 1-rings is such
 *      an end. Then it claims its ends (CLAIM_END) and every vertex of
 *      their triangles (CLAIM_RING). A candidate that is not free is
 *      deferred to a later pass (counted: claim_conflicts);
 *   2. every slab's batch is applied together, on every thread, in items of
 *      at most APPLY_ITEM collapses (not slab by slab: the threads share
 *      the work whatever the slabs' sizes);
 *   3. boundary: every slab's boundary candidates in one (cost, edge id)
 *      order, a single global claim walk on the calling thread (candidates
 *      with an end that moved in step 2 are dropped: their costs are
 *      stale), then that batch applied together as in step 2;
 *   4. the tail (few collapses left, or a quota hit): partitioned.c's
 *      sequential pass.
 * Why the batches may be applied together: in a batch, no end of one
 * collapse shares a triangle with an end of another (that is what the
 * claims exclude), which is the relation under which collapse.h says two
 * shared collapses commute and may run at once; each one's validity,
 * tested on the mesh as the walk found it, still holds after the others.
 * Where a list lands in refs does not change a collapse's result, so the
 * items' split and order do not matter either.
 *
 * Rebalancing, from counts only (never from time), checked after each
 * pass from the second after a balance, the first that fires counted in
 * mr_simplify_stats:
 *   count       the live vertices halved since the last balance (the
 *               partitioned strategy's only trigger);
 *   imbalance   one slab gathered MR_TRIGGER_IMBALANCE_RATIO times the mean
 *               slab's interior candidates (one part of the surface
 *               simplifies faster: a flat region);
 *   boundary    the fraction of candidates across slabs grew to
 *               MR_TRIGGER_BOUNDARY_GROWTH times its value in the first pass
 *               after the balance (edges lengthen as the mesh coarsens, and
 *               vertices drift across the planes as they move);
 *   acceptance  the slabs' acceptance rate (collapses made / candidates
 *               walked) fell to MR_TRIGGER_ACCEPT_DROP times its value in
 *               that first pass.
 *
 * Determinism: the walks run in a fixed order on the mesh as it stands
 * (slab walks touch only their slab's vertices, lists and claims); the
 * batches' collapses commute; refs compaction gives the same layout on any
 * number of threads. For a fixed `partitions` the output is byte-identical
 * at every thread count and in the serial build.
 *
 * Against partitioned.c: a slab's walk there applies as it goes, so a
 * collapse may follow a neighbour's in the same pass; here a neighbour
 * waits for the next pass (fewer collapses per pass, more passes), and the
 * boundary step has no shifted slabs. The report found its variant
 * slower and coarser than its plain partitioned batch; bench_partitioned
 * measures ours against partitioned.c's.
 */
#include "partitioned.h"

/* Collapses per item of a batch's parallel application. */
#define APPLY_ITEM 256
/* Claim rounds per pass (each walks what the claims deferred in the one
 * before, on the mesh the one before left), while a round makes at least
 * ROUND_MIN collapses. */
#define ROUNDS 2
#define ROUND_MIN 64

/* What collapse r -> k will remove (its lists clean): *dt triangles (those
 * on the edge) and *dv vertices (r, and an opposite vertex whose only live
 * triangle is on the edge: an ear's tip). */
static void predict(const mr_collapse_mesh *m, uint32_t r, uint32_t k, size_t *dv, size_t *dt)
{
    const uint32_t *list = mr_collapse_vertex_tris(m, r);
    size_t v = 1, t = 0;
    for (uint32_t i = 0, n = m->count[r]; i < n; i++) {
        const uint32_t e = list[i], j = e % 3, *x = m->tris + (e - j);
        const uint32_t jn = mr_local_next(j), jp = mr_local_prev(j);
        if (x[jn] != k && x[jp] != k)
            continue;
        const uint32_t c = x[jn] == k ? x[jp] : x[jn];
        t++;
        const uint32_t live = m->count[c] - (m->dead ? m->dead[c] : 0);
        v += live == 1;
    }
    *dv = v;
    *dt = t;
}

/* Room for one more accepted collapse in b. */
static bool batch_room(pbatch *b)
{
    if (b->n < b->cap)
        return true;
    const size_t cap = b->cap ? 2 * b->cap : 1024;
    paccept *acc = realloc(b->acc, cap * sizeof *acc);
    if (!acc)
        return false;
    b->acc = acc;
    b->cap = cap;
    return true;
}

/* Accept collapse r -> k (lists clean, valid) into b: claims, marks, its
 * refs room. */
static void accept(mr_partitioned *pt, const mr_collapse_mesh *m, pbatch *b, uint32_t r,
                   uint32_t k, const double target[3], double cost)
{
    mr_claim_take(m, pt->claim, r, k);
    pt->mark[r] = pt->mark[k] = 1;
    paccept *x = &b->acc[b->n++];
    memcpy(x->target, target, sizeof x->target);
    x->cost = cost;
    x->r = r;
    x->k = k;
    x->off = b->need;
    b->need += (size_t)m->count[r] + m->count[k] - 1;
}

/* An item of a batch's application: its collapses [i0, i1), their merged
 * lists from refs + base on (need entries in all). */
typedef struct pitem {
    size_t i0, i1, need, base;
} pitem;

/* The refs room of b's collapse i. */
static inline size_t acc_need(const pbatch *b, size_t i)
{
    return (i + 1 < b->n ? b->acc[i + 1].off : b->need) - b->acc[i].off;
}

/* Apply collapse x (of batch b, room `need` at out). */
static inline void apply_one(mr_simplifier *s, const paccept *x, size_t need, uint32_t *out,
                             size_t *gone, size_t *deleted)
{
    size_t rm;
    *deleted += mr_simplifier_collapse_at(s, x->r, x->k, x->target, out, &rm);
    *gone += rm;
    for (size_t q = s->m.count[x->k]; q < need; q++)
        out[q] = 0; /* no compaction tag may stay behind */
}

/* Step 3's application: the collapses of batch b applied together on
 * every thread, in items, as many items at a time as the free room in
 * refs holds (compacted between); an item that does not fit after
 * compaction (a small mesh) goes one collapse at a time on this thread.
 * Updates the mesh's counts. Returns false when out of memory (nothing
 * applied). */
static bool apply_batch(mr_simplifier *s, pbatch *b)
{
    mr_partitioned *pt = s->state;
    mr_collapse_mesh *m = &s->m;
    const size_t ni = (b->n + APPLY_ITEM - 1) / APPLY_ITEM;
    if (ni == 0)
        return true;
    pitem *items = mr_alloc_array(ni, sizeof *items);
    if (!items)
        return false;
    for (size_t j = 0; j < ni; j++) {
        const size_t i0 = j * APPLY_ITEM, i1 = b->n - i0 < APPLY_ITEM ? b->n : i0 + APPLY_ITEM;
        const size_t end = i1 < b->n ? b->acc[i1].off : b->need;
        items[j] = (pitem){i0, i1, end - b->acc[i0].off, 0};
    }
    size_t gone = 0, deleted = 0;
    for (size_t k0 = 0; k0 < ni;) {
        if (m->refs_size + items[k0].need > m->refs_capacity)
            mr_collapse_compact(m);
        size_t k1 = k0, at = m->refs_size;
        while (k1 < ni && at + items[k1].need <= m->refs_capacity) {
            items[k1].base = at;
            at += items[k1].need;
            k1++;
        }
        if (k1 == k0) {
            /* too big for the room even after compaction: one at a time */
            const pitem *it = &items[k0];
            for (size_t i = it->i0; i < it->i1; i++) {
                const size_t need = acc_need(b, i);
                if (m->refs_size + need > m->refs_capacity)
                    mr_collapse_compact(m);
                apply_one(s, &b->acc[i], need, m->refs + m->refs_size, &gone, &deleted);
                m->refs_size += need;
            }
            k0++;
            continue;
        }
        m->refs_size = at;
        const ptrdiff_t lo = (ptrdiff_t)k0, hi = (ptrdiff_t)k1;
#pragma omp parallel for schedule(dynamic, 2) num_threads(pt->threads) \
    if (pt->threads > 1 && hi - lo > 1) reduction(+ : gone, deleted)
        for (ptrdiff_t q = lo; q < hi; q++) {
            const pitem *it = &items[q];
            const size_t first = b->acc[it->i0].off;
            for (size_t i = it->i0; i < it->i1; i++) {
                /* the collapses a few turns ahead, in stages (the walk's
                 * cache lines are long gone) */
                static const size_t ahead[3] = {PF0, PF1, PF2};
                for (int st = 0; st < 3; st++) {
                    if (i + ahead[st] < it->i1) {
                        const paccept *y = &b->acc[i + ahead[st]];
                        mr_collapse_prefetch(m, y->r, st);
                        mr_collapse_prefetch(m, y->k, st);
                        if (st == 1) {
                            __builtin_prefetch(s->q + y->r);
                            __builtin_prefetch(s->q + y->k);
                            __builtin_prefetch(m->pos + 3 * (size_t)y->k);
                        }
                    }
                }
                const paccept *x = &b->acc[i];
                apply_one(s, x, acc_need(b, i), m->refs + it->base + (x->off - first),
                          &gone, &deleted);
            }
        }
        k0 = k1;
    }
    free(items);
    m->live_vertices -= gone;
    m->live_triangles -= deleted;
    return true;
}

/* bstate[]: a boundary candidate's test before the walk. */
enum { B_SKIP, B_VALID, B_WALK };

/* The lists, triangles, quadrics and claims of the boundary candidates a
 * few turns after seq[i] (of seq[0..n)), in stages (the merged order jumps
 * about the mesh); with `state`, those it skips left out. */
static inline void prefetch_ahead(const mr_simplifier *s, size_t i, size_t n,
                                  const uint8_t *state)
{
    const mr_partitioned *pt = s->state;
    const mr_collapse_mesh *m = &s->m;
    static const size_t ahead[3] = {PF0, PF1, PF2};
    for (int st = 0; st < 3; st++) {
        const size_t j = i + ahead[st];
        if (j >= n || (state && state[j] == B_SKIP))
            continue;
        const pcand y = pt->seq[j];
        mr_collapse_prefetch(m, y.a, st);
        mr_collapse_prefetch(m, y.b, st);
        if (st == 1) {
            __builtin_prefetch(s->q + y.a);
            __builtin_prefetch(s->q + y.b);
            __builtin_prefetch(pt->claim + y.a);
            __builtin_prefetch(pt->claim + y.b);
        }
    }
}

/* Step 3's tests, on every thread, on the mesh as it stands (no collapse
 * runs meanwhile, and the walk changes nothing before its batch is
 * applied, so each result is the one the walk would find): each candidate
 * of seq[0..n) whose ends did not move this pass and whose lists are clean
 * is planned and tested (mr_simplifier_allowed): B_VALID with its plan in
 * bplan, or B_SKIP; an end that moved, B_SKIP (its cost is stale); a
 * dirty list (a vertex of high valence), B_WALK: cleaned, planned and
 * tested by the walk itself. Returns false when out of memory. */
static bool boundary_test(mr_simplifier *s, size_t n, double limit)
{
    mr_partitioned *pt = s->state;
    const mr_collapse_mesh *m = &s->m;
    if (n > pt->bcap || !pt->bplan) {
        free(pt->bplan);
        free(pt->bstate);
        pt->bcap = n + n / 8 + 64;
        pt->bplan = mr_alloc_array(pt->bcap, sizeof *pt->bplan);
        pt->bstate = mr_alloc_array(pt->bcap, 1);
        if (!pt->bplan || !pt->bstate) {
            pt->bcap = 0;
            return false;
        }
    }
    const ptrdiff_t nn = (ptrdiff_t)n;
#pragma omp parallel for schedule(dynamic, 256) num_threads(pt->threads) \
    if (pt->threads > 1 && nn > 4096)
    for (ptrdiff_t i = 0; i < nn; i++) {
        prefetch_ahead(s, (size_t)i, (size_t)nn, NULL);
        const pcand e = pt->seq[i];
        if (pt->mark[e.a] | pt->mark[e.b]) {
            pt->bstate[i] = B_SKIP;
            continue;
        }
        if (mr_collapse_dirty(m, e.a) || mr_collapse_dirty(m, e.b)) {
            pt->bstate[i] = B_WALK;
            continue;
        }
        pplan *x = &pt->bplan[i];
        x->cost = mr_simplifier_plan_edge(s, e.a, e.b, &x->r, &x->k, x->target);
        mr_simplifier_place(s, x->r, x->k, x->target, &x->cost);
        pt->bstate[i] = mr_simplifier_allowed(s, x->r, x->k, x->target, x->cost, limit)
                            ? B_VALID
                            : B_SKIP;
    }
    return true;
}

/* Step 3's walk, one round: the boundary candidates seq[0..*n) (sorted)
 * on this thread (their tests on every thread before: boundary_test), into
 * pt->bbatch, up to the targets (as a sequential pass
 * would stop: a collapse is taken while the targets are not met after the
 * ones before it); the ones a claim deferred stay in seq[0..*n), in order,
 * for the next round. Returns false when out of memory. */
static bool boundary_claim(mr_simplifier *s, size_t *n, const mr_simplify_goal *g, double *worst,
                           size_t *deferred)
{
    mr_partitioned *pt = s->state;
    mr_collapse_mesh *m = &s->m;
    pbatch *b = &pt->bbatch;
    b->n = b->need = 0;
    if (!boundary_test(s, *n, g->limit))
        return false;
    size_t lv = m->live_vertices, lt = m->live_triangles, keep = 0;
    for (size_t i = 0; i < *n; i++) {
        if (lv <= g->vertices || (g->triangles && lt <= g->triangles)) {
            keep = 0; /* the targets: no next round */
            break;
        }
        prefetch_ahead(s, i, *n, pt->bstate);
        if (pt->bstate[i] == B_SKIP)
            continue; /* an end moved this pass, or not allowed */
        const pcand e = pt->seq[i];
        if (!mr_claim_free(m, pt->claim, e.a, e.b)) {
            (*deferred)++;
            pt->seq[keep++] = e; /* to the next round */
            continue;
        }
        pplan x = pt->bplan[i];
        if (pt->bstate[i] == B_WALK) { /* a dirty list: cleaned here */
            mr_collapse_clean(m, e.a);
            mr_collapse_clean(m, e.b);
            x.cost = mr_simplifier_plan_edge(s, e.a, e.b, &x.r, &x.k, x.target);
            mr_simplifier_place(s, x.r, x.k, x.target, &x.cost);
            if (!mr_simplifier_allowed(s, x.r, x.k, x.target, x.cost, g->limit))
                continue;
        }
        if (!batch_room(b))
            return false;
        size_t dv, dt;
        predict(m, x.r, x.k, &dv, &dt);
        accept(pt, m, b, x.r, x.k, x.target, x.cost);
        lv -= dv < lv ? dv : lv;
        lt -= dt < lt ? dt : lt;
        *worst = x.cost > *worst ? x.cost : *worst;
    }
    *n = keep;
    return true;
}

int mr_part_trigger(mr_part_triggers *tr, size_t live, const pslab *slabs, unsigned parts,
                    size_t gathered, size_t nbd, size_t walked, size_t made)
{
    const double bfrac = gathered ? (double)nbd / (double)gathered : 0;
    const double acc = walked ? (double)made / (double)walked : 1;
    if (++tr->passes == 1) {
        tr->bfrac = bfrac;
        tr->accept = acc;
        return -1;
    }
    if (2 * live <= tr->live)
        return MR_TRIGGER_COUNT;
    size_t most = 0, all = 0;
    for (unsigned p = 0; p < parts; p++) {
        all += slabs[p].gathered;
        most = slabs[p].gathered > most ? slabs[p].gathered : most;
    }
    if (parts > 1 && all > 0 && (double)most * parts >= MR_TRIGGER_IMBALANCE_RATIO * (double)all)
        return MR_TRIGGER_IMBALANCE;
    if (tr->bfrac > 0 && bfrac >= MR_TRIGGER_BOUNDARY_GROWTH * tr->bfrac)
        return MR_TRIGGER_BOUNDARY;
    if (walked && acc <= MR_TRIGGER_ACCEPT_DROP * tr->accept)
        return MR_TRIGGER_ACCEPTANCE;
    return -1;
}

static size_t boundary_run(mr_simplifier *s, double *max_error)
{
    mr_partitioned *pt = s->state;
    mr_collapse_mesh *m = &s->m;
    mr_partition_profile *prof = &pt->profile;
    const mr_simplify_goal g = s->plan.goal;
    size_t next_report = g.planned / 100 + 1, done = 0;
    double worst = 0, share = 1.0;
    bool force_tail = false, rebalance = false;
    const ptrdiff_t np = (ptrdiff_t)pt->parts;
    const bool par = pt->threads > 1 && np > 1;
    mr_part_triggers tr = {m->live_vertices, 0, 0, 0};
    memset(prof, 0, sizeof *prof);
    while (!mr_simplifier_reached(s)) {
        if (rebalance) {
            mr_part_balance(s);
            prof->rebalances++;
            tr = (mr_part_triggers){m->live_vertices, 0, 0, 0};
            rebalance = false;
        }
        mr_part_pass ps;
        if (!mr_part_begin(s, &g, share, force_tail, &ps))
            break;
        prof->passes++;
        size_t pass_done = 0, made_in = 0;
        bool quota_hit = false, ok = true;
        if (!ps.tail) {
            /* steps 1 and 2 */
            mr_part_quotas(s, &g, pt->slab, pt->parts, ps.nin + ps.nbd);
            for (unsigned round = 0; round < ROUNDS; round++) {
                memset(pt->claim, 0, m->vertex_count);
                for (unsigned p = 0; p < pt->parts; p++)
                    pt->slab[p].deferred = 0;
                const size_t round_made =
                    mr_part_apply_slabs(s, pt->slab, pt->parts, g.limit, &worst, &quota_hit);
                made_in += round_made;
                size_t left = 0;
                for (unsigned p = 0; p < pt->parts; p++) {
                    prof->deferred += pt->slab[p].deferred;
                    left += pt->slab[p].keep;
                }
                if (quota_hit || round_made < ROUND_MIN || left == 0 || round + 1 == ROUNDS)
                    break;
#pragma omp parallel for schedule(dynamic, 1) num_threads(pt->threads) if (par)
                for (ptrdiff_t p = 0; p < np; p++)
                    mr_part_next_round(s, &pt->slab[p]);
            }
            prof->interior += made_in;
            pass_done += made_in;
            done += made_in;
            if (mr_part_progress(s, &g, done, &next_report))
                break; /* cancelled */
        }
        /* step 3 (a tail pass: step 4 on all the candidates) */
        size_t k = mr_part_merge(s, ps.tail);
        if (k == SIZE_MAX)
            break; /* no memory: stop here */
        if (ps.tail) {
            const size_t made = mr_part_sequential(s, k, &g, &worst);
            prof->tail += made;
            pass_done += made;
            done += made;
        } else {
            pbatch *bb = &pt->bbatch;
            for (unsigned round = 0; round < ROUNDS && k && ok; round++) {
                if (mr_simplifier_reached(s))
                    break;
                memset(pt->claim, 0, m->vertex_count);
                ok = boundary_claim(s, &k, &g, &worst, &prof->deferred) &&
                     apply_batch(s, bb);
                prof->boundary += bb->n;
                pass_done += bb->n;
                done += bb->n;
                if (bb->n < ROUND_MIN)
                    break;
            }
            if (!ok)
                break; /* no memory: stop here */
        }
        if (mr_part_progress(s, &g, done, &next_report))
            break; /* cancelled */
        force_tail = quota_hit;
        if (!ps.tail) {
            const int why = mr_part_trigger(&tr, m->live_vertices, pt->slab, pt->parts, ps.n,
                                            ps.nbd_all, ps.nin, made_in);
            if (why >= 0) {
                prof->trigger[why]++;
                rebalance = true;
            }
        }
        if (!mr_part_next(pass_done, &ps, &share))
            break; /* nothing valid is left */
    }
    mr_part_add_profile(s, prof);
    *max_error = sqrt(worst);
    return done;
}

const mr_strategy_ops mr_strategy_partitioned_boundary = {mr_part_start, boundary_run,
                                                      mr_part_release, false};
