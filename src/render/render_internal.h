/* Pieces of the rasterizer shared by the sheet composer. Not public. */
#ifndef MR_RENDER_INTERNAL_H
#define MR_RENDER_INTERNAL_H

#include "../core/internal.h"

/* What the camera frames: a centre in world space and the extent, in view
 * coordinates relative to that centre, that must fit the image. */
typedef struct mr_render_frame {
    double c[3];
    double xmin, xmax, ymin, ymax;
} mr_render_frame;

/* An empty frame around centre c (extents grown by mr_render_frame_grow). */
void mr_render_frame_init(mr_render_frame *f, const double c[3]);

/* Grow f's extents by the drawn vertices (referenced ones of a mesh, all of
 * a point cloud) as seen from the options' view. Indices must be valid. */
void mr_render_frame_grow(mr_render_frame *f, const mr_render_options *o, const float *positions,
                          size_t vertex_count, const uint32_t *indices, size_t triangle_count);

/* mr_render with the camera framed on `frame` (NULL: as mr_render). */
mr_status mr_render_framed(const float *positions, size_t vertex_count, const uint32_t *indices,
                           size_t triangle_count, const mr_render_options *options,
                           const mr_render_frame *frame, uint8_t *rgba, size_t row_bytes,
                           mr_error *err);

#endif
