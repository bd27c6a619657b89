/*
 * The software rasterizer behind mr_render.
 *
 * Pipeline:
 *   1. Bounds and checks: the box of the vertices that are drawn (referenced
 *      ones for a mesh, all for a point cloud), index range and finiteness.
 *   2. Camera: orthographic, looking along -e, framed so that the box's
 *      eight corners fit the image minus a margin.
 *   3. Transform every vertex once into sample space (the image at k x k
 *      samples per pixel): fixed-point x, y with SUB_BITS fraction bits and
 *      a float depth (larger = nearer the camera).
 *   4. Bin primitives into horizontal bands of BAND_PIXELS output rows by
 *      a counting sort over fixed chunks of the primitive list, so every
 *      band lists its primitives in increasing index order whatever the
 *      thread count.
 *   5. Each band, independently (one OpenMP work item): rasterize its
 *      primitives into a band-sized depth + primitive-id buffer (the
 *      nearest sample wins; on equal depth the lower index, which comes
 *      first), then shade its samples and box-filter them into the output
 *      rows. A band's pixels depend only on that band's list, so the image
 *      is the same at any thread count and schedule.
 *
 * Triangles are rasterized with exact integer edge functions (64-bit) at
 * sample centres, with a tie rule that gives a sample on an edge shared by
 * two triangles to exactly one of them: no cracks, no double hits. A small
 * triangle tests every sample of its bounding box; a wide one walks the
 * exact first and last sample of each row (integer floors stepped row by
 * row), so a long sliver costs its height and its samples, not its box.
 * Both cover the same samples at the same depths. Shading
 * is deferred: the raster loop writes only depth and id, and the colour of
 * a sample is computed once, from the id (the face's headlight Lambert
 * term, the heat colour, the wireframe distance to the nearest edge).
 */
#include "render_internal.h"

#include <float.h>

#include "../core/omp_compat.h"

#define SUB_BITS 8                 /* fraction bits of sample coordinates */
#define SUB_ONE (1 << SUB_BITS)
#define SUB_HALF (SUB_ONE / 2)
#define BAND_PIXELS 16             /* output rows per band */
#define MAX_SIDE 16384
#define MAX_SUPERSAMPLE 8
/* Sample coordinates are clamped to +-COORD_LIMIT before the fixed-point
 * conversion, which keeps every edge-function product inside int64 (only
 * vertices far outside a caller's bounds box ever reach the clamp). */
#define COORD_LIMIT 1048576.0
#define NO_PRIM UINT32_MAX
#define PI 3.14159265358979323846

void mr_render_options_default(mr_render_options *o)
{
    if (!o)
        return;
    memset(o, 0, sizeof *o);
    o->width = 1024;
    o->height = 768;
    o->view = MR_VIEW_ISO;
    o->supersample = 3;
    o->background = 0xffffff;
    o->color = 0xb8c4d6;
    o->wire_color = 0x2a2f3a;
    o->margin = 0.04;
}

int mr_view_from_name(const char *name, mr_view *view)
{
    static const struct { const char *name; mr_view view; } names[] = {
        {"iso", MR_VIEW_ISO}, {"front", MR_VIEW_FRONT}, {"side", MR_VIEW_SIDE},
        {"top", MR_VIEW_TOP}};
    for (size_t i = 0; name && i < sizeof names / sizeof *names; i++)
        if (!strcmp(name, names[i].name)) {
            *view = names[i].view;
            return 0;
        }
    return -1;
}

/* ---- camera ---------------------------------------------------------------- */

typedef struct camera {
    double c[3];          /* centre of the framed box */
    double r[3], u[3], e[3]; /* right, up, towards the camera */
    double scale;         /* samples per world unit */
    double ox, oy;        /* sample position of c */
} camera;

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void view_angles(const mr_render_options *o, double *yaw, double *pitch)
{
    switch (o->view) {
    case MR_VIEW_FRONT: *yaw = 0; *pitch = 0; break;
    case MR_VIEW_SIDE: *yaw = 90; *pitch = 0; break;
    case MR_VIEW_TOP: *yaw = 0; *pitch = 90; break;
    case MR_VIEW_CUSTOM: *yaw = o->yaw; *pitch = o->pitch; break;
    case MR_VIEW_ISO:
    default: *yaw = 45; *pitch = 35.26438968; break; /* atan(1 / sqrt 2) */
    }
}

/* The camera's axes for the options' view. */
static void view_basis(const mr_render_options *o, double r[3], double u[3], double e[3])
{
    double yaw, pitch;
    view_angles(o, &yaw, &pitch);
    double cy = cos(yaw * PI / 180), sy = sin(yaw * PI / 180);
    double cp = cos(pitch * PI / 180), sp = sin(pitch * PI / 180);
    /* e points from the scene to the camera; yaw 0 pitch 0 looks along -z. */
    e[0] = sy * cp, e[1] = sp, e[2] = cy * cp;
    r[0] = cy, r[1] = 0, r[2] = -sy;
    u[0] = e[1] * r[2] - e[2] * r[1];
    u[1] = e[2] * r[0] - e[0] * r[2];
    u[2] = e[0] * r[1] - e[1] * r[0];
}

void mr_render_frame_init(mr_render_frame *f, const double c[3])
{
    memcpy(f->c, c, sizeof f->c);
    f->xmin = f->ymin = DBL_MAX;
    f->xmax = f->ymax = -DBL_MAX;
}

void mr_render_frame_grow(mr_render_frame *f, const mr_render_options *o, const float *positions,
                          size_t vertex_count, const uint32_t *indices, size_t triangle_count)
{
    double r[3], u[3], e[3];
    view_basis(o, r, u, e);
    double xl = f->xmin, xh = f->xmax, yl = f->ymin, yh = f->ymax;
    const size_t n = triangle_count ? 3 * triangle_count : vertex_count;
    const ptrdiff_t pn = (ptrdiff_t)n;
#pragma omp parallel for schedule(static) num_threads(mr_thread_count(o->threads)) \
    reduction(min : xl, yl) reduction(max : xh, yh)
    for (ptrdiff_t i = 0; i < pn; i++) {
        size_t v = triangle_count ? indices[i] : (size_t)i;
        const float *p = positions + 3 * v;
        double d[3] = {p[0] - f->c[0], p[1] - f->c[1], p[2] - f->c[2]};
        double x = dot3(d, r), y = dot3(d, u);
        xl = x < xl ? x : xl;
        xh = x > xh ? x : xh;
        yl = y < yl ? y : yl;
        yh = y > yh ? y : yh;
    }
    f->xmin = xl, f->xmax = xh, f->ymin = yl, f->ymax = yh;
}

