/*
 * The MultiQueue with mutable priorities: with one queue exact against a
 * model and the sequential heap; with many a relaxed pop that still takes
 * exactly an element the model holds; 2, 3 and 8 threads with the exact
 * multiset left and the invariants at every round's barrier.
 */
#include "testutil.h"
#include "queue_check.h"
#include "qem/strategies/parallel/multiqueue.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static bool op_insert(void *q, uint32_t id, float key, uint64_t *rng)
{
    return mr_multiqueue_insert(q, id, key, rng);
}

static bool op_update(void *q, uint32_t id, float key, uint64_t *rng)
{
    return mr_multiqueue_update(q, id, key, rng);
}

static bool op_remove(void *q, uint32_t id) { return mr_multiqueue_remove(q, id); }

static bool op_pop(void *q, int thread, uint64_t *rng, uint64_t *item)
{
    (void)thread;
    uint32_t id;
    float key;
    if (!mr_multiqueue_pop(q, rng, &id, &key))
        return false;
    *item = tq_pack(id, key);
    return true;
}

static size_t op_size(const void *q) { return mr_multiqueue_size(q); }
static bool op_check(const void *q) { return mr_multiqueue_check(q); }

static tq_queue as_queue(mr_multiqueue *q)
{
    tq_queue t = {q, q->capacity, op_insert, op_update, op_remove, op_pop, op_size, op_check};
    return t;
}

static void model_cases(int threads, unsigned per_thread, bool exact, uint64_t seed)
{
    const unsigned scale = tq_quick() ? 1 : 6;
    const uint32_t sizes[] = {300, 5000};
    for (int i = 0; i < 2; i++) {
        mr_multiqueue q;
        assert_int_equal(mr_multiqueue_init(&q, sizes[i], threads, per_thread, NULL), MR_OK);
        assert_int_equal(q.count, threads * (per_thread ? per_thread : 2));
        const tq_queue t = as_queue(&q);
        tq_model_run(&t, 25000 * scale, exact, seed + (uint64_t)i);
        mr_multiqueue_free(&q);
    }
}

/* One queue (one thread, one queue per thread): pops are mr_heap_pop's. */
static void test_model_one_queue(void **state)
{
    (void)state;
    model_cases(1, 1, true, 1);
}

/* 8 queues (4 threads' worth, the default 2 each), used by one thread:
 * every pop is an element present with its latest key. */
static void test_model_many_queues(void **state)
{
    (void)state;
    model_cases(4, 0, false, 3);
}

static void concurrent_case(void *ctx, int threads, bool overlap, uint64_t seed)
{
    (void)ctx;
    const tq_sizes z = tq_concurrent_sizes();
    mr_multiqueue q;
    assert_int_equal(mr_multiqueue_init(&q, z.ids, threads, 2, NULL), MR_OK);
    const tq_queue t = as_queue(&q);
    tq_concurrent_run(&t, threads, z.rounds, 2 * z.ops, overlap, seed);
    mr_multiqueue_free(&q);
}

static void test_concurrent(void **state)
{
    (void)state;
    tq_thread_cases(concurrent_case, NULL, 10);
}

/* Every id fits however the inserts fall (the queues' fixed room), and
 * the relaxed pops stay near the top: the mean rank over a drain of
 * 20000 elements from 8 queues is a few times the queue count. */
static void test_room_and_rank(void **state)
{
    (void)state;
    const uint32_t caps[] = {1, 7, 100, 20000};
    for (int c = 0; c < 4; c++) {
        const uint32_t n = caps[c];
        mr_multiqueue q;
        assert_int_equal(mr_multiqueue_init(&q, n, 8, 2, NULL), MR_OK);
        uint64_t rng = mr_multiqueue_seed(7, 0);
        for (uint32_t id = 0; id < n; id++)
            assert_true(mr_multiqueue_insert(&q, id, (float)((id * 7919u) % n), &rng));
        assert_false(mr_multiqueue_insert(&q, 0, 1.0f, &rng));
        assert_int_equal(mr_multiqueue_size(&q), n);
        assert_true(mr_multiqueue_check(&q));
        /* keys are a permutation of 0 .. n - 1: a key is its rank among
         * all, less the smaller ones already popped */
        uint32_t *left = calloc(n + 1, sizeof *left); /* Fenwick tree of keys left */
        assert_non_null(left);
        for (uint32_t k = 1; k <= n; k++)
            for (uint32_t i = k; i <= n; i += i & (0 - i))
                left[i]++;
        double rank_sum = 0;
        for (uint32_t i = 0; i < n; i++) {
            uint32_t id;
            float key;
            assert_true(mr_multiqueue_pop(&q, &rng, &id, &key));
            assert_true(key == (float)((id * 7919u) % n));
            for (uint32_t j = (uint32_t)key; j > 0; j -= j & (0 - j))
                rank_sum += left[j]; /* keys below key still in */
            for (uint32_t j = (uint32_t)key + 1; j <= n; j += j & (0 - j))
                left[j]--;
        }
        assert_false(mr_multiqueue_pop(&q, &rng, NULL, NULL));
        if (n >= 20000)
            assert_true(rank_sum / n < 4.0 * q.count);
        free(left);
        mr_multiqueue_free(&q);
    }
}

static void test_init_errors(void **state)
{
    (void)state;
    mr_multiqueue q;
    mr_error err;
    assert_int_equal(mr_multiqueue_init(&q, 10, 40000, 2, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "queues");
    mr_multiqueue_free(&q);
    assert_int_equal(mr_multiqueue_init(&q, 0, 2, 0, NULL), MR_OK);
    uint64_t rng = mr_multiqueue_seed(1, 0);
    assert_false(mr_multiqueue_pop(&q, &rng, NULL, NULL));
    assert_true(mr_multiqueue_check(&q));
    mr_multiqueue_free(&q);
    /* per-thread generators differ */
    assert_true(mr_multiqueue_seed(1, 0) != mr_multiqueue_seed(1, 1));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_model_one_queue), cmocka_unit_test(test_model_many_queues),
        cmocka_unit_test(test_concurrent),      cmocka_unit_test(test_room_and_rank),
        cmocka_unit_test(test_init_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
