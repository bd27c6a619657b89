/* Output files and write errors, shared by the formats' writers, the
 * dispatcher (io.c) and the PNG writer (render/png.c): output.c. Internal. */
#ifndef MR_IO_OUTPUT_H
#define MR_IO_OUTPUT_H

#include "../core/internal.h"

#include <stdio.h>

/*
 * Output files. mr_output_open opens `path` for writing (out->f) and
 * mr_output_close flushes and closes it; it returns the final status: st, or
 * the first write error, with strerror's reason.
 *
 * A new or existing regular file appears whole or not at all: it is written
 * to a hidden temporary file beside it (".meshreduce-PID-XXXXXX", registered
 * for mr_remove_pending_files) and, when st is MR_OK and every write worked,
 * renamed onto it, else removed. An existing file keeps its permission
 * bits. A symbolic link is followed: its target is replaced, the link stays;
 * a dangling link is an error. Anything else (a device such as /dev/null, a
 * FIFO, a name for an open descriptor such as /dev/stdout) cannot be
 * replaced by a rename and is written in place: there, a failure can leave
 * part of the output written.
 */
#define MR_OUTPUT_PATH_CAP 4200 /* PATH_MAX and the temporary name */
typedef struct mr_output_file {
    FILE *f;
    bool direct;                   /* written in place, no temporary file */
    int slot;                      /* the temporary file's registry slot, or -1 */
    char dest[MR_OUTPUT_PATH_CAP]; /* what is written: path, or its link's target */
    char tmp[MR_OUTPUT_PATH_CAP];  /* the temporary file, when not direct */
} mr_output_file;
mr_status mr_output_open(mr_output_file *out, const char *path, mr_error *err);
mr_status mr_output_close(mr_output_file *out, const char *path, mr_status st, mr_error *err);
/* Files that appear together: mr_output_finish closes one as
 * mr_output_close does but keeps its temporary file (removed on failure);
 * mr_output_commit then moves it into place, or mr_output_abandon removes
 * it (each at most once; a file written in place is already there). */
mr_status mr_output_finish(mr_output_file *out, const char *path, mr_status st, mr_error *err);
mr_status mr_output_commit(mr_output_file *out, const char *path, mr_error *err);
void mr_output_abandon(mr_output_file *out);

/* Report a failed write as "<name>: write failed: <strerror(errnum)>"
 * (MR_ERR_IO); errnum 0 (no errno) reads as an I/O error. */
mr_status mr_fail_write(mr_error *err, const char *name, int errnum);

/*
 * Scratch files (the out-of-core paths' spills): mr_scratch_open opens a
 * new file in dir for reading and writing that has no name -- O_TMPFILE,
 * where the file system has it; else one created under a registered name,
 * .meshreduce-scratch-HOST-PID-XXXXXX, and unlinked at once -- so that it
 * goes with its descriptor however the process ends, SIGKILL included
 * (bar that moment of a name). Returns the descriptor, or -1 with err set
 * (naming dir). mr_scratch_sweep removes the scratch names of this host
 * whose process no longer exists (a SIGKILL at that moment); returns how
 * many.
 */
int mr_scratch_open(const char *dir, mr_error *err);
size_t mr_scratch_sweep(const char *dir);

#endif /* MR_IO_OUTPUT_H */
