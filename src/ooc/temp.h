/*
 * The out-of-core paths' temporary files (temp.c): scratch files without a
 * name in one directory (mr_scratch_open: nothing is left behind however
 * the process ends), read and written at offsets, their bytes counted
 * against a budget for temporary disk. Internal.
 */
#ifndef MR_OOC_TEMP_H
#define MR_OOC_TEMP_H

#include "../core/internal.h"

#define MR_TEMP_DIR_CAP 4096

typedef struct ooc_temp {
    char dir[MR_TEMP_DIR_CAP];
    uint64_t budget;  /* bytes at most (0: no limit) */
    uint64_t used;    /* bytes in the open files */
    uint64_t peak;
    size_t files;     /* open now */
} ooc_temp;

typedef struct ooc_file {
    int fd;           /* -1: closed */
    uint64_t size;    /* bytes written (the end of the furthest write) */
} ooc_file;

/* The directory: dir, else $TMPDIR, else that of out_path when it names a
 * file in a directory, else /tmp. It must exist and take a file: checked
 * by opening one. Removes the scratch names of processes of this host
 * that no longer exist (mr_scratch_sweep). */
mr_status ooc_temp_init(ooc_temp *t, const char *dir, const char *out_path, uint64_t budget,
                        mr_error *err);

mr_status ooc_file_open(ooc_temp *t, ooc_file *f, mr_error *err);
/* Write n bytes at off (growing the file: counted against the budget). */
mr_status ooc_file_write(ooc_temp *t, ooc_file *f, uint64_t off, const void *buf, size_t n,
                         mr_error *err);
mr_status ooc_file_read(const ooc_temp *t, const ooc_file *f, uint64_t off, void *buf, size_t n,
                        mr_error *err);
/* Close (the file goes, its bytes leave the count); a closed one is left. */
void ooc_file_close(ooc_temp *t, ooc_file *f);

#endif
