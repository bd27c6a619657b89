/* Exact welding's map: which vertices are bitwise one (weld_map.c).
 * Internal. */
#ifndef MR_MESH_WELD_MAP_H
#define MR_MESH_WELD_MAP_H

#include "../core/internal.h"

/* The words that make up a vertex's identity for welding: the bit patterns
 * of its position and (when asked) its attributes, with -0 read as +0 so
 * that the two zeros, which compare equal as numbers, weld. */
typedef struct mr_weld_layout {
    const float *arrays[4];
    unsigned widths[4];
    unsigned count;
} mr_weld_layout;

/* target[v] = the first vertex whose data in `l` equals v's (v itself for
 * the first of each group); keep[v] = 1 for those first vertices (when
 * keep is non-NULL); *merged = the number of later copies. */
mr_status mr_weld_map(const mr_weld_layout *l, size_t vc, uint32_t *target, uint8_t *keep,
                      size_t *merged, mr_error *err);

/* For one run of k vertices ids[] (in increasing id order), point each at
 * the first vertex of the run with the same data (target, keep, *merged
 * as mr_weld_map's); reps: scratch room for k ids. */
void mr_weld_run(const mr_weld_layout *l, const uint32_t *ids, size_t k, uint32_t *target,
                 uint8_t *keep, uint32_t *reps, size_t *merged);

/* target[v] = the first vertex whose position is bitwise equal to v's
 * (-0 and +0 equal), v itself for the first of each group: the map that
 * mr_mesh_weld_exact applies. Deterministic at any thread count. */
mr_status mr_weld_positions(const float *positions, size_t vertex_count, uint32_t *target,
                            mr_error *err);

#endif
