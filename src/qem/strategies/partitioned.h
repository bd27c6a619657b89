/*
 * What the two partitioned strategies share (partitioned.c: the slabs,
 * the gathering, the cost threshold and sorting, the quotas and the
 * sequential tail; partitioned_boundary.c: the boundary-aware variant's
 * claims and batches). Internal.
 */
#ifndef MR_QEM_PARTITIONED_H
#define MR_QEM_PARTITIONED_H

#include "passes.h"

#include "../../core/omp_compat.h"

#include <math.h>

#define NONE MR_COLLAPSE_NONE

/* The slack on the goal-th cheapest cost (as batched.c's PASS_SLACK). */
#define PASS_SLACK 1.5f
/* Histogram buckets over the top 16 bits of a cost key. */
#define HIST_BUCKETS 65536u
/* Bins of the slab quantiles along the axis. */
#define SLAB_BINS 4096u
/* Tail passes (one global order, one thread) once fewer collapses than
 * this many per slab are needed. */
#define TAIL_PER_PARTITION 64
/* Triangles per gathering block (a constant: the candidates' order must
 * not depend on the thread count). */
#define BLOCK_TRIANGLES 4096
/* Edges per call of the vectorised cost planner: gathering, planning. */
#define GATHER_BATCH 256
#define PLAN_BATCH 64
/* How many candidates ahead the three prefetch stages of
 * mr_collapse_prefetch run (as batched.c's). */
#define PF0 6
#define PF1 4
#define PF2 2

/* pure[] bit: counted in the room bound of this pass (a scratch mark). */
#define SEEN 2u

/* A candidate edge (a, b) -- a the end whose slab gathered it -- and the
 * bits of its (float) cost. */
typedef struct pcand {
    uint32_t key, a, b;
} pcand;

/* A candidate's planned collapse: r goes, k stays, at target. */
typedef struct pplan {
    double target[3];
    double cost;
    uint32_t r, k;
} pplan;

/* A collapse a claim walk accepted (partitioned_boundary.c): r goes, k
 * stays, at target; off: where its merged list goes among its batch's
 * (the sum of the refs room of the collapses before it in the batch). */
typedef struct paccept {
    double target[3];
    double cost;
    uint32_t r, k;
    size_t off;
} paccept;

/* The collapses one claim walk accepted, applied together. */
typedef struct pbatch {
    paccept *acc;
    size_t n, cap;
    size_t need;          /* their refs room: sum of count[r] + count[k] - 1 */
} pbatch;

/* One slab's state in a pass. */
typedef struct pslab {
    pplan *plan;          /* plan[i]: candidate buf[i]'s (interior ones) */
    size_t pcap;
    pcand *buf;           /* its candidates: interior ones in buf[0..nin),
                             the others in buf[c1 - nbd .. c1); a slab's a
                             slice of arena_buf, a shifted slab's its own */
    pcand *tmp;           /* a slab's radix sort scratch (of arena_tmp,
                             c1 long) */
    size_t cap;           /* a shifted slab's buf size */
    size_t c1;            /* this pass's bound on its candidates */
    size_t nin, nbd;
    size_t next;          /* interior: the next candidate to try */
    size_t demand;        /* refs room bound of what is left */
    size_t room0, room1;  /* its room in refs this step, [room0, room1) */
    size_t qv, qt;        /* quotas: vertices, triangles */
    size_t gone, deleted, made, refused;
    double worst;
    bool paused, quota_hit;
    size_t gathered;      /* interior candidates gathered (before the
                             threshold): the load-imbalance trigger's */
    size_t deferred;      /* claims: candidates whose neighbourhood met a
                             claimed one (kept in buf[0..keep), with their
                             plans, for the next round) */
    size_t keep;
} pslab;

/* What the partitioned strategies count (mr_simplify_stats' fields). */
typedef struct mr_partition_profile {
    size_t passes, interior, boundary, boundary_seq, tail, rebalances;
    size_t deferred;     /* the boundary-aware variant's claim conflicts */
    size_t trigger[4];   /* its rebalances by trigger (MR_TRIGGER_*) */
} mr_partition_profile;

/* The boundary-aware variant's rebalance triggers, as counted. */
enum { MR_TRIGGER_COUNT, MR_TRIGGER_IMBALANCE, MR_TRIGGER_BOUNDARY, MR_TRIGGER_ACCEPTANCE };

