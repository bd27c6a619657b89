/* The prepared reference's hierarchy, for the heat maps (render/heat.c):
 * compare.c owns mr_reference. Internal. */
#ifndef MR_METRICS_REFERENCE_H
#define MR_METRICS_REFERENCE_H

#include "../geometry/distance.h"

const mr_tri_bvh *mr_reference_hierarchy(const mr_reference *ref);
int mr_reference_threads(const mr_reference *ref);

#endif
