/* The out-of-core paths' temporary files (temp.h). */
#define _GNU_SOURCE
#include "temp.h"
#include "../io/output.h"

#include <errno.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

mr_status ooc_temp_init(ooc_temp *t, const char *dir, const char *out_path, uint64_t budget,
                        mr_error *err)
{
    memset(t, 0, sizeof *t);
    t->budget = budget;
    const char *env = getenv("TMPDIR");
    if (dir && *dir) {
        snprintf(t->dir, sizeof t->dir, "%s", dir);
    } else if (env && *env) {
        snprintf(t->dir, sizeof t->dir, "%s", env);
    } else {
        /* beside a regular output, else /tmp */
        struct stat sb;
        const char *slash = out_path ? strrchr(out_path, '/') : NULL;
        const bool regular = out_path && (stat(out_path, &sb) != 0 || S_ISREG(sb.st_mode));
        if (regular && slash && (size_t)(slash - out_path) < sizeof t->dir)
            snprintf(t->dir, sizeof t->dir, "%.*s", slash == out_path ? 1 : (int)(slash - out_path),
                     out_path);
        else if (regular && !slash)
            snprintf(t->dir, sizeof t->dir, ".");
        else
            snprintf(t->dir, sizeof t->dir, "/tmp");
    }
    if (strlen(t->dir) + 64 >= sizeof t->dir)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "temporary directory name too long");
    struct stat sb;
    if (stat(t->dir, &sb) != 0)
        return mr_fail_plain(err, MR_ERR_IO, t->dir, "temporary directory: %s", strerror(errno));
    if (!S_ISDIR(sb.st_mode))
        return mr_fail_plain(err, MR_ERR_IO, t->dir, "temporary directory: not a directory");
    mr_scratch_sweep(t->dir);
    ooc_file probe = {-1, 0};
    mr_status st = ooc_file_open(t, &probe, err);
    ooc_file_close(t, &probe);
    return st;
}

mr_status ooc_file_open(ooc_temp *t, ooc_file *f, mr_error *err)
{
    f->size = 0;
    f->fd = mr_scratch_open(t->dir, err);
    if (f->fd < 0)
        return MR_ERR_IO;
    t->files++;
    return MR_OK;
}

static char *bytes(char *buf, size_t cap, uint64_t n)
{
    if (n >= (uint64_t)1 << 30)
        snprintf(buf, cap, "%.2f GiB", (double)n / (double)((uint64_t)1 << 30));
    else if (n >= (uint64_t)1 << 20)
        snprintf(buf, cap, "%.1f MiB", (double)n / (double)((uint64_t)1 << 20));
    else
        snprintf(buf, cap, "%llu bytes", (unsigned long long)n);
    return buf;
}

mr_status ooc_file_write(ooc_temp *t, ooc_file *f, uint64_t off, const void *buf, size_t n,
                         mr_error *err)
{
    const uint64_t end = off + n;
    if (end > f->size) {
        const uint64_t grow = end - f->size;
        if (t->budget && t->used + grow > t->budget) {
            char a[32], b[32];
            return mr_fail_plain(err, MR_ERR_IO, t->dir,
                                 "temporary files would exceed the temporary-disk budget of "
                                 "%s (%s in use): give a larger --temp-budget, or a larger "
                                 "--memory (fewer, larger chunks spill less)",
                                 bytes(a, sizeof a, t->budget), bytes(b, sizeof b, t->used));
        }
    }
    const char *p = buf;
    size_t left = n;
    uint64_t at = off;
    while (left > 0) {
        const ssize_t w = pwrite(f->fd, p, left, (off_t)at);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            const int e = w < 0 ? errno : ENOSPC;
            char a[32];
            return mr_fail_plain(err, MR_ERR_IO, t->dir,
                                 "writing a temporary file failed (%s of temporary files in "
                                 "use): %s",
                                 bytes(a, sizeof a, t->used), strerror(e));
        }
        p += w;
        left -= (size_t)w;
        at += (uint64_t)w;
    }
    if (end > f->size) {
        t->used += end - f->size;
        f->size = end;
        t->peak = t->used > t->peak ? t->used : t->peak;
    }
    return MR_OK;
}

mr_status ooc_file_read(const ooc_temp *t, const ooc_file *f, uint64_t off, void *buf, size_t n,
                        mr_error *err)
{
    char *p = buf;
    size_t left = n;
    uint64_t at = off;
    while (left > 0) {
        const ssize_t r = pread(f->fd, p, left, (off_t)at);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            return mr_fail_plain(err, MR_ERR_IO, t->dir, "reading a temporary file failed: %s",
                                 r < 0 ? strerror(errno) : "it ended early");
        p += r;
        left -= (size_t)r;
        at += (uint64_t)r;
    }
    return MR_OK;
}

void ooc_file_close(ooc_temp *t, ooc_file *f)
{
    if (f->fd < 0)
        return;
    close(f->fd);
    f->fd = -1;
    t->used -= f->size;
    f->size = 0;
    t->files--;
}
