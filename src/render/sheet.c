/*
 * Comparison sheets: several meshes side by side from one camera, each
 * with a caption, and a colour bar when they carry heat values.
 *
 * Layout, top to bottom: an optional title line; rows of cells (a framed
 * panel, its caption under it); the colour bar with its label above and
 * its end values below.
 */
#include "render_internal.h"

#include <float.h>
#include <stdio.h>

#define TEXT_COLOR 0x202020
#define FRAME_COLOR 0xc8c8c8

void mr_sheet_options_default(mr_sheet_options *o)
{
    if (!o)
        return;
    memset(o, 0, sizeof *o);
    mr_render_options_default(&o->render);
    o->render.width = 400;
    o->render.height = 400;
    o->scalar_min = 0;
    o->scalar_max = 1;
}

static void fill_rect(uint8_t *img, int w, int h, int x0, int y0, int x1, int y1, uint32_t color)
{
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > w ? w : x1;
    y1 = y1 > h ? h : y1;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            uint8_t *p = img + 4 * ((size_t)y * (size_t)w + (size_t)x);
            p[0] = (uint8_t)(color >> 16);
            p[1] = (uint8_t)(color >> 8);
            p[2] = (uint8_t)color;
            p[3] = 255;
        }
}

/* Box of the drawn vertices of one panel, grown into lo/hi. */
static mr_status grow_bounds(const mr_sheet_panel *p, size_t which, float lo[3], float hi[3],
                             mr_error *err)
{
    if (!p->positions || p->vertex_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, "sheet", "panel %zu has no vertices", which + 1);
    if (p->triangle_count && !p->indices)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "sheet", "panel %zu has no indices",
                             which + 1);
    size_t n = p->triangle_count ? 3 * p->triangle_count : p->vertex_count;
    for (size_t i = 0; i < n; i++) {
        size_t v = p->triangle_count ? p->indices[i] : i;
        if (v >= p->vertex_count)
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "sheet",
                                 "panel %zu: triangle %zu uses vertex %zu, but there are %zu "
                                 "vertices",
                                 which + 1, i / 3, v, p->vertex_count);
        const float *q = p->positions + 3 * v;
        for (int c = 0; c < 3; c++) {
            if (!isfinite(q[c]))
                return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "sheet",
                                     "panel %zu: vertex %zu has a non-finite coordinate",
                                     which + 1, v);
            lo[c] = fminf(lo[c], q[c]);
            hi[c] = fmaxf(hi[c], q[c]);
        }
    }
    return MR_OK;
}

