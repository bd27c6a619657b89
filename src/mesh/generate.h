/* The sphere and the scan of generate.c made in pieces, for writers that
 * stream them (io/generate_file.c): the counts, then the positions and the
 * triangles of any range, the same values as mr_generate's. Internal. */
#ifndef MR_MESH_GENERATE_H
#define MR_MESH_GENERATE_H

#include "../core/internal.h"

typedef struct mr_gen_stream mr_gen_stream;

/* MR_GEN_SPHERE or MR_GEN_SCAN (the torus: MR_ERR_UNSUPPORTED). */
mr_status mr_gen_stream_open(mr_generator kind, size_t triangles, uint64_t seed,
                             mr_gen_stream **out, mr_error *err);
size_t mr_gen_stream_vertex_count(const mr_gen_stream *gs);
size_t mr_gen_stream_triangle_count(const mr_gen_stream *gs);
/* Vertices [first, first + count) into pos (3 count floats). */
void mr_gen_stream_positions(const mr_gen_stream *gs, size_t first, size_t count, float *pos);
/* Triangles [first, first + count) into idx (3 count). */
mr_status mr_gen_stream_triangles(const mr_gen_stream *gs, size_t first, size_t count,
                                  uint32_t *idx, mr_error *err);
void mr_gen_stream_close(mr_gen_stream *gs);

#endif
