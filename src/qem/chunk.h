/*
 * One chunk of a mesh too large to simplify whole (the out-of-core path,
 * ooc/): the simplification of a piece whose cut vertices -- those the
 * other chunks' triangles use too -- stay where they are, carrying each
 * vertex's quadric from the chunks it was made of and handing the
 * survivors' quadrics on to the next level (chunk.c). Internal.
 *
 * A chunk is given as flat arrays, the vertices it uses only. Its cut
 * vertices are locked; the rules that keep the joined mesh manifold
 * without seeing the other chunks are the core's (mr_vertex_marks).
 * Quadrics travel in one length unit for the whole job (the input's
 * bounding-box diagonal): each run scales them to its own normalised
 * lengths and back.
 */
#ifndef MR_QEM_CHUNK_H
#define MR_QEM_CHUNK_H

#include "core/quadric.h"
#include "../core/internal.h"

typedef struct mr_chunk {
    const float *positions;       /* 3 * vertex_count */
    size_t vertex_count;
    const uint32_t *indices;      /* 3 * triangle_count */
    size_t triangle_count;
    const uint8_t *cut;           /* per vertex: on the cut (locked) */
    const uint8_t *locked;        /* per vertex, or NULL: the caller's locks */
    const mr_quadricf *quadrics;  /* per vertex, or NULL (a first level:
                                     from the triangles) */
    const uint8_t *was_cut;       /* with quadrics: cut where they were made */
    double unit;                  /* the quadrics' length unit, in and out */
    /* Attributes per vertex, or NULL. With any, the vertices are wedges:
     * those that are one surface point (mr_surface_points) are one
     * geometric vertex, simplified as mr_mesh_simplify does (seams kept,
     * attributes interpolated), cut or locked when one of its wedges is,
     * with the sum of its wedges' quadrics (mr_mesh_chunk_marks). */
    const float *normals;         /* 3 * vertex_count */
    const float *texcoords;       /* 2 * vertex_count */
    const float *colors;          /* 4 * vertex_count */
    bool wedges;                  /* without attributes too, the vertices are
                                     wedges (split at seams whose attributes
                                     were dropped) */
} mr_chunk;

/* The simplified chunk: positions, triangles and each output vertex's
 * chunk vertex (mesh.origin: a locked vertex keeps its input position bit
 * for bit), and the output vertices' quadrics in the chunk's unit. */
typedef struct mr_chunk_result {
    mr_simplified mesh;
    mr_quadricf *quadrics;
    /* with the chunk's attributes: the output vertices' (mesh.origin: the
     * chunk vertex, a wedge), and the quadrics per geometric vertex on
     * the first of its output vertices, zero on its others */
    float *normals, *texcoords, *colors;
} mr_chunk_result;

void mr_chunk_result_free(mr_chunk_result *r);

/* Simplify the chunk by the options (its targets, error bound and rules;
 * options->vertex_lock is ignored: chunk->locked says). Deterministic:
 * the same chunk and options give the same result on any number of
 * threads. */
mr_status mr_simplify_chunk(const mr_chunk *chunk, const mr_simplify_options *options,
                            mr_chunk_result *out, mr_error *err);

#endif
