/*
 * Throughput of the concurrent priority queues (internal components, for
 * the queue-driven simplifiers): PPQ (strict pop), RPPQ (pop among the
 * FPPQ's top nodes, no filter), FPPQ (default filter levels for the thread
 * count) and the MultiQueue (2 queues per thread).
 *
 * The load imitates a decimation step: pop an element, give 4 random others
 * new keys near the popped one's (up or down: the keys present span about
 * as much), put the popped one back with a larger key; the queue keeps its
 * size. Each thread runs for --seconds; the figure is
 * steps (and queue operations: 6 per step) per second over all threads.
 *
 *   bench_queues [--n N] [--seconds S] [--threads T1,T2,...]
 */
#include "benchutil.h"

#include "core/internal.h"
#include "core/omp_compat.h"
#include "qem/strategies/parallel/fppq.h"
#include "qem/strategies/parallel/multiqueue.h"

#include <stdlib.h>
#include <string.h>

typedef enum kind { PPQ, RPPQ, FPPQ, MQ } kind;
static const char *const names[] = {"PPQ", "RPPQ", "FPPQ", "MultiQueue"};

typedef struct queue {
    kind k;
    unsigned levels;
    mr_ppq ppq;
    mr_fppq fppq;
    mr_multiqueue mq;
} queue;

static inline uint64_t next(uint64_t *s)
{
    *s += UINT64_C(0x9e3779b97f4a7c15);
    return mr_mix64(*s);
}

static inline float rkey(uint64_t *s) { return (float)(next(s) >> 40) * (1.0f / 16777216.0f); }

static void update(queue *q, uint32_t id, float key, uint64_t *rng)
{
    switch (q->k) {
    case PPQ:
    case RPPQ:
        mr_ppq_update(&q->ppq, id, key);
        break;
    case FPPQ:
        mr_fppq_update(&q->fppq, id, key);
        break;
    case MQ:
        mr_multiqueue_update(&q->mq, id, key, rng);
        break;
    }
}

static bool pop(queue *q, uint64_t *rng, uint32_t *id, float *key)
{
    switch (q->k) {
    case PPQ:
        return mr_ppq_pop(&q->ppq, id, key);
    case RPPQ:
        return mr_ppq_pop_relaxed(&q->ppq, mr_fppq_top_nodes(q->levels), 0, id, key);
    case FPPQ:
        return mr_fppq_pop(&q->fppq, id, key);
    case MQ:
        return mr_multiqueue_pop(&q->mq, rng, id, key);
    }
    return false;
}

static double run(kind k, uint32_t n, int threads, double seconds)
{
    queue q;
    memset(&q, 0, sizeof q);
    q.k = k;
    q.levels = mr_fppq_default_levels(threads);
    mr_error err;
    mr_status st = MR_OK;
    if (k == PPQ || k == RPPQ)
        st = mr_ppq_init(&q.ppq, n, &err);
    else if (k == FPPQ)
        st = mr_fppq_init(&q.fppq, n, q.levels, &err);
    else
        st = mr_multiqueue_init(&q.mq, n, threads, 2, &err);
    bench_check(st, &err);
    uint64_t rng = 12345;
    for (uint32_t id = 0; id < n; id++)
        update(&q, id, rkey(&rng), &rng);
    uint64_t steps = 0;
    double elapsed = 0;
#pragma omp parallel num_threads(threads) reduction(+ : steps)
    {
        uint64_t r = mr_mix64(99 + (uint64_t)omp_get_thread_num());
        const double t0 = bench_now();
        double t = t0;
        while (t - t0 < seconds) {
            for (int i = 0; i < 64; i++) {
                uint32_t id;
                float key;
                if (!pop(&q, &r, &id, &key))
                    continue;
                /* new keys near the popped one, as a collapse's
                 * neighbours get (the keys present span about 1) */
                for (int j = 0; j < 4; j++)
                    update(&q, (uint32_t)(next(&r) % n), key + rkey(&r), &r);
                update(&q, id, key + rkey(&r), &r);
                steps++;
            }
            t = bench_now();
        }
#pragma omp master
        elapsed = t - t0;
    }
    if (k == PPQ || k == RPPQ)
        mr_ppq_free(&q.ppq);
    else if (k == FPPQ)
        mr_fppq_free(&q.fppq);
    else
        mr_multiqueue_free(&q.mq);
    return (double)steps / elapsed;
}

int main(int argc, char **argv)
{
    uint32_t n = 100000;
    double seconds = 0.3;
    int threads[16] = {1, 2};
    int nthreads = 2;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--n") && i + 1 < argc) {
            n = (uint32_t)strtoul(argv[++i], NULL, 10);
        } else if (!strcmp(argv[i], "--seconds") && i + 1 < argc) {
            seconds = strtod(argv[++i], NULL);
        } else if (!strcmp(argv[i], "--threads") && i + 1 < argc) {
            nthreads = 0;
            for (char *s = argv[++i]; *s && nthreads < 16;) {
                threads[nthreads++] = (int)strtol(s, &s, 10);
                if (*s == ',')
                    s++;
            }
        } else {
            fprintf(stderr, "usage: bench_queues [--n N] [--seconds S] [--threads T1,T2]\n");
            return 2;
        }
    }
    bench_print_machine(stdout);
    printf("%u elements, %.2f s a run; steps/s (a step: 1 pop + 5 updates)\n", n, seconds);
    printf("%-11s", "queue");
    for (int t = 0; t < nthreads; t++)
        printf("  %9d thr", threads[t]);
    printf("\n");
    for (int k = PPQ; k <= MQ; k++) {
        printf("%-11s", names[k]);
        for (int t = 0; t < nthreads; t++)
            printf("  %13.0f", run((kind)k, n, threads[t], seconds));
        printf("\n");
    }
    return 0;
}
