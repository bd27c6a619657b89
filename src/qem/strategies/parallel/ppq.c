/* The concurrent heap with mutable priorities (PPQ, RPPQ; the FPPQ's
 * engine): see ppq.h. */
#include "ppq.h"

/* Test builds (tests/CMakeLists.txt compiles this file into the queue tests
 * with MR_PPQ_STRESS) yield the core at the points between a read and the
 * lock that checks it, and inside locked steps, while mr_ppq_stress is set:
 * on few cores that puts other threads into those windows far more often
 * than preemption alone would. Elsewhere the points are empty. */
#ifdef MR_PPQ_STRESS
_Atomic int mr_ppq_stress;
static void stress_point(void)
{
    static _Thread_local uint32_t turn;
    if (atomic_load_explicit(&mr_ppq_stress, memory_order_relaxed) &&
        (++turn * UINT32_C(2654435761)) >> 29 == 0)
        sched_yield();
}
#else
#define stress_point() ((void)0)
#endif

/* Longest path an element can bubble up: 31 levels of a binary heap of
 * 2^31 slots and the filter rows. */
#define MAX_PATH (32 + MR_FILTER_MAX_LEVELS + 2)
/* Slots a bubble-up locks: the path, the path's parents, the last slot. */
#define MAX_REGION (3 * MAX_PATH + 1)

/* A slot outside the heap holds 0, never a packed element (the smallest
 * key bits, -inf's, are 0x007fffff): a slot's membership can be read from
 * the slot itself under its lock, without the count's cache line, which
 * every insert and removal writes. */
#define EMPTY UINT64_C(0)

static inline uint64_t pack(uint32_t id, float key)
{
    return ((uint64_t)mr_heap_key_bits(key) << 32) | id;
}

static inline uint64_t item_at(const mr_ppq *q, uint32_t s)
{
    return atomic_load_explicit(&q->items[s], memory_order_relaxed);
}

/* Write an element into a slot and point its lookup entry there; under the
 * slot's lock. */
static inline void put(mr_ppq *q, uint32_t s, uint64_t item)
{
    atomic_store_explicit(&q->items[s], item, memory_order_relaxed);
    atomic_store_explicit(&q->pos[(uint32_t)item], s + 1, memory_order_relaxed);
}

static inline uint32_t load_size(const mr_ppq *q)
{
    return atomic_load_explicit(&q->size, memory_order_relaxed);
}

static inline bool cas_size(mr_ppq *q, uint32_t from, uint32_t to)
{
    return atomic_compare_exchange_strong_explicit(&q->size, &from, to, memory_order_acq_rel,
                                                   memory_order_relaxed);
}

static inline void lock(mr_ppq *q, uint32_t s) { mr_vlock_lock(&q->locks[s]); }
static inline void unlock(mr_ppq *q, uint32_t s) { mr_vlock_unlock(&q->locks[s]); }

static inline unsigned parents_of(const mr_ppq *q, uint32_t s, uint32_t p[2])
{
    return s == 0 ? 0 : mr_filter_parents(&q->layout, s, p);
}

mr_status mr_ppq_init_layout(mr_ppq *q, size_t capacity, unsigned filter_levels,
                             mr_error *err)
{
    memset(q, 0, sizeof *q);
    if (capacity >= (size_t)1 << 31)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "concurrent queue of %zu ids",
                             capacity);
    if (filter_levels > MR_FILTER_MAX_LEVELS)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "%u filter levels (at most %d)", filter_levels,
                             MR_FILTER_MAX_LEVELS);
    const size_t n = capacity ? capacity : 1;
    /* zero bytes: every slot EMPTY, every id absent (pos 0), every lock
     * free */
    q->items = mr_calloc_array(n, sizeof *q->items);
    q->pos = mr_calloc_array(n, sizeof *q->pos);
    q->locks = mr_calloc_array(n, sizeof *q->locks);
    if (!q->items || !q->pos || !q->locks) {
        mr_ppq_free(q);
        return mr_fail_nomem(err, NULL, n * (sizeof *q->items + sizeof *q->pos + 1));
    }
    q->capacity = (uint32_t)capacity;
    q->layout = mr_filter_layout_make(filter_levels);
    atomic_init(&q->size, 0);
    return MR_OK;
}