/* The frame of a box: its centre and its eight corners. */
static void frame_of_box(const mr_render_options *o, const double lo[3], const double hi[3],
                         mr_render_frame *f)
{
    double r[3], u[3], e[3], c[3];
    view_basis(o, r, u, e);
    for (int i = 0; i < 3; i++)
        c[i] = 0.5 * (lo[i] + hi[i]);
    mr_render_frame_init(f, c);
    for (int k = 0; k < 8; k++) {
        double p[3] = {(k & 1 ? hi[0] : lo[0]) - c[0], (k & 2 ? hi[1] : lo[1]) - c[1],
                       (k & 4 ? hi[2] : lo[2]) - c[2]};
        double x = dot3(p, r), y = dot3(p, u);
        f->xmin = fmin(f->xmin, x);
        f->xmax = fmax(f->xmax, x);
        f->ymin = fmin(f->ymin, y);
        f->ymax = fmax(f->ymax, y);
    }
}

static void camera_setup(const mr_render_options *o, const mr_render_frame *f, int sw, int sh,
                         camera *cam)
{
    view_basis(o, cam->r, cam->u, cam->e);
    memcpy(cam->c, f->c, sizeof cam->c);
    double margin = o->margin > 0 && o->margin < 0.45 ? o->margin : 0;
    double border = margin * (sw < sh ? sw : sh);
    double aw = sw - 2 * border, ah = sh - 2 * border;
    double ex = f->xmax - f->xmin, ey = f->ymax - f->ymin;
    double scale;
    if (ex > 0 && ey > 0)
        scale = fmin(aw / ex, ah / ey);
    else if (ex > 0)
        scale = aw / ex;
    else if (ey > 0)
        scale = ah / ey;
    else
        scale = 1; /* a single point: any scale, it lands in the centre */
    double mx = ex >= 0 ? 0.5 * (f->xmin + f->xmax) : 0;
    double my = ey >= 0 ? 0.5 * (f->ymin + f->ymax) : 0;
    cam->scale = scale;
    cam->ox = 0.5 * sw - scale * mx;
    cam->oy = 0.5 * sh + scale * my;
}

/* ---- transformed vertices ------------------------------------------------- */

typedef struct svert {
    int32_t x, y; /* fixed-point sample coordinates */
    float z;      /* depth: larger is nearer */
} svert;

static int32_t to_fixed(double v)
{
    if (!(v > -COORD_LIMIT)) /* also NaN */
        v = -COORD_LIMIT;
    if (v > COORD_LIMIT)
        v = COORD_LIMIT;
    return (int32_t)lrint(v * SUB_ONE);
}

static void transform(const camera *cam, const float *p, svert *s)
{
    double d[3] = {(double)p[0] - cam->c[0], (double)p[1] - cam->c[1],
                   (double)p[2] - cam->c[2]};
    s->x = to_fixed(cam->ox + cam->scale * dot3(d, cam->r));
    s->y = to_fixed(cam->oy - cam->scale * dot3(d, cam->u));
    s->z = (float)(cam->scale * dot3(d, cam->e));
}

/* First and last sample index whose centre (i + 1/2) lies in [lo, hi]
 * (fixed-point), clamped to [0, n - 1]; first > last when none does. */
static void sample_span(int64_t lo, int64_t hi, int n, int *first, int *last)
{
    int64_t f = lo - SUB_HALF;
    f = f <= 0 ? -((-f) >> SUB_BITS) : ((f + SUB_ONE - 1) >> SUB_BITS);
    int64_t l = hi - SUB_HALF;
    l = l >= 0 ? (l >> SUB_BITS) : -(((-l) + SUB_ONE - 1) >> SUB_BITS);
    if (f < 0)
        f = 0;
    if (l > n - 1)
        l = n - 1;
    *first = (int)(f > n ? n : f);
    *last = (int)(l < -1 ? -1 : l);
}

/* ---- triangle setup -------------------------------------------------------- */

/* Edge function of edge a -> b: E(p) = A px + B py + C, positive on the
 * inside of a triangle with positive area. A sample exactly on an edge
 * belongs to the triangle for which the edge is "owned": (A, B) and
 * (-A, -B), the two sides of a shared edge, never both are. */
typedef struct edge {
    int64_t a, b, c;
    int64_t bias; /* 0 when owned, else -1: test E + bias >= 0 */
} edge;

static void edge_setup(edge *e, const svert *p, const svert *q)
{
    e->a = (int64_t)p->y - q->y;
    e->b = (int64_t)q->x - p->x;
    e->c = -(e->b * p->y) - e->a * p->x;
    e->bias = (e->a > 0 || (e->a == 0 && e->b < 0)) ? 0 : -1;
}

typedef struct tri_setup {
    svert v[3];       /* in positive-area order */
    edge e[3];        /* e[i]: the edge opposite v[i] (its weight) */
    int64_t area;     /* twice the signed area, > 0 */
    int swapped;      /* v[1], v[2] are the input's corners 2, 1 */
    int x0, x1, y0, y1; /* sample bounding box, clamped to the image */
} tri_setup;

