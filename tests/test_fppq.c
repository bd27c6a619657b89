/*
 * The parallel priority queue with filter levels (FPPQ): Table 1's index
 * formulas against the filter graph built as the paper describes it; the
 * paper's k from that graph; one thread against a model and the sequential
 * heap; 2, 3 and 8 threads with the exact multiset left; and the top-k
 * guarantee in the quiescent states of a stress run.
 */
#include "testutil.h"
#include "queue_check.h"
#include "qem/strategies/parallel/fppq.h"
#include "core/omp_compat.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* The yield points of the test build of ppq.c (tests/CMakeLists.txt). */
extern _Atomic int mr_ppq_stress;

/* ---- Table 1 against the filter graph ------------------------------- */

#define NONE UINT32_MAX

/* The graph as the paper draws it (Fig. 1), built row by row: the top
 * levels a binary tree; each filter row w wide, a node's first parent
 * directly above, its second that many columns to the left (wrapping),
 * 1 in the bottom filter row and doubling going up; below the filter a
 * binary tree again under the bottom filter row. Slots are numbered row by
 * row, left to right. */
typedef struct graph {
    uint32_t n;
    uint32_t parent[2][4096], child[2][4096];
} graph;

static uint32_t row_start(unsigned levels, unsigned row, unsigned *width)
{
    /* rows 0 .. levels: the top tree; levels + 1 .. 2 levels: the filter;
     * then the rows below, doubling */
    uint32_t start = 0, wd = 1;
    for (unsigned r = 0; r < row; r++) {
        start += wd;
        if (r < levels || r >= 2 * levels)
            wd *= 2;
    }
    *width = wd;
    return start;
}

static void build_graph(graph *g, unsigned levels, unsigned below_rows)
{
    const uint32_t w = 1u << levels;
    const unsigned rows = 2 * levels + 1 + below_rows;
    unsigned last_width;
    g->n = row_start(levels, rows, &last_width);
    assert_true(g->n <= 4096);
    for (uint32_t i = 0; i < g->n; i++)
        g->parent[0][i] = g->parent[1][i] = g->child[0][i] = g->child[1][i] = NONE;
    for (unsigned r = 1; r < rows; r++) {
        unsigned width, up_width;
        const uint32_t s = row_start(levels, r, &width);
        const uint32_t up = row_start(levels, r - 1, &up_width);
        const bool filter = r > levels && r <= 2 * levels;
        for (uint32_t c = 0; c < width; c++) {
            const uint32_t node = s + c;
            if (filter) {
                const unsigned f = r - levels;          /* 1: top filter row */
                const uint32_t offset = 1u << (levels - f); /* bottom row: 1 */
                const uint32_t p1 = up + c, p2 = up + (c + w - offset) % w;
                g->parent[0][node] = p1;
                g->parent[1][node] = p2;
                g->child[0][p1] = node; /* directly below */
                g->child[1][p2] = node;
            } else {
                const uint32_t p = up + c / 2;
                g->parent[0][node] = p;
                g->child[c % 2][p] = node;
            }
        }
    }
}

static void test_layout_table1(void **state)
{
    (void)state;
    static graph g;
    for (unsigned levels = 0; levels <= 5; levels++) {
        const mr_filter_layout l = mr_filter_layout_make(levels);
        assert_int_equal(l.top, mr_fppq_top_nodes(levels));
        build_graph(&g, levels, levels >= 5 ? 2 : 4);
        for (uint32_t i = 0; i < g.n; i++) {
            uint32_t p[2] = {NONE, NONE};
            const unsigned np = i ? mr_filter_parents(&l, i, p) : 0;
            assert_int_equal(np, (g.parent[0][i] != NONE) + (g.parent[1][i] != NONE));
            assert_int_equal(np ? p[0] : NONE, g.parent[0][i]);
            assert_int_equal(np == 2 ? p[1] : NONE, g.parent[1][i]);
            /* children the graph has (the last rows' lie beyond it) */
            if (g.child[0][i] != NONE) {
                assert_int_equal(mr_filter_child1(&l, i), g.child[0][i]);
                assert_int_equal(mr_filter_child2(&l, i), g.child[1][i]);
            } else {
                assert_true(mr_filter_child1(&l, i) >= g.n);
                assert_true(mr_filter_child2(&l, i) >= g.n);
            }
        }
    }
    /* Fig. 1c and its text: node 7 has parents 3 and 5, node 10 has 6 and
     * 4, node 11 has 7 and 10 */
    const mr_filter_layout l2 = mr_filter_layout_make(2);
    uint32_t p[2];
    assert_int_equal(mr_filter_parents(&l2, 7, p), 2);
    assert_true(p[0] == 3 && p[1] == 5);
    assert_int_equal(mr_filter_parents(&l2, 10, p), 2);
    assert_true(p[0] == 6 && p[1] == 4);
    assert_int_equal(mr_filter_parents(&l2, 11, p), 2);
    assert_true(p[0] == 7 && p[1] == 10);
}