typedef struct mr_partitioned {
    mr_partition_profile profile; /* this run's counts */
    unsigned parts;
    int threads;
    uint16_t *part;       /* per vertex: its slab */
    uint16_t *part2;      /* per vertex: its shifted slab (parts + 1 of
                             them, planes halfway between part's) */
    pslab *slab2;         /* parts + 1: the boundary step's slabs */
    uint8_t *in2;         /* per boundary candidate: interior to a shifted
                             slab */
    uint32_t *impure;     /* per vertex: the gathering (gen) at which one of
                             its triangles was found to span slabs */
    uint32_t gen;         /* the gatherings so far */
    pcand *bcand;         /* the gathering's blocks: 3 * BLOCK_TRIANGLES
                             candidates each */
    size_t nblocks;
    uint32_t *bcount;     /* per block: candidates; then per block and slab
                             (2 * parts): interior and boundary counts, then
                             their offsets in the slab's list */
    size_t in2_cap;
    uint8_t *pure;        /* per vertex: SEEN */
    uint8_t *mark;        /* per vertex: an end of a collapse of this pass */
    pslab *slab;          /* parts; their buf and tmp are slices of: */
    pcand *arena_buf, *arena_tmp; /* one block each for all slabs (one
                             allocation, on huge pages, instead of 2 *
                             parts small ones page-faulted 4 KiB at a time) */
    size_t arena_cap;
    pcand *seq, *seq_tmp; /* the boundary (or tail) candidates, merged;
                             the radix sort's scratch */
    size_t seq_cap, seq_tmp_cap;
    uint32_t *hist;       /* HIST_BUCKETS per thread */
    size_t balanced_live; /* live vertices at the last balance */
    /* partitioned_boundary.c's */
    uint8_t *claim;       /* per vertex: CLAIM_* bits of this round, or
                             NULL (the partitioned strategy) */
    pbatch bbatch;        /* the boundary pass's accepted collapses */
    pplan *bplan;         /* per merged boundary candidate: its plan, */
    uint8_t *bstate;      /* and its test (partitioned_boundary.c's B_*) */
    size_t bcap;
} mr_partitioned;

/* claim[] bits: an end of an accepted collapse; in the closed 1-ring of
 * one (an end is in its own). */
#define CLAIM_END 1u
#define CLAIM_RING 2u

/* Runs the block with t set to each live triangle of a and then of b (a
 * list may hold deleted triangles: skipped). */
#define MR_FOR_EACH_RING_TRIANGLE(m, a, b, t, ...)                                      \
    do {                                                                               \
        const uint32_t e_[2] = {(a), (b)};                                             \
        for (int j_ = 0; j_ < 2; j_++) {                                               \
            const uint32_t *list_ = mr_collapse_vertex_tris((m), e_[j_]);              \
            for (uint32_t i_ = 0, n_ = (m)->count[e_[j_]]; i_ < n_; i_++) {            \
                const uint32_t *t = (m)->tris + (list_[i_] - list_[i_] % 3);           \
                if (t[0] == NONE)                                                      \
                    continue;                                                          \
                __VA_ARGS__                                                            \
            }                                                                          \
        }                                                                              \
    } while (0)

/* Is collapse (a, b) free of the claims: neither end claimed (an end of
 * an accepted collapse, or in the closed 1-ring of one), and no claimed
 * end among the vertices of their triangles? */
static inline bool mr_claim_free(const mr_collapse_mesh *m, const uint8_t *claim, uint32_t a,
                                 uint32_t b)
{
    if (claim[a] | claim[b])
        return false;
    MR_FOR_EACH_RING_TRIANGLE(m, a, b, t, {
        if ((claim[t[0]] | claim[t[1]] | claim[t[2]]) & CLAIM_END)
            return false;
    });
    return true;
}

/* Claim collapse (a, b)'s ends and the vertices of their triangles (before
 * it is applied). */
static inline void mr_claim_take(const mr_collapse_mesh *m, uint8_t *claim, uint32_t a,
                                 uint32_t b)
{
    MR_FOR_EACH_RING_TRIANGLE(m, a, b, t, {
        claim[t[0]] |= CLAIM_RING;
        claim[t[1]] |= CLAIM_RING;
        claim[t[2]] |= CLAIM_RING;
    });
    claim[a] = claim[b] = CLAIM_END | CLAIM_RING;
}

/* ---- partitioned_boundary.c's rebalance triggers (counts only) */
#define MR_TRIGGER_IMBALANCE_RATIO 1.5
#define MR_TRIGGER_BOUNDARY_GROWTH 1.25
#define MR_TRIGGER_ACCEPT_DROP 0.5

typedef struct mr_part_triggers {
    size_t live;          /* live vertices at the last balance */
    unsigned passes;      /* passes since */
    double bfrac, accept; /* the first pass's boundary fraction and
                             acceptance rate */
} mr_part_triggers;