/* Returns 0 for a triangle with zero area or no sample in the image. */
static int triangle_setup(const svert *sv, const uint32_t *tri, int sw, int sh, tri_setup *t)
{
    t->v[0] = sv[tri[0]];
    t->v[1] = sv[tri[1]];
    t->v[2] = sv[tri[2]];
    int64_t area = ((int64_t)t->v[1].x - t->v[0].x) * ((int64_t)t->v[2].y - t->v[0].y) -
                   ((int64_t)t->v[1].y - t->v[0].y) * ((int64_t)t->v[2].x - t->v[0].x);
    if (area == 0)
        return 0;
    t->swapped = area < 0;
    if (area < 0) {
        svert s = t->v[1];
        t->v[1] = t->v[2];
        t->v[2] = s;
        area = -area;
    }
    t->area = area;
    int64_t xl = t->v[0].x, xh = xl, yl = t->v[0].y, yh = yl;
    for (int i = 1; i < 3; i++) {
        xl = t->v[i].x < xl ? t->v[i].x : xl;
        xh = t->v[i].x > xh ? t->v[i].x : xh;
        yl = t->v[i].y < yl ? t->v[i].y : yl;
        yh = t->v[i].y > yh ? t->v[i].y : yh;
    }
    sample_span(xl, xh, sw, &t->x0, &t->x1);
    sample_span(yl, yh, sh, &t->y0, &t->y1);
    if (t->x0 > t->x1 || t->y0 > t->y1)
        return 0;
    edge_setup(&t->e[0], &t->v[1], &t->v[2]);
    edge_setup(&t->e[1], &t->v[2], &t->v[0]);
    edge_setup(&t->e[2], &t->v[0], &t->v[1]);
    return 1;
}

/* Rows (sample) covered by a splat of radius rad (fixed) around v. */
static int splat_rows(const svert *v, int64_t rad, int sw, int sh, int *x0, int *x1, int *y0,
                      int *y1)
{
    sample_span((int64_t)v->x - rad, (int64_t)v->x + rad, sw, x0, x1);
    sample_span((int64_t)v->y - rad, (int64_t)v->y + rad, sh, y0, y1);
    return *x0 <= *x1 && *y0 <= *y1;
}

/* ---- the render context ---------------------------------------------------- */

typedef struct ctx {
    const mr_render_options *o;
    const float *pos;
    const uint32_t *idx;
    size_t nv, nt;
    int k, sw, sh;       /* supersampling, sample image size */
    camera cam;
    svert *sv;           /* nv */
    float *shade;        /* nt: headlight Lambert term per face */
    int64_t splat_rad;   /* point radius, fixed-point samples */
    double splat_rad_s;  /* the same in samples */
    uint32_t *band_start; /* nbands + 1 */
    uint32_t *band_list;
    int nbands, band_rows;
    float base[3], bg[3], wire[3];
    int look;            /* texcoords, vertex colours or materials given */
    float base_lin[3];   /* `color` in linear light */
    float texel_lin[256]; /* the 8-bit texel values in linear light */
} ctx;

/* ---- the surface's look: textures, materials, vertex colours ---------------- */

/* Texel index i of a side of n texels under a wrap mode. */
static int wrap_index(int i, int n, mr_wrap mode)
{
    if (mode == MR_WRAP_CLAMP)
        return i < 0 ? 0 : i >= n ? n - 1 : i;
    if (mode == MR_WRAP_MIRROR) {
        int m = i % (2 * n);
        m = m < 0 ? m + 2 * n : m;
        return m < n ? m : 2 * n - 1 - m;
    }
    int m = i % n;
    return m < 0 ? m + n : m;
}

/* A texture coordinate brought into the range its wrap mode repeats. */
static double wrap_coord(double t, mr_wrap mode)
{
    if (!isfinite(t))
        return 0;
    if (mode == MR_WRAP_CLAMP)
        return t < -1 ? -1 : t > 2 ? 2 : t;
    if (mode == MR_WRAP_MIRROR)
        return t - 2 * floor(t / 2);
    return t - floor(t);
}

/* The texture's colour at (u, v), bilinear, in linear light. */
static void texture_sample(const ctx *c, const mr_render_material *m, double u, double v,
                           float out[3])
{
    const mr_image *im = m->texture;
    u = wrap_coord(u, m->wrap_s);
    v = wrap_coord(v, m->wrap_t);
    if (m->v_up)
        v = 1 - v;
    const double x = u * im->width - 0.5, y = v * im->height - 0.5;
    const double fx0 = floor(x), fy0 = floor(y);
    const float fx = (float)(x - fx0), fy = (float)(y - fy0);
    const int x0 = (int)fx0, y0 = (int)fy0;
    const int xs[2] = {wrap_index(x0, im->width, m->wrap_s),
                       wrap_index(x0 + 1, im->width, m->wrap_s)};
    const int ys[2] = {wrap_index(y0, im->height, m->wrap_t),
                       wrap_index(y0 + 1, im->height, m->wrap_t)};
    const float wx[2] = {1 - fx, fx}, wy[2] = {1 - fy, fy};
    out[0] = out[1] = out[2] = 0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            const uint8_t *t = im->rgba + 4 * ((size_t)ys[j] * (size_t)im->width + (size_t)xs[i]);
            const float w = wx[i] * wy[j];
            for (int k = 0; k < 3; k++)
                out[k] += w * c->texel_lin[t[k]];
        }
}

/* Face f's material, or NULL for the plain colour. */
static const mr_render_material *face_material(const ctx *c, size_t f)
{
    const mr_render_options *o = c->o;
    if (!o->materials || !o->material_count)
        return NULL;
    const uint32_t m = o->face_material ? o->face_material[f] : 0;
    return m < o->material_count ? &o->materials[m] : NULL;
}

/* The albedo (linear light) of face id at the point whose weights of the
 * face's vertices cv are w / area. */
static void surface_albedo(const ctx *c, uint32_t id, const uint32_t cv[3], const double w[3],
                           double area, float out[3])
{
    const mr_render_options *o = c->o;
    const mr_render_material *m = c->nt ? face_material(c, id) : NULL;
    if (m) {
        for (int k = 0; k < 3; k++)
            out[k] = mr_srgb_to_linear(m->color[k]);
        if (m->texture && m->texture->rgba && o->texcoords) {
            double u = 0, v = 0;
            for (int i = 0; i < 3; i++) {
                u += w[i] * (double)o->texcoords[2 * (size_t)cv[i]];
                v += w[i] * (double)o->texcoords[2 * (size_t)cv[i] + 1];
            }
            float t[3];
            texture_sample(c, m, u / area, v / area, t);
            for (int k = 0; k < 3; k++)
                out[k] *= t[k];
        }
    } else if (o->vertex_colors) {
        out[0] = out[1] = out[2] = 1;
    } else {
        for (int k = 0; k < 3; k++)
            out[k] = c->base_lin[k];
        return;
    }
    if (o->vertex_colors) {
        for (int k = 0; k < 3; k++) {
            double s = 0;
            for (int i = 0; i < 3; i++)
                s += w[i] * (double)o->vertex_colors[4 * (size_t)cv[i] + (size_t)k];
            out[k] *= mr_srgb_to_linear((float)(s / area));
        }
    }
}