mr_status mr_ppq_init(mr_ppq *q, size_t capacity, mr_error *err)
{
    return mr_ppq_init_layout(q, capacity, 0, err);
}

void mr_ppq_free(mr_ppq *q)
{
    if (!q)
        return;
    free(q->items);
    free(q->pos);
    free(q->locks);
    memset(q, 0, sizeof *q);
}

/* ---- bubble-down ---------------------------------------------------- */

/* The element of a child slot, UINT64_MAX when the slot is outside the
 * heap (or past the last slot). */
static inline uint64_t child_item(const mr_ppq *q, uint64_t c)
{
    if (c >= q->capacity)
        return UINT64_MAX;
    const uint64_t v = item_at(q, (uint32_t)c);
    return v == EMPTY ? UINT64_MAX : v;
}

/*
 * Holding the lock of slot s, which is to take x (no smaller than s's
 * parents, no smaller than what s shows now): move x down until no child is
 * smaller, then write it. Releases every lock, s's too.
 *
 * The slots are written as a hole moving down: each slot on the way gets
 * its final element once (its smaller child's, or x at the end), and until
 * then shows the element it had, no larger. So while s is held, what a
 * child of s shows can only grow -- whatever makes it smaller (a bubble-up
 * through it, an insert into it, a smaller element moved into its hole)
 * locks its parents, s among them, first -- or the child leaves the heap
 * (EMPTY, read as larger than anything). A child read without its lock is
 * then a lower bound of what it holds: only the smaller child is locked,
 * read again, and checked against the other one.
 */
static void sift_down(mr_ppq *q, uint32_t s, uint64_t x)
{
    /* x's lookup entry follows the hole: an operation on x waits there */
    atomic_store_explicit(&q->pos[(uint32_t)x], s + 1, memory_order_relaxed);
    for (;;) {
        const uint64_t c1 = mr_filter_child1(&q->layout, s);
        const uint64_t c2 = mr_filter_child2(&q->layout, s);
        const uint64_t v1 = child_item(q, c1), v2 = child_item(q, c2);
        const uint64_t m = v1 < v2 ? c1 : c2, other = v1 < v2 ? c2 : c1;
        if ((v1 < v2 ? v1 : v2) > x)
            break; /* no child, or none smaller */
        lock(q, (uint32_t)m);
        stress_point();
        const uint64_t v = child_item(q, m);
        if (v == UINT64_MAX || child_item(q, other) < v) {
            unlock(q, (uint32_t)m); /* it left, or the other may be smaller */
            continue;
        }
        if (v > x) {
            unlock(q, (uint32_t)m);
            break;
        }
        put(q, s, v); /* m shows v until its turn comes */
        atomic_store_explicit(&q->pos[(uint32_t)x], (uint32_t)m + 1, memory_order_relaxed);
        unlock(q, s);
        s = (uint32_t)m;
    }
    put(q, s, x);
    unlock(q, s);
}

/* ---- bubble-up ------------------------------------------------------ */

typedef struct region {
    uint32_t slot[MAX_REGION];
    unsigned n;
} region;

static void region_add(region *r, uint32_t s)
{
    if (r->n < MAX_REGION)
        r->slot[r->n++] = s;
}

/* Sort (insertion: a few dozen slots, mostly in reverse order) and drop
 * repeats. */
