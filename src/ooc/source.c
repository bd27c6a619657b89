/* An input mesh read in passes (source.h). */
#define _GNU_SOURCE
#include "source.h"
#include "../io/io_internal.h"

#include "extsort.h"
#include "../io/mapped.h"

#include <errno.h>
#include <math.h>
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

static void ply_vertex(const void *impl, uint32_t v, const mr_mesh *one)
{
    mr_ply_source_vertex(impl, v, one);
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

static mr_status ply_next_batch(void *impl, uint32_t *idx, size_t cap, size_t max_chunks,
                                size_t *count, size_t *chunks, mr_error *err)
{
    return mr_ply_source_next_batch(impl, idx, cap, max_chunks, count, chunks, err);
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
    /* an OBJ file's attributes (MR_ATTR_*), each vertex's in a row of
     * astride floats (normals, texture coordinates, colors), mapped */
    unsigned attrs;
    size_t astride;
    ooc_file attr;
    const float *amap;
    size_t amap_bytes;
    ooc_file org;          /* each vertex's v line */
    const uint32_t *omap;
    size_t omap_bytes;
} raw_source;

static mr_status raw_vertices(void *impl, size_t first, size_t count, const mr_mesh *block,
                              mr_error *err)
{
    (void)err;
    const raw_source *r = impl;
    memcpy(block->positions, r->map + 3 * first, 12 * count);
    /* copied: the pages within the range go (they count in the resident set) */
    const uintptr_t page = 4096, a = (uintptr_t)(r->map + 3 * first),
                    b = (uintptr_t)(r->map + 3 * (first + count));
    const uintptr_t lo = (a + page - 1) / page * page, hi = b / page * page;
    if (hi > lo)
        madvise((void *)lo, hi - lo, MADV_DONTNEED);
    return MR_OK;
}

static void raw_position(const void *impl, uint32_t v, float p[3])
{
    const raw_source *r = impl;
    memcpy(p, r->map + 3 * (size_t)v, 12);
}

static void raw_vertex(const void *impl, uint32_t v, const mr_mesh *one)
{
    const raw_source *r = impl;
    memcpy(one->positions, r->map + 3 * (size_t)v, 12);
    const float *a = r->amap + r->astride * (size_t)v;
    if (r->attrs & MR_ATTR_NORMALS) {
        if (one->normals)
            memcpy(one->normals, a, 12);
        a += 3;
    }
    if (r->attrs & MR_ATTR_TEXCOORDS) {
        if (one->texcoords)
            memcpy(one->texcoords, a, 8);
        a += 2;
    }
    if ((r->attrs & MR_ATTR_COLORS) && one->colors)
        memcpy(one->colors, a, 16);
}

static uint32_t raw_origin(const void *impl, uint32_t v)
{
    return ((const raw_source *)impl)->omap[v];
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

static mr_status raw_next_batch(void *impl, uint32_t *idx, size_t cap, size_t max_chunks,
                                size_t *count, size_t *chunks, mr_error *err)
{
    raw_source *r = impl;
    const size_t left = (r->nt - r->next + RAW_FACES - 1) / RAW_FACES;
    size_t k = cap / RAW_FACES;
    k = k < 1 ? 1 : k;
    k = k < max_chunks ? k : max_chunks;
    k = k < left ? k : left;
    *count = 0;
    *chunks = 0;
    if (k == 0)
        return MR_OK;
    const size_t n = r->nt - r->next < k * RAW_FACES ? r->nt - r->next : k * RAW_FACES;
    mr_status st = ooc_file_read(r->temp, &r->tri, 12 * (uint64_t)r->next, idx, 12 * n, err);
    if (st == MR_OK) {
        r->next += n;
        *count = n;
        *chunks = k;
    }
    return st;
}

static void raw_release(void *impl)
{
    const raw_source *r = impl;
    if (r->map_bytes)
        madvise((void *)r->map, r->map_bytes, MADV_DONTNEED);
    if (r->amap_bytes)
        madvise((void *)r->amap, r->amap_bytes, MADV_DONTNEED);
    if (r->omap_bytes)
        madvise((void *)r->omap, r->omap_bytes, MADV_DONTNEED);
}

static void raw_close(void *impl)
{
    raw_source *r = impl;
    if (r->map_bytes)
        munmap((void *)r->map, r->map_bytes);
    if (r->amap_bytes)
        munmap((void *)r->amap, r->amap_bytes);
    if (r->omap_bytes)
        munmap((void *)r->omap, r->omap_bytes);
    ooc_file_close(r->temp, &r->pos);
    ooc_file_close(r->temp, &r->tri);
    ooc_file_close(r->temp, &r->attr);
    ooc_file_close(r->temp, &r->org);
    free(r);
}

static mr_status raw_finish(raw_source *r, size_t nv, ooc_source *s, mr_error *err);

/* An OBJ file's attribute tables in temporary files while it streams:
 * the v lines' colors, the vt and vn lines, each corner's vt and vn. */
typedef struct obj_tables {
    ooc_file col, vt, vn, cvt, cvn;
} obj_tables;

static void obj_tables_close(ooc_temp *t, obj_tables *x)
{
    ooc_file_close(t, &x->col);
    ooc_file_close(t, &x->vt);
    ooc_file_close(t, &x->vn);
    ooc_file_close(t, &x->cvt);
    ooc_file_close(t, &x->cvn);
}

static mr_status obj_tables_write(ooc_temp *t, obj_tables *x, const mr_obj_window *w,
                                  mr_error *err)
{
    mr_status st = MR_OK;
    if (w->colors && w->vertex_count)
        st = ooc_file_write(t, &x->col, 16 * (uint64_t)w->first_vertex, w->colors,
                            16 * w->vertex_count, err);
    if (st == MR_OK && w->texcoords && w->texcoord_count)
        st = ooc_file_write(t, &x->vt, 8 * (uint64_t)w->first_texcoord, w->texcoords,
                            8 * w->texcoord_count, err);
    if (st == MR_OK && w->normals && w->normal_count)
        st = ooc_file_write(t, &x->vn, 12 * (uint64_t)w->first_normal, w->normals,
                            12 * w->normal_count, err);
    if (st == MR_OK && w->corner_texcoords && w->triangle_count)
        st = ooc_file_write(t, &x->cvt, 12 * (uint64_t)w->first_triangle, w->corner_texcoords,
                            12 * w->triangle_count, err);
    if (st == MR_OK && w->corner_normals && w->triangle_count)
        st = ooc_file_write(t, &x->cvn, 12 * (uint64_t)w->first_triangle, w->corner_normals,
                            12 * w->triangle_count, err);
    return st;
}

static mr_status map_temp(const ooc_temp *t, const ooc_file *f, size_t bytes, const void **out,
                          mr_error *err);
static mr_status obj_tuples(raw_source *r, obj_tables *x, size_t nv, size_t nvt, size_t nvn,
                            unsigned attrs, uint64_t memory, int threads, const char *path,
                            size_t *tuples, mr_error *err);

mr_status ooc_source_from_obj(mr_obj_stream *os, const char *path, ooc_temp *t, unsigned keep,
                              uint64_t memory, int threads, ooc_source *s, mr_error *err)
{
    memset(s, 0, sizeof *s);
    mr_status st;
    raw_source *r = mr_calloc_array(1, sizeof *r);
    if (!r) {
        mr_obj_stream_close(os);
        return mr_fail_nomem(err, path, sizeof *r);
    }
    r->temp = t;
    r->pos.fd = r->tri.fd = r->attr.fd = r->org.fd = -1;
    obj_tables x;
    x.col.fd = x.vt.fd = x.vn.fd = x.cvt.fd = x.cvn.fd = -1;
    size_t nv = mr_obj_stream_vertex_count(os);
    r->nt = mr_obj_stream_triangle_count(os);
    st = ooc_file_open(t, &r->pos, err);
    if (st == MR_OK)
        st = ooc_file_open(t, &r->tri, err);
    if (st == MR_OK && keep)
        st = mr_obj_stream_keep(os, keep, err);
    ooc_file *tab[5] = {&x.col, &x.vt, &x.vn, &x.cvt, &x.cvn};
    const unsigned need[5] = {MR_ATTR_COLORS, MR_ATTR_TEXCOORDS, MR_ATTR_NORMALS,
                              MR_ATTR_TEXCOORDS, MR_ATTR_NORMALS};
    for (int i = 0; i < 5 && st == MR_OK; i++)
        if (keep & need[i])
            st = ooc_file_open(t, tab[i], err);
    size_t nvt = 0, nvn = 0;
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
        if (st == MR_OK && keep)
            st = obj_tables_write(t, &x, &w, err);
        nvt = w.first_texcoord + w.texcoord_count > nvt ? w.first_texcoord + w.texcoord_count
                                                         : nvt;
        nvn = w.first_normal + w.normal_count > nvn ? w.first_normal + w.normal_count : nvn;
    }
    const unsigned attributes = st == MR_OK ? mr_obj_stream_attributes(os) : 0;
    mr_obj_stream_close(os);
    /* the attributes kept that the file has: its vertices are then the
     * distinct (v, vt, vn) of its corners, as the in-memory reader splits
     * them (numbered otherwise: by v, then vt and vn) */
    const unsigned carried = attributes & keep;
    if (st == MR_OK && carried)
        st = obj_tuples(r, &x, nv, nvt, nvn, carried, memory, threads, path, &nv, err);
    obj_tables_close(t, &x);
    if (st != MR_OK) {
        raw_close(r);
        return st;
    }
    st = raw_finish(r, nv, s, err);
    s->attributes = attributes;
    if (st != MR_OK || !carried)
        return st;
    /* the attribute rows and the v lines, mapped */
    const void *am, *om;
    if ((st = map_temp(t, &r->attr, 4 * r->astride * nv, &am, err)) != MR_OK ||
        (st = map_temp(t, &r->org, 4 * nv, &om, err)) != MR_OK) {
        ooc_source_close(s);
        return st;
    }
    r->amap = am, r->amap_bytes = am ? 4 * r->astride * nv : 0;
    r->omap = om, r->omap_bytes = om ? 4 * nv : 0;
    s->vertex = raw_vertex;
    s->origin = raw_origin;
    s->carried = carried;
    return MR_OK;
}

/* The source over r's two files, the positions mapped (nv vertices); on
 * failure r is closed. */
static mr_status raw_finish(raw_source *r, size_t nv, ooc_source *s, mr_error *err)
{
    const void *m;
    const mr_status st = map_temp(r->temp, &r->pos, 12 * nv, &m, err);
    if (st != MR_OK) {
        raw_close(r);
        return st;
    }
    r->map = m;
    r->map_bytes = 12 * nv;
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
    s->next_batch = raw_next_batch;
    s->release = raw_release;
    s->close = raw_close;
    return MR_OK;
}

/* ---- a binary STL file, welded through external sorts ------------------------------ */

/* A corner: its coordinates' bits and its number (3 t + k). */
typedef struct stl_corner {
    uint32_t bits[3];
    uint32_t lo, hi; /* the corner's number, in two halves (no padding) */
} stl_corner;

/* A corner with the first corner at its position (its vertex's key). */
typedef struct stl_member {
    uint32_t first_lo, first_hi, lo, hi;
    uint32_t bits[3];
} stl_member;

/* A corner's vertex. */
typedef struct stl_vertex_of {
    uint32_t lo, hi, v;
} stl_vertex_of;

static inline uint64_t join64(uint32_t lo, uint32_t hi) { return (uint64_t)hi << 32 | lo; }

static int cmp_u64(uint64_t a, uint64_t b) { return a < b ? -1 : a > b; }

static int corner_cmp(const void *a, const void *b)
{
    const stl_corner *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->bits[k] != y->bits[k])
            return x->bits[k] < y->bits[k] ? -1 : 1;
    return cmp_u64(join64(x->lo, x->hi), join64(y->lo, y->hi));
}

