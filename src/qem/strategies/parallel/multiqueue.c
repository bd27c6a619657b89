/* MultiQueue with mutable priorities: see multiqueue.h. */
#include "multiqueue.h"

static inline uint64_t next_random(uint64_t *s)
{
    *s += UINT64_C(0x9e3779b97f4a7c15);
    return mr_mix64(*s);
}

/* Uniform in 0 .. n - 1 (n >= 1). */
static inline uint32_t random_below(uint64_t *s, uint32_t n)
{
    return (uint32_t)(((next_random(s) >> 32) * n) >> 32);
}

uint64_t mr_multiqueue_seed(uint64_t seed, int thread)
{
    return mr_mix64(seed ^ mr_mix64((uint64_t)(uint32_t)thread + 1));
}

mr_status mr_multiqueue_init(mr_multiqueue *q, size_t capacity, int threads,
                             unsigned per_thread, mr_error *err)
{
    memset(q, 0, sizeof *q);
    if (capacity >= UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "MultiQueue of %zu ids", capacity);
    /* the threads that will use it, as asked (not the team a region
     * opened here could have: the caller's threads drive it) */
    const uint64_t count = (uint64_t)(threads > 0 ? threads : mr_thread_count(0)) *
                           (per_thread ? per_thread : 2);
    if (count > MR_MQ_MAX_QUEUES)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "%llu queues (at most %u)", (unsigned long long)count,
                             MR_MQ_MAX_QUEUES);
    /* room for twice the capacity in all (at least the capacity in one) */
    uint64_t room = 2 * ((capacity + count - 1) / count) + 8;
    if (room > capacity)
        room = capacity ? capacity : 1;
    const unsigned pos_bytes = room < 0xffffffu ? 3 : 4;
    const size_t ids = capacity ? capacity : 1;
    q->queues = aligned_alloc(64, (size_t)count * sizeof *q->queues);
    q->owner = mr_calloc_array(ids, sizeof *q->owner); /* 0: absent */
    q->pos = mr_alloc_array(ids, pos_bytes);
    q->slots = mr_alloc_array((size_t)(count * room), sizeof *q->slots);
    if (!q->queues || !q->owner || !q->pos || !q->slots) {
        mr_multiqueue_free(q);
        return mr_fail_nomem(err, NULL, (size_t)(count * (room * 8 + sizeof *q->queues)) +
                                            ids * (pos_bytes + sizeof *q->owner));
    }
    memset(q->pos, 0xff, ids * pos_bytes); /* every id absent */
    for (uint32_t i = 0; i < count; i++) {
        mr_mq_queue *m = &q->queues[i];
        memset(m, 0, sizeof *m);
        atomic_init(&m->lock, 0);
        atomic_init(&m->top, MR_MQ_EMPTY);
        atomic_init(&m->size, 0);
        mr_heap_attach(&m->heap, q->slots + (size_t)i * room, room, q->pos, pos_bytes, capacity);
    }
    q->count = (uint32_t)count;
    q->room = (uint32_t)room;
    q->capacity = (uint32_t)capacity;
    return MR_OK;
}

void mr_multiqueue_free(mr_multiqueue *q)
{
    if (!q)
        return;
    free(q->queues);
    free(q->owner);
    free(q->pos);
    free(q->slots);
    memset(q, 0, sizeof *q);
}

/* After a change, under the queue's lock. */
static inline void refresh_top(mr_mq_queue *m)
{
    atomic_store_explicit(&m->top, m->heap.size ? m->heap.items[0] : MR_MQ_EMPTY,
                          memory_order_relaxed);
    atomic_store_explicit(&m->size, m->heap.size, memory_order_relaxed);
}

static inline uint16_t owner_of(const mr_multiqueue *q, uint32_t id)
{
    return atomic_load_explicit(&q->owner[id], memory_order_acquire);
}

static bool claim(mr_multiqueue *q, uint32_t id)
{
    uint16_t absent = 0;
    return atomic_compare_exchange_strong_explicit(&q->owner[id], &absent, MR_MQ_CLAIMED,
                                                   memory_order_acq_rel, memory_order_relaxed);
}

/* Into a random queue with room; the id is claimed. */
static void insert_claimed(mr_multiqueue *q, uint32_t id, float key, uint64_t *rng)
{
    mr_spin spin = MR_SPIN_INIT;
    for (;;) {
        const uint32_t i = random_below(rng, q->count);
        mr_mq_queue *m = &q->queues[i];
        if (mr_vlock_try(&m->lock)) {
            if (m->heap.size < q->room) {
                mr_heap_push(&m->heap, id, key);
                atomic_store_explicit(&q->owner[id], (uint16_t)(i + 1), memory_order_release);
                refresh_top(m);
                mr_vlock_unlock(&m->lock);
                return;
            }
            mr_vlock_unlock(&m->lock);
        }
        mr_spin_wait(&spin);
    }
}