static void rgb_of(uint32_t c, float out[3])
{
    out[0] = (float)((c >> 16) & 255) / 255.0f;
    out[1] = (float)((c >> 8) & 255) / 255.0f;
    out[2] = (float)(c & 255) / 255.0f;
}

/* Referenced-vertex box, index checks, finiteness. */
static mr_status bounds_and_checks(const ctx *c, int nthreads, double lo[3], double hi[3],
                                   mr_error *err)
{
    float xl = FLT_MAX, yl = FLT_MAX, zl = FLT_MAX, xh = -FLT_MAX, yh = -FLT_MAX, zh = -FLT_MAX;
    long long bad_index = -1, bad_vertex = -1;
    const size_t n = c->nt ? 3 * c->nt : c->nv;
#pragma omp parallel for schedule(static) num_threads(nthreads) \
    reduction(min : xl, yl, zl) reduction(max : xh, yh, zh, bad_index, bad_vertex)
    for (size_t i = 0; i < n; i++) {
        uint32_t v = c->nt ? c->idx[i] : (uint32_t)i;
        if (v >= c->nv) {
            if ((long long)i > bad_index)
                bad_index = (long long)i;
            continue;
        }
        const float *p = c->pos + 3 * (size_t)v;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
            if ((long long)v > bad_vertex)
                bad_vertex = (long long)v;
            continue;
        }
        xl = fminf(xl, p[0]);
        yl = fminf(yl, p[1]);
        zl = fminf(zl, p[2]);
        xh = fmaxf(xh, p[0]);
        yh = fmaxf(yh, p[1]);
        zh = fmaxf(zh, p[2]);
    }
    if (bad_index >= 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "triangle %lld uses vertex %u, but there are %zu vertices",
                             bad_index / 3, c->idx[bad_index], c->nv);
    if (bad_vertex >= 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "vertex %lld has a non-finite coordinate", bad_vertex);
    lo[0] = xl, lo[1] = yl, lo[2] = zl;
    hi[0] = xh, hi[1] = yh, hi[2] = zh;
    return MR_OK;
}

/* Band range of primitive i, or 0 when it covers no sample. */
static int prim_bands(const ctx *c, size_t i, int *b0, int *b1)
{
    int x0, x1, y0, y1;
    if (c->nt) {
        tri_setup t;
        if (!triangle_setup(c->sv, c->idx + 3 * i, c->sw, c->sh, &t))
            return 0;
        y0 = t.y0;
        y1 = t.y1;
    } else if (!splat_rows(&c->sv[i], c->splat_rad, c->sw, c->sh, &x0, &x1, &y0, &y1)) {
        return 0;
    }
    *b0 = y0 / c->band_rows;
    *b1 = y1 / c->band_rows;
    return 1;
}

/* Counting sort of the primitives into bands, in index order per band. */
static mr_status bin_primitives(ctx *c, int nthreads, mr_error *err)
{
    const size_t np = c->nt ? c->nt : c->nv;
    const int nb = c->nbands;
    const int chunks = nthreads;
    size_t *count = mr_calloc_array((size_t)chunks * (size_t)nb, sizeof *count);
    c->band_start = mr_alloc_array((size_t)nb + 1, sizeof *c->band_start);
    if (!count || !c->band_start) {
        free(count);
        return mr_fail_nomem(err, "render", (size_t)chunks * (size_t)nb * sizeof *count);
    }
#pragma omp parallel for schedule(static, 1) num_threads(nthreads)
    for (int ch = 0; ch < chunks; ch++) {
        size_t first = np * (size_t)ch / (size_t)chunks, end = np * (size_t)(ch + 1) / (size_t)chunks;
        size_t *cnt = count + (size_t)ch * (size_t)nb;
        for (size_t i = first; i < end; i++) {
            int b0, b1;
            if (prim_bands(c, i, &b0, &b1))
                for (int b = b0; b <= b1; b++)
                    cnt[b]++;
        }
    }
    /* Exclusive prefix sum in (band, chunk) order: count becomes offsets. */
    size_t total = 0;
    for (int b = 0; b < nb; b++) {
        c->band_start[b] = (uint32_t)total;
        for (int ch = 0; ch < chunks; ch++) {
            size_t n = count[(size_t)ch * (size_t)nb + (size_t)b];
            count[(size_t)ch * (size_t)nb + (size_t)b] = total;
            total += n;
        }
    }
    if (total > UINT32_MAX) {
        free(count);
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, "render",
                             "too many primitive-band pairs (%zu) for this image", total);
    }
    c->band_start[nb] = (uint32_t)total;
    c->band_list = mr_alloc_array(total, sizeof *c->band_list);
    if (!c->band_list) {
        free(count);
        return mr_fail_nomem(err, "render", total * sizeof *c->band_list);
    }
#pragma omp parallel for schedule(static, 1) num_threads(nthreads)
    for (int ch = 0; ch < chunks; ch++) {
        size_t first = np * (size_t)ch / (size_t)chunks, end = np * (size_t)(ch + 1) / (size_t)chunks;
        size_t *off = count + (size_t)ch * (size_t)nb;
        for (size_t i = first; i < end; i++) {
            int b0, b1;
            if (prim_bands(c, i, &b0, &b1))
                for (int b = b0; b <= b1; b++)
                    c->band_list[off[b]++] = (uint32_t)i;
        }
    }
    free(count);
    return MR_OK;
}

/* ---- rasterization of one band ------------------------------------------- */

/* Triangles at most this many samples wide scan their bounding box row by
 * row (a few cheap tests per sample); wider ones walk the exact span of
 * each row, so a long sliver costs its height plus its covered samples,
 * never its bounding box. Both paths cover the same samples with the same
 * depths: the choice changes only the speed. */