static void region_sort(region *r)
{
    for (unsigned i = 1; i < r->n; i++) {
        const uint32_t v = r->slot[i];
        unsigned j = i;
        for (; j > 0 && r->slot[j - 1] > v; j--)
            r->slot[j] = r->slot[j - 1];
        r->slot[j] = v;
    }
    unsigned m = 0;
    for (unsigned i = 0; i < r->n; i++)
        if (m == 0 || r->slot[m - 1] != r->slot[i])
            r->slot[m++] = r->slot[i];
    r->n = m;
}

static bool region_has(const region *r, uint32_t s)
{
    unsigned lo = 0, hi = r->n;
    while (lo < hi) {
        const unsigned mid = (lo + hi) / 2;
        if (r->slot[mid] < s)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < r->n && r->slot[lo] == s;
}

/*
 * The path of element e up from slot start: path[0] = start, then at each
 * step the worse parent while e is smaller than it. Without `locked` it
 * reads without locks and adds every slot it reads to `collect`; with it,
 * every slot read must be locked (in `locked`), else it returns false.
 */
static bool up_path(const mr_ppq *q, uint32_t start, uint64_t e, uint32_t *path, unsigned *len,
                    region *collect, const region *locked)
{
    unsigned k = 0;
    path[0] = start;
    for (uint32_t u = start;;) {
        uint32_t p[2];
        const unsigned np = parents_of(q, u, p);
        if (np == 0)
            break;
        for (unsigned j = 0; j < np; j++) {
            if (collect)
                region_add(collect, p[j]);
            if (locked && !region_has(locked, p[j]))
                return false;
        }
        uint32_t w = p[0];
        uint64_t wv = item_at(q, p[0]);
        if (np == 2) {
            const uint64_t v = item_at(q, p[1]);
            if (v > wv) {
                wv = v;
                w = p[1];
            }
        }
        if (e > wv || k + 1 == MAX_PATH)
            break;
        path[++k] = w;
        u = w;
    }
    *len = k + 1;
    return true;
}

typedef enum up_kind {
    UP_DECREASE, /* start holds `old`; e is the same id with a smaller key */
    UP_INSERT,   /* start is the first free slot; e's id is claimed */
    UP_REPLACE   /* start holds `old`, to be removed; e is the last slot's
                    element, smaller than old, moved into its place */
} up_kind;

/* Bubble e up from start as one locked step; false when the heap changed
 * under the walk without locks (the caller starts over). */
static bool bubble_up(mr_ppq *q, up_kind kind, uint32_t start, uint64_t old, uint64_t e,
                      uint32_t last)
{
    uint32_t path[MAX_PATH];
    unsigned len;
    region r;
    r.n = 0;
    up_path(q, start, e, path, &len, &r, NULL);
    for (unsigned j = 0; j < len; j++)
        region_add(&r, path[j]);
    if (kind == UP_REPLACE)
        region_add(&r, last);
    region_sort(&r);
    stress_point();
    for (unsigned j = 0; j < r.n; j++)
        lock(q, r.slot[j]);
    stress_point();

    bool ok;
    if (kind == UP_INSERT)
        ok = load_size(q) == start;
    else if (kind == UP_DECREASE)
        ok = item_at(q, start) == old;
    else
        ok = load_size(q) == last + 1 && item_at(q, start) == old && item_at(q, last) == e;
    ok = ok && up_path(q, start, e, path, &len, NULL, &r);
    if (ok && kind == UP_INSERT)
        ok = cas_size(q, start, start + 1);
    else if (ok && kind == UP_REPLACE)
        ok = cas_size(q, last + 1, last);
    if (ok) {
        if (kind == UP_REPLACE) {
            atomic_store_explicit(&q->pos[(uint32_t)old], 0, memory_order_relaxed);
            atomic_store_explicit(&q->items[last], EMPTY, memory_order_relaxed);
        }
        for (unsigned j = 1; j < len; j++)
            put(q, path[j - 1], item_at(q, path[j]));
        put(q, path[len - 1], e);
    }
    for (unsigned j = 0; j < r.n; j++)
        unlock(q, r.slot[j]);
    return ok;
}

/* ---- removal -------------------------------------------------------- */

/* Holding slot t, which holds r: remove r, the last element filling the
 * hole. Returns true when done; false when it had to let t go first and
 * then found the heap changed (r may have moved or gone: start over). Every
 * lock is released either way. */
static bool remove_held(mr_ppq *q, uint32_t t, uint64_t r)
{
    for (;;) {
        /* t is in the heap and locked, so the count stays above t */
        const uint32_t n = load_size(q), last = n - 1;
        if (last == t) {
            if (!cas_size(q, n, last))
                continue; /* an insert grew the heap */
            atomic_store_explicit(&q->pos[(uint32_t)r], 0, memory_order_relaxed);
            atomic_store_explicit(&q->items[t], EMPTY, memory_order_relaxed);
            unlock(q, t);
            return true;
        }
        stress_point();
        lock(q, last);
        if (load_size(q) != n) {
            unlock(q, last);
            continue;
        }
        const uint64_t z = item_at(q, last);
        if (z > r) {
            /* no smaller than r, so no smaller than t's parents: down */
            if (!cas_size(q, n, last)) {
                unlock(q, last);
                continue;
            }
            atomic_store_explicit(&q->pos[(uint32_t)r], 0, memory_order_relaxed);
            atomic_store_explicit(&q->items[last], EMPTY, memory_order_relaxed);
            atomic_store_explicit(&q->pos[(uint32_t)z], t + 1, memory_order_relaxed);
            unlock(q, last);
            sift_down(q, t, z); /* t shows r, smaller, until then */
            return true;
        }
        /* z goes up from t: the path above t is locked before t */
        unlock(q, last);
        unlock(q, t);
        stress_point();
        return bubble_up(q, UP_REPLACE, t, r, z, last);
    }
}

/* ---- operations ----------------------------------------------------- */

static void insert_claimed(mr_ppq *q, uint64_t e)
{
    mr_spin spin = MR_SPIN_INIT;
    while (!bubble_up(q, UP_INSERT, load_size(q), 0, e, 0))
        mr_spin_wait(&spin);
}

static bool claim(mr_ppq *q, uint32_t id)
{
    uint32_t absent = 0;
    return atomic_compare_exchange_strong_explicit(&q->pos[id], &absent, MR_PPQ_CLAIMED,
                                                   memory_order_acq_rel, memory_order_relaxed);
}

/* Lock the slot holding id and return it (its element in *item);
 * MR_PPQ_CLAIMED never, UINT32_MAX when id is absent. */
static uint32_t lock_id(mr_ppq *q, uint32_t id, uint64_t *item)
{
    mr_spin spin = MR_SPIN_INIT;
    for (;;) {
        const uint32_t p = atomic_load_explicit(&q->pos[id], memory_order_relaxed);
        if (p == 0)
            return UINT32_MAX;
        if (p == MR_PPQ_CLAIMED) {
            mr_spin_wait(&spin);
            continue;
        }
        const uint32_t s = p - 1;
        stress_point();
        lock(q, s);
        *item = item_at(q, s);
        if (*item != EMPTY && (uint32_t)*item == id)
            return s;
        unlock(q, s); /* it moved, or went */
        mr_spin_wait(&spin);
    }
}

bool mr_ppq_insert(mr_ppq *q, uint32_t id, float key)
{
    if (!claim(q, id))
        return false;
    insert_claimed(q, pack(id, key));
    return true;
}

bool mr_ppq_update(mr_ppq *q, uint32_t id, float key)
{
    const uint64_t e = pack(id, key);
    for (;;) {
        uint64_t old;
        const uint32_t s = lock_id(q, id, &old);
        if (s == UINT32_MAX) {
            if (!claim(q, id))
                continue; /* another thread inserted it meanwhile */
            insert_claimed(q, e);
            return true;
        }
        if (e > old) {
            sift_down(q, s, e);
            return false;
        }
        unlock(q, s);
        stress_point();
        if (e == old || bubble_up(q, UP_DECREASE, s, old, e, 0))
            return false;
    }
}

bool mr_ppq_remove(mr_ppq *q, uint32_t id)
{
    for (;;) {
        uint64_t r;
        const uint32_t s = lock_id(q, id, &r);
        if (s == UINT32_MAX)
            return false;
        if (remove_held(q, s, r))
            return true;
    }
}

static void unpack(uint64_t item, uint32_t *id, float *key)
{
    if (id)
        *id = (uint32_t)item;
    if (key)
        *key = mr_heap_bits_key((uint32_t)(item >> 32));
}

bool mr_ppq_pop(mr_ppq *q, uint32_t *id, float *key)
{
    for (;;) {
        if (load_size(q) == 0)
            return false;
        lock(q, 0);
        /* an insert into an empty heap takes slot 0's lock */
        const uint64_t r = item_at(q, 0);
        if (r == EMPTY) {
            unlock(q, 0);
            return false;
        }
        if (remove_held(q, 0, r)) {
            unpack(r, id, key);
            return true;
        }
    }
}

bool mr_ppq_pop_relaxed(mr_ppq *q, uint32_t top, uint32_t first, uint32_t *id, float *key)
{
    mr_spin spin = MR_SPIN_INIT;
    if (top == 0)
        top = 1;
    for (;;) {
        const uint32_t n = load_size(q);
        if (n == 0)
            return false;
        uint32_t t = first % top;
        bool tried = false;
        for (uint32_t k = 0; k < top; k++, t = t + 1 == top ? 0 : t + 1) {
            if (t >= n || !mr_vlock_try(&q->locks[t]))
                continue;
            const uint64_t r = item_at(q, t);
            if (r == EMPTY) {
                unlock(q, t);
                continue;
            }
            stress_point();
            if (remove_held(q, t, r)) {
                unpack(r, id, key);
                return true;
            }
            tried = true;
            break;
        }
        if (!tried)
            mr_spin_wait(&spin); /* every top slot was locked */
    }
}

void mr_ppq_build(mr_ppq *q, const uint32_t *ids, const float *keys, size_t n)
{
    for (size_t i = 0; i < n; i++)
        put(q, (uint32_t)i, pack(ids[i], keys[i]));
    atomic_store_explicit(&q->size, (uint32_t)n, memory_order_relaxed);
    /* Floyd: every slot from the last up sinks into its sub-heap (with
     * filter levels too: a slot's other parent, when larger, sinks later) */
    for (size_t i = n; i-- > 0;) {
        lock(q, (uint32_t)i);
        sift_down(q, (uint32_t)i, item_at(q, (uint32_t)i));
    }
}

bool mr_ppq_check(const mr_ppq *q)
{
    const uint32_t n = load_size(q);
    if (n > q->capacity)
        return false;
    for (uint32_t s = n; s < q->capacity; s++)
        if (item_at(q, s) != EMPTY)
            return false;
    for (uint32_t s = 0; s < n; s++) {
        const uint64_t v = item_at(q, s);
        if (v == EMPTY || (uint32_t)v >= q->capacity ||
            atomic_load_explicit(&q->pos[(uint32_t)v], memory_order_relaxed) != s + 1)
            return false;
        uint32_t p[2];
        const unsigned np = parents_of(q, s, p);
        for (unsigned j = 0; j < np; j++)
            if (item_at(q, p[j]) > v)
                return false;
        if (atomic_load_explicit(&q->locks[s], memory_order_relaxed) != 0)
            return false;
    }
    uint32_t present = 0;
    for (uint32_t id = 0; id < q->capacity; id++)
        present += atomic_load_explicit(&q->pos[id], memory_order_relaxed) != 0;
    return present == n;
}
