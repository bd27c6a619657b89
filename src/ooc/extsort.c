/* An external sort of fixed-size records (extsort.h). */
#include "extsort.h"

#include "../mesh/adjacency.h"

#include <stdlib.h>

/* Bytes a record takes in a run beside itself: the sorted copy is the
 * record again; its key and its place; the radix sort's copies of both
 * live in the sorted copy's room (free until the sort is done) when a
 * record has 12 bytes at least, else beside. */
enum { RUN_EXTRA = 8 + 4, RADIX_EXTRA = 8 + 4 };

mr_status ooc_extsort_init(ooc_extsort *x, ooc_temp *t, size_t record_bytes, size_t run_bytes,
                           ooc_record_key key, unsigned key_bits, ooc_record_cmp cmp,
                           int threads, mr_error *err)
{
    memset(x, 0, sizeof *x);
    x->temp = t;
    x->file.fd = -1;
    if (record_bytes == 0 || record_bytes > 64)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "an external sort's records of %zu bytes (1 to 64)", record_bytes);
    x->rec = record_bytes;
    const size_t per = 2 * record_bytes + RUN_EXTRA + (record_bytes < RADIX_EXTRA ? RADIX_EXTRA : 0);
    x->run_records = run_bytes / per < 1024 ? 1024 : run_bytes / per;
    if (x->run_records > UINT32_MAX)
        x->run_records = UINT32_MAX;
    x->key = key;
    x->key_bits = key_bits ? key_bits : 64;
    x->cmp = cmp;
    x->threads = threads > 0 ? threads : 1;
    x->buf = mr_alloc_array(x->run_records, record_bytes);
    x->sorted = mr_alloc_array(x->run_records, record_bytes);
    x->keys = mr_alloc_array(x->run_records, sizeof *x->keys);
    x->ids = mr_alloc_array(x->run_records, sizeof *x->ids);
    if (!x->buf || !x->sorted || !x->keys || !x->ids)
        return mr_fail_nomem(err, NULL, x->run_records * per);
    return ooc_file_open(t, &x->file, err);
}

/* The full order: the key, then the comparator. */
static int order(const ooc_extsort *x, const void *a, const void *b)
{
    const uint64_t ka = x->key(a), kb = x->key(b);
    return ka < kb ? -1 : ka > kb ? 1 : x->cmp(a, b);
}

/* The run in memory in order: radix-sorted by key (stable), then each
 * stretch of one key put in the comparator's order (an insertion sort:
 * such stretches are short and mostly in order already). */
static mr_status sort_run(ooc_extsort *x, mr_error *err)
{
    const size_t n = x->fill, rec = x->rec;
    for (size_t i = 0; i < n; i++) {
        x->keys[i] = x->key(x->buf + i * rec);
        x->ids[i] = (uint32_t)i;
    }
    mr_status st;
    if (rec >= RADIX_EXTRA) {
        /* the sort's copies in the sorted run's room: allocated once,
         * faulted in once, not again for every run */
        uint64_t *tk = (uint64_t *)(void *)x->sorted;
        uint32_t *tv = (uint32_t *)(void *)(x->sorted + 8 * n);
        st = mr_radix_sort_u64_scratch(x->keys, x->ids, n, x->key_bits, x->threads, tk, tv, err);
    } else {
        st = mr_radix_sort_u64(x->keys, x->ids, n, x->key_bits, x->threads, err);
    }
    if (st != MR_OK)
        return st;
    for (size_t i = 0; i < n; i++)
        memcpy(x->sorted + i * rec, x->buf + (size_t)x->ids[i] * rec, rec);
    char tmp[64];
    for (size_t i = 1; i < n; i++) {
        if (x->keys[i] != x->keys[i - 1] ||
            x->cmp(x->sorted + (i - 1) * rec, x->sorted + i * rec) <= 0)
            continue;
        /* out of order within its key: insert it back */
        memcpy(tmp, x->sorted + i * rec, rec);
        size_t j = i;
        while (j > 0 && x->keys[j - 1] == x->keys[i] && x->cmp(x->sorted + (j - 1) * rec, tmp) > 0) {
            memcpy(x->sorted + j * rec, x->sorted + (j - 1) * rec, rec);
            j--;
        }
        memcpy(x->sorted + j * rec, tmp, rec);
    }
    return MR_OK;
}

