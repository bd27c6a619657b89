/*
 * An input mesh read in passes (source.c), for the out-of-core paths: its
 * counts, its vertices in blocks, a vertex's position at random, its faces
 * chunk by chunk (again from the first after a rewind), and its pages
 * given back. A binary PLY file is read in place (mr_ply_source); an OBJ
 * file is parsed once in windows (mr_obj_stream) into two temporary
 * files, its positions (12 bytes a vertex, mapped for the reads at
 * random) and its triangles (12 bytes each, read in order), which the
 * passes then read; a binary STL file is welded through external sorts
 * into the same two files. Internal.
 */
#ifndef MR_OOC_SOURCE_H
#define MR_OOC_SOURCE_H

#include "temp.h"

typedef struct ooc_source {
    size_t vertex_count, triangle_count;
    size_t max_faces;     /* the most triangles one next_faces call gives */
    unsigned attributes;  /* MR_ATTR_* of the vertices */
    void *impl;
    mr_status (*vertices)(void *impl, size_t first, size_t count, const mr_mesh *block,
                          mr_error *err);
    void (*position)(const void *impl, uint32_t v, float p[3]);
    /* vertex v's attributes at random into the arrays of `one` (a mesh of
     * one vertex, positions included), or NULL: the format's attributes
     * are not carried out of core */
    void (*vertex)(const void *impl, uint32_t v, const mr_mesh *one);
    unsigned carried;     /* MR_ATTR_* that vertex() fills */
    /* vertex v's place among the file's own vertices (an OBJ's v line,
     * where its vertices are the corners' (v, vt, vn)), or NULL: v */
    uint32_t (*origin)(const void *impl, uint32_t v);
    void (*prefetch)(const void *impl, uint32_t first, uint32_t last);
    size_t face_chunks;   /* next_faces calls from the first to the last */
    void (*rewind)(void *impl);
    void (*seek)(void *impl, size_t chunk); /* faces from that call on */
    mr_status (*next_faces)(void *impl, uint32_t *idx, size_t *count, mr_error *err);
    /* the next whole next_faces calls' triangles at once (decoded on
     * several threads where the format allows): while they fit cap
     * triangles (one call's at least), at most max_chunks calls';
     * *chunks the calls it stands for (0: none left) */
    mr_status (*next_batch)(void *impl, uint32_t *idx, size_t cap, size_t max_chunks,
                            size_t *count, size_t *chunks, mr_error *err);
    void (*release)(void *impl);
    void (*close)(void *impl);
} ooc_source;

/* A binary PLY file as a source: MR_ERR_UNSUPPORTED (err set, saying
 * why) for one that is not read in place (ascii, lists in the vertex
 * element, strips; another format). */
mr_status ooc_source_open(const char *path, int threads, ooc_source *s, mr_error *err);
/* An OBJ file as a source, from its opened stream (which this closes):
 * its windows parsed into temporary files in t. The vertices are the v
 * lines; but where the file has attributes among `keep` (MR_ATTR_*: the
 * faces' vt and vn, the v lines' colors), they are the distinct (v, vt,
 * vn) of the corners, as the in-memory reader splits them at seams
 * (numbered by v, then vt and vn; through two external sorts in about
 * `memory` bytes, on `threads`), read whole by the source's vertex(). */
typedef struct mr_obj_stream mr_obj_stream;
mr_status ooc_source_from_obj(mr_obj_stream *os, const char *path, ooc_temp *t, unsigned keep,
                              uint64_t memory, int threads, ooc_source *s, mr_error *err);
/* A binary STL file as a source: its corners welded as mr_read_stl welds
 * them (bitwise equal positions, numbered by first use) through external
 * sorts in temporary files, in about `memory` bytes (the runs' radix
 * sorts on `threads`); MR_ERR_UNSUPPORTED
 * for an ascii STL or a file of another size (read whole). */
mr_status ooc_source_from_stl(const char *path, ooc_temp *t, uint64_t memory, int threads,
                              ooc_source *s, mr_error *err);
/* The triangles of the binary STL file at path, from its header, when its
 * size is the header's (0: not such a file, or unreadable). */
uint64_t ooc_stl_triangles(const char *path);
void ooc_source_close(ooc_source *s);

#endif
