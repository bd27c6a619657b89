/* The parallel priority queue with filter levels: see fppq.h. */
#include "fppq.h"

unsigned mr_fppq_default_levels(int threads)
{
    unsigned levels = 1;
    while (levels < MR_FILTER_MAX_LEVELS && ((uint64_t)2 << levels) < (uint64_t)threads)
        levels++;
    return levels;
}

mr_status mr_fppq_init(mr_fppq *q, size_t capacity, unsigned levels, mr_error *err)
{
    if (levels == 0) {
        memset(q, 0, sizeof *q);
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "a filter-level queue needs at least one filter level");
    }
    return mr_ppq_init_layout(&q->heap, capacity, levels, err);
}

void mr_fppq_free(mr_fppq *q)
{
    if (q)
        mr_ppq_free(&q->heap);
}
