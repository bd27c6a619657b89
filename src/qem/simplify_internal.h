/*
 * The sequential simplifier's state and phases, shared by mr_simplify and
 * mr_mesh_simplify (attributes). Internal.
 */
#ifndef MR_SIMPLIFY_INTERNAL_H
#define MR_SIMPLIFY_INTERNAL_H

#include "../mesh/adjacency.h"
#include "collapse.h"
#include "heap.h"
#include "quadric.h"

typedef struct mr_simplifier mr_simplifier;

struct mr_simplifier {
    mr_collapse_mesh m;
    mr_quadricf *q;          /* per vertex, relative to its position */
    uint32_t *best;          /* per vertex: other end of its queued collapse */
    uint8_t *stale;          /* per vertex: key is only a lower bound */
    mr_heap heap;
    mr_collapse_limits limits;
    int half;
    uint8_t pin_flags;       /* flags that pin a full collapse's target to
                                that end (MR_VF_SEAM with attributes) */
    double centre[3], scale, diagonal;
    size_t input_vertices;
    /* Attribute hooks (mr_mesh_simplify): extra validity, and an action
     * before a collapse r -> k to target is applied. */
    bool (*attr_valid)(mr_simplifier *s, uint32_t r, uint32_t k);
    void (*attr_apply)(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3]);
    void *attr;
};

mr_status mr_simplify_check_options(const mr_simplify_options *o, size_t input_vertices,
                                    size_t input_triangles, mr_error *err);
mr_status mr_simplifier_init(mr_simplifier *s, const float *positions, size_t stride,
                             size_t vertex_count, const uint32_t *indices,
                             size_t triangle_count, const mr_simplify_options *o,
                             const uint8_t *extra_flags, mr_error *err);
mr_status mr_simplifier_fill_queue(mr_simplifier *s, mr_error *err);
size_t mr_simplifier_run(mr_simplifier *s, const mr_simplify_options *o, double *max_error);
bool mr_simplifier_valid(mr_simplifier *s, uint32_t u, uint32_t w, double *cost);
mr_status mr_simplifier_output(const mr_simplifier *s, const float *positions, size_t stride,
                               mr_simplified *out, mr_error *err);
void mr_simplifier_free(mr_simplifier *s);

#endif