/* Lock the queue holding id and return it; NULL when id is absent. */
static mr_mq_queue *lock_owner(mr_multiqueue *q, uint32_t id)
{
    mr_spin spin = MR_SPIN_INIT;
    for (;;) {
        const uint16_t o = owner_of(q, id);
        if (o == 0)
            return NULL;
        if (o == MR_MQ_CLAIMED) {
            mr_spin_wait(&spin);
            continue;
        }
        mr_mq_queue *m = &q->queues[o - 1];
        mr_vlock_lock(&m->lock);
        /* the owner entry changes only under its queue's lock */
        if (atomic_load_explicit(&q->owner[id], memory_order_relaxed) == o)
            return m;
        mr_vlock_unlock(&m->lock);
    }
}

bool mr_multiqueue_insert(mr_multiqueue *q, uint32_t id, float key, uint64_t *rng)
{
    if (!claim(q, id))
        return false;
    insert_claimed(q, id, key, rng);
    return true;
}

bool mr_multiqueue_update(mr_multiqueue *q, uint32_t id, float key, uint64_t *rng)
{
    for (;;) {
        mr_mq_queue *m = lock_owner(q, id);
        if (m) {
            mr_heap_update(&m->heap, id, key);
            refresh_top(m);
            mr_vlock_unlock(&m->lock);
            return false;
        }
        if (claim(q, id)) {
            insert_claimed(q, id, key, rng);
            return true;
        }
    }
}

bool mr_multiqueue_remove(mr_multiqueue *q, uint32_t id)
{
    mr_mq_queue *m = lock_owner(q, id);
    if (!m)
        return false;
    mr_heap_remove(&m->heap, id);
    atomic_store_explicit(&q->owner[id], 0, memory_order_release);
    refresh_top(m);
    mr_vlock_unlock(&m->lock);
    return true;
}

static inline uint64_t top_of(const mr_multiqueue *q, uint32_t i)
{
    return atomic_load_explicit(&q->queues[i].top, memory_order_relaxed);
}

/* The queue with the smallest cached element, UINT32_MAX when all are
 * empty. */
static uint32_t best_queue(const mr_multiqueue *q)
{
    uint32_t best = UINT32_MAX;
    uint64_t bv = MR_MQ_EMPTY;
    for (uint32_t i = 0; i < q->count; i++) {
        const uint64_t v = top_of(q, i);
        if (v < bv) {
            bv = v;
            best = i;
        }
    }
    return best;
}

bool mr_multiqueue_pop(mr_multiqueue *q, uint64_t *rng, uint32_t *id, float *key)
{
    mr_spin spin = MR_SPIN_INIT;
    unsigned empty_picks = 0;
    for (;;) {
        uint32_t b = random_below(rng, q->count);
        if (q->count > 1) {
            uint32_t j = random_below(rng, q->count - 1);
            j += j >= b;
            if (top_of(q, j) < top_of(q, b))
                b = j;
        }
        if (top_of(q, b) == MR_MQ_EMPTY) {
            /* two empty queues: after a second such pick, look at all */
            if (++empty_picks < 2)
                continue;
            empty_picks = 0;
            b = best_queue(q);
            if (b == UINT32_MAX)
                return false;
        }
        mr_mq_queue *m = &q->queues[b];
        if (!mr_vlock_try(&m->lock)) {
            mr_spin_wait(&spin);
            continue;
        }
        if (m->heap.size == 0) {
            mr_vlock_unlock(&m->lock);
            continue;
        }
        const uint64_t item = m->heap.items[0];
        mr_heap_pop(&m->heap);
        atomic_store_explicit(&q->owner[(uint32_t)item], 0, memory_order_release);
        refresh_top(m);
        mr_vlock_unlock(&m->lock);
        if (id)
            *id = (uint32_t)item;
        if (key)
            *key = mr_heap_bits_key((uint32_t)(item >> 32));
        return true;
    }
}

size_t mr_multiqueue_size(const mr_multiqueue *q)
{
    size_t n = 0;
    for (uint32_t i = 0; i < q->count; i++)
        n += atomic_load_explicit(&q->queues[i].size, memory_order_relaxed);
    return n;
}

bool mr_multiqueue_check(const mr_multiqueue *q)
{
    size_t total = 0;
    for (uint32_t i = 0; i < q->count; i++) {
        const mr_mq_queue *m = &q->queues[i];
        const mr_heap *h = &m->heap;
        if (atomic_load_explicit(&m->lock, memory_order_relaxed) != 0 || h->size > q->room)
            return false;
        if (top_of(q, i) != (h->size ? h->items[0] : MR_MQ_EMPTY))
            return false;
        for (uint32_t s = 0; s < h->size; s++) {
            const uint32_t id = (uint32_t)h->items[s];
            if (id >= q->capacity || mr_heap_slot(h, id) != s ||
                atomic_load_explicit(&q->owner[id], memory_order_relaxed) != i + 1)
                return false;
            if (s > 0 && h->items[(s - 1) / MR_HEAP_ARITY] > h->items[s])
                return false;
        }
        total += h->size;
    }
    size_t owned = 0;
    for (uint32_t id = 0; id < q->capacity; id++)
        owned += atomic_load_explicit(&q->owner[id], memory_order_relaxed) != 0;
    return owned == total;
}