#define SPAN_MIN_WIDTH 16

/* The row loop below is instantiated for each side of the pair of walks. */
#if defined(__GNUC__)
#define MR_RASTER_INLINE __attribute__((always_inline))
#else
#define MR_RASTER_INLINE
#endif

/* floor(n / d) = q with remainder r (0 <= r < d), for d > 0, kept exact
 * while n grows by a fixed step each row: the quotient and remainder of
 * the step are added and one carry fixes the remainder. */
typedef struct floor_walk {
    int64_t q, r, d, sq, sr;
} floor_walk;

/* A walk whose bound never binds: q stays far beyond any sample index. */
#define WALK_NONE ((floor_walk){INT64_MAX / 4, 0, 1, 0, 0})

static inline void floor_div(int64_t n, int64_t d, int64_t *q, int64_t *r)
{
    int64_t qq = n / d, rr = n % d;
    if (rr < 0) {
        rr += d;
        qq--;
    }
    *q = qq;
    *r = rr;
}

static inline floor_walk floor_walk_start(int64_t n, int64_t d, int64_t step)
{
    floor_walk w;
    w.d = d;
    floor_div(n, d, &w.q, &w.r);
    floor_div(step, d, &w.sq, &w.sr);
    return w;
}

static inline void floor_walk_next(floor_walk *w)
{
    w->q += w->sq;
    w->r += w->sr;
    const bool carry = w->r >= w->d;
    w->r -= carry ? w->d : 0;
    w->q += carry;
}

/* Depth test and write of samples [xa, xb] of one row; w1, w2 are the
 * (biased) edge weights of v1 and v2 at xa. */
static inline void raster_run(const tri_setup *t, uint32_t id, int xa, int xb, int64_t w1,
                              int64_t w2, int64_t s1, int64_t s2, double z0, double dz1,
                              double dz2, float *drow, uint32_t *irow)
{
    for (int x = xa; x <= xb; x++, w1 += s1, w2 += s2) {
        /* Unbiased weights of v1 and v2 for the depth. */
        float z = (float)(z0 + (double)(w1 - t->e[1].bias) * dz1 +
                          (double)(w2 - t->e[2].bias) * dz2);
        if (z > drow[x]) {
            drow[x] = z;
            irow[x] = id;
        }
    }
}

/* The rows of raster_triangle_spans: `pair` are the two walks of one
 * side (left when pair_left), `one` the walk of the other. */
static inline MR_RASTER_INLINE void
span_rows(const tri_setup *t, uint32_t id, int y0, int y1, int r0, int sw,
          const int64_t alpha[3], const int64_t beta[3], const floor_walk pair[2],
          floor_walk one, const int pair_left, double z0, double dz1, double dz2,
          float *depth, uint32_t *ids)
{
    floor_walk p0 = pair[0], p1 = pair[1];
    const int64_t s1 = alpha[1], s2 = alpha[2];
    const int64_t db1 = t->e[1].b * SUB_ONE, db2 = t->e[2].b * SUB_ONE;
    int64_t b1 = beta[1], b2 = beta[2];
    for (int y = y0; y <= y1; y++, b1 += db1, b2 += db2) {
        int64_t lo, hi;
        if (pair_left) {
            lo = -p0.q > -p1.q ? -p0.q : -p1.q;
            hi = one.q;
        } else {
            lo = -one.q;
            hi = p0.q < p1.q ? p0.q : p1.q;
        }
        lo = lo > t->x0 ? lo : t->x0;
        hi = hi < t->x1 ? hi : t->x1;
        floor_walk_next(&p0);
        floor_walk_next(&p1);
        floor_walk_next(&one);
        if (lo > hi)
            continue;
        const int xa = (int)lo;
        const size_t row = (size_t)(y - r0) * (size_t)sw;
        raster_run(t, id, xa, (int)hi, s1 * xa + b1, s2 * xa + b2, s1, s2, z0, dz1, dz2,
                   depth + row, ids + row);
    }
}

/*
 * Edge i at sample (x, y) is w_i = alpha_i x + beta_i(y), alpha_i = A_i
 * SUB_ONE, beta_i growing by B_i SUB_ONE per row; the sample is in the
 * triangle when every w_i >= 0. An edge with alpha > 0 bounds the row from
 * the left, x >= ceil(-beta / alpha) = -floor(beta / alpha); one with alpha
 * < 0 from the right, x <= floor(beta / -alpha); both floors are walked
 * exactly. The alphas sum to 0, so a triangle has one or two edges of each
 * side, and at most one with alpha = 0 (a horizontal edge), which bounds
 * the rows instead: beta(y) >= 0.
 */
static void raster_triangle_spans(const tri_setup *t, uint32_t id, int y0, int y1, int r0,
                                  int sw, double z0, double dz1, double dz2, float *depth,
                                  uint32_t *ids)
{
    /* A horizontal edge: beta(y0 + j) = beta0 + j step >= 0 holds for j >=
     * -floor(beta0 / step) when step > 0, for j <= floor(beta0 / -step)
     * when step < 0. */
    for (int i = 0; i < 3; i++) {
        const edge *e = &t->e[i];
        if (e->a != 0)
            continue;
        const int64_t beta0 = e->b * ((int64_t)y0 * SUB_ONE + SUB_HALF) + e->c + e->bias;
        const int64_t step = e->b * SUB_ONE;
        int64_t q, r;
        if (step > 0) {
            floor_div(beta0, step, &q, &r);
            if (-q > (int64_t)y1 - y0)
                return;
            if (-q > 0)
                y0 += (int)-q;
        } else if (step < 0) {
            floor_div(beta0, -step, &q, &r);
            if (q < 0)
                return;
            if (q < (int64_t)y1 - y0)
                y1 = y0 + (int)q;
        } else if (beta0 < 0) {
            return;
        }
    }
    floor_walk left[2] = {WALK_NONE, WALK_NONE}, right[2] = {WALK_NONE, WALK_NONE};
    int nl = 0, nr = 0;
    const int64_t py0 = (int64_t)y0 * SUB_ONE + SUB_HALF;
    int64_t alpha[3], beta[3];
    for (int i = 0; i < 3; i++) {
        const edge *e = &t->e[i];
        alpha[i] = e->a * SUB_ONE;
        beta[i] = e->a * SUB_HALF + e->b * py0 + e->c + e->bias;
        const int64_t step = e->b * SUB_ONE;
        if (alpha[i] > 0 && nl < 2)
            left[nl++] = floor_walk_start(beta[i], alpha[i], step);
        else if (alpha[i] < 0 && nr < 2)
            right[nr++] = floor_walk_start(beta[i], -alpha[i], step);
    }
    /* Two edges on one side, one on the other (or, with a horizontal edge,
     * one each: the second walk is then WALK_NONE). */
    if (nl == 2)
        span_rows(t, id, y0, y1, r0, sw, alpha, beta, left, right[0], 1, z0, dz1, dz2, depth,
                  ids);
    else
        span_rows(t, id, y0, y1, r0, sw, alpha, beta, right, left[0], 0, z0, dz1, dz2, depth,
                  ids);
}

