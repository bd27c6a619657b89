/* The indexed min-heap against a brute-force model. */
#include "testutil.h"
#include "qem/strategies/heap.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng_state = 88172645463325252ull;
static uint32_t rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)rng_state;
}

/* The model's minimum: smallest key, then smallest id. */
static uint32_t model_min(const float *key, const uint8_t *in, uint32_t n)
{
    uint32_t best = MR_HEAP_NONE;
    for (uint32_t i = 0; i < n; i++)
        if (in[i] && (best == MR_HEAP_NONE || key[i] < key[best]))
            best = i;
    return best;
}

static void check_invariant(const mr_heap *h)
{
    for (uint32_t i = 1; i < h->size; i++)
        assert_true(h->items[(i - 1) / MR_HEAP_ARITY] <= h->items[i]);
    for (uint32_t i = 0; i < h->size; i++)
        assert_int_equal(mr_heap_slot(h, (uint32_t)h->items[i]), i);
}

static void run_random_operations(unsigned pos_bytes)
{
    enum { N = 2000, OPS = 100000 };
    mr_heap h;
    assert_int_equal(mr_heap_init_width(&h, N, N, pos_bytes, NULL), MR_OK);
    assert_int_equal(h.pos_bytes, pos_bytes ? pos_bytes : 3);
    float key[N];
    uint8_t in[N] = {0};
    uint32_t count = 0;
    for (int op = 0; op < OPS; op++) {
        uint32_t id = rnd() % N;
        /* few distinct keys, so ties are common */
        float k = (float)(rnd() % 64) * 0.25f;
        switch (rnd() % 4) {
        case 0:
            if (!in[id]) {
                mr_heap_push(&h, id, k);
                in[id] = 1;
                key[id] = k;
                count++;
            }
            break;
        case 1:
            count += !in[id];
            mr_heap_update(&h, id, k);
            in[id] = 1;
            key[id] = k;
            break;
        case 2:
            count -= in[id];
            mr_heap_remove(&h, id);
            in[id] = 0;
            break;
        default:
            if (count) {
                uint32_t want = model_min(key, in, N);
                assert_int_equal(mr_heap_top(&h), want);
                assert_true(mr_heap_top_key(&h) == key[want]);
                assert_int_equal(mr_heap_pop(&h), want);
                in[want] = 0;
                count--;
            }
        }
        assert_int_equal(h.size, count);
        assert_int_equal(mr_heap_contains(&h, id), in[id]);
        if (in[id])
            assert_true(mr_heap_key(&h, id) == key[id]);
        if (op % 997 == 0)
            check_invariant(&h);
    }
    /* Drain: the order is by key, then id. */
    float last_key = -INFINITY;
    uint32_t last_id = 0;
    while (!mr_heap_empty(&h)) {
        float k = mr_heap_top_key(&h);
        uint32_t id = mr_heap_pop(&h);
        assert_true(k > last_key || (k == last_key && id > last_id));
        last_key = k;
        last_id = id;
    }
    mr_heap_free(&h);
}

static void test_random_operations(void **state)
{
    (void)state;
    run_random_operations(0);
}

/* The same with 32-bit positions (what heaps of 2^24 items and more get). */
static void test_random_operations_wide(void **state)
{
    (void)state;
    run_random_operations(4);
}

/* 24-bit positions beyond 16 bits: a heap of 200000 items, built by pushes
 * in reverse key order (every push sifts to the root), updated, drained. */
static void test_large_positions(void **state)
{
    (void)state;
    enum { N = 200000 };
    mr_heap h;
    assert_int_equal(mr_heap_init(&h, N, NULL), MR_OK);
    assert_int_equal(h.pos_bytes, 3);
    for (uint32_t i = 0; i < N; i++)
        mr_heap_push(&h, i, (float)(N - i));
    check_invariant(&h);
    for (uint32_t i = 0; i < N; i += 7)
        mr_heap_update(&h, i, (float)i + 0.5f);
    check_invariant(&h);
    mr_heap_remove(&h, N - 1);
    assert_false(mr_heap_contains(&h, N - 1));
    uint64_t last = 0;
    uint32_t n = 0;
    while (!mr_heap_empty(&h)) {
        const uint64_t item = h.items[0];
        assert_true(item >= last);
        last = item;
        mr_heap_pop(&h);
        n++;
    }
    assert_int_equal(n, N - 1);
    mr_heap_free(&h);
}