static mr_status flush_run(ooc_extsort *x, mr_error *err)
{
    if (x->fill == 0)
        return MR_OK;
    mr_status st = sort_run(x, err);
    if (st != MR_OK)
        return st;
    if (x->nruns == x->cap) {
        const size_t ncap = x->cap ? 2 * x->cap : 16;
        ooc_run *r = mr_realloc_array(x->runs, ncap, sizeof *r);
        if (!r)
            return mr_fail_nomem(err, NULL, ncap * sizeof *r);
        x->runs = r;
        x->cap = ncap;
    }
    ooc_run *r = &x->runs[x->nruns++];
    memset(r, 0, sizeof *r);
    r->at = x->total - x->fill;
    r->count = x->fill;
    st = ooc_file_write(x->temp, &x->file, r->at * x->rec, x->sorted, x->fill * x->rec, err);
    x->fill = 0;
    return st;
}

mr_status ooc_extsort_add(ooc_extsort *x, const void *record, mr_error *err)
{
    memcpy(x->buf + x->fill * x->rec, record, x->rec);
    x->fill++;
    x->total++;
    return x->fill == x->run_records ? flush_run(x, err) : MR_OK;
}

/* The heap of runs by their head record (ties: the lower run, whose
 * records came first). */
static const char *head(const ooc_extsort *x, uint32_t r)
{
    const ooc_run *u = &x->runs[r];
    return u->buf + u->pos * x->rec;
}

static bool before(const ooc_extsort *x, uint32_t a, uint32_t b)
{
    const int c = order(x, head(x, a), head(x, b));
    return c < 0 || (c == 0 && a < b);
}

static void sift_down(ooc_extsort *x, size_t i)
{
    for (;;) {
        size_t l = 2 * i + 1, m = i;
        if (l < x->nheap && before(x, x->heap[l], x->heap[m]))
            m = l;
        if (l + 1 < x->nheap && before(x, x->heap[l + 1], x->heap[m]))
            m = l + 1;
        if (m == i)
            return;
        const uint32_t t = x->heap[i];
        x->heap[i] = x->heap[m];
        x->heap[m] = t;
        i = m;
    }
}

/* Read a run's next block; false when it is done. */
static mr_status refill(ooc_extsort *x, ooc_run *r, bool *more, mr_error *err)
{
    const uint64_t left = r->count - r->next;
    *more = left > 0;
    if (!left)
        return MR_OK;
    const size_t n = left < x->block ? (size_t)left : x->block;
    mr_status st = ooc_file_read(x->temp, &x->file, (r->at + r->next) * x->rec, r->buf, n * x->rec,
                                 err);
    r->next += n;
    r->have = n;
    r->pos = 0;
    return st;
}

mr_status ooc_extsort_finish(ooc_extsort *x, size_t merge_bytes, mr_error *err)
{
    mr_status st = flush_run(x, err);
    free(x->buf);
    free(x->sorted);
    free(x->keys);
    free(x->ids);
    x->buf = x->sorted = NULL;
    x->keys = NULL;
    x->ids = NULL;
    if (st != MR_OK)
        return st;
    const size_t per = x->nruns ? merge_bytes / x->nruns / x->rec : 0;
    x->block = per < 256 ? 256 : per;
    x->heap = mr_alloc_array(x->nruns + 1, sizeof *x->heap);
    x->last = mr_alloc_array(1, x->rec);
    if (!x->heap || !x->last)
        return mr_fail_nomem(err, NULL, x->nruns * 4);
    for (size_t r = 0; r < x->nruns; r++) {
        ooc_run *u = &x->runs[r];
        u->buf = mr_alloc_array(x->block, x->rec);
        if (!u->buf)
            return mr_fail_nomem(err, NULL, x->block * x->rec);
        bool more;
        if ((st = refill(x, u, &more, err)) != MR_OK)
            return st;
        if (more)
            x->heap[x->nheap++] = (uint32_t)r;
    }
    for (size_t i = x->nheap / 2; i-- > 0;)
        sift_down(x, i);
    return MR_OK;
}

mr_status ooc_extsort_next(ooc_extsort *x, const void **record, mr_error *err)
{
    *record = NULL;
    if (x->nheap == 0)
        return MR_OK;
    const uint32_t r = x->heap[0];
    ooc_run *u = &x->runs[r];
    memcpy(x->last, head(x, r), x->rec);
    *record = x->last;
    if (++u->pos == u->have) {
        bool more;
        mr_status st = refill(x, u, &more, err);
        if (st != MR_OK)
            return st;
        if (!more)
            x->heap[0] = x->heap[--x->nheap];
    }
    if (x->nheap)
        sift_down(x, 0);
    return MR_OK;
}

void ooc_extsort_free(ooc_extsort *x)
{
    free(x->buf);
    free(x->sorted);
    free(x->keys);
    free(x->ids);
    for (size_t r = 0; r < x->nruns; r++)
        free(x->runs[r].buf);
    free(x->runs);
    free(x->heap);
    free(x->last);
    ooc_file_close(x->temp, &x->file);
    memset(x, 0, sizeof *x);
    x->file.fd = -1;
}
