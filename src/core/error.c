/* madvise and MADV_HUGEPAGE (Linux) are beyond POSIX */
#define _DEFAULT_SOURCE 1

/* Error records and the library's small shared utilities. */
#include "internal.h"

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include <stdio.h>
#include <string.h>
#include <time.h>

#include "omp_compat.h"

const char *mr_version(void) { return MR_VERSION_STRING; }

const char *mr_status_string(mr_status status)
{
    switch (status) {
    case MR_OK: return "ok";
    case MR_ERR_INVALID_ARGUMENT: return "invalid argument";
    case MR_ERR_IO: return "i/o error";
    case MR_ERR_PARSE: return "parse error";
    case MR_ERR_UNSUPPORTED: return "unsupported";
    case MR_ERR_EMPTY: return "empty input";
    case MR_ERR_TOO_LARGE: return "too large";
    case MR_ERR_NO_MEMORY: return "out of memory";
    case MR_ERR_CANCELLED: return "cancelled";
    }
    return "unknown status";
}

void mr_error_clear(mr_error *err)
{
    if (!err)
        return;
    err->status = MR_OK;
    err->line = MR_NO_POSITION;
    err->offset = MR_NO_POSITION;
    err->message[0] = '\0';
}

mr_status mr_fail(mr_error *err, mr_status status, const char *name, uint64_t line,
                  uint64_t offset, const char *fmt, ...)
{
    if (!err)
        return status;
    err->status = status;
    err->line = line;
    err->offset = offset;

    char *out = err->message;
    size_t cap = sizeof err->message;
    int n;
    const char *sep = name ? ": " : "";
    if (!name)
        name = "";
    if (line != MR_NO_POSITION)
        n = snprintf(out, cap, "%s%s%llu: ", name, name[0] ? ":" : "line ",
                     (unsigned long long)line);
    else if (offset != MR_NO_POSITION)
        n = snprintf(out, cap, "%s%sbyte %llu: ", name, sep, (unsigned long long)offset);
    else
        n = snprintf(out, cap, "%s%s", name, sep);
    if (n < 0)
        n = 0;
    if ((size_t)n >= cap)
        n = (int)cap - 1;

    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out + n, cap - (size_t)n, fmt, ap);
    va_end(ap);
    return status;
}

mr_status mr_fail_nomem(mr_error *err, const char *name, size_t bytes)
{
    return mr_fail_plain(err, MR_ERR_NO_MEMORY, name, "out of memory allocating %zu bytes",
                         bytes);
}

/*
 * Large arrays on huge pages where the system offers them on request
 * (Linux transparent huge pages in "madvise" or "always" mode): a 2 MiB
 * page costs one page fault where 4 KiB pages cost 512, and one TLB entry
 * instead of 512 -- the simplifiers read their arrays at random. A block
 * gets the huge pages inside it, and the one it ends in when that wastes
 * at most an eighth of the block (so the resident memory grows by at most
 * that). Measured on a 2-core KVM guest, where a 4 KiB page fault cost
 * about 12 us: `meshreduce simplify` of a 1M-triangle scan to 10 % went
 * from 37,500 page faults to 1,450 and from 1.48 to 0.79 s (1 thread), 0.89
 * to 0.51 s (2 threads). MR_HUGE_PAGES=0 in the environment turns it off
 * (for comparisons). Elsewhere, or when madvise refuses, these are plain
 * blocks; every block is freed by free() as any other.
 */
#if defined(__linux__) && defined(MADV_HUGEPAGE)
#define MR_HUGE 1
#define HUGE_PAGE ((size_t)2 << 20)

static bool huge_pages(void)
{
    static int on = -1; /* unknown yet; every thread finds the same answer */
    int v = __atomic_load_n(&on, __ATOMIC_RELAXED);
    if (v < 0) {
        const char *e = getenv("MR_HUGE_PAGES");
        v = !(e && strcmp(e, "0") == 0);
        __atomic_store_n(&on, v, __ATOMIC_RELAXED);
    }
    return v;
}

/* How much of a block of `bytes` to put on huge pages (0: none). */
static size_t huge_span(size_t bytes)
{
    const size_t up = (bytes + HUGE_PAGE - 1) & ~(HUGE_PAGE - 1);
    return up - bytes <= bytes / 8 ? up : bytes & ~(HUGE_PAGE - 1);
}
#endif

static void *alloc_bytes(size_t bytes)
{
#ifdef MR_HUGE
    const size_t huge = huge_span(bytes);
    if (huge && huge_pages()) {
        void *p = NULL;
        if (posix_memalign(&p, HUGE_PAGE, huge > bytes ? huge : bytes) != 0)
            return NULL;
        (void)madvise(p, huge, MADV_HUGEPAGE); /* a hint: may fail */
        return p;
    }
#endif
    return malloc(bytes ? bytes : 1);
}

void *mr_alloc_array(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    return alloc_bytes(count * size);
}

void *mr_calloc_array(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    if (!count || !size)
        return calloc(1, 1);
#ifdef MR_HUGE
    const size_t bytes = count * size;
    if (huge_span(bytes) && huge_pages()) {
        void *p = alloc_bytes(bytes);
        if (p)
            memset(p, 0, bytes);
        return p;
    }
#endif
    return calloc(count, size);
}

void *mr_realloc_array(void *p, size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    if (!p)
        return alloc_bytes(bytes);
    void *q = realloc(p, bytes ? bytes : 1);
#ifdef MR_HUGE
    /* grown in place or moved: the whole huge pages inside it */
    if (q && bytes >= 2 * HUGE_PAGE && huge_pages()) {
        const uintptr_t a = ((uintptr_t)q + HUGE_PAGE - 1) & ~(uintptr_t)(HUGE_PAGE - 1);
        const uintptr_t b = ((uintptr_t)q + bytes) & ~(uintptr_t)(HUGE_PAGE - 1);
        if (b > a)
            (void)madvise((void *)a, b - a, MADV_HUGEPAGE);
    }
#endif
    return q;
}

int mr_thread_count(int requested)
{
    int n = requested > 0 ? requested : omp_get_max_threads();
    /* No more active levels of parallelism allowed (a call from inside the
     * caller's own parallel region, nesting off; or the serial build): a
     * team opened here has one thread, so one is asked for. */
    if (omp_get_active_level() >= omp_get_max_active_levels())
        n = 1;
    const int limit = omp_get_thread_limit();
    if (limit > 0 && n > limit)
        n = limit;
    return n > 0 ? n : 1;
}

double mr_now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
