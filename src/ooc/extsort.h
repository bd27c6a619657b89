/*
 * An external sort of fixed-size records through one temporary file
 * (extsort.c), for the out-of-core readers' tables that grow with the
 * input (binary STL's weld of its corners): records come in any order,
 * are sorted in memory in runs and written, then come back in order from
 * a merge of the runs (a heap of the runs' heads, each read in blocks).
 * The order: a 64-bit key of each record first (a run is radix-sorted by
 * it, stably), then the comparator among equal keys. Internal.
 */
#ifndef MR_OOC_EXTSORT_H
#define MR_OOC_EXTSORT_H

#include "temp.h"

/* A key that puts records of bitwise-equal positions (three floats'
 * bits) together. */
static inline uint64_t ooc_position_key(const uint32_t bits[3])
{
    return mr_mix64(((uint64_t)bits[0] << 32 | bits[1]) ^ mr_mix64(bits[2]));
}

/* A total order of two records (<0, 0, >0), among records of one key. */
typedef int (*ooc_record_cmp)(const void *a, const void *b);
/* A record's key: the order's first part. */
typedef uint64_t (*ooc_record_key)(const void *a);

typedef struct ooc_run {
    uint64_t at, count;   /* first record, records */
    uint64_t next;        /* merge: the next record to read */
    char *buf;            /* merge: a block of it */
    size_t have, pos;
} ooc_run;

typedef struct ooc_extsort {
    ooc_temp *temp;
    ooc_file file;
    size_t rec;           /* bytes a record */
    size_t run_records;   /* records a run holds in memory */
    ooc_record_cmp cmp;
    ooc_record_key key;
    unsigned key_bits;    /* the keys' significant bits */
    int threads;          /* for a run's sort */
    char *buf;            /* the run being filled */
    char *sorted;         /* a run in order */
    uint64_t *keys;       /* a run's keys */
    uint32_t *ids;        /* and its records' places */
    size_t fill;
    ooc_run *runs;
    size_t nruns, cap;
    uint64_t total;
    /* the merge */
    size_t block;         /* records a run's block */
    uint32_t *heap;
    size_t nheap;
    char *last;           /* the record next() handed out */
} ooc_extsort;

/* Runs in about run_bytes of memory (the records, their keys and the
 * sort's buffers). */
mr_status ooc_extsort_init(ooc_extsort *x, ooc_temp *t, size_t record_bytes, size_t run_bytes,
                           ooc_record_key key, unsigned key_bits, ooc_record_cmp cmp,
                           int threads, mr_error *err);
mr_status ooc_extsort_add(ooc_extsort *x, const void *record, mr_error *err);
/* No more records: the merge starts (its blocks take about
 * merge_bytes in all). */
mr_status ooc_extsort_finish(ooc_extsort *x, size_t merge_bytes, mr_error *err);
/* The next record in order into *record (valid until the next call), or
 * NULL at the end. */
mr_status ooc_extsort_next(ooc_extsort *x, const void **record, mr_error *err);
void ooc_extsort_free(ooc_extsort *x);

#endif
