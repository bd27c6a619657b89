/* Error records and the library's small shared utilities. */
#include "internal.h"

#include <stdio.h>
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

void *mr_alloc_array(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    return malloc(bytes ? bytes : 1);
}

void *mr_calloc_array(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    if (!count || !size)
        return calloc(1, 1);
    return calloc(count, size);
}

void *mr_realloc_array(void *p, size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    return realloc(p, bytes ? bytes : 1);
}

int mr_thread_count(int requested)
{
    if (requested > 0)
        return requested;
    int n = omp_get_max_threads();
    return n > 0 ? n : 1;
}

double mr_now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