/* Mark the ancestors (descendants) of node in the graph; returns count. */
static unsigned mark(const graph *g, uint32_t node, bool up, uint8_t *seen)
{
    unsigned n = 0;
    for (int j = 0; j < 2; j++) {
        const uint32_t next = up ? g->parent[j][node] : g->child[j][node];
        if (next != NONE && !seen[next]) {
            seen[next] = 1;
            n += 1 + mark(g, next, up, seen);
        }
    }
    return n;
}

/* The paper's k from the graph: every node below the filter is below every
 * node of the last top row (so worse than every top node), and a top node
 * can be worse only than the top and filter nodes that are not below it:
 * its rank is below 1 + (n_t + n_f - 1 - its descendants there). The worst
 * top node must give k = l_f 2^l_f + 1 (eq. 2, Table 2). */
static void test_guarantee(void **state)
{
    (void)state;
    static graph g;
    static uint8_t seen[4096];
    const size_t table2[] = {1, 3, 9, 25, 65, 161};
    for (unsigned levels = 0; levels <= 5; levels++) {
        const mr_filter_layout l = mr_filter_layout_make(levels);
        const uint32_t region = l.top + l.filter, w = l.width;
        assert_int_equal(mr_fppq_guarantee(levels), table2[levels]);
        build_graph(&g, levels, 2);
        /* the butterfly: every node from the bottom filter row down has
         * all w last-top-row nodes above it */
        for (uint32_t i = region - w; i < g.n; i++) {
            memset(seen, 0, g.n);
            seen[i] = 1; /* with no filter level the last top row is the root */
            mark(&g, i, true, seen);
            for (uint32_t t = l.top - w; t < l.top; t++)
                assert_true(seen[t]);
        }
        size_t worst = 0;
        for (uint32_t t = 0; t < l.top; t++) {
            memset(seen, 0, g.n);
            mark(&g, t, false, seen);
            unsigned below = 0;
            for (uint32_t i = 0; i < region; i++)
                below += seen[i];
            const size_t bound = 1 + (region - 1 - below);
            if (bound > worst)
                worst = bound;
        }
        assert_int_equal(worst, mr_fppq_guarantee(levels));
    }
}

/* The paper picks 4 filter levels (31 top nodes) for 32 threads. */
static void test_default_levels(void **state)
{
    (void)state;
    const int threads[] = {0, 1, 2, 4, 5, 8, 9, 16, 17, 32, 33, 64, 65};
    const unsigned want[] = {1, 1, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6};
    for (size_t i = 0; i < sizeof threads / sizeof *threads; i++)
        assert_int_equal(mr_fppq_default_levels(threads[i]), want[i]);
    for (int t = 2; t <= 200; t++) {
        const unsigned lf = mr_fppq_default_levels(t);
        assert_true(mr_fppq_top_nodes(lf) + 1 >= (uint32_t)t);
        assert_true(lf == 1 || mr_fppq_top_nodes(lf - 1) + 1 < (uint32_t)t);
    }
}

/* ---- the queue ------------------------------------------------------ */

static bool op_insert(void *q, uint32_t id, float key, uint64_t *rng)
{
    (void)rng;
    return mr_fppq_insert(q, id, key);
}

static bool op_update(void *q, uint32_t id, float key, uint64_t *rng)
{
    (void)rng;
    return mr_fppq_update(q, id, key);
}

static bool op_remove(void *q, uint32_t id) { return mr_fppq_remove(q, id); }

static bool pop_item(mr_fppq *q, uint32_t first, uint64_t *item)
{
    uint32_t id;
    float key;
    if (!mr_fppq_pop_from(q, first, &id, &key))
        return false;
    *item = tq_pack(id, key);
    return true;
}

static bool op_pop(void *q, int thread, uint64_t *rng, uint64_t *item)
{
    (void)thread;
    (void)rng;
    return pop_item(q, 0, item);
}

/* Starting at a top node of the thread's own: pops below the root. */
static bool op_pop_spread(void *q, int thread, uint64_t *rng, uint64_t *item)
{
    (void)rng;
    return pop_item(q, (uint32_t)thread * 3, item);
}

static size_t op_size(const void *q) { return mr_fppq_size(q); }
static bool op_check(const void *q) { return mr_fppq_check(q); }

static tq_queue as_queue(mr_fppq *q, bool spread)
{
    tq_queue t = {q, q->heap.capacity, op_insert, op_update, op_remove,
                  spread ? op_pop_spread : op_pop, op_size, op_check};
    return t;
}

