/*
 * Checks shared by the tests of the concurrent priority queues (PPQ, RPPQ,
 * FPPQ, MultiQueue): a queue is seen through a table of its operations.
 */
#ifndef MR_QUEUE_CHECK_H
#define MR_QUEUE_CHECK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct tq_queue {
    void *q;
    uint32_t capacity; /* ids 0 .. capacity - 1 */
    /* rng: the calling thread's generator state (for the MultiQueue) */
    bool (*insert)(void *q, uint32_t id, float key, uint64_t *rng);
    bool (*update)(void *q, uint32_t id, float key, uint64_t *rng);
    bool (*remove)(void *q, uint32_t id);
    /* the packed element (mr_heap's order) into *item; thread: the
     * caller's number (relaxed pops may start their search from it) */
    bool (*pop)(void *q, int thread, uint64_t *rng, uint64_t *item);
    size_t (*size)(const void *q);
    bool (*check)(const void *q); /* invariants, with nothing running */
} tq_queue;

/* MR_TEST_QUICK is set (the sanitizer stages): shrink the runs. */
bool tq_quick(void);

/* (mr_heap_key_bits(key) << 32) | id: the order every queue keeps. */
uint64_t tq_pack(uint32_t id, float key);

/* One of 64 keys (ties are common): -inf, -0, +0, +inf, NaN and halves
 * from -14.5 to 14.5. */
float tq_key(unsigned index);

/* One thread: `ops` random inserts, updates, removes and pops against a
 * brute-force model and mr_heap, then a drain. exact: every pop is the one
 * mr_heap_pop makes; else it must be an element the model holds. */
void tq_model_run(const tq_queue *t, unsigned ops, bool exact, uint64_t seed);

/*
 * `threads` threads (oversubscribed on purpose), `rounds` rounds of `ops`
 * random operations each, the invariants checked at the barrier after
 * each round, then a drain. disjoint ids (each thread updates, inserts and
 * removes only its own ids; any thread pops anything): the multiset of
 * popped and drained elements must be exactly the versions that were
 * popped or are left -- known from what each update, insert and remove
 * returned. Overlapping ids (every thread uses every id): for each id,
 * inserts = removes + pops, and every popped key was written to that id.
 */
void tq_concurrent_run(const tq_queue *t, int threads, unsigned rounds, unsigned ops,
                       bool overlap, uint64_t seed);

/* fn(ctx, threads, overlap, seed) at 2, 3 and 8 threads (8 on 2 cores on
 * purpose), each with disjoint and with overlapping ids; the seeds differ. */
typedef void (*tq_case_fn)(void *ctx, int threads, bool overlap, uint64_t seed);
void tq_thread_cases(tq_case_fn fn, void *ctx, uint64_t seed);

/* Ids, rounds and operations a round for tq_concurrent_run (fewer under
 * MR_TEST_QUICK). */
typedef struct tq_sizes {
    uint32_t ids;
    unsigned rounds, ops;
} tq_sizes;
tq_sizes tq_concurrent_sizes(void);

/* Sorting packed elements. */
int tq_cmp_u64(const void *a, const void *b);

#endif
