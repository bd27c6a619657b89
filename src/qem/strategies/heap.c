/* Indexed 4-ary min-heap: see heap.h. */
#include "heap.h"

#include <math.h>

mr_status mr_heap_init_width(mr_heap *h, size_t capacity, size_t max_size, unsigned pos_bytes,
                             mr_error *err)
{
    memset(h, 0, sizeof *h);
    if (capacity >= UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "heap of %zu ids", capacity);
    if (max_size > capacity)
        max_size = capacity;
    /* 24-bit positions hold slots below 0xffffff (all ones is "absent"). */
    if (pos_bytes != 3 || max_size >= 0xffffffu)
        pos_bytes = pos_bytes == 0 && max_size < 0xffffffu ? 3 : 4;
    h->pos_bytes = pos_bytes;
    h->items = mr_alloc_array(max_size ? max_size : 1, sizeof *h->items);
    h->pos = mr_alloc_array(capacity ? capacity : 1, pos_bytes);
    if (!h->items || !h->pos) {
        mr_heap_free(h);
        return mr_fail_nomem(err, NULL, max_size * 8 + capacity * pos_bytes);
    }
    memset(h->pos, 0xff, capacity * pos_bytes); /* MR_HEAP_NONE */
    h->capacity = (uint32_t)capacity;
    h->max_size = (uint32_t)max_size;
    return MR_OK;
}

mr_status mr_heap_init_sized(mr_heap *h, size_t capacity, size_t max_size, mr_error *err)
{
    return mr_heap_init_width(h, capacity, max_size, 0, err);
}

mr_status mr_heap_init(mr_heap *h, size_t capacity, mr_error *err)
{
    return mr_heap_init_sized(h, capacity, capacity, err);
}

void mr_heap_attach(mr_heap *h, uint64_t *items, size_t max_size, uint8_t *pos,
                    unsigned pos_bytes, size_t capacity)
{
    h->items = items;
    h->pos = pos;
    h->pos_bytes = pos_bytes;
    h->size = 0;
    h->capacity = (uint32_t)capacity;
    h->max_size = (uint32_t)max_size;
}

void mr_heap_free(mr_heap *h)
{
    if (!h)
        return;
    free(h->items);
    free(h->pos);
    memset(h, 0, sizeof *h);
}

static inline uint64_t pack(uint32_t id, float key)
{
    return ((uint64_t)mr_heap_key_bits(key) << 32) | id;
}

/* Move the item at slot i up to its place; the hole moves, the item is
 * written once at the end. */
static void sift_up(mr_heap *h, uint32_t i)
{
    const uint64_t item = h->items[i];
    while (i > 0) {
        uint32_t parent = (i - 1) / MR_HEAP_ARITY;
        uint64_t p = h->items[parent];
        if (p <= item)
            break;
        h->items[i] = p;
        mr_heap_set_slot(h, (uint32_t)p, i);
        i = parent;
    }
    h->items[i] = item;
    mr_heap_set_slot(h, (uint32_t)item, i);
}

static void sift_down(mr_heap *h, uint32_t i)
{
    const uint64_t item = h->items[i];
    const uint32_t n = h->size;
    for (;;) {
        const uint32_t first = MR_HEAP_ARITY * i + 1;
        if (first >= n)
            break;
        uint32_t child = first;
        uint64_t c = h->items[first];
        const uint32_t end = n - first < MR_HEAP_ARITY ? n : first + MR_HEAP_ARITY;
        for (uint32_t j = first + 1; j < end; j++) {
            if (h->items[j] < c) {
                c = h->items[j];
                child = j;
            }
        }
        if (item <= c)
            break;
        h->items[i] = c;
        mr_heap_set_slot(h, (uint32_t)c, i);
        i = child;
    }
    h->items[i] = item;
    mr_heap_set_slot(h, (uint32_t)item, i);
}

void mr_heap_heapify(mr_heap *h)
{
    for (uint32_t i = 0; i < h->size; i++)
        mr_heap_set_slot(h, (uint32_t)h->items[i], i);
    /* from the last slot with a child down to the root (sift_down reads
     * the item at its slot: never start past the end) */
    if (h->size < 2)
        return;
    for (uint32_t i = (h->size - 2) / MR_HEAP_ARITY + 1; i-- > 0;)
        sift_down(h, i);
}

void mr_heap_push(mr_heap *h, uint32_t id, float key)
{
    uint32_t i = h->size++;
    h->items[i] = pack(id, key);
    sift_up(h, i);
}

/* Take the item out of slot i: the last item fills the hole and moves up or
 * down. */
static void remove_slot(mr_heap *h, uint32_t i)
{
    const uint32_t id = (uint32_t)h->items[i];
    mr_heap_set_slot(h, id, MR_HEAP_NONE);
    const uint32_t last = --h->size;
    if (i == last)
        return;
    const uint64_t moved = h->items[last];
    const uint64_t old = h->items[i];
    h->items[i] = moved;
    if (moved < old)
        sift_up(h, i);
    else
        sift_down(h, i);
}

uint32_t mr_heap_pop(mr_heap *h)
{
    const uint32_t id = (uint32_t)h->items[0];
    remove_slot(h, 0);
    return id;
}

void mr_heap_update(mr_heap *h, uint32_t id, float key)
{
    const uint32_t i = mr_heap_slot(h, id);
    if (i == MR_HEAP_NONE) {
        mr_heap_push(h, id, key);
        return;
    }
    const uint64_t old = h->items[i], item = pack(id, key);
    h->items[i] = item;
    if (item < old)
        sift_up(h, i);
    else if (item > old)
        sift_down(h, i);
}

void mr_heap_remove(mr_heap *h, uint32_t id)
{
    const uint32_t i = mr_heap_slot(h, id);
    if (i != MR_HEAP_NONE)
        remove_slot(h, i);
}
