/* Input files mapped into memory: see mapped.h. */
#define _DEFAULT_SOURCE /* madvise under strict C11 */
#include "mapped.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

mr_status mr_map_file(const char *path, mr_mapped_file *f, mr_error *err)
{
    f->data = NULL;
    f->size = 0;
    /* O_NONBLOCK: a FIFO would wait for its writer before fstat could refuse it */
    int fd = open(path, O_RDONLY | O_NONBLOCK);
    if (fd < 0)
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot open for reading: %s",
                             strerror(errno));
    struct stat sb;
    if (fstat(fd, &sb) != 0) {
        int e = errno;
        close(fd);
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot stat: %s", strerror(e));
    }
    if (S_ISDIR(sb.st_mode)) {
        close(fd);
        return mr_fail_plain(err, MR_ERR_IO, path, "is a directory, not a mesh file");
    }
    if (!S_ISREG(sb.st_mode)) {
        close(fd);
        return mr_fail_plain(err, MR_ERR_IO, path,
                             "is not a regular file (standard input, a FIFO or a device is "
                             "read in one pass, and mesh files are read in several: write it "
                             "to a file first)");
    }
    const size_t size = (size_t)sb.st_size;
    if (size == 0) {
        close(fd);
        return mr_fail_plain(err, MR_ERR_EMPTY, path, "file is empty");
    }
    void *map = mmap(NULL, size, PROT_READ, MAP_PRIVATE, fd, 0);
    close(fd);
    if (map == MAP_FAILED)
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot map file: %s", strerror(errno));
    f->data = map;
    f->size = size;
    return MR_OK;
}

void mr_unmap_file(mr_mapped_file *f)
{
    if (f->data)
        munmap((void *)f->data, f->size);
    f->data = NULL;
    f->size = 0;
}

void mr_release_mapped(const mr_mapped_file *f, size_t begin, size_t end)
{
    const size_t page = (size_t)sysconf(_SC_PAGESIZE);
    const uintptr_t base = (uintptr_t)f->data;
    uintptr_t a = (base + begin + page - 1) / page * page, b = (base + end) / page * page;
    if (end >= f->size)
        b = (base + f->size + page - 1) / page * page; /* the last, partial page too */
    if (b > a)
        madvise((void *)a, b - a, MADV_DONTNEED);
}

void mr_populate_mapped(const mr_mapped_file *f, size_t begin, size_t end)
{
#ifdef MADV_POPULATE_READ
    const size_t page = (size_t)sysconf(_SC_PAGESIZE);
    const uintptr_t base = (uintptr_t)f->data;
    end = end < f->size ? end : f->size;
    if (end <= begin)
        return;
    const uintptr_t a = (base + begin) / page * page, b = base + end;
    (void)madvise((void *)a, b - a, MADV_POPULATE_READ); /* a hint: faults do the same */
#else
    (void)f;
    (void)begin;
    (void)end;
#endif
}
