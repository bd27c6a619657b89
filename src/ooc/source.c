/* An input mesh read in passes (source.h). */
#define _GNU_SOURCE
#include "source.h"
#include "../io/io_internal.h"

#include <errno.h>
#include <sys/mman.h>

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

static void ply_seek(void *impl, size_t chunk) { mr_ply_source_seek(impl, chunk); }

static mr_status ply_next_faces(void *impl, uint32_t *idx, size_t *count, mr_error *err)
{
    return mr_ply_source_next_faces(impl, idx, count, err);
}

static void ply_release(void *impl) { mr_ply_source_release(impl); }

static void ply_close(void *impl) { mr_ply_source_close(impl); }

/* ---- an OBJ file, through temporary files ---------------------------------- */

enum { RAW_FACES = 1 << 16 }; /* triangles a next_faces call */

typedef struct raw_source {
    ooc_temp *temp;
    ooc_file pos, tri;
    const float *map; /* the positions, mapped */
    size_t map_bytes;
    size_t nt, next;  /* triangles; the next to read */
} raw_source;

static mr_status raw_vertices(void *impl, size_t first, size_t count, const mr_mesh *block,
                              mr_error *err)
{
    (void)err;
    const raw_source *r = impl;
    memcpy(block->positions, r->map + 3 * first, 12 * count);
    return MR_OK;
}

static void raw_position(const void *impl, uint32_t v, float p[3])
{
    const raw_source *r = impl;
    memcpy(p, r->map + 3 * (size_t)v, 12);
}

static void raw_prefetch(const void *impl, uint32_t first, uint32_t last)
{
    const raw_source *r = impl;
    const size_t page = 4096;
    const size_t b = (size_t)first * 12 / page * page, e = ((size_t)last + 1) * 12;
    madvise((char *)r->map + b, e - b, MADV_WILLNEED);
}

static void raw_rewind(void *impl) { ((raw_source *)impl)->next = 0; }

static void raw_seek(void *impl, size_t chunk)
{
    raw_source *r = impl;
    const uint64_t t = (uint64_t)chunk * RAW_FACES;
    r->next = t < r->nt ? (size_t)t : r->nt;
}

static mr_status raw_next_faces(void *impl, uint32_t *idx, size_t *count, mr_error *err)
{
    raw_source *r = impl;
    const size_t n = r->nt - r->next < RAW_FACES ? r->nt - r->next : RAW_FACES;
    *count = 0;
    if (n == 0)
        return MR_OK;
    mr_status st = ooc_file_read(r->temp, &r->tri, 12 * (uint64_t)r->next, idx, 12 * n, err);
    if (st == MR_OK) {
        r->next += n;
        *count = n;
    }
    return st;
}

static void raw_release(void *impl)
{
    const raw_source *r = impl;
    if (r->map_bytes)
        madvise((void *)r->map, r->map_bytes, MADV_DONTNEED);
}

static void raw_close(void *impl)
{
    raw_source *r = impl;
    if (r->map_bytes)
        munmap((void *)r->map, r->map_bytes);
    ooc_file_close(r->temp, &r->pos);
    ooc_file_close(r->temp, &r->tri);
    free(r);
}

mr_status ooc_source_from_obj(mr_obj_stream *os, const char *path, ooc_temp *t, ooc_source *s,
                              mr_error *err)
{
    memset(s, 0, sizeof *s);
    mr_status st;
    raw_source *r = mr_calloc_array(1, sizeof *r);
    if (!r) {
        mr_obj_stream_close(os);
        return mr_fail_nomem(err, path, sizeof *r);
    }
    r->temp = t;
    r->pos.fd = r->tri.fd = -1;
    const size_t nv = mr_obj_stream_vertex_count(os);
    r->nt = mr_obj_stream_triangle_count(os);
    st = ooc_file_open(t, &r->pos, err);
    if (st == MR_OK)
        st = ooc_file_open(t, &r->tri, err);
    for (;;) {
        if (st != MR_OK)
            break;
        mr_obj_window w;
        if ((st = mr_obj_stream_next(os, &w, err)) != MR_OK)
            break;
        if (w.vertex_count == 0 && w.triangle_count == 0 && w.positions == NULL)
            break;
        if (w.vertex_count)
            st = ooc_file_write(t, &r->pos, 12 * (uint64_t)w.first_vertex, w.positions,
                                12 * w.vertex_count, err);
        if (st == MR_OK && w.triangle_count)
            st = ooc_file_write(t, &r->tri, 12 * (uint64_t)w.first_triangle, w.indices,
                                12 * w.triangle_count, err);
    }
    s->attributes = st == MR_OK ? mr_obj_stream_attributes(os) : 0;
    mr_obj_stream_close(os);
    if (st == MR_OK && r->nt == 0)
        st = mr_fail_plain(err, MR_ERR_EMPTY, path,
                           "a point cloud (%zu vertices, no faces): simplify needs a triangle "
                           "mesh",
                           nv);
    if (st == MR_OK) {
        r->map_bytes = 12 * nv;
        void *m = mmap(NULL, r->map_bytes, PROT_READ, MAP_SHARED, r->pos.fd, 0);
        if (m == MAP_FAILED) {
            r->map_bytes = 0;
            st = mr_fail_plain(err, MR_ERR_IO, t->dir, "cannot map a temporary file: %s",
                               strerror(errno));
        } else {
            r->map = m;
        }
    }
    if (st != MR_OK) {
        raw_close(r);
        return st;
    }
    s->impl = r;
    s->vertex_count = nv;
    s->triangle_count = r->nt;
    s->max_faces = RAW_FACES;
    s->face_chunks = (r->nt + RAW_FACES - 1) / RAW_FACES;
    s->vertices = raw_vertices;
    s->position = raw_position;
    s->prefetch = raw_prefetch;
    s->rewind = raw_rewind;
    s->seek = raw_seek;
    s->next_faces = raw_next_faces;
    s->release = raw_release;
    s->close = raw_close;
    return MR_OK;
}

mr_status ooc_source_open(const char *path, int threads, ooc_source *s, mr_error *err)
{
    memset(s, 0, sizeof *s);
    if (mr_format_from_path(path) != MR_FORMAT_PLY)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, path,
                             "only binary PLY is read in place");
    mr_ply_source *p;
    mr_status st = mr_ply_source_open(path, threads, &p, err);
    if (st != MR_OK)
        return st;
    s->impl = p;
    s->vertex_count = mr_ply_source_vertex_count(p);
    s->triangle_count = mr_ply_source_triangle_count(p);
    s->max_faces = mr_ply_source_max_faces(p);
    s->attributes = mr_ply_source_attributes(p);
    s->face_chunks = mr_ply_source_face_chunks(p);
    s->vertices = ply_vertices;
    s->position = ply_position;
    s->prefetch = ply_prefetch;
    s->rewind = ply_rewind;
    s->seek = ply_seek;
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
