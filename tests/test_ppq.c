/*
 * The concurrent heap with mutable priorities (PPQ) and its relaxed pop
 * (RPPQ): at one thread against a brute-force model and the sequential
 * heap (the same pops, ties by id); at 2, 3 and 8 threads (8 on 2 cores on
 * purpose) with the exact multiset of what must be left, and the heap
 * invariant at every round's barrier.
 */
#include "testutil.h"
#include "queue_check.h"
#include "qem/strategies/parallel/ppq.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* The yield points of the test build of ppq.c (tests/CMakeLists.txt). */
extern _Atomic int mr_ppq_stress;

/* RPPQ's top slots in these tests: those of an FPPQ with 2 filter levels. */
#define RELAXED_TOP 7

static bool op_insert(void *q, uint32_t id, float key, uint64_t *rng)
{
    (void)rng;
    return mr_ppq_insert(q, id, key);
}

static bool op_update(void *q, uint32_t id, float key, uint64_t *rng)
{
    (void)rng;
    return mr_ppq_update(q, id, key);
}

static bool op_remove(void *q, uint32_t id) { return mr_ppq_remove(q, id); }

static bool op_pop(void *q, int thread, uint64_t *rng, uint64_t *item)
{
    (void)thread;
    (void)rng;
    uint32_t id;
    float key;
    if (!mr_ppq_pop(q, &id, &key))
        return false;
    *item = tq_pack(id, key);
    return true;
}

static bool op_pop_relaxed(void *q, int thread, uint64_t *rng, uint64_t *item)
{
    (void)thread;
    (void)rng;
    uint32_t id;
    float key;
    if (!mr_ppq_pop_relaxed(q, RELAXED_TOP, 0, &id, &key))
        return false;
    *item = tq_pack(id, key);
    return true;
}

static size_t op_size(const void *q) { return mr_ppq_size(q); }
static bool op_check(const void *q) { return mr_ppq_check(q); }

static tq_queue as_queue(mr_ppq *q, bool relaxed)
{
    tq_queue t = {q, q->capacity, op_insert, op_update, op_remove,
                  relaxed ? op_pop_relaxed : op_pop, op_size, op_check};
    return t;
}

static void model_case(uint32_t ids, unsigned ops, bool relaxed, uint64_t seed)
{
    mr_ppq q;
    assert_int_equal(mr_ppq_init(&q, ids, NULL), MR_OK);
    const tq_queue t = as_queue(&q, relaxed);
    /* one thread: the root is never locked, so the relaxed pop is exact */
    tq_model_run(&t, ops, true, seed);
    mr_ppq_free(&q);
}

/* Random insert/update/remove/pop with ties: every pop is mr_heap_pop's. */
static void test_model(void **state)
{
    (void)state;
    const unsigned scale = tq_quick() ? 1 : 6;
    model_case(300, 30000 * scale, false, 1);
    model_case(5000, 20000 * scale, false, 2);
    model_case(1, 200, false, 3);
}

static void test_model_relaxed(void **state)
{
    (void)state;
    const unsigned scale = tq_quick() ? 1 : 6;
    model_case(300, 30000 * scale, true, 4);
    model_case(5000, 20000 * scale, true, 5);
}

/* Each case twice: as built, then with the test build's yields. */
static void concurrent_case(void *relaxed, int threads, bool overlap, uint64_t seed)
{
    const tq_sizes z = tq_concurrent_sizes();
    for (int stress = 0; stress < 2; stress++) {
        mr_ppq q;
        assert_int_equal(mr_ppq_init(&q, z.ids, NULL), MR_OK);
        const tq_queue t = as_queue(&q, relaxed != NULL);
        atomic_store(&mr_ppq_stress, stress);
        tq_concurrent_run(&t, threads, z.rounds, z.ops, overlap, seed + (uint64_t)stress * 100);
        atomic_store(&mr_ppq_stress, 0);
        mr_ppq_free(&q);
    }
}

static void test_concurrent(void **state)
{
    (void)state;
    tq_thread_cases(concurrent_case, NULL, 10);
}

static void test_concurrent_relaxed(void **state)
{
    (void)state;
    static int relaxed;
    tq_thread_cases(concurrent_case, &relaxed, 30);
}

/* Bulk build, then pops in (key, id) order. */
static void test_build(void **state)
{
    (void)state;
    enum { N = 3000 };
    static uint32_t ids[N];
    static float keys[N];
    static uint64_t want[N];
    for (uint32_t i = 0; i < N; i++) {
        ids[i] = (i * 7919u) % N;
        keys[i] = tq_key(i * 31u);
        want[i] = tq_pack(ids[i], keys[i]);
    }
    qsort(want, N, sizeof *want, tq_cmp_u64);
    mr_ppq q;
    assert_int_equal(mr_ppq_init(&q, N, NULL), MR_OK);
    mr_ppq_build(&q, ids, keys, N);
    assert_true(mr_ppq_check(&q));
    for (uint32_t i = 0; i < N; i++) {
        uint32_t id;
        float key;
        assert_true(mr_ppq_pop(&q, &id, &key));
        assert_true(tq_pack(id, key) == want[i]);
    }
    assert_false(mr_ppq_pop(&q, NULL, NULL));
    mr_ppq_free(&q);
}

static void test_init_errors(void **state)
{
    (void)state;
    mr_ppq q;
    mr_error err;
    assert_int_equal(mr_ppq_init(&q, (size_t)1 << 31, &err), MR_ERR_TOO_LARGE);
    tu_assert_contains(err.message, "ids");
    mr_ppq_free(&q);
    assert_int_equal(mr_ppq_init_layout(&q, 10, MR_FILTER_MAX_LEVELS + 1, &err),
                     MR_ERR_INVALID_ARGUMENT);
    mr_ppq_free(&q);
    /* an empty queue of no ids */
    assert_int_equal(mr_ppq_init(&q, 0, NULL), MR_OK);
    assert_false(mr_ppq_pop(&q, NULL, NULL));
    assert_false(mr_ppq_pop_relaxed(&q, 3, 1, NULL, NULL));
    assert_true(mr_ppq_check(&q));
    mr_ppq_free(&q);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_model),
        cmocka_unit_test(test_model_relaxed),
        cmocka_unit_test(test_concurrent),
        cmocka_unit_test(test_concurrent_relaxed),
        cmocka_unit_test(test_build),
        cmocka_unit_test(test_init_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
