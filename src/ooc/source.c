/* An input mesh read in passes (source.h). */
#include "source.h"
#include "../io/io_internal.h"

static mr_status ply_vertices(void *impl, size_t first, size_t count, const mr_mesh *block,
                              mr_error *err)
{
    return mr_ply_source_vertices(impl, first, count, block, err);
}

static void ply_position(const void *impl, uint32_t v, float p[3])
{
    mr_ply_source_position(impl, v, p);
}

static void ply_prefetch(const void *impl, uint32_t first, uint32_t last)
{
    mr_ply_source_prefetch(impl, first, last);
}

static void ply_rewind(void *impl) { mr_ply_source_rewind(impl); }

static mr_status ply_next_faces(void *impl, uint32_t *idx, size_t *count, mr_error *err)
{
    return mr_ply_source_next_faces(impl, idx, count, err);
}

static void ply_release(void *impl) { mr_ply_source_release(impl); }

static void ply_close(void *impl) { mr_ply_source_close(impl); }

mr_status ooc_source_open(const char *path, int threads, ooc_source *s, mr_error *err)
{
    memset(s, 0, sizeof *s);
    if (mr_format_from_path(path) != MR_FORMAT_PLY)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, path,
                             "only binary PLY is read in pieces");
    mr_ply_source *p;
    mr_status st = mr_ply_source_open(path, threads, &p, err);
    if (st != MR_OK)
        return st;
    s->impl = p;
    s->vertex_count = mr_ply_source_vertex_count(p);
    s->triangle_count = mr_ply_source_triangle_count(p);
    s->max_faces = mr_ply_source_max_faces(p);
    s->attributes = mr_ply_source_attributes(p);
    s->vertices = ply_vertices;
    s->position = ply_position;
    s->prefetch = ply_prefetch;
    s->rewind = ply_rewind;
    s->next_faces = ply_next_faces;
    s->release = ply_release;
    s->close = ply_close;
    return MR_OK;
}

void ooc_source_close(ooc_source *s)
{
    if (s->impl)
        s->close(s->impl);
    memset(s, 0, sizeof *s);
}
