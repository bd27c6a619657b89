/*
 * MultiQueue: a relaxed concurrent priority queue (Rihani, Sanders and
 * Dementiev, SPAA 2015), with mutable priorities. Internal.
 *
 * c * t sequential heaps (src/qem/heap.h; c queues per thread, 2 by
 * default), each behind a lock. An insert puts the element into a random
 * queue; a pop looks at the smallest elements of two random queues and
 * removes the better one. Elements are ids 0 .. capacity - 1, each at most
 * once in the whole MultiQueue, ordered as mr_heap orders them (key, ties
 * by the smaller id, NaN as +inf).
 *
 * Mutable priorities: an owner table id -> queue says which heap holds an
 * id, so update and remove go straight to that heap and change it there
 * (mr_heap_update, mr_heap_remove): exact, with no stale copies to skip and
 * no memory that grows with the number of updates -- unlike lazy deletion
 * with version stamps. The heaps share one lookup table id -> slot (each
 * writes only its own ids' entries).
 *
 * Randomness comes from the caller's per-thread generator state (a
 * uint64_t seeded by mr_multiqueue_seed), never from a shared one.
 *
 * Memory, allocated once by mr_multiqueue_init: per id of capacity, 2 bytes
 * (owner) + 3 (slot; 4 when a queue holds 2^24 - 1 or more) + 16 (heap
 * slots: the queues together have room for twice the capacity, so an
 * insert always finds a queue with room among random picks); and 128 bytes
 * per queue.
 *
 * Concurrency contract
 *   - insert, update, remove and pop may run at the same time from any
 *     threads, on any ids (the same id included); each takes effect at one
 *     instant (under one queue's lock) between call and return.
 *   - pop removes the smallest element of one queue: of the better of two
 *     random queues' smallest elements, read without their locks, then the
 *     better queue's lock taken (if another thread holds it, two new
 *     queues). No rank bound holds for every pop; the expected rank is
 *     O(c * t) (the MultiQueue paper). With one queue (c * t = 1) pop is
 *     exact: the smallest element, as mr_heap_pop.
 *   - pop returns false when every queue was seen empty in one sweep (exact
 *     when no insert runs at the same time).
 *   - size is a sum of per-queue snapshots; check, init and free run alone.
 *   - Blocking, deadlock-free: no thread holds two queue locks at once.
 *
 * Read/write sets: an operation writes only the one queue whose lock it
 * holds (its heap, its smallest-element cache, the shared slot table's
 * entries of that queue's ids) and the owner entry of the id it inserts or
 * removes; pop reads two (or, to find out the MultiQueue is empty, all)
 * queues' smallest-element caches without their locks.
 *
 * Decision: a queue's room is fixed at init (no allocation while threads
 * run, so no operation can fail): an insert that picks a full queue picks
 * again. That makes the insert's choice slightly less than uniform when
 * some queues are full, which needs half the MultiQueue's elements in a
 * quarter of its queues.
 */
#ifndef MR_MULTIQUEUE_H
#define MR_MULTIQUEUE_H

#include "../../../core/internal.h"
#include "../heap.h"
#include "vlock.h"

#include <stdatomic.h>

#define MR_MQ_EMPTY UINT64_MAX /* a queue's cached smallest element when empty */
#define MR_MQ_CLAIMED 0xffffu  /* owner entry while an insert of the id runs */
#define MR_MQ_MAX_QUEUES 65534u

typedef union mr_mq_queue {
    struct {
        mr_vlock lock;
        _Atomic uint64_t top;  /* heap's smallest packed element or MR_MQ_EMPTY;
                                  written under the lock, read without */
        _Atomic uint32_t size; /* heap's size, the same way */
        mr_heap heap;
    };
    char pad[128]; /* one queue per two cache lines: no false sharing */
} mr_mq_queue;

typedef struct mr_multiqueue {
    mr_mq_queue *queues;
    uint32_t count;          /* c * t */
    uint32_t room;           /* heap slots per queue */
    uint32_t capacity;
    _Atomic uint16_t *owner; /* id -> queue + 1; 0 absent; MR_MQ_CLAIMED */
    uint8_t *pos;            /* id -> slot in its queue's heap, shared */
    uint64_t *slots;         /* the heaps' items, room per queue */
} mr_multiqueue;

/* An empty MultiQueue for ids below capacity with per_thread (0: 2) queues
 * for each of threads (0: all cores) threads. On failure it is empty and
 * safe to free. */
mr_status mr_multiqueue_init(mr_multiqueue *q, size_t capacity, int threads,
                             unsigned per_thread, mr_error *err);
void mr_multiqueue_free(mr_multiqueue *q);

/* A generator state for one thread: mr_multiqueue_seed(seed, thread). */
uint64_t mr_multiqueue_seed(uint64_t seed, int thread);

/* Insert id with key when absent (into a random queue); false, and nothing
 * changed, when id is present. */
bool mr_multiqueue_insert(mr_multiqueue *q, uint32_t id, float key, uint64_t *rng);
/* Set the key of id in its queue, inserting it when absent; true when it
 * was inserted. */
bool mr_multiqueue_update(mr_multiqueue *q, uint32_t id, float key, uint64_t *rng);
/* Remove id; true when it was present. */
bool mr_multiqueue_remove(mr_multiqueue *q, uint32_t id);
/* Remove the smallest element of the better of two random queues into *id
 * and *key; false when the MultiQueue is empty. */
bool mr_multiqueue_pop(mr_multiqueue *q, uint64_t *rng, uint32_t *id, float *key);

size_t mr_multiqueue_size(const mr_multiqueue *q);

/* Every heap's order and slot table, the owner table and the caches; for
 * tests, with nothing running. */
bool mr_multiqueue_check(const mr_multiqueue *q);

#endif /* MR_MULTIQUEUE_H */
