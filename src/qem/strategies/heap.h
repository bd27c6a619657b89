/*
 * Indexed 4-ary min-heap with mutable priorities. Internal.
 *
 * Elements are ids 0 .. capacity - 1, each at most once in the heap, with a
 * float key. A position table id -> slot lets update() and remove() find
 * an element in O(1) and restore the heap order in O(log n).
 *
 * Order: by key, and among equal keys by id (smaller first), so the pop
 * order -- and everything built on it -- is deterministic. Both are packed
 * into one 64-bit word (the key's bits made order-preserving as an
 * unsigned integer in the high half, the id in the low half), so a
 * comparison is a single integer compare. NaN keys are stored as +inf.
 * Memory: 8 bytes per slot and 4 per id, or 3 per id when fewer than
 * 2^24 - 1 items can be in the heap at once (mr_heap_init_sized bounds
 * the slots; the position table then packs 24-bit positions).
 */
#ifndef MR_HEAP_H
#define MR_HEAP_H

#include "../../core/internal.h"

#include <math.h>

#define MR_HEAP_NONE UINT32_MAX

/* Children per node: a 4-ary heap is shallower than a binary one and its
 * four children share a cache line (measured faster on large queues). */
#define MR_HEAP_ARITY 4

typedef struct mr_heap {
    uint64_t *items;  /* slots 0 .. size - 1: (key bits << 32) | id */
    uint8_t *pos;     /* id -> slot, pos_bytes (3 or 4) little-endian bytes
                         each; all ones when absent */
    uint32_t pos_bytes;
    uint32_t size;
    uint32_t capacity;
    uint32_t max_size; /* slots allocated */
} mr_heap;

/* An empty heap for ids below capacity. On failure the heap is empty (safe
 * to free). */
mr_status mr_heap_init(mr_heap *h, size_t capacity, mr_error *err);
/* The same for ids below capacity of which at most max_size are in the
 * heap at once (items sized to max_size: 8 bytes per item, 4 per id). */
mr_status mr_heap_init_sized(mr_heap *h, size_t capacity, size_t max_size, mr_error *err);
/* The same with the position table's width forced (3 or 4 bytes; 0 picks
 * the smallest that fits). For tests. */
mr_status mr_heap_init_width(mr_heap *h, size_t capacity, size_t max_size, unsigned pos_bytes,
                             mr_error *err);
void mr_heap_free(mr_heap *h);
/* A heap over arrays the caller owns and frees (never mr_heap_free it):
 * items of max_size slots, pos of capacity entries of pos_bytes (3 or 4)
 * bytes, all ones (absent) for every id the heap does not hold. Several
 * heaps may share one pos table while no id is in two of them at once:
 * each heap reads and writes only its own ids' entries. */
void mr_heap_attach(mr_heap *h, uint64_t *items, size_t max_size, uint8_t *pos,
                    unsigned pos_bytes, size_t capacity);

/* id -> slot, MR_HEAP_NONE when absent. */
static inline uint32_t mr_heap_slot(const mr_heap *h, uint32_t id)
{
    if (h->pos_bytes == 3) {
        const uint8_t *p = h->pos + 3 * (size_t)id;
        const uint32_t v = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16;
        return v == 0xffffffu ? MR_HEAP_NONE : v;
    }
    uint32_t v;
    memcpy(&v, h->pos + 4 * (size_t)id, sizeof v);
    return v;
}

static inline void mr_heap_set_slot(mr_heap *h, uint32_t id, uint32_t slot)
{
    if (h->pos_bytes == 3) {
        uint8_t *p = h->pos + 3 * (size_t)id;
        p[0] = (uint8_t)slot;
        p[1] = (uint8_t)(slot >> 8);
        p[2] = (uint8_t)(slot >> 16);
        return;
    }
    memcpy(h->pos + 4 * (size_t)id, &slot, sizeof slot);
}

/* Keys <-> order-preserving unsigned bits (-0 < +0 is harmless). */
static inline uint32_t mr_heap_key_bits(float key)
{
    uint32_t b;
    if (key != key)
        key = INFINITY;
    memcpy(&b, &key, sizeof b);
    return (b & 0x80000000u) ? ~b : (b | 0x80000000u);
}

static inline float mr_heap_bits_key(uint32_t b)
{
    b = (b & 0x80000000u) ? (b & 0x7fffffffu) : ~b;
    float key;
    memcpy(&key, &b, sizeof key);
    return key;
}

static inline bool mr_heap_contains(const mr_heap *h, uint32_t id)
{
    return mr_heap_slot(h, id) != MR_HEAP_NONE;
}

static inline bool mr_heap_empty(const mr_heap *h) { return h->size == 0; }

/* Key of an element in the heap. */
static inline float mr_heap_key(const mr_heap *h, uint32_t id)
{
    return mr_heap_bits_key((uint32_t)(h->items[mr_heap_slot(h, id)] >> 32));
}

/* The smallest element without removing it; the heap must not be empty. */
static inline uint32_t mr_heap_top(const mr_heap *h) { return (uint32_t)h->items[0]; }
static inline float mr_heap_top_key(const mr_heap *h)
{
    return mr_heap_bits_key((uint32_t)(h->items[0] >> 32));
}

/* Bulk build: append items with mr_heap_append (no order kept, at most
 * max_size of them, into an empty heap), then mr_heap_heapify orders them
 * in O(n). */
static inline void mr_heap_append(mr_heap *h, uint32_t id, float key)
{
    h->items[h->size++] = ((uint64_t)mr_heap_key_bits(key) << 32) | id;
}
void mr_heap_heapify(mr_heap *h);

/* Insert id (not in the heap) with a key. */
void mr_heap_push(mr_heap *h, uint32_t id, float key);

/* Remove and return the smallest element; the heap must not be empty. */
uint32_t mr_heap_pop(mr_heap *h);

/* Change the key of id, inserting it when absent. */
void mr_heap_update(mr_heap *h, uint32_t id, float key);

/* Remove id when present. */
void mr_heap_remove(mr_heap *h, uint32_t id);

#endif /* MR_HEAP_H */