static void test_key_order(void **state)
{
    (void)state;
    const float keys[] = {-INFINITY, -3.5f, -0.0f, 0.0f, 1e-30f, 2.0f, 1e30f, INFINITY};
    for (size_t i = 1; i < sizeof keys / sizeof *keys; i++)
        assert_true(mr_heap_key_bits(keys[i - 1]) <= mr_heap_key_bits(keys[i]));
    for (size_t i = 0; i < sizeof keys / sizeof *keys; i++)
        assert_true(mr_heap_bits_key(mr_heap_key_bits(keys[i])) == keys[i]);
    /* NaN sorts as +inf */
    assert_true(mr_heap_key_bits(NAN) == mr_heap_key_bits(INFINITY));
}

/* Heapify of tiny heaps, sized to exactly their items: an empty or
 * one-item heap was sifted from a slot past its end (a write through a
 * garbage id when the simplifier found no collapsible edge). */
static void test_heapify_tiny(void **state)
{
    (void)state;
    for (uint32_t n = 0; n < 10; n++) {
        mr_heap h;
        assert_int_equal(mr_heap_init_sized(&h, 16, n, NULL), MR_OK);
        for (uint32_t i = 0; i < n; i++)
            mr_heap_append(&h, 15 - i, (float)((i * 5) % 7));
        mr_heap_heapify(&h);
        check_invariant(&h);
        for (uint32_t id = 0; id < 16; id++)
            assert_int_equal(mr_heap_contains(&h, id), id >= 16 - n);
        float last = -INFINITY;
        while (!mr_heap_empty(&h)) {
            const float k = mr_heap_top_key(&h);
            assert_true(k >= last);
            last = k;
            mr_heap_pop(&h);
        }
        mr_heap_free(&h);
    }
}

/* Bulk build: append in any order, heapify, then pops come in (key, id)
 * order and the heap stays indexed for updates; sized heaps hold fewer
 * items than ids. */
static void test_heapify(void **state)
{
    (void)state;
    enum { N = 5000, M = 1200 };
    mr_heap h;
    assert_int_equal(mr_heap_init_sized(&h, N, M, NULL), MR_OK);
    static float key[N];
    static uint8_t in[N];
    memset(in, 0, sizeof in);
    for (uint32_t i = 0; i < M; i++) {
        uint32_t id = (i * 7919u) % N; /* distinct: 7919 is prime, N < 7919 * N */
        key[id] = (float)(rnd() % 50); /* many ties */
        in[id] = 1;
        mr_heap_append(&h, id, key[id]);
    }
    mr_heap_heapify(&h);
    check_invariant(&h);
    for (uint32_t i = 0; i < N; i++)
        assert_int_equal(mr_heap_contains(&h, i), in[i] != 0);
    /* a few updates and removals on the built heap */
    for (uint32_t i = 0; i < 200; i++) {
        uint32_t id = (rnd() % M) * 7919u % N;
        if (i % 3 == 0) {
            mr_heap_remove(&h, id);
            in[id] = 0;
        } else {
            key[id] = (float)(rnd() % 50);
            in[id] = 1;
            mr_heap_update(&h, id, key[id]);
        }
        check_invariant(&h);
    }
    float last = -INFINITY;
    uint32_t last_id = 0;
    while (!mr_heap_empty(&h)) {
        uint32_t want = model_min(key, in, N);
        uint32_t id = mr_heap_pop(&h);
        assert_int_equal(id, want);
        assert_true(key[id] > last || (key[id] == last && id > last_id));
        last = key[id];
        last_id = id;
        in[id] = 0;
    }
    mr_heap_free(&h);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_operations),
        cmocka_unit_test(test_random_operations_wide),
        cmocka_unit_test(test_large_positions),
        cmocka_unit_test(test_heapify_tiny),
        cmocka_unit_test(test_heapify),
        cmocka_unit_test(test_key_order),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
