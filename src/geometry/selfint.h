/*
 * Self-intersections of a triangle mesh (selfint.c). Internal: the tests
 * and the benchmarks check that a simplification adds none, and the
 * surface fit (qem/core/refine.c) puts back the moves that would add some.
 */
#ifndef MR_GEOMETRY_SELFINT_H
#define MR_GEOMETRY_SELFINT_H

#include "../core/internal.h"

/* Do triangles u and v (three points each) meet? Touching counts; in a
 * common plane, only overlap or crossing edges. */
bool mr_triangles_meet(const double *u[3], const double *v[3]);

/* The pairs of triangles that share no vertex and meet (packed positions,
 * indices in range), on up to `threads` threads: the same count on any
 * number. */
mr_status mr_self_intersections(const float *positions, const uint32_t *indices,
                                size_t triangle_count, int threads, size_t *pairs,
                                mr_error *err);

/* The same pairs listed: *count of them, triangle indices two by two in
 * *pairs (malloc'd; NULL when there are none), in an order that does not
 * depend on the thread count. */
mr_status mr_self_intersection_pairs(const float *positions, const uint32_t *indices,
                                     size_t triangle_count, int threads, uint32_t **pairs,
                                     size_t *count, mr_error *err);

#endif /* MR_GEOMETRY_SELFINT_H */