static int member_cmp(const void *a, const void *b)
{
    const stl_member *x = a, *y = b;
    const int c = cmp_u64(join64(x->first_lo, x->first_hi), join64(y->first_lo, y->first_hi));
    return c ? c : cmp_u64(join64(x->lo, x->hi), join64(y->lo, y->hi));
}

/* The sorts' keys: a corner's position hashed (equal positions are
 * neighbours in the order, which is all the weld asks of it), a member's
 * first corner, a corner's number. */
static uint64_t corner_key(const void *a)
{
    return ooc_position_key(((const stl_corner *)a)->bits);
}

static uint64_t member_key(const void *a)
{
    const stl_member *x = a;
    return join64(x->first_lo, x->first_hi);
}

static uint64_t vertex_of_key(const void *a)
{
    const stl_vertex_of *x = a;
    return join64(x->lo, x->hi);
}

static int vertex_of_cmp(const void *a, const void *b)
{
    const stl_vertex_of *x = a, *y = b;
    return cmp_u64(join64(x->lo, x->hi), join64(y->lo, y->hi));
}

/* The corners' vertex ids from the merge of c, in corner order: the
 * triangles, into f. */
static mr_status write_corners(ooc_temp *t, ooc_extsort *c, ooc_file *f, mr_error *err)
{
    uint32_t tri[3 * 4096];
    size_t tfill = 0;
    uint64_t written = 0;
    mr_status st = MR_OK;
    for (;;) {
        const void *rec;
        if ((st = ooc_extsort_next(c, &rec, err)) != MR_OK || !rec)
            break;
        tri[tfill++] = ((const stl_vertex_of *)rec)->v;
        if (tfill == 3 * 4096) {
            st = ooc_file_write(t, f, 4 * written, tri, 4 * tfill, err);
            written += tfill;
            tfill = 0;
            if (st != MR_OK)
                break;
        }
    }
    if (st == MR_OK && tfill)
        st = ooc_file_write(t, f, 4 * written, tri, 4 * tfill, err);
    return st;
}

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* A binary STL's triangles, when the file is one of the size its header
 * says (else 0). */