/* One thread, filter levels 1 .. 5: pops are mr_heap_pop's. */
static void test_model(void **state)
{
    (void)state;
    const unsigned scale = tq_quick() ? 1 : 4;
    for (unsigned levels = 1; levels <= 5; levels++) {
        const uint32_t sizes[] = {300, 3000};
        for (int i = 0; i < 2; i++) {
            mr_fppq q;
            assert_int_equal(mr_fppq_init(&q, sizes[i], levels, NULL), MR_OK);
            const tq_queue t = as_queue(&q, false);
            tq_model_run(&t, 12000 * scale, true, 100 + levels * 2 + (uint64_t)i);
            mr_fppq_free(&q);
        }
    }
}

/* Default filter levels for twice the threads (more top nodes than
 * threads); half the cases pop from the root first, half from a top node of
 * the thread's own; each as built, then with the test build's yields. */
static void concurrent_case(void *ctx, int threads, bool overlap, uint64_t seed)
{
    (void)ctx;
    const tq_sizes z = tq_concurrent_sizes();
    for (int stress = 0; stress < 2; stress++) {
        mr_fppq q;
        assert_int_equal(mr_fppq_init(&q, z.ids, mr_fppq_default_levels(2 * threads), NULL),
                         MR_OK);
        const tq_queue t = as_queue(&q, (seed + (uint64_t)stress) % 2 == 1);
        atomic_store(&mr_ppq_stress, stress);
        tq_concurrent_run(&t, threads, z.rounds, z.ops, overlap, seed + (uint64_t)stress * 100);
        atomic_store(&mr_ppq_stress, 0);
        mr_fppq_free(&q);
    }
}

static void test_concurrent(void **state)
{
    (void)state;
    tq_thread_cases(concurrent_case, NULL, 200);
}

/* ---- the top-k guarantee under stress -------------------------------- */

/* Rank of item among the sorted snapshot (the number of smaller ones). */
static size_t rank_of(const uint64_t *sorted, size_t n, uint64_t item)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        const size_t mid = (lo + hi) / 2;
        if (sorted[mid] < item)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

enum { POPS = 2, UPDATES = 24, MAX_THREADS = 8 };

typedef struct topk_state {
    mr_fppq *q;
    uint64_t *snap;            /* sorted elements at the round's start */
    size_t snap_n;
    uint64_t popped[MAX_THREADS][POPS];
    size_t worst_top, worst_pop;
    unsigned bad_top, bad_pop, bad_heap, missing;
} topk_state;

static float random_key(uint64_t *rng)
{
    *rng += UINT64_C(0x9e3779b97f4a7c15);
    return (float)(mr_mix64(*rng) % 4096) / 64.0f; /* ties now and then */
}

/* Quiescent: every top node's element must rank below k among all. */
static void check_tops(topk_state *st, size_t k)
{
    const mr_ppq *h = &st->q->heap;
    const uint32_t n = (uint32_t)mr_ppq_size(h);
    for (uint32_t s = 0; s < n; s++)
        st->snap[s] = mr_ppq_slot_item(h, s);
    qsort(st->snap, n, sizeof *st->snap, tq_cmp_u64);
    st->snap_n = n;
    for (uint32_t t = 0; t < h->layout.top && t < n; t++) {
        const size_t r = rank_of(st->snap, n, mr_ppq_slot_item(h, t));
        if (r > st->worst_top)
            st->worst_top = r;
        st->bad_top += r >= k;
    }
    st->bad_heap += !mr_ppq_check(h);
}

/* The round's pops: each ranked below k plus the pops that may have come
 * before it in the round, among the round's starting elements. */
static void check_pops(topk_state *st, int team, size_t k)
{
    const size_t slack = (size_t)team * POPS - 1;
    for (int i = 0; i < team; i++)
        for (int p = 0; p < POPS; p++) {
            const uint64_t it = st->popped[i][p];
            if (it == UINT64_MAX)
                continue;
            const size_t r = rank_of(st->snap, st->snap_n, it);
            st->missing += r >= st->snap_n || st->snap[r] != it;
            if (r > st->worst_pop)
                st->worst_pop = r;
            st->bad_pop += r >= k + slack;
        }
}

/*
 * Rounds: at a barrier, every top node's element is checked against the
 * guarantee (rank < k among everything present) and the heap invariant;
 * then each thread pops POPS elements starting its search at a top node
 * of its own (so pops below the root happen without waiting for
 * contention); then each thread puts back what it popped with new keys and
 * changes UPDATES random keys, up and down (bubble-ups through the filter
 * with every update that lowers a key).
 */
