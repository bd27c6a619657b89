/*
 * An input mesh read in passes (source.c), for the out-of-core paths: its
 * counts, its vertices in blocks, a vertex's position at random, its faces
 * chunk by chunk (again from the first after a rewind), and its pages
 * given back. A binary PLY file is read in place (mr_ply_source). Internal.
 */
#ifndef MR_OOC_SOURCE_H
#define MR_OOC_SOURCE_H

#include "../core/internal.h"

typedef struct ooc_source {
    size_t vertex_count, triangle_count;
    size_t max_faces;     /* the most triangles one next_faces call gives */
    unsigned attributes;  /* MR_ATTR_* of the vertices */
    void *impl;
    mr_status (*vertices)(void *impl, size_t first, size_t count, const mr_mesh *block,
                          mr_error *err);
    void (*position)(const void *impl, uint32_t v, float p[3]);
    void (*prefetch)(const void *impl, uint32_t first, uint32_t last);
    void (*rewind)(void *impl);
    mr_status (*next_faces)(void *impl, uint32_t *idx, size_t *count, mr_error *err);
    void (*release)(void *impl);
    void (*close)(void *impl);
} ooc_source;

/* Open path as a source: MR_ERR_UNSUPPORTED (err set, saying why) for a
 * file that is not read in pieces. */
mr_status ooc_source_open(const char *path, int threads, ooc_source *s, mr_error *err);
void ooc_source_close(ooc_source *s);

#endif