static uint64_t stl_count(const mr_mapped_file *f)
{
    const unsigned char *d = (const unsigned char *)f->data;
    const uint64_t count = f->size >= 84 ? le32(d + 80) : 0;
    return f->size >= 84 && f->size == 84 + 50 * count ? count : 0;
}

uint64_t ooc_stl_triangles(const char *path)
{
    mr_mapped_file f;
    mr_error quiet;
    if (mr_map_file(path, &f, &quiet) != MR_OK)
        return 0;
    const uint64_t count = stl_count(&f);
    mr_unmap_file(&f);
    return count;
}

/*
 * The weld of mr_read_stl -- corners whose coordinates are bitwise equal
 * are one vertex, numbered in the order of their first corner -- in three
 * external sorts: the corners by position, hashed (each group's first corner is
 * its vertex's key), the corners by that key (the keys in order number
 * the vertices, whose positions go to the first file), the corners' vertex
 * ids back by corner (the triangles, in order, to the second).
 */
mr_status ooc_source_from_stl(const char *path, ooc_temp *t, uint64_t memory, int threads,
                              ooc_source *s, mr_error *err)
{
    memset(s, 0, sizeof *s);
    mr_mapped_file f;
    mr_status st = mr_map_file(path, &f, err);
    if (st != MR_OK)
        return st;
    const unsigned char *d = (const unsigned char *)f.data;
    const uint64_t count = stl_count(&f);
    if (count == 0) {
        mr_unmap_file(&f);
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, path,
                             "not a binary STL of the size its header says (read whole)");
    }
    raw_source *r = mr_calloc_array(1, sizeof *r);
    if (!r) {
        mr_unmap_file(&f);
        return mr_fail_nomem(err, path, sizeof *r);
    }
    r->temp = t;
    r->pos.fd = r->tri.fd = -1;
    r->nt = (size_t)count;
    const uint64_t corners = 3 * count;
    /* the runs and the merges in about half the budget; the corners'
     * numbers (3 t + k) in index_bits */
    const size_t run = (size_t)(memory / 2);
    unsigned index_bits = 1;
    while (index_bits < 64 && (corners >> index_bits) != 0)
        index_bits++;
    ooc_extsort a, b, c;
    memset(&a, 0, sizeof a), memset(&b, 0, sizeof b), memset(&c, 0, sizeof c);
    a.file.fd = b.file.fd = c.file.fd = -1;
    if ((st = ooc_file_open(t, &r->pos, err)) == MR_OK &&
        (st = ooc_file_open(t, &r->tri, err)) == MR_OK)
        st = ooc_extsort_init(&a, t, sizeof(stl_corner), run, corner_key, 64, corner_cmp, threads,
                              err);
    /* 1: the corners by position (hashed: equal positions together), in runs */
    for (uint64_t k = 0; k < corners && st == MR_OK; k++) {
        const unsigned char *p = d + 84 + 50 * (k / 3) + 12 + 12 * (k % 3);
        stl_corner e;
        for (int j = 0; j < 3; j++) {
            e.bits[j] = le32(p + 4 * j);
            float x;
            memcpy(&x, &e.bits[j], 4);
            if (!isfinite(x))
                st = mr_fail(err, MR_ERR_PARSE, path, MR_NO_POSITION, (uint64_t)(p - d),
                             "triangle %llu, vertex %d of 3 has a non-finite coordinate",
                             (unsigned long long)(k / 3), (int)(k % 3) + 1);
        }
        e.lo = (uint32_t)k;
        e.hi = (uint32_t)(k >> 32);
        if (st == MR_OK)
            st = ooc_extsort_add(&a, &e, err);
        if ((k + 1) % (3u << 20) == 0)
            mr_release_mapped(&f, 0, (size_t)(p - d));
    }
    mr_unmap_file(&f);
    if (st == MR_OK)
        st = ooc_extsort_finish(&a, (size_t)(memory / 4), err);
    /* 2: each corner with its group's first, by that */
    if (st == MR_OK)
        st = ooc_extsort_init(&b, t, sizeof(stl_member), run, member_key, index_bits, member_cmp,
                              threads, err);
    stl_member m = {0};
    uint32_t prev[3] = {0, 0, 0};
    bool any = false;
    for (;;) {
        const void *rec;
        if (st != MR_OK || (st = ooc_extsort_next(&a, &rec, err)) != MR_OK || !rec)
            break;
        const stl_corner *e = rec;
        if (!any || memcmp(prev, e->bits, 12) != 0) {
            m.first_lo = e->lo;
            m.first_hi = e->hi;
            memcpy(prev, e->bits, 12);
            memcpy(m.bits, e->bits, 12);
            any = true;
        }
        m.lo = e->lo;
        m.hi = e->hi;
        st = ooc_extsort_add(&b, &m, err);
    }
    ooc_extsort_free(&a);
    if (st == MR_OK)
        st = ooc_extsort_finish(&b, (size_t)(memory / 4), err);
    /* 3: the vertices in order of their first corner, each corner's id */
    if (st == MR_OK)
        st = ooc_extsort_init(&c, t, sizeof(stl_vertex_of), run, vertex_of_key, index_bits,
                              vertex_of_cmp, threads, err);
    uint64_t nv = 0, key = UINT64_MAX;
    float block[3 * 4096];
    size_t fill = 0;
    for (;;) {
        const void *rec;
        if (st != MR_OK || (st = ooc_extsort_next(&b, &rec, err)) != MR_OK || !rec)
            break;
        const stl_member *e = rec;
        const uint64_t first = join64(e->first_lo, e->first_hi);
        if (first != key) {
            key = first;
            memcpy(block + 3 * fill, e->bits, 12);
            if (++fill == 4096) {
                st = ooc_file_write(t, &r->pos, 12 * (nv + 1 - fill), block, 12 * fill, err);
                fill = 0;
            }
            nv++;
        }
        const stl_vertex_of o = {e->lo, e->hi, (uint32_t)(nv - 1)};
        if (st == MR_OK)
            st = ooc_extsort_add(&c, &o, err);
    }
    if (st == MR_OK && fill)
        st = ooc_file_write(t, &r->pos, 12 * (nv - fill), block, 12 * fill, err);
    ooc_extsort_free(&b);
    if (st == MR_OK && nv > UINT32_MAX)
        st = mr_fail_plain(err, MR_ERR_TOO_LARGE, path,
                           "%llu vertices exceed the 32-bit index limit",
                           (unsigned long long)nv);
    if (st == MR_OK)
        st = ooc_extsort_finish(&c, (size_t)(memory / 4), err);
    /* 4: the triangles, corner by corner */
    if (st == MR_OK)
        st = write_corners(t, &c, &r->tri, err);
    ooc_extsort_free(&c);
    if (st != MR_OK) {
        raw_close(r);
        return st;
    }
    return raw_finish(r, (size_t)nv, s, err);
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
    s->vertex = ply_vertex;
    s->carried = s->attributes;
    s->prefetch = ply_prefetch;
    s->rewind = ply_rewind;
    s->seek = ply_seek;
    s->next_faces = ply_next_faces;
    s->next_batch = ply_next_batch;
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

