/*
 * What mr_mesh_simplify carries besides the attributes it weighs
 * (carried.c): materials (vertices split where two meet, triangles
 * grouped by material), texture sets 1-3, joints and weights (the
 * surviving vertex's). Internal.
 */
#ifndef MR_QEM_CARRIED_H
#define MR_QEM_CARRIED_H

#include "../core/internal.h"

typedef struct mr_carried {
    mr_mesh split;   /* the input split by material (its weighed attributes) */
    uint32_t *src;   /* split vertex -> input vertex (NULL: not split) */
    uint32_t *vmat;  /* split vertex -> its material */
    uint8_t *lock;   /* the vertex locks by split vertex, or NULL */
} mr_carried;

/* Split in (which has materials) by material; lock (by input vertex, or
 * NULL) follows. */
mr_status mr_carried_split(const mr_mesh *in, const uint8_t *lock, mr_carried *c, mr_error *err);

/* After the run on c->split (or on in, with c zeroed): origin[] (by the
 * run's input vertex) becomes the input's vertex; out gets in's texture
 * sets 1-3, joints and weights by origin, and, where in has materials,
 * its triangles grouped by material and their materials. */
mr_status mr_carried_finish(const mr_mesh *in, const mr_carried *c, mr_mesh *out,
                            uint32_t *origin, mr_error *err);

void mr_carried_free(mr_carried *c);

#endif /* MR_QEM_CARRIED_H */
