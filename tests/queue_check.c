/* Checks shared by the concurrent priority queue tests: see queue_check.h. */
#include "queue_check.h"
#include "testutil.h"

#include "core/internal.h"
#include "core/omp_compat.h"
#include "qem/strategies/heap.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

bool tq_quick(void)
{
    const char *q = getenv("MR_TEST_QUICK");
    return q && *q && strcmp(q, "0") != 0;
}

uint64_t tq_pack(uint32_t id, float key)
{
    return ((uint64_t)mr_heap_key_bits(key) << 32) | id;
}

float tq_key(unsigned index)
{
    switch (index % 64) {
    case 0:
        return -INFINITY;
    case 1:
        return -0.0f;
    case 2:
        return 0.0f;
    case 62:
        return NAN;
    case 63:
        return INFINITY;
    default:
        return ((float)(index % 64) - 32.0f) * 0.5f;
    }
}

int tq_cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static inline uint64_t next(uint64_t *s)
{
    *s += UINT64_C(0x9e3779b97f4a7c15);
    return mr_mix64(*s);
}

/* ---- one thread against a model ------------------------------------- */

typedef struct model {
    uint64_t *item; /* id -> packed element when present */
    uint8_t *in;
    uint32_t count;
    mr_heap heap; /* the same elements in the sequential heap */
} model;

/* Pop from the queue: the element must be one the model holds (exact: the
 * one mr_heap_pop would give); the model drops it. */
static void model_pop(const tq_queue *t, model *m, bool exact, uint64_t *rng)
{
    uint64_t it;
    const bool got = t->pop(t->q, 0, rng, &it);
    assert_int_equal(got, m->count > 0);
    if (!got)
        return;
    const uint32_t id = (uint32_t)it;
    assert_true(id < t->capacity);
    assert_true(m->in[id]);
    assert_true(it == m->item[id]);
    if (exact)
        assert_true(it == m->heap.items[0]);
    m->in[id] = 0;
    m->count--;
    mr_heap_remove(&m->heap, id);
}

void tq_model_run(const tq_queue *t, unsigned ops, bool exact, uint64_t seed)
{
    const uint32_t n = t->capacity;
    model m;
    m.item = calloc(n, sizeof *m.item);
    m.in = calloc(n, 1);
    m.count = 0;
    assert_non_null(m.item);
    assert_non_null(m.in);
    assert_int_equal(mr_heap_init(&m.heap, n, NULL), MR_OK);
    uint64_t rng = seed;
    for (unsigned op = 0; op < ops; op++) {
        const uint64_t r = next(&rng);
        const uint32_t id = (uint32_t)(r % n);
        const float key = tq_key((unsigned)(r >> 32));
        const uint64_t e = tq_pack(id, key);
        switch ((r >> 40) % 8) {
        case 0:
        case 1:
        case 2: {
            const bool inserted = t->update(t->q, id, key, &rng);
            assert_int_equal(inserted, !m.in[id]);
            m.count += inserted;
            m.in[id] = 1;
            m.item[id] = e;
            mr_heap_update(&m.heap, id, key);
            break;
        }
        case 3: {
            const bool inserted = t->insert(t->q, id, key, &rng);
            assert_int_equal(inserted, !m.in[id]);
            if (inserted) {
                m.count++;
                m.in[id] = 1;
                m.item[id] = e;
                mr_heap_push(&m.heap, id, key);
            }
            break;
        }
        case 4: {
            const bool was = t->remove(t->q, id);
            assert_int_equal(was, m.in[id]);
            m.count -= was;
            m.in[id] = 0;
            mr_heap_remove(&m.heap, id);
            break;
        }
        default:
            model_pop(t, &m, exact, &rng);
        }
        assert_int_equal(t->size(t->q), m.count);
        if (op % 613 == 0)
            assert_true(t->check(t->q));
    }
    assert_true(t->check(t->q));
    while (m.count)
        model_pop(t, &m, exact, &rng);
    model_pop(t, &m, exact, &rng); /* empty: false */
    assert_true(t->check(t->q));
    mr_heap_free(&m.heap);
    free(m.item);
    free(m.in);
}

/* ---- threads ---------------------------------------------------------- */

