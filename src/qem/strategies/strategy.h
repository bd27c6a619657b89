/*
 * The strategies: which collapses run when. Each implements these verbs
 * on the core (qem/core/simplifier.h) and reads only s->plan, never the
 * options; the entry points (qem/simplify.c, qem/mesh_simplify.c) choose
 * one by plan.strategy and own its state (s->state) through them.
 * Internal.
 */
#ifndef MR_QEM_STRATEGY_H
#define MR_QEM_STRATEGY_H

#include "../core/simplifier.h"

typedef struct mr_strategy_ops {
    /* Fill the strategy's queue or candidate arrays (s->state) from the
     * mesh as set up (mr_mesh_simplify's seams included), from clean
     * lists. Deterministic: the same input and plan give the same queue.
     * On failure the state is released. */
    mr_status (*start)(mr_simplifier *s, mr_error *err);
    /* Collapse to the plan's goal (or until nothing is allowed, or the
     * progress callback asks to stop): returns the collapses made and, in
     * *worst, the largest cost's root (a normalised distance). Counts go
     * to s->profile's fields (added: a second stage adds to the first). */
    size_t (*run)(mr_simplifier *s, double *worst);
    /* Release s->state (NULL-safe). */
    void (*release)(mr_simplifier *s);
    /* The run releases the state itself: another run needs start again. */
    bool one_run;
} mr_strategy_ops;

extern const mr_strategy_ops mr_strategy_greedy;  /* greedy.c: the sequential reference */
extern const mr_strategy_ops mr_strategy_batched; /* batched.c: the default */
extern const mr_strategy_ops mr_strategy_queued;  /* parallel/queued.c: ppq, rppq, fppq, multiqueue */
extern const mr_strategy_ops mr_strategy_partitioned;          /* partitioned.c */
extern const mr_strategy_ops mr_strategy_partitioned_boundary; /* partitioned_boundary.c */

/* Is strategy x one of the concurrent-queue ones (parallel/queued.c)? */
static inline bool mr_strategy_is_queued(int x)
{
    return x >= MR_STRATEGY_PPQ && x <= MR_STRATEGY_MULTIQUEUE;
}

#endif
