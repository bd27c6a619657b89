/*
 * FPPQ: the parallel priority queue with filter levels (the filter-level
 * queue paper, section 3.2). Internal.
 *
 * A PPQ (ppq.h: the same engine, locks, lookup table and element order)
 * whose slots follow Table 1 of the paper (filter_layout.h): l_f filter
 * levels of w = 2^l_f nodes each lie below the l_f + 1 top levels, every
 * filter node has two parents, and an element bubbling up is compared with
 * the worse of them (Fig. 2). Then every element of the n_t = 2^(l_f+1) - 1
 * top nodes is among the k = l_f * 2^l_f + 1 best elements of the queue
 * (eq. 2, Table 2: k = 3, 9, 25, 65, 161 for l_f = 1 .. 5), and a pop may
 * take any unlocked top node: it tries the root first, then the next top
 * node, and so on, round and round until it gets one.
 *
 * Memory: as the PPQ, 13 bytes per id of capacity.
 *
 * Concurrency contract: the PPQ's (ppq.h) -- insert, update, remove and pop
 * run concurrently on any ids and are linearizable; mr_fppq_pop removes, at
 * its instant, the element of an unlocked top node, so of rank below k
 * (0 = the smallest) among the elements present then. With nothing else
 * running the root is never locked and a pop returns the smallest element,
 * exactly as mr_heap_pop would. Read/write sets: the PPQ's.
 *
 * Decisions, where the paper leaves it open:
 *   - Default filter levels for t threads (mr_fppq_default_levels): the
 *     paper picks l_f = 4 for 32 threads "because ... this results in
 *     n_t = 31 top nodes"; so a top node for each of the other t - 1
 *     threads: the smallest l_f >= 1 with n_t + 1 = 2^(l_f+1) >= t
 *     (1 for up to 4 threads, 2 up to 8, 3 up to 16, 4 up to 32, 5 up to
 *     64). Reading it as n_t >= t would give 5 for 32 threads, against the
 *     paper's own choice.
 *   - The paper's pop fills the hole with the last element and bubbles it
 *     down; below the root the last element may be smaller than the hole's
 *     parents, and then it bubbles up instead (as the sequential heap's
 *     removal does).
 */
#ifndef MR_FPPQ_H
#define MR_FPPQ_H

#include "ppq.h"

typedef struct mr_fppq {
    mr_ppq heap; /* heap.layout.levels filter levels */
} mr_fppq;

/* Filter levels for a number of threads (see the decisions above). */
unsigned mr_fppq_default_levels(int threads);

/* n_t and k for l_f filter levels. */
static inline uint32_t mr_fppq_top_nodes(unsigned levels) { return (2u << levels) - 1; }
static inline size_t mr_fppq_guarantee(unsigned levels)
{
    return ((size_t)levels << levels) + 1;
}

/* An empty queue for ids below capacity with 1 .. MR_FILTER_MAX_LEVELS
 * filter levels. On failure the queue is empty and safe to free. */
mr_status mr_fppq_init(mr_fppq *q, size_t capacity, unsigned levels, mr_error *err);
void mr_fppq_free(mr_fppq *q);

/* As mr_ppq_insert, _update, _remove and _build. */
static inline bool mr_fppq_insert(mr_fppq *q, uint32_t id, float key)
{
    return mr_ppq_insert(&q->heap, id, key);
}
static inline bool mr_fppq_update(mr_fppq *q, uint32_t id, float key)
{
    return mr_ppq_update(&q->heap, id, key);
}
static inline bool mr_fppq_remove(mr_fppq *q, uint32_t id)
{
    return mr_ppq_remove(&q->heap, id);
}
static inline void mr_fppq_build(mr_fppq *q, const uint32_t *ids, const float *keys, size_t n)
{
    mr_ppq_build(&q->heap, ids, keys, n);
}

/* Remove the element of an unlocked top node, trying the root first, into
 * *id and *key; false when the queue is empty. */
static inline bool mr_fppq_pop(mr_fppq *q, uint32_t *id, float *key)
{
    return mr_ppq_pop_relaxed(&q->heap, q->heap.layout.top, 0, id, key);
}
/* The same, trying top node first % n_t first (tests use it to pop below
 * the root without contention). */
static inline bool mr_fppq_pop_from(mr_fppq *q, uint32_t first, uint32_t *id, float *key)
{
    return mr_ppq_pop_relaxed(&q->heap, q->heap.layout.top, first, id, key);
}

static inline size_t mr_fppq_size(const mr_fppq *q) { return mr_ppq_size(&q->heap); }
static inline bool mr_fppq_check(const mr_fppq *q) { return mr_ppq_check(&q->heap); }

#endif /* MR_FPPQ_H */