static void raster_triangle(const ctx *c, uint32_t id, int r0, int r1, float *depth,
                            uint32_t *ids)
{
    tri_setup t;
    if (!triangle_setup(c->sv, c->idx + 3 * (size_t)id, c->sw, c->sh, &t))
        return;
    int y0 = t.y0 > r0 ? t.y0 : r0, y1 = t.y1 < r1 ? t.y1 : r1;
    const double inv = 1.0 / (double)t.area;
    const double z0 = t.v[0].z, dz1 = ((double)t.v[1].z - z0) * inv,
                 dz2 = ((double)t.v[2].z - z0) * inv;
    if (t.x1 - t.x0 >= SPAN_MIN_WIDTH) {
        raster_triangle_spans(&t, id, y0, y1, r0, c->sw, z0, dz1, dz2, depth, ids);
        return;
    }
    const int64_t px0 = (int64_t)t.x0 * SUB_ONE + SUB_HALF;
    for (int y = y0; y <= y1; y++) {
        const int64_t py = (int64_t)y * SUB_ONE + SUB_HALF;
        int64_t w0 = t.e[0].a * px0 + t.e[0].b * py + t.e[0].c + t.e[0].bias;
        int64_t w1 = t.e[1].a * px0 + t.e[1].b * py + t.e[1].c + t.e[1].bias;
        int64_t w2 = t.e[2].a * px0 + t.e[2].b * py + t.e[2].c + t.e[2].bias;
        const int64_t s0 = t.e[0].a * SUB_ONE, s1 = t.e[1].a * SUB_ONE, s2 = t.e[2].a * SUB_ONE;
        float *drow = depth + (size_t)(y - r0) * (size_t)c->sw;
        uint32_t *irow = ids + (size_t)(y - r0) * (size_t)c->sw;
        for (int x = t.x0; x <= t.x1; x++, w0 += s0, w1 += s1, w2 += s2) {
            if ((w0 | w1 | w2) < 0)
                continue;
            /* Unbiased weights of v1 and v2 for the depth. */
            float z = (float)(z0 + (double)(w1 - t.e[1].bias) * dz1 +
                              (double)(w2 - t.e[2].bias) * dz2);
            if (z > drow[x]) {
                drow[x] = z;
                irow[x] = id;
            }
        }
    }
}

static void raster_splat(const ctx *c, uint32_t id, int r0, int r1, float *depth, uint32_t *ids)
{
    const svert *v = &c->sv[id];
    int x0, x1, y0, y1;
    if (!splat_rows(v, c->splat_rad, c->sw, c->sh, &x0, &x1, &y0, &y1))
        return;
    if (y0 < r0)
        y0 = r0;
    if (y1 > r1)
        y1 = r1;
    const double rad = c->splat_rad_s, r2 = rad * rad;
    for (int y = y0; y <= y1; y++) {
        double dy = (y + 0.5) - (double)v->y / SUB_ONE;
        float *drow = depth + (size_t)(y - r0) * (size_t)c->sw;
        uint32_t *irow = ids + (size_t)(y - r0) * (size_t)c->sw;
        for (int x = x0; x <= x1; x++) {
            double dx = (x + 0.5) - (double)v->x / SUB_ONE;
            double d2 = dx * dx + dy * dy;
            if (d2 > r2)
                continue;
            /* A sphere's front: overlapping splats intersect like balls. */
            float z = (float)((double)v->z + sqrt(r2 - d2));
            if (z > drow[x]) {
                drow[x] = z;
                irow[x] = id;
            }
        }
    }
}

/* ---- shading --------------------------------------------------------------- */

static double scalar_t(const mr_render_options *o, double v)
{
    double span = o->scalar_max - o->scalar_min;
    if (!(span > 0) || !(v == v))
        return 0;
    return (v - o->scalar_min) / span;
}

