/*
 * The contract between the format dispatcher (io.c) and the per-format
 * readers and writers (obj.c, ply.c, stl.c, xyz.c), which both stand on
 * output.h (options, output files, write errors).
 *
 * Readers:
 *   - parse `size` bytes at `data` (not NUL-terminated; may be a memory
 *     map), never reading outside [data, data + size);
 *   - fill the empty `mesh`, which the caller frees on failure too (a
 *     reader may leave partial arrays in it when it fails);
 *   - report every problem through mr_fail with `name` and the 1-based line
 *     (text) or byte offset (binary), and return its status;
 *   - never allocate per line or per element: count first, then allocate
 *     exact arrays (check counts announced by a header against the bytes
 *     that remain before allocating);
 *   - reject NaN and infinite coordinates, indices out of range, and files
 *     that hold nothing (MR_ERR_EMPTY).
 *   - `threads` is the resolved thread count (>= 1) a reader may use.
 *
 * Writers write to an open stdio stream; the dispatcher owns the temporary
 * file, checks ferror() and fclose(), and renames it into place, so that a
 * failed write leaves no partial file. `name` is the destination path for
 * messages. Writers:
 *   - report a failed fwrite/fputs with mr_fail_write(err, name, errno),
 *     straight after the call, so that the message says why (disk full);
 *   - are given only finite values: before creating any file the dispatcher
 *     refuses a mesh with NaN or infinity in what the format writes
 *     (written_arrays in io.c lists that per format: keep it in step when a
 *     writer writes a new attribute).
 */
#ifndef MR_IO_INTERNAL_H
#define MR_IO_INTERNAL_H

#include "output.h"

#include <errno.h>
#include <stdio.h>

mr_status mr_read_obj(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err);
mr_status mr_read_ply(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err);
mr_status mr_read_stl(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err);
mr_status mr_read_xyz(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err);

mr_status mr_write_obj(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err);
mr_status mr_write_ply(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err);
mr_status mr_write_stl(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err);
mr_status mr_write_xyz(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err);

/*
 * The PLY writer as a stream, for outputs that never stand in memory whole
 * (a generated mesh of a billion triangles, the out-of-core paths): the
 * header with the counts, then the vertices and then the faces in blocks
 * of any size, then the end, which checks the counts. The bytes are
 * mr_write_ply's for the same mesh and options. The stream writes to an
 * open FILE (an output file of output.h).
 */
typedef struct mr_ply_writer {
    const mr_mesh *mesh; /* the rows' arrays (a block, when streaming) */
    bool ascii, swap;
    bool normals, texcoords, colors;
} mr_ply_writer;
typedef struct mr_ply_stream {
    FILE *f;
    const char *name;
    size_t vertex_count, triangle_count, vertices_written, triangles_written;
    mr_ply_writer w;
} mr_ply_stream;
mr_status mr_ply_stream_begin(mr_ply_stream *s, FILE *f, size_t vertex_count,
                              size_t triangle_count, unsigned attributes,
                              const mr_write_options *options, const char *name, mr_error *err);
/* block: vertex_count vertices with the attribute arrays begin asked for */
mr_status mr_ply_stream_vertices(mr_ply_stream *s, const mr_mesh *block, mr_error *err);
mr_status mr_ply_stream_faces(mr_ply_stream *s, const uint32_t *indices, size_t count,
                              mr_error *err);
mr_status mr_ply_stream_end(mr_ply_stream *s, mr_error *err);

/* Check that every coordinate of the mesh's positions is finite and every
 * index is below vertex_count; on failure report the first bad element.
 * Readers that cannot check while parsing call this at the end. */
mr_status mr_validate_mesh(const mr_mesh *mesh, const char *name, mr_error *err);

#endif /* MR_IO_INTERNAL_H */
