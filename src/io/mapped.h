/* Input files mapped into memory, and their pages given back when read
 * (mapped.c): the readers of whole files (io.c) and of files in pieces
 * (the PLY source). Internal. */
#ifndef MR_IO_MAPPED_H
#define MR_IO_MAPPED_H

#include "../core/internal.h"

typedef struct mr_mapped_file {
    const char *data;
    size_t size;
} mr_mapped_file;

/* Map a regular, non-empty file read-only. A directory, a FIFO, a device
 * or standard input is refused with a clear error (MR_ERR_IO), an empty
 * file with MR_ERR_EMPTY. */
mr_status mr_map_file(const char *path, mr_mapped_file *f, mr_error *err);
void mr_unmap_file(mr_mapped_file *f);
/* Give back the pages of bytes [begin, end) (whole pages within it): they
 * leave the resident set and are read again from the page cache when
 * touched. Mapped pages count in the resident set, so a pass over a big
 * file gives its pages back as it goes. */
void mr_release_mapped(const mr_mapped_file *f, size_t begin, size_t end);

/* Map the pages of bytes [begin, end) ahead of reading them, in one call
 * instead of a fault per page (Linux's MADV_POPULATE_READ; elsewhere
 * nothing: the reads fault them in). */
void mr_populate_mapped(const mr_mapped_file *f, size_t begin, size_t end);

#endif
