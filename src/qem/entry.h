/*
 * What the two entry points (simplify.c: mr_simplify; mesh_simplify.c:
 * mr_mesh_simplify) share: the strategy chosen by the options, the run in
 * its stages, and the release of the strategy's state. The core
 * (core/simplifier.h) knows no strategy; this layer alone does. Internal
 * (the tests use it to set up a simplifier as a call would).
 */
#ifndef MR_QEM_ENTRY_H
#define MR_QEM_ENTRY_H

#include "strategies/strategy.h"

/* The options' strategy part checked, and the plan's strategy part from
 * them; then the core's set-up (mr_simplifier_init). On failure s is left
 * freed. */
mr_status mr_simplify_setup(mr_simplifier *s, const float *positions, size_t stride,
                            size_t vertex_count, const uint32_t *indices,
                            size_t triangle_count, const mr_simplify_options *o,
                            const mr_vertex_marks *marks, mr_error *err);
/* The chosen strategy's verbs. */
const mr_strategy_ops *mr_simplify_strategy(const mr_simplifier *s);
/* Start the strategy (its queue, from the mesh as set up, mr_mesh_simplify's
 * seams included); mr_simplify_run must follow. On failure nothing of the
 * strategy is left, and the simplifier must still be discarded. */
mr_status mr_simplifier_fill_queue(mr_simplifier *s, mr_error *err);
/* The run in up to two stages (corners kept, then released when the
 * target needs them), then mr_simplifier_finish: returns the collapses
 * made, the largest error in the options' units in *max_error. */
size_t mr_simplify_run(mr_simplifier *s, double *max_error);
/* Release the strategy's state and the quadrics: what only the run
 * needed (before the surface fit and the output). */
void mr_simplify_release_run(mr_simplifier *s);
/* Free everything: the strategy's state, then the core's. */
void mr_simplify_discard(mr_simplifier *s);

/* mr_mesh_simplify on one chunk of a larger mesh (chunk.c, for a chunk
 * whose vertices carry attributes): per input vertex (wedge) its cut and
 * lock, and the quadrics carried in; a geometric vertex (the wedges that
 * are one surface point) is cut, locked or was cut when one of its wedges
 * is, and carries the sum of its wedges' quadrics. Out: per output vertex
 * a quadric in the unit -- its geometric vertex's on the first of that
 * vertex's output vertices, zero on the others -- so that a join of
 * chunks sums each surface point's once whatever wedges meet there. */
typedef struct mr_mesh_chunk_marks {
    const uint8_t *cut;           /* per vertex */
    const uint8_t *locked;        /* per vertex, or NULL */
    const mr_quadricf *quadrics;  /* per vertex, or NULL */
    const uint8_t *was_cut;       /* with quadrics */
    double unit;
    mr_quadricf **quadrics_out;   /* filled: output vertex_count of them */
} mr_mesh_chunk_marks;
mr_status mr_mesh_simplify_chunk(const mr_mesh *in, const mr_simplify_options *options,
                                 const mr_mesh_chunk_marks *marks, mr_mesh *out,
                                 uint32_t **origin, mr_simplify_stats *stats, mr_error *err);

#endif