/* A growable-free list: sized for the most entries a thread can add. */
typedef struct item_list {
    uint64_t *v;
    size_t n;
} item_list;

/* What the run shares: per-id records (disjoint: owned by one thread) and
 * per-thread lists, all sized before the threads start. */
typedef struct run_state {
    const tq_queue *t;
    bool overlap;
    uint64_t *cur;                /* disjoint: id -> the owner's latest version */
    uint8_t *cur_in;              /*   ... and whether it thinks it is in */
    _Atomic uint32_t *inserts;    /* overlap: id -> inserts that happened */
    _Atomic uint32_t *removes;    /*   ... removes that found it */
    _Atomic uint64_t *written;    /*   ... bit k: key tq_key(k) was written */
    item_list *expect;            /* thread -> versions some pop must take */
    item_list *popped;            /* thread -> what its pops took */
    _Atomic unsigned failures;
} run_state;

/* The owner's record of id after an operation that returned `present`
 * (update: !inserted, remove: found) and left it in or out. */
static void owner_record(run_state *st, int tid, uint32_t id, bool present, bool in_after,
                         uint64_t version)
{
    if (st->cur_in[id] && !present) /* a pop took the version */
        st->expect[tid].v[st->expect[tid].n++] = st->cur[id];
    if (!st->cur_in[id] && present) /* nobody else adds this id */
        atomic_fetch_add(&st->failures, 1);
    st->cur_in[id] = in_after;
    if (in_after)
        st->cur[id] = version;
}

static void thread_ops(run_state *st, int tid, int threads, unsigned ops, uint64_t *rng)
{
    const tq_queue *t = st->t;
    const uint32_t n = t->capacity;
    const uint32_t own = (n - 1 - (uint32_t)tid) / (uint32_t)threads + 1; /* ids of tid */
    for (unsigned op = 0; op < ops; op++) {
        const uint64_t r = next(rng);
        const uint32_t id = st->overlap ? (uint32_t)(r % n)
                                        : (uint32_t)(r % own) * (uint32_t)threads + (uint32_t)tid;
        const unsigned k = (unsigned)(r >> 32) % 64;
        const float key = tq_key(k);
        const unsigned what = (unsigned)(r >> 40) % 8;
        if (what <= 3) {
            /* update (3 in 8) or insert (1 in 8) */
            const bool ins = what == 3 ? t->insert(t->q, id, key, rng)
                                       : t->update(t->q, id, key, rng);
            if (st->overlap) {
                if (ins)
                    atomic_fetch_add(&st->inserts[id], 1);
                if (ins || what != 3)
                    atomic_fetch_or(&st->written[id], (uint64_t)1 << k);
            } else if (what == 3 && !ins) {
                owner_record(st, tid, id, true, true, st->cur[id]); /* still in, unchanged */
            } else {
                owner_record(st, tid, id, !ins, true, tq_pack(id, key));
            }
        } else if (what == 4) {
            const bool was = t->remove(t->q, id);
            if (st->overlap) {
                if (was)
                    atomic_fetch_add(&st->removes[id], 1);
            } else {
                owner_record(st, tid, id, was, false, 0);
            }
        } else {
            uint64_t it;
            if (t->pop(t->q, tid, rng, &it))
                st->popped[tid].v[st->popped[tid].n++] = it;
        }
    }
}

/* Every popped element of id: a key that was written to it. */
static bool key_written(const run_state *st, uint64_t item)
{
    const uint64_t mask = atomic_load(&st->written[(uint32_t)item]);
    for (unsigned k = 0; k < 64; k++)
        if ((mask >> k & 1) && tq_pack((uint32_t)item, tq_key(k)) == item)
            return true;
    return false;
}