/* ---- an OBJ file's vertices: the distinct (v, vt, vn) of its corners ----------- */

/* A corner: its v, vt and vn (UINT32_MAX: none, or not kept) and number. */
typedef struct obj_corner_rec {
    uint32_t v, vt, vn, lo, hi;
} obj_corner_rec;

static uint64_t obj_corner_key(const void *a)
{
    const obj_corner_rec *x = a;
    return (uint64_t)x->v << 32 | (uint32_t)mr_mix64((uint64_t)x->vt << 32 | x->vn);
}

static int obj_corner_cmp(const void *a, const void *b)
{
    const obj_corner_rec *x = a, *y = b;
    if (x->v != y->v)
        return x->v < y->v ? -1 : 1;
    if (x->vt != y->vt)
        return x->vt < y->vt ? -1 : 1;
    if (x->vn != y->vn)
        return x->vn < y->vn ? -1 : 1;
    return cmp_u64(join64(x->lo, x->hi), join64(y->lo, y->hi));
}

/* A read-only map of a temporary file's first `bytes` (NULL for none). */
static mr_status map_temp(const ooc_temp *t, const ooc_file *f, size_t bytes, const void **out,
                          mr_error *err)
{
    *out = NULL;
    if (!bytes)
        return MR_OK;
    void *m = mmap(NULL, bytes, PROT_READ, MAP_SHARED, f->fd, 0);
    if (m == MAP_FAILED)
        return mr_fail_plain(err, MR_ERR_IO, t->dir, "cannot map a temporary file: %s",
                             strerror(errno));
    *out = m;
    return MR_OK;
}

