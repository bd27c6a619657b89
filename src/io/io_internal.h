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

#include "mapped.h"
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

/*
 * A binary PLY file read in pieces, for the paths that never hold a whole
 * mesh (the out-of-core cluster): the file is mapped and its header parsed
 * and checked as mr_read_ply does; the vertices of any range then decode
 * into a block of arrays (positions, and the attributes the block has
 * arrays for), their rows' pages given back once decoded, a vertex's
 * position reads straight from the map, and the faces come chunk by chunk
 * (at most mr_ply_source_max_faces triangles a call, polygons as fans),
 * their pages given back as they are read. The
 * values are mr_read_ply's for the same file, byte for byte, and so are
 * the errors (bad indices, non-finite positions: file and offset). Ascii
 * PLY, vertex elements with lists and triangle strips are refused
 * (MR_ERR_UNSUPPORTED): such files are read whole.
 */
typedef struct mr_ply_source mr_ply_source;
mr_status mr_ply_source_open(const char *path, int threads, mr_ply_source **out, mr_error *err);
void mr_ply_source_close(mr_ply_source *s);
size_t mr_ply_source_vertex_count(const mr_ply_source *s);
size_t mr_ply_source_triangle_count(const mr_ply_source *s);
unsigned mr_ply_source_attributes(const mr_ply_source *s); /* MR_ATTR_* */
size_t mr_ply_source_max_faces(const mr_ply_source *s);
mr_status mr_ply_source_vertices(mr_ply_source *s, size_t first, size_t count,
                                 const mr_mesh *block, mr_error *err);
void mr_ply_source_position(const mr_ply_source *s, uint32_t v, float p[3]);
/* Vertex v whole, at random: the arrays of `one` (a mesh of one vertex,
 * its attribute arrays those wanted, or NULL) filled as the reader fills
 * a vertex. */
void mr_ply_source_vertex(const mr_ply_source *s, uint32_t v, const mr_mesh *one);
/* The next chunk's triangles into idx; *count 0 once every face is read. */
mr_status mr_ply_source_next_faces(mr_ply_source *s, uint32_t *idx, size_t *count,
                                   mr_error *err);
/* The next face chunks' triangles into idx, decoded on the source's
 * threads: whole chunks while they fit `cap` triangles (one at least), at
 * most max_chunks of them and none past the end of a face element;
 * *count the triangles, *chunks the chunks (0: every face is read). */
mr_status mr_ply_source_next_batch(mr_ply_source *s, uint32_t *idx, size_t cap,
                                   size_t max_chunks, size_t *count, size_t *chunks,
                                   mr_error *err);
/* Start the faces again from the first (another pass). */
void mr_ply_source_rewind(mr_ply_source *s);
/* The face chunks (next_faces calls) of the file; start the faces at the
 * k-th (k past the last: none left). */
size_t mr_ply_source_face_chunks(const mr_ply_source *s);
void mr_ply_source_seek(mr_ply_source *s, size_t k);
/* Give back every page of the map read so far (after random reads). */
void mr_ply_source_release(mr_ply_source *s);
/* Map ahead the rows of vertices first..last (before reading their
 * positions at random). */
void mr_ply_source_prefetch(const mr_ply_source *s, uint32_t first, uint32_t last);

/*
 * An OBJ file read in windows of about `window` bytes (at line starts),
 * for the out-of-core paths: mr_obj_stream_open maps it and counts every
 * window (the in-memory reader's first pass); each mr_obj_stream_next then
 * parses the next window (its second pass) into its v lines' positions
 * and its faces' triangles (polygons as fans), with their global vertex
 * indices (relative ones resolved), until a window of no lines. The
 * values and the errors are mr_read_obj's, but for what its seams would
 * split: the vertices are the v lines (texture coordinate and normal
 * indices are noted, not kept; mr_obj_stream_attributes says which the
 * faces used, and whether a v line had a color, after the last window).
 * Each window's pages are given back once read.
 */
typedef struct mr_obj_stream mr_obj_stream;
typedef struct mr_obj_window {
    size_t first_vertex, vertex_count;     /* 0 at the end */
    const float *positions;                /* 3 * vertex_count */
    size_t first_triangle, triangle_count;
    const uint32_t *indices;               /* 3 * triangle_count */
    /* with mr_obj_stream_keep's attributes, else NULL: */
    const float *colors;                   /* 4 * vertex_count (white where a
                                              v line has none) */
    const uint32_t *corner_texcoords;      /* 3 * triangle_count: vt index
                                              (global), UINT32_MAX: none */
    const uint32_t *corner_normals;        /* 3 * triangle_count: vn index */
    size_t first_texcoord, texcoord_count; /* the window's vt lines */
    const float *texcoords;                /* 2 * texcoord_count */
    size_t first_normal, normal_count;     /* its vn lines */
    const float *normals;                  /* 3 * normal_count */
} mr_obj_window;
mr_status mr_obj_stream_open(const char *path, int threads, size_t window,
                             mr_obj_stream **out, mr_error *err);
void mr_obj_stream_close(mr_obj_stream *s);
size_t mr_obj_stream_vertex_count(const mr_obj_stream *s);
size_t mr_obj_stream_triangle_count(const mr_obj_stream *s);
size_t mr_obj_stream_max_vertices(const mr_obj_stream *s);  /* a window's most */
size_t mr_obj_stream_max_triangles(const mr_obj_stream *s);
unsigned mr_obj_stream_attributes(const mr_obj_stream *s);
/* Before the windows, from the counts: the attributes the file may have
 * (vt or vn lines; a color on the first v line of some window: the
 * windows depend on the file and `window` only). */
unsigned mr_obj_stream_may_have(const mr_obj_stream *s);
mr_status mr_obj_stream_next(mr_obj_stream *s, mr_obj_window *w, mr_error *err);
/* Before the first window: keep these attributes (MR_ATTR_*) of the
 * windows too -- the v lines' colors, the vt and vn lines, and each
 * corner's vt and vn index. */
mr_status mr_obj_stream_keep(mr_obj_stream *s, unsigned attributes, mr_error *err);

/* Check that every coordinate of the mesh's positions is finite and every
 * index is below vertex_count; on failure report the first bad element.
 * Readers that cannot check while parsing call this at the end. */
mr_status mr_validate_mesh(const mr_mesh *mesh, const char *name, mr_error *err);

#endif /* MR_IO_INTERNAL_H */
