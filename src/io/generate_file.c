/* Generating straight into a file (mr_generate_file): the sphere and the
 * scan as PLY through the PLY stream, block by block, in bounded memory;
 * anything else made in memory and written by mr_mesh_write. Either way
 * the bytes are mr_generate's mesh written by mr_mesh_write. */
#include "io_internal.h"
#include "../mesh/generate.h"

#include <stdlib.h>

/* Vertices or triangles a block: 12 MB of each array. */
enum { GEN_BLOCK = 1 << 20 };

static mr_status stream_ply(mr_gen_stream *gs, const char *path,
                            const mr_write_options *options, mr_error *err)
{
    const size_t vc = mr_gen_stream_vertex_count(gs), tc = mr_gen_stream_triangle_count(gs);
    float *pos = mr_alloc_array(3 * (size_t)GEN_BLOCK, sizeof *pos);
    uint32_t *idx = mr_alloc_array(3 * (size_t)GEN_BLOCK, sizeof *idx);
    if (!pos || !idx) {
        free(pos);
        free(idx);
        return mr_fail_nomem(err, path, 24 * (size_t)GEN_BLOCK);
    }
    mr_output_file out;
    mr_status st = mr_output_open(&out, path, err);
    if (st != MR_OK) {
        free(pos);
        free(idx);
        return st;
    }
    static const size_t bufsize = 1 << 20; /* as mr_mesh_write's */
    char *buf = malloc(bufsize);
    if (buf)
        setvbuf(out.f, buf, _IOFBF, bufsize);
    mr_ply_stream ps;
    st = mr_ply_stream_begin(&ps, out.f, vc, tc, 0, options, path, err);
    for (size_t v0 = 0; v0 < vc && st == MR_OK; v0 += GEN_BLOCK) {
        const size_t n = vc - v0 < GEN_BLOCK ? vc - v0 : GEN_BLOCK;
        mr_gen_stream_positions(gs, v0, n, pos);
        const mr_mesh block = {.vertex_count = n, .positions = pos};
        st = mr_ply_stream_vertices(&ps, &block, err);
    }
    for (size_t t0 = 0; t0 < tc && st == MR_OK; t0 += GEN_BLOCK) {
        const size_t n = tc - t0 < GEN_BLOCK ? tc - t0 : GEN_BLOCK;
        st = mr_gen_stream_triangles(gs, t0, n, idx, err);
        if (st == MR_OK)
            st = mr_ply_stream_faces(&ps, idx, n, err);
    }
    if (st == MR_OK)
        st = mr_ply_stream_end(&ps, err);
    st = mr_output_close(&out, path, st, err);
    free(buf);
    free(pos);
    free(idx);
    return st;
}

mr_status mr_generate_file(mr_generator kind, size_t triangles, uint64_t seed, const char *path,
                           const mr_write_options *options, size_t *vertices_out,
                           size_t *triangles_out, mr_error *err)
{
    mr_error_clear(err);
    if (vertices_out)
        *vertices_out = 0;
    if (triangles_out)
        *triangles_out = 0;
    if (!path)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no path given");
    mr_write_options defaults;
    if (!options) {
        mr_write_options_default(&defaults);
        options = &defaults;
    }
    const mr_format fmt =
        options->format != MR_FORMAT_AUTO ? options->format : mr_format_from_path(path);
    if (fmt == MR_FORMAT_PLY && (kind == MR_GEN_SPHERE || kind == MR_GEN_SCAN)) {
        mr_gen_stream *gs;
        mr_status st = mr_gen_stream_open(kind, triangles, seed, &gs, err);
        if (st != MR_OK)
            return st;
        st = stream_ply(gs, path, options, err);
        if (st == MR_OK && vertices_out)
            *vertices_out = mr_gen_stream_vertex_count(gs);
        if (st == MR_OK && triangles_out)
            *triangles_out = mr_gen_stream_triangle_count(gs);
        mr_gen_stream_close(gs);
        return st;
    }
    mr_mesh m;
    mr_mesh_init(&m);
    mr_status st = mr_generate(kind, triangles, seed, &m, err);
    if (st == MR_OK)
        st = mr_mesh_write(path, &m, options, err);
    if (st == MR_OK && vertices_out)
        *vertices_out = m.vertex_count;
    if (st == MR_OK && triangles_out)
        *triangles_out = m.triangle_count;
    mr_mesh_free(&m);
    return st;
}