mr_status mr_render_sheet(const mr_sheet_panel *panels, size_t panel_count,
                          const mr_sheet_options *options, uint8_t **rgba, int *width,
                          int *height, mr_error *err)
{
    mr_error_clear(err);
    if (!rgba || !width || !height)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "sheet", "no output given");
    *rgba = NULL;
    *width = *height = 0;
    if (!panels || panel_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, "sheet", "no panels given");
    if (panel_count > 64)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "sheet",
                             "%zu panels: at most 64 fit a sheet", panel_count);
    mr_sheet_options defaults;
    if (!options) {
        mr_sheet_options_default(&defaults);
        options = &defaults;
    }
    mr_render_options ro = options->render;
    const int pw = ro.width, ph = ro.height;
    if (pw < 1 || ph < 1 || pw > 8192 || ph > 8192)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "sheet",
                             "panel size %dx%d is invalid (1 to 8192 pixels a side)", pw, ph);

    /* One camera for all, framed on every panel's vertices around the
     * centre of their joint box. */
    mr_render_frame frame;
    if (!ro.use_bounds) {
        float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
        for (size_t i = 0; i < panel_count; i++) {
            mr_status st = grow_bounds(&panels[i], i, lo, hi, err);
            if (st != MR_OK)
                return st;
        }
        double mid[3] = {0.5 * ((double)lo[0] + hi[0]), 0.5 * ((double)lo[1] + hi[1]),
                         0.5 * ((double)lo[2] + hi[2])};
        mr_render_frame_init(&frame, mid);
        for (size_t i = 0; i < panel_count; i++)
            mr_render_frame_grow(&frame, &ro, panels[i].positions, panels[i].vertex_count,
                                 panels[i].indices, panels[i].triangle_count);
    }

    const int ts = options->text_scale > 0 ? options->text_scale : pw >= 360 ? 2 : 1;
    const int pad = 5 * ts;
    const int cols = options->columns > 0 && (size_t)options->columns < panel_count
                         ? options->columns
                         : (int)panel_count;
    const int rows = (int)((panel_count + (size_t)cols - 1) / (size_t)cols);
    int heat = 0, caption_h = 0;
    for (size_t i = 0; i < panel_count; i++) {
        int th = 0;
        if (panels[i].caption && panels[i].caption[0])
            mr_text_size(panels[i].caption, ts, NULL, &th);
        caption_h = th > caption_h ? th : caption_h;
        heat |= panels[i].face_scalar || panels[i].vertex_scalar;
    }
    int title_h = 0;
    if (options->title && options->title[0]) {
        mr_text_size(options->title, ts, NULL, &title_h);
        title_h += 2 * pad;
    }
    const int cell_w = pw + 2, cell_h = ph + 2 + (caption_h ? caption_h + 2 * pad : pad);
    const int line_h = 9 * ts;
    const int bar_h = heat ? 2 * pad + line_h + 3 * ts + 4 * ts + 3 * ts + line_h + pad : 0;
    const int w = cols * cell_w + (cols + 1) * pad;
    const int h = title_h + (title_h ? 0 : pad) + rows * cell_h + bar_h;
    uint8_t *img = mr_alloc_array((size_t)w * (size_t)h, 4);
    if (!img)
        return mr_fail_nomem(err, "sheet", (size_t)w * (size_t)h * 4);
    const uint32_t bg = ro.background;
    fill_rect(img, w, h, 0, 0, w, h, bg);
    if (title_h)
        mr_draw_text(img, w, h, 0, pad, pad, options->title, ts, TEXT_COLOR);

    ro.scalar_min = options->scalar_min;
    ro.scalar_max = options->scalar_max;
    const int top = title_h ? title_h : pad;
    for (size_t i = 0; i < panel_count; i++) {
        const mr_sheet_panel *p = &panels[i];
        int cx = pad + (int)(i % (size_t)cols) * (cell_w + pad);
        int cy = top + (int)(i / (size_t)cols) * cell_h;
        fill_rect(img, w, h, cx, cy, cx + cell_w, cy + ph + 2, FRAME_COLOR);
        ro.face_scalar = p->face_scalar;
        ro.vertex_scalar = p->vertex_scalar;
        ro.texcoords = p->texcoords;
        ro.vertex_colors = p->vertex_colors;
        ro.face_material = p->face_material;
        ro.materials = p->materials;
        ro.material_count = p->material_count;
        uint8_t *sub = img + 4 * ((size_t)(cy + 1) * (size_t)w + (size_t)(cx + 1));
        mr_status st = mr_render_framed(p->positions, p->vertex_count, p->indices,
                                        p->triangle_count, &ro, ro.use_bounds ? NULL : &frame,
                                        sub, 4 * (size_t)w, err);
        if (st != MR_OK) {
            free(img);
            return st;
        }
        if (p->caption && p->caption[0])
            mr_draw_text(img, w, h, 0, cx + 1, cy + ph + 2 + pad, p->caption, ts, TEXT_COLOR);
    }

    if (heat) {
        /* Label above, the bar, the end values below it. */
        int bw = w / 2 < 200 * ts ? w / 2 : 200 * ts;
        if (bw < 64)
            bw = w - 2 * pad;
        int bx = (w - bw) / 2;
        int y = top + rows * cell_h + pad;
        if (options->colorbar_label && options->colorbar_label[0]) {
            int tw;
            mr_text_size(options->colorbar_label, ts, &tw, NULL);
            mr_draw_text(img, w, h, 0, (w - tw) / 2, y, options->colorbar_label, ts, TEXT_COLOR);
        }
        y += line_h + 3 * ts;
        int bh = 4 * ts;
        fill_rect(img, w, h, bx - 1, y - 1, bx + bw + 1, y + bh + 1, 0x808080);
        for (int x = 0; x < bw; x++) {
            uint8_t rgb[3];
            mr_colormap(bw > 1 ? (double)x / (bw - 1) : 0, rgb);
            fill_rect(img, w, h, bx + x, y, bx + x + 1, y + bh,
                      (uint32_t)rgb[0] << 16 | (uint32_t)rgb[1] << 8 | rgb[2]);
        }
        y += bh + 3 * ts;
        char lo_text[64], hi_text[64];
        const char *lo = options->colorbar_min_label, *hi = options->colorbar_max_label;
        if (!lo) {
            snprintf(lo_text, sizeof lo_text, "%.3g", options->scalar_min);
            lo = lo_text;
        }
        if (!hi) {
            snprintf(hi_text, sizeof hi_text, "%.3g", options->scalar_max);
            hi = hi_text;
        }
        int tw;
        mr_text_size(hi, ts, &tw, NULL);
        mr_draw_text(img, w, h, 0, bx, y, lo, ts, TEXT_COLOR);
        mr_draw_text(img, w, h, 0, bx + bw - tw, y, hi, ts, TEXT_COLOR);
    }
    *rgba = img;
    *width = w;
    *height = h;
    return MR_OK;
}