/* After a pass (not a tail pass) with `live` vertices left: the trigger
 * (MR_TRIGGER_*) that asks for a rebalance, or -1. The pass gathered
 * `gathered` candidates, nbd of them across slabs (the slabs' own counts
 * in slabs[p].gathered), and made `made` collapses of the `walked`
 * interior ones it walked. The first pass after a balance sets the
 * reference rates and never fires. */
int mr_part_trigger(mr_part_triggers *tr, size_t live, const pslab *slabs, unsigned parts,
                    size_t gathered, size_t nbd, size_t walked, size_t made);

/* ---- partitioned.c, used by both */
mr_status mr_part_start(mr_simplifier *s, mr_error *err);
void mr_part_release(mr_simplifier *s);
/* Add a run's counts to s->profile. */
void mr_part_add_profile(mr_simplifier *s, const mr_partition_profile *p);
void mr_part_balance(mr_simplifier *s);
void mr_part_quotas(const mr_simplifier *s, const mr_simplify_goal *g, pslab *sl, size_t ns,
                    size_t all);
size_t mr_part_sequential(mr_simplifier *s, size_t n, const mr_simplify_goal *g,
                          double *worst);
/* The boundary (all, in a tail pass) candidates of every slab, merged in
 * one (cost, edge id) order in seq; returns their number, or SIZE_MAX
 * when out of memory. */
size_t mr_part_merge(mr_simplifier *s, bool tail);

/* What a pass's start found (mr_part_begin). */
typedef struct mr_part_pass {
    size_t n;        /* candidates gathered */
    size_t nbd_all;  /* of those across slabs */
    size_t nin, nbd; /* under the pass's threshold: interior, across */
    bool tail;       /* a tail pass: every candidate in one order */
} mr_part_pass;

/* A pass's start, the same in both strategies: gather, the cost threshold
 * (the goal-th cheapest key -- goal: the collapses still needed, times
 * `share` -- times PASS_SLACK), each slab's selection, the marks cleared.
 * A tail pass when force_tail or few collapses are left. False when
 * nothing is left to gather or memory ran out: the run ends. */
bool mr_part_begin(mr_simplifier *s, const mr_simplify_goal *g, double share, bool force_tail,
                   mr_part_pass *ps);

/* Report progress once `done` collapses pass *next (then moved on a
 * hundredth of the plan); true when the callback asked to stop. */
static inline bool mr_part_progress(mr_simplifier *s, const mr_simplify_goal *g, size_t done,
                                    size_t *next)
{
    if (!s->plan.progress || done < *next)
        return false;
    *next = done + g->planned / 100 + 1;
    return mr_simplifier_progress(s, g->planned ? (double)done / (double)g->planned : 1.0);
}

/* After a pass that made `made` collapses: false when the run is over
 * (nothing valid was left under the threshold, and it held every
 * candidate); else the next pass's share of the goal (widened 4x after a
 * pass that made nothing: the cheapest were all invalid). */
static inline bool mr_part_next(size_t made, const mr_part_pass *ps, double *share)
{
    if (made) {
        *share = 1.0;
        return true;
    }
    *share *= 4;
    return ps->nin + ps->nbd < ps->n;
}
/* The slabs sl[0..ns) apply their sorted, planned candidates concurrently,
 * each in its order on the mesh as it stands (with claims when pt->claim:
 * the ones a claim defers are kept, see pslab.keep); room in refs by
 * prefix sums. Returns the collapses made. */
size_t mr_part_apply_slabs(mr_simplifier *s, pslab *slabs, size_t ns, double limit,
                           double *worst, bool *quota_hit);
/* Slab sl's candidates buf[0..keep) for another round: nin = keep, and
 * its refs room bound anew (the plans stay: their ends have not moved). */
void mr_part_next_round(mr_simplifier *s, pslab *sl);

/* For the tests: vertex v's slab (or shifted slab), whether edge (a, b)
 * is interior to a shifted slab (the boundary step's test), and the
 * candidates a pass of the partitioned strategy would gather now (no cost
 * limit), each with whether it is interior; returns their number (at most
 * cap are stored). */
unsigned mr_partitioned_slab(const mr_simplifier *s, uint32_t v, bool shifted_slabs);
bool mr_partitioned_shifted_interior(const mr_simplifier *s, uint32_t a, uint32_t b);
size_t mr_partitioned_edges(mr_simplifier *s, uint32_t *a, uint32_t *b, uint8_t *interior,
                            size_t cap);

#endif /* MR_QEM_PARTITIONED_H */