/* Colour of one sample (0..255 per channel, rounded) into acc[]. */
static void shade_sample(const ctx *c, uint32_t id, int x, int y, int acc[3])
{
    const mr_render_options *o = c->o;
    float col[3];
    if (id == NO_PRIM) {
        for (int i = 0; i < 3; i++)
            acc[i] += (int)lrintf(c->bg[i] * 255.0f);
        return;
    }
    const double px = (x + 0.5) * SUB_ONE, py = (y + 0.5) * SUB_ONE;
    double light;
    float albedo[3];
    int lit = 0; /* albedo holds the surface's look */
    int heat = 0;
    double value = 0;
    int on_wire = 0;
    if (c->nt) {
        light = c->shade[id];
        if (o->face_scalar) {
            heat = 1;
            value = o->face_scalar[id];
        }
        const int look = c->look && !o->face_scalar && !o->vertex_scalar;
        if (o->vertex_scalar || o->wire || look) {
            tri_setup t;
            const uint32_t *tri = c->idx + 3 * (size_t)id;
            /* Non-zero area: the sample was drawn from this setup; the
             * image bounds do not matter here. */
            triangle_setup(c->sv, tri, INT32_MAX / 2, INT32_MAX / 2, &t);
            double w[3];
            for (int i = 0; i < 3; i++)
                w[i] = (double)t.e[i].a * px + (double)t.e[i].b * py + (double)t.e[i].c;
            /* e[i] weighs set-up vertex i; the setup may have swapped
             * the input's corners 1 and 2. */
            const uint32_t cv[3] = {tri[0], t.swapped ? tri[2] : tri[1],
                                    t.swapped ? tri[1] : tri[2]};
            if (look) {
                surface_albedo(c, id, cv, w, (double)t.area, albedo);
                lit = 1;
            }
            if (o->vertex_scalar) {
                double sum = 0;
                for (int i = 0; i < 3; i++)
                    sum += w[i] * (double)o->vertex_scalar[cv[i]];
                heat = 1;
                value = sum / (double)t.area;
            }
            if (o->wire) {
                /* Distance to the nearest edge in samples: E / |edge|. */
                double half = 0.45 * c->k;
                for (int i = 0; i < 3 && !on_wire; i++) {
                    double len = sqrt((double)t.e[i].a * (double)t.e[i].a +
                                      (double)t.e[i].b * (double)t.e[i].b);
                    if (w[i] / (len * SUB_ONE) < half)
                        on_wire = 1;
                }
            }
        }
    } else {
        const svert *v = &c->sv[id];
        double dx = px / SUB_ONE - (double)v->x / SUB_ONE;
        double dy = py / SUB_ONE - (double)v->y / SUB_ONE;
        double r2 = c->splat_rad_s * c->splat_rad_s;
        double q = 1 - (dx * dx + dy * dy) / r2;
        light = sqrt(q > 0 ? q : 0); /* the ball's normal towards the eye */
        const float *s = o->vertex_scalar ? o->vertex_scalar : o->face_scalar;
        if (s) {
            heat = 1;
            value = s[id];
        } else if (o->vertex_colors) {
            for (int k = 0; k < 3; k++)
                albedo[k] = mr_srgb_to_linear(o->vertex_colors[4 * (size_t)id + (size_t)k]);
            lit = 1;
        }
    }
    if (on_wire) {
        for (int i = 0; i < 3; i++)
            acc[i] += (int)lrintf(c->wire[i] * 255.0f);
        return;
    }
    if (lit) {
        /* in linear light, then back to display values */
        const float f = (float)(0.15 + 0.85 * light);
        for (int i = 0; i < 3; i++)
            acc[i] += (int)lrintf(mr_linear_to_srgb(albedo[i] * f) * 255.0f);
        return;
    }
    float f;
    if (heat) {
        uint8_t rgb[3];
        mr_colormap(scalar_t(o, value), rgb);
        for (int i = 0; i < 3; i++)
            col[i] = rgb[i] / 255.0f;
        f = (float)(0.35 + 0.65 * light); /* keep the colours readable */
    } else {
        for (int i = 0; i < 3; i++)
            col[i] = c->base[i];
        f = (float)(0.12 + 0.88 * light);
    }
    for (int i = 0; i < 3; i++) {
        float v = col[i] * f;
        acc[i] += (int)lrintf((v > 1 ? 1 : v) * 255.0f);
    }
}

static void shade_band(const ctx *c, int r0, int r1, const uint32_t *ids, uint8_t *rgba,
                       size_t row_bytes)
{
    const int k = c->k, n = k * k;
    for (int py = r0 / k; py <= r1 / k; py++) {
        uint8_t *out = rgba + (size_t)py * row_bytes;
        for (int px = 0; px < c->o->width; px++) {
            int acc[3] = {0, 0, 0};
            for (int sy = py * k; sy < py * k + k; sy++)
                for (int sx = px * k; sx < px * k + k; sx++)
                    shade_sample(c, ids[(size_t)(sy - r0) * (size_t)c->sw + (size_t)sx], sx, sy,
                                 acc);
            for (int i = 0; i < 3; i++)
                out[4 * px + i] = (uint8_t)((acc[i] + n / 2) / n);
            out[4 * px + 3] = 255;
        }
    }
}

/* ---- entry point ----------------------------------------------------------- */

static mr_status check_options(const mr_render_options *o, mr_error *err)
{
    if (o->width < 1 || o->height < 1 || o->width > MAX_SIDE || o->height > MAX_SIDE)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "image size %dx%d is invalid (1 to %d pixels a side)", o->width,
                             o->height, MAX_SIDE);
    if (o->supersample < 1 || o->supersample > MAX_SUPERSAMPLE)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "supersampling %d is invalid (1 to %d)", o->supersample,
                             MAX_SUPERSAMPLE);
    if (o->face_scalar && o->vertex_scalar)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "give per-face or per-vertex heat values, not both");
    if ((int)o->view < MR_VIEW_ISO || o->view > MR_VIEW_CUSTOM)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render", "unknown view %d",
                             (int)o->view);
    if (!isfinite(o->yaw) || !isfinite(o->pitch) || !(o->point_radius >= 0) ||
        !isfinite(o->point_radius))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "camera angles and point radius must be finite (radius >= 0)");
    for (size_t i = 0; o->materials && i < o->material_count; i++) {
        const mr_image *t = o->materials[i].texture;
        if (t && (!t->rgba || t->width < 1 || t->height < 1))
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                                 "material %zu: its texture has no pixels", i);
    }
    if (o->use_bounds)
        for (int i = 0; i < 3; i++)
            if (!isfinite(o->bounds_lo[i]) || !isfinite(o->bounds_hi[i]) ||
                o->bounds_lo[i] > o->bounds_hi[i])
                return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                                     "the bounds box is not a finite box (lo <= hi)");
    return MR_OK;
}

mr_status mr_render(const float *positions, size_t vertex_count, const uint32_t *indices,
                    size_t triangle_count, const mr_render_options *options, uint8_t *rgba,
                    size_t row_bytes, mr_error *err)
{
    return mr_render_framed(positions, vertex_count, indices, triangle_count, options, NULL,
                            rgba, row_bytes, err);
}