void tq_concurrent_run(const tq_queue *t, int threads, unsigned rounds, unsigned ops,
                       bool overlap, uint64_t seed)
{
    const uint32_t n = t->capacity;
    const size_t per_thread = (size_t)rounds * ops;
    run_state st;
    memset(&st, 0, sizeof st);
    st.t = t;
    st.overlap = overlap;
    st.cur = calloc(n, sizeof *st.cur);
    st.cur_in = calloc(n, 1);
    st.inserts = calloc(n, sizeof *st.inserts);
    st.removes = calloc(n, sizeof *st.removes);
    st.written = calloc(n, sizeof *st.written);
    st.expect = calloc((size_t)threads, sizeof *st.expect);
    st.popped = calloc((size_t)threads, sizeof *st.popped);
    assert_true(st.cur && st.cur_in && st.inserts && st.removes && st.written && st.expect &&
                st.popped);
    for (int i = 0; i < threads; i++) {
        st.expect[i].v = malloc(per_thread * sizeof(uint64_t) + 8);
        st.popped[i].v = malloc(per_thread * sizeof(uint64_t) + 8);
        assert_true(st.expect[i].v && st.popped[i].v);
    }
    atomic_init(&st.failures, 0);
    int team = 1;
#pragma omp parallel num_threads(threads)
    {
        const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
#pragma omp single
        team = nt;
        uint64_t rng = mr_mix64(seed + (uint64_t)tid * 7919);
        for (unsigned round = 0; round < rounds; round++) {
            thread_ops(&st, tid, nt, ops, &rng);
#pragma omp barrier
#pragma omp single
            {
                if (!t->check(t->q))
                    atomic_fetch_add(&st.failures, 1);
            }
        }
    }
    assert_int_equal(atomic_load(&st.failures), 0);

    /* drain, then compare what came out with what had to */
    size_t out_n = 0, want_n = 0;
    for (int i = 0; i < team; i++) {
        out_n += st.popped[i].n;
        want_n += st.expect[i].n;
    }
    uint64_t *out = malloc((out_n + n + 1) * sizeof *out);
    uint64_t *want = malloc((want_n + n + 1) * sizeof *want);
    assert_true(out && want);
    out_n = want_n = 0;
    for (int i = 0; i < team; i++) {
        memcpy(out + out_n, st.popped[i].v, st.popped[i].n * sizeof *out);
        out_n += st.popped[i].n;
        memcpy(want + want_n, st.expect[i].v, st.expect[i].n * sizeof *want);
        want_n += st.expect[i].n;
    }
    const size_t out_cap = out_n + n + 1;
    uint64_t rng = seed;
    uint64_t it;
    while (t->pop(t->q, 0, &rng, &it)) {
        assert_true(out_n < out_cap); /* no more than every id once */
        out[out_n++] = it;
    }
    assert_int_equal(t->size(t->q), 0);
    assert_true(t->check(t->q));
    qsort(out, out_n, sizeof *out, tq_cmp_u64);
    if (!overlap) {
        for (uint32_t id = 0; id < n; id++)
            if (st.cur_in[id])
                want[want_n++] = st.cur[id];
        qsort(want, want_n, sizeof *want, tq_cmp_u64);
        assert_int_equal(out_n, want_n);
        for (size_t i = 0; i < out_n; i++)
            assert_true(out[i] == want[i]);
    } else {
        /* out is sorted by key, then id: count per id */
        uint32_t *pops = calloc(n, sizeof *pops);
        assert_non_null(pops);
        for (size_t i = 0; i < out_n; i++) {
            assert_true(key_written(&st, out[i]));
            pops[(uint32_t)out[i]]++;
        }
        for (uint32_t id = 0; id < n; id++)
            assert_int_equal(atomic_load(&st.inserts[id]), atomic_load(&st.removes[id]) + pops[id]);
        free(pops);
    }
    free(out);
    free(want);
    for (int i = 0; i < threads; i++) {
        free(st.expect[i].v);
        free(st.popped[i].v);
    }
    free(st.expect);
    free(st.popped);
    free(st.cur);
    free(st.cur_in);
    free((void *)st.inserts);
    free((void *)st.removes);
    free((void *)st.written);
}

void tq_thread_cases(tq_case_fn fn, void *ctx, uint64_t seed)
{
    const int threads[] = {2, 3, 8};
    for (int i = 0; i < 3; i++)
        for (int overlap = 0; overlap < 2; overlap++)
            fn(ctx, threads[i], overlap, seed + (uint64_t)(2 * i + overlap));
}

tq_sizes tq_concurrent_sizes(void)
{
    const bool quick = tq_quick();
    const tq_sizes s = {quick ? 256 : 1024, quick ? 4 : 12, quick ? 300 : 1500};
    return s;
}