static void topk_case(unsigned levels, int threads, unsigned rounds, uint32_t n, uint64_t seed)
{
    mr_fppq q;
    assert_int_equal(mr_fppq_init(&q, n, levels, NULL), MR_OK);
    topk_state st;
    memset(&st, 0, sizeof st);
    st.q = &q;
    st.snap = malloc(n * sizeof *st.snap);
    assert_non_null(st.snap);
    uint64_t rng = seed;
    for (uint32_t id = 0; id < n; id++)
        mr_fppq_update(&q, id, random_key(&rng));
    const size_t k = mr_fppq_guarantee(levels);
    int team = 1;
#pragma omp parallel num_threads(threads)
    {
        const int tid = omp_get_thread_num();
#pragma omp single
        team = omp_get_num_threads();
        uint64_t trng = mr_mix64(seed + 31 * (uint64_t)tid);
        for (unsigned round = 0; round < rounds; round++) {
#pragma omp single
            check_tops(&st, k);
            for (int p = 0; p < POPS; p++) {
                uint64_t it;
                const uint32_t first = (uint32_t)(tid * 5 + round * 3 + p);
                st.popped[tid][p] = pop_item(&q, first, &it) ? it : UINT64_MAX;
            }
#pragma omp barrier
#pragma omp single
            check_pops(&st, team, k);
            for (int p = 0; p < POPS; p++)
                if (st.popped[tid][p] != UINT64_MAX)
                    mr_fppq_update(&q, (uint32_t)st.popped[tid][p], random_key(&trng));
            for (int u = 0; u < UPDATES; u++) {
                trng += UINT64_C(0x9e3779b97f4a7c15);
                const uint32_t id = (uint32_t)(mr_mix64(trng) % n);
                mr_fppq_update(&q, id, random_key(&trng));
            }
#pragma omp barrier
        }
    }
    check_tops(&st, k);
    assert_int_equal(st.missing, 0);
    if (st.bad_top || st.bad_pop)
        print_message("l_f %u, %d threads: k %zu, worst top-node rank %zu (%u over), worst "
                      "pop rank %zu (%u over k + %d)\n",
                      levels, team, k, st.worst_top, st.bad_top, st.worst_pop, st.bad_pop,
                      team * POPS - 1);
    assert_int_equal(st.bad_top, 0);
    assert_int_equal(st.bad_pop, 0);
    assert_int_equal(st.bad_heap, 0);
    free(st.snap);
    mr_fppq_free(&q);
}

static void test_topk(void **state)
{
    (void)state;
    const bool quick = tq_quick();
    const unsigned rounds = quick ? 40 : 250;
    const uint32_t n = quick ? 400 : 2000;
    for (int stress = 0; stress < 2; stress++) {
        atomic_store(&mr_ppq_stress, stress);
        topk_case(1, 2, rounds, n, 300 + (uint64_t)stress);
        topk_case(2, 3, rounds, n, 310 + (uint64_t)stress);
        topk_case(3, 8, rounds, n, 320 + (uint64_t)stress);
        topk_case(5, 4, rounds / 2, n, 330 + (uint64_t)stress);
    }
    atomic_store(&mr_ppq_stress, 0);
}

/* Bulk build with filter levels: the heap order, the guarantee, the
 * order of the pops. */
static void test_build(void **state)
{
    (void)state;
    enum { N = 2500 };
    static uint32_t ids[N];
    static float keys[N];
    static uint64_t want[N];
    for (unsigned levels = 1; levels <= 5; levels++) {
        for (uint32_t i = 0; i < N; i++) {
            ids[i] = (i * 7919u) % N;
            keys[i] = tq_key(i * 37u + levels);
            want[i] = tq_pack(ids[i], keys[i]);
        }
        qsort(want, N, sizeof *want, tq_cmp_u64);
        mr_fppq q;
        assert_int_equal(mr_fppq_init(&q, N, levels, NULL), MR_OK);
        mr_fppq_build(&q, ids, keys, N);
        assert_true(mr_fppq_check(&q));
        for (uint32_t t = 0; t < q.heap.layout.top; t++)
            assert_true(rank_of(want, N, mr_ppq_slot_item(&q.heap, t)) <
                        mr_fppq_guarantee(levels));
        for (uint32_t i = 0; i < N; i++) {
            uint64_t it;
            assert_true(pop_item(&q, 0, &it));
            assert_true(it == want[i]);
        }
        mr_fppq_free(&q);
    }
}

static void test_init_errors(void **state)
{
    (void)state;
    mr_fppq q;
    mr_error err;
    assert_int_equal(mr_fppq_init(&q, 10, 0, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "filter level");
    mr_fppq_free(&q);
    assert_int_equal(mr_fppq_init(&q, 10, MR_FILTER_MAX_LEVELS + 1, &err),
                     MR_ERR_INVALID_ARGUMENT);
    mr_fppq_free(&q);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layout_table1), cmocka_unit_test(test_guarantee),
        cmocka_unit_test(test_default_levels), cmocka_unit_test(test_model),
        cmocka_unit_test(test_concurrent),     cmocka_unit_test(test_topk),
        cmocka_unit_test(test_build),          cmocka_unit_test(test_init_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