mr_status mr_render_framed(const float *positions, size_t vertex_count, const uint32_t *indices,
                           size_t triangle_count, const mr_render_options *options,
                           const mr_render_frame *frame, uint8_t *rgba, size_t row_bytes,
                           mr_error *err)
{
    mr_error_clear(err);
    mr_render_options defaults;
    if (!options) {
        mr_render_options_default(&defaults);
        options = &defaults;
    }
    mr_status st = check_options(options, err);
    if (st != MR_OK)
        return st;
    if (!rgba)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render", "no image buffer given");
    if (vertex_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, "render", "nothing to render: no vertices");
    if (!positions || (triangle_count && !indices))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "no positions or indices given");
    if (vertex_count > UINT32_MAX || triangle_count > UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, "render",
                             "more than 2^32 - 1 vertices or triangles");
    if (row_bytes == 0)
        row_bytes = 4 * (size_t)options->width;
    if (row_bytes < 4 * (size_t)options->width)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "render",
                             "row_bytes %zu is less than 4 * width", row_bytes);

    ctx c;
    memset(&c, 0, sizeof c);
    c.o = options;
    c.pos = positions;
    c.idx = indices;
    c.nv = vertex_count;
    c.nt = triangle_count;
    c.k = options->supersample;
    c.sw = options->width * c.k;
    c.sh = options->height * c.k;
    c.band_rows = BAND_PIXELS * c.k;
    c.nbands = (c.sh + c.band_rows - 1) / c.band_rows;
    rgb_of(options->color, c.base);
    rgb_of(options->background, c.bg);
    rgb_of(options->wire_color, c.wire);
    c.look = options->texcoords || options->vertex_colors || options->materials;
    for (int i = 0; i < 3; i++)
        c.base_lin[i] = mr_srgb_to_linear(c.base[i]);
    for (int i = 0; c.look && i < 256; i++)
        c.texel_lin[i] = mr_srgb_to_linear((float)i / 255.0f);
    const int nthreads = mr_thread_count(options->threads);

    double lo[3], hi[3];
    if ((st = bounds_and_checks(&c, nthreads, lo, hi, err)) != MR_OK)
        return st;
    /* Framing: the caller's frame; the corners of the caller's box; or,
     * tightest, the drawn vertices themselves around their box's centre. */
    mr_render_frame own;
    if (!frame) {
        if (options->use_bounds) {
            for (int i = 0; i < 3; i++) {
                lo[i] = options->bounds_lo[i];
                hi[i] = options->bounds_hi[i];
            }
            frame_of_box(options, lo, hi, &own);
        } else {
            double mid[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]),
                             0.5 * (lo[2] + hi[2])};
            mr_render_frame_init(&own, mid);
            mr_render_frame_grow(&own, options, positions, vertex_count, indices,
                                 triangle_count);
        }
        frame = &own;
    }
    camera_setup(options, frame, c.sw, c.sh, &c.cam);

    c.sv = mr_alloc_array(c.nv, sizeof *c.sv);
    c.shade = mr_alloc_array(c.nt, sizeof *c.shade);
    float *depth = mr_alloc_array((size_t)nthreads * (size_t)c.band_rows * (size_t)c.sw,
                                  sizeof *depth);
    uint32_t *ids = mr_alloc_array((size_t)nthreads * (size_t)c.band_rows * (size_t)c.sw,
                                   sizeof *ids);
    if (!c.sv || !c.shade || !depth || !ids) {
        st = mr_fail_nomem(err, "render", c.nv * sizeof *c.sv + c.nt * sizeof *c.shade);
        goto done;
    }

    const ptrdiff_t nv = (ptrdiff_t)c.nv, nt = (ptrdiff_t)c.nt;
#pragma omp parallel num_threads(nthreads)
    {
#pragma omp for schedule(static)
        for (ptrdiff_t v = 0; v < nv; v++)
            transform(&c.cam, positions + 3 * v, &c.sv[v]);
        /* Headlight Lambert term, two-sided (open meshes show their
         * insides lit too). */
#pragma omp for schedule(static)
        for (ptrdiff_t t = 0; t < nt; t++) {
            const float *a = positions + 3 * (size_t)indices[3 * t];
            const float *b = positions + 3 * (size_t)indices[3 * t + 1];
            const float *d = positions + 3 * (size_t)indices[3 * t + 2];
            double u[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
            double w[3] = {(double)d[0] - a[0], (double)d[1] - a[1], (double)d[2] - a[2]};
            double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                           u[0] * w[1] - u[1] * w[0]};
            double len = sqrt(dot3(n, n));
            c.shade[t] = len > 0 ? (float)fabs(dot3(n, c.cam.e) / len) : 0.0f;
        }
    }

    if (!c.nt) {
        double r = options->point_radius;
        if (r <= 0) {
            /* From the density: about the spacing of the points if they
             * covered a third of the image. */
            r = 0.55 * sqrt((double)options->width * options->height / 3.0 / (double)c.nv);
            r = r < 1 ? 1 : r > 6 ? 6 : r;
        }
        c.splat_rad_s = r * c.k;
        c.splat_rad = (int64_t)ceil(c.splat_rad_s * SUB_ONE);
    }

    if ((st = bin_primitives(&c, nthreads, err)) != MR_OK)
        goto done;

    const size_t band_samples = (size_t)c.band_rows * (size_t)c.sw;
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads)
    for (int b = 0; b < c.nbands; b++) {
        const int tid = omp_get_thread_num();
        float *bd = depth + (size_t)tid * band_samples;
        uint32_t *bi = ids + (size_t)tid * band_samples;
        int r0 = b * c.band_rows, r1 = r0 + c.band_rows - 1;
        if (r1 > c.sh - 1)
            r1 = c.sh - 1;
        size_t used = (size_t)(r1 - r0 + 1) * (size_t)c.sw;
        for (size_t i = 0; i < used; i++) {
            bd[i] = -FLT_MAX;
            bi[i] = NO_PRIM;
        }
        for (uint32_t j = c.band_start[b]; j < c.band_start[b + 1]; j++) {
            if (c.nt)
                raster_triangle(&c, c.band_list[j], r0, r1, bd, bi);
            else
                raster_splat(&c, c.band_list[j], r0, r1, bd, bi);
        }
        shade_band(&c, r0, r1, bi, rgba, row_bytes);
    }

done:
    free(c.sv);
    free(c.shade);
    free(c.band_start);
    free(c.band_list);
    free(depth);
    free(ids);
    return st;
}
