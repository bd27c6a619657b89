/*
 * PPQ: a concurrent heap-based priority queue with mutable priorities, after
 * Tamir, Morrison and Rinetzky (OPODIS 2015), as the filter-level queue
 * paper (section 2.2) describes it; with RPPQ, its relaxed pop. Internal.
 *
 * Elements are ids 0 .. capacity - 1, each at most once in the queue, with a
 * float key. They are ordered as the sequential heap orders them
 * (src/qem/heap.h): by the packed word (mr_heap_key_bits(key) << 32) | id,
 * so by key, ties by the smaller id, NaN as +inf. The order is total, so a
 * strict pop at one thread returns exactly what mr_heap_pop returns.
 *
 * Layout: an array heap with a lock per slot, an atomic element count and a
 * lookup table id -> slot. The same engine serves the FPPQ (fppq.h), whose
 * slots follow Table 1 of that paper (filter_layout.h); a PPQ is the layout
 * with no filter level, the binary heap.
 *
 * Memory, allocated once by mr_ppq_init (nothing is allocated later):
 * 13 bytes per id of capacity -- a slot (8: the packed element), its lock
 * (1) and the id's lookup entry (4).
 *
 * Concurrency contract
 *   - mr_ppq_insert, _update, _remove, _pop and _pop_relaxed may run at the
 *     same time from any number of threads, on any ids, the same id
 *     included. Each is linearizable: insert, update and remove take effect
 *     at one instant between call and return; mr_ppq_pop removes and
 *     returns the smallest element present at that instant (an element
 *     whose update has not taken effect yet counts with its old key).
 *   - mr_ppq_pop_relaxed (RPPQ) removes the element of one of the top `top`
 *     slots 0 .. top - 1 at its instant: the root when the root is not
 *     locked, else any unlocked one of them. Without filter levels that is
 *     no rank guarantee at all (slot 2 may hold the median); with them
 *     (FPPQ) it is the top-k guarantee of fppq.h.
 *   - mr_ppq_size and _contains are snapshots, exact only when nothing runs
 *     concurrently. mr_ppq_init, _free, _build and _check run alone.
 *   - Blocking and deadlock-free: a thread that waits for a lock holds only
 *     locks of smaller slots (locks are taken top-down), or holds none.
 *     The lookup table is changed only under the lock of the slot it names.
 *
 * Read/write sets (all under the slots' locks)
 *   - bubble-down of an element x from slot s (a larger key, or the last
 *     element moved into a hole), hand over hand: s stays locked while the
 *     smaller child is found, locked and its element moved up into s; then
 *     s is released and the child is the next s; x is written where it
 *     stops. The slots on the way are written once each (a hole moving
 *     down), so while s is held a child of s can only show a larger element
 *     than before, and the other child is read without its lock. Writes the
 *     slots on x's way and the lookup entries of the elements moved.
 *   - bubble-up (a smaller key, an insert, the last element moved into a
 *     hole above its place): first a walk without locks finds the path the
 *     element would take (at each step the worse parent, as Fig. 2 of the
 *     paper: with one parent that is the parent); then the path and every
 *     parent of a path slot are locked at once, in increasing slot order,
 *     the path is walked again under the locks (if it left them, all is
 *     released and the operation starts over), and the path's elements move
 *     one step down while the element lands at the top of the path. Writes
 *     the path slots and their elements' lookup entries.
 *   - insert also claims the slot `size` (and the count); remove and pop
 *     the last slot (moved into the hole) and the count.
 *
 * Decision, where the papers leave it open: a bubble-up one step at a time
 * (Fig. 2's recursion, each step locking a parent and the element's slot
 * and checking the element is still there) leaves an element on its way up
 * standing for a while below a parent it is smaller than, unlocked, where
 * other operations meet it. In a heap with
 * filter levels a node has two parents, and a bubble-down that passes such
 * an element upward would leave the node's other parent unchecked. Locking
 * the path at once means no element is ever seen out of order but below
 * the hole of a bubble-down: at every moment each parent-child pair is in
 * order unless a bubble-down holds the parent (and will compare what it
 * carries with that child before letting it go), which the top-k argument
 * of the filter levels relies on. The path is short (the element moves
 * only as far as its key asks) and locked top-down like everything else.
 */
#ifndef MR_PPQ_H
#define MR_PPQ_H

#include "../../../core/internal.h"
#include "../heap.h"
#include "filter_layout.h"
#include "vlock.h"

#include <stdatomic.h>

typedef struct mr_ppq {
    _Atomic uint64_t *items; /* slot -> (key bits << 32) | id */
    _Atomic uint32_t *pos;   /* id -> slot + 1; 0 absent; MR_PPQ_CLAIMED while
                                an insert of the id is under way */
    mr_vlock *locks;         /* slot -> lock */
    uint32_t capacity;
    mr_filter_layout layout;
    char pad0[64];           /* the count on a cache line of its own */
    _Atomic uint32_t size;
    char pad1[64];
} mr_ppq;

#define MR_PPQ_CLAIMED UINT32_MAX

/* An empty queue for ids below capacity (< 2^31). On failure the queue is
 * empty and safe to free. */
mr_status mr_ppq_init(mr_ppq *q, size_t capacity, mr_error *err);
/* The same with filter levels (0 .. MR_FILTER_MAX_LEVELS): the FPPQ's heap. */
mr_status mr_ppq_init_layout(mr_ppq *q, size_t capacity, unsigned filter_levels,
                             mr_error *err);
void mr_ppq_free(mr_ppq *q);

/* Fill an empty queue with n distinct ids and their keys in O(n); alone. */
void mr_ppq_build(mr_ppq *q, const uint32_t *ids, const float *keys, size_t n);

/* Insert id with key when absent; returns false (and changes nothing) when
 * id is present. */
bool mr_ppq_insert(mr_ppq *q, uint32_t id, float key);
/* Set the key of id, inserting it when absent; returns true when it was
 * inserted. */
bool mr_ppq_update(mr_ppq *q, uint32_t id, float key);
/* Remove id; returns true when it was present. */
bool mr_ppq_remove(mr_ppq *q, uint32_t id);
/* Remove the smallest element (the root) into *id and *key; false when the
 * queue is empty. */
bool mr_ppq_pop(mr_ppq *q, uint32_t *id, float *key);
/* RPPQ: remove the element of an unlocked slot among 0 .. top - 1 (top >=
 * 1), trying them in turn from slot first % top (0: the root first, as the
 * paper's pop); false when the queue is empty. */
bool mr_ppq_pop_relaxed(mr_ppq *q, uint32_t top, uint32_t first, uint32_t *id, float *key);

static inline size_t mr_ppq_size(const mr_ppq *q)
{
    return atomic_load_explicit(&q->size, memory_order_relaxed);
}

static inline bool mr_ppq_contains(const mr_ppq *q, uint32_t id)
{
    return atomic_load_explicit(&q->pos[id], memory_order_relaxed) != 0;
}

/* The heap order against every parent, the lookup table and the count; for
 * tests, with nothing running. */
bool mr_ppq_check(const mr_ppq *q);

/* The packed element at a slot below the size; for tests, with nothing
 * running. */
static inline uint64_t mr_ppq_slot_item(const mr_ppq *q, uint32_t slot)
{
    return atomic_load_explicit(&q->items[slot], memory_order_relaxed);
}

#endif /* MR_PPQ_H */