/* Vertices first..first+n: their positions, attribute rows (astride
 * floats) and v lines. */
static mr_status write_rows(ooc_temp *t, ooc_file *pos, ooc_file *attr, ooc_file *org,
                            size_t astride, uint64_t first, size_t n, const float *prow,
                            const float *arow, const uint32_t *orow, mr_error *err)
{
    mr_status st = ooc_file_write(t, pos, 12 * first, prow, 12 * n, err);
    if (st == MR_OK)
        st = ooc_file_write(t, attr, 4 * astride * first, arow, 4 * astride * n, err);
    if (st == MR_OK)
        st = ooc_file_write(t, org, 4 * first, orow, 4 * n, err);
    return st;
}

/* Each vertex (a distinct (v, vt, vn), in that order) gets its position
 * and attribute row in new files, each corner its vertex, through two
 * external sorts: the corners by (v, vt, vn), then their vertex ids by
 * corner (the triangles, in order). r's files become the vertices' ones;
 * *tuples their count. */
static mr_status obj_tuples(raw_source *r, obj_tables *x, size_t nv, size_t nvt, size_t nvn,
                            unsigned attrs, uint64_t memory, int threads, const char *path,
                            size_t *tuples, mr_error *err)
{
    ooc_temp *t = r->temp;
    /* a sort's runs or its merge in a quarter of the budget each: one
     * sort merges while the next fills its runs */
    const size_t run = (size_t)(memory / 4 < ((uint64_t)4 << 20) ? (uint64_t)4 << 20 : memory / 4);
    const uint64_t corners = 3 * (uint64_t)r->nt;
    unsigned index_bits = 1;
    while (index_bits < 64 && (corners >> index_bits) != 0)
        index_bits++;
    const bool tex = attrs & MR_ATTR_TEXCOORDS, nrm = attrs & MR_ATTR_NORMALS,
               col = attrs & MR_ATTR_COLORS;
    r->attrs = attrs;
    r->astride = (nrm ? 3 : 0) + (tex ? 2 : 0) + (col ? 4 : 0);
    ooc_extsort a, c;
    memset(&a, 0, sizeof a), memset(&c, 0, sizeof c);
    a.file.fd = c.file.fd = -1;
    ooc_file pos = {.fd = -1}, tri = {.fd = -1};
    const void *mp = NULL, *mc = NULL, *mt = NULL, *mn = NULL;
    uint32_t *blk = mr_alloc_array(3 * (size_t)RAW_FACES, 3 * sizeof *blk);
    mr_status st = blk ? MR_OK : mr_fail_nomem(err, path, 36 * (size_t)RAW_FACES);
    if (st == MR_OK)
        st = ooc_extsort_init(&a, t, sizeof(obj_corner_rec), run, obj_corner_key, 64,
                              obj_corner_cmp, threads, err);
    /* 1: the corners by (v, vt, vn) */
    for (uint64_t t0 = 0; t0 < r->nt && st == MR_OK; t0 += RAW_FACES) {
        const size_t n = r->nt - t0 < RAW_FACES ? (size_t)(r->nt - t0) : RAW_FACES;
        uint32_t *cv = blk, *ct = blk + 3 * (size_t)RAW_FACES, *cn = blk + 6 * (size_t)RAW_FACES;
        st = ooc_file_read(t, &r->tri, 12 * t0, cv, 12 * n, err);
        if (st == MR_OK && tex)
            st = ooc_file_read(t, &x->cvt, 12 * t0, ct, 12 * n, err);
        if (st == MR_OK && nrm)
            st = ooc_file_read(t, &x->cvn, 12 * t0, cn, 12 * n, err);
        for (size_t i = 0; i < 3 * n && st == MR_OK; i++) {
            const uint64_t k = 3 * t0 + i;
            const obj_corner_rec e = {cv[i], tex ? ct[i] : UINT32_MAX, nrm ? cn[i] : UINT32_MAX,
                                      (uint32_t)k, (uint32_t)(k >> 32)};
            st = ooc_extsort_add(&a, &e, err);
        }
    }
    /* the corners are in the sort: their files go (temporary disk) */
    ooc_file_close(t, &r->tri);
    ooc_file_close(t, &x->cvt);
    ooc_file_close(t, &x->cvn);
    if (st == MR_OK)
        st = ooc_extsort_finish(&a, run, err);
    /* 2: each distinct (v, vt, vn) a vertex: its position and attribute
     * row; each corner's vertex, to be sorted back by corner */
    if (st == MR_OK && (st = ooc_file_open(t, &pos, err)) == MR_OK &&
        (st = ooc_file_open(t, &r->attr, err)) == MR_OK &&
        (st = map_temp(t, &r->pos, 12 * nv, &mp, err)) == MR_OK &&
        (st = map_temp(t, &x->col, col ? 16 * nv : 0, &mc, err)) == MR_OK &&
        (st = map_temp(t, &x->vt, tex ? 8 * nvt : 0, &mt, err)) == MR_OK &&
        (st = map_temp(t, &x->vn, nrm ? 12 * nvn : 0, &mn, err)) == MR_OK)
        st = ooc_extsort_init(&c, t, sizeof(stl_vertex_of), run, vertex_of_key, index_bits,
                              vertex_of_cmp, threads, err);
    enum { ROWS = 4096 };
    /* positions, attribute rows (9 floats at most), v lines */
    float *prow = mr_alloc_array(13 * ROWS, sizeof *prow), *arow = prow ? prow + 3 * ROWS : NULL;
    uint32_t *orow = prow ? (uint32_t *)(arow + 9 * ROWS) : NULL;
    if (st == MR_OK && !prow)
        st = mr_fail_nomem(err, path, 52 * ROWS);
    if (st == MR_OK)
        st = ooc_file_open(t, &r->org, err);
    size_t fill = 0;
    uint64_t n = 0;
    obj_corner_rec prev = {UINT32_MAX, 0, 0, 0, 0};
    for (;;) {
        const void *rec;
        if (st != MR_OK || (st = ooc_extsort_next(&a, &rec, err)) != MR_OK || !rec)
            break;
        const obj_corner_rec *e = rec;
        if (e->v != prev.v || e->vt != prev.vt || e->vn != prev.vn) {
            prev = *e;
            memcpy(prow + 3 * fill, (const float *)mp + 3 * (size_t)e->v, 12);
            orow[fill] = e->v;
            float *ar = arow + r->astride * fill;
            if (nrm) {
                if (e->vn != UINT32_MAX)
                    memcpy(ar, (const float *)mn + 3 * (size_t)e->vn, 12);
                else
                    ar[0] = ar[1] = ar[2] = 0;
                ar += 3;
            }
            if (tex) {
                if (e->vt != UINT32_MAX)
                    memcpy(ar, (const float *)mt + 2 * (size_t)e->vt, 8);
                else
                    ar[0] = ar[1] = 0;
                ar += 2;
            }
            if (col)
                memcpy(ar, (const float *)mc + 4 * (size_t)e->v, 16);
            if (++fill == ROWS) {
                st = write_rows(t, &pos, &r->attr, &r->org, r->astride, n + 1 - fill, fill, prow,
                                arow, orow, err);
                fill = 0;
            }
            n++;
            if (n >= UINT32_MAX) {
                st = mr_fail_plain(err, MR_ERR_TOO_LARGE, path,
                                   "more than %u distinct vertex/texture/normal combinations",
                                   UINT32_MAX - 1);
                break;
            }
            if (n % (1u << 20) == 0) {
                /* read: the pages go (they count in the resident set) */
                madvise((void *)mp, 12 * nv, MADV_DONTNEED);
                if (mc)
                    madvise((void *)mc, 16 * nv, MADV_DONTNEED);
                if (mt)
                    madvise((void *)mt, 8 * nvt, MADV_DONTNEED);
                if (mn)
                    madvise((void *)mn, 12 * nvn, MADV_DONTNEED);
            }
        }
        const stl_vertex_of o = {e->lo, e->hi, (uint32_t)(n - 1)};
        if (st == MR_OK)
            st = ooc_extsort_add(&c, &o, err);
    }
    if (st == MR_OK && fill)
        st = write_rows(t, &pos, &r->attr, &r->org, r->astride, n - fill, fill, prow, arow, orow,
                        err);
    free(prow);
    ooc_extsort_free(&a);
    if (mp)
        munmap((void *)mp, 12 * nv);
    if (mc)
        munmap((void *)mc, 16 * nv);
    if (mt)
        munmap((void *)mt, 8 * nvt);
    if (mn)
        munmap((void *)mn, 12 * nvn);
    if (st == MR_OK)
        st = ooc_extsort_finish(&c, run, err);
    /* 3: the triangles, corner by corner */
    if (st == MR_OK && (st = ooc_file_open(t, &tri, err)) == MR_OK)
        st = write_corners(t, &c, &tri, err);
    ooc_extsort_free(&c);
    free(blk);
    if (st != MR_OK) {
        ooc_file_close(t, &pos);
        ooc_file_close(t, &tri);
        return st;
    }
    ooc_file_close(t, &r->pos);
    ooc_file_close(t, &r->tri);
    r->pos = pos;
    r->tri = tri;
    *tuples = (size_t)n;
    return MR_OK;
}
