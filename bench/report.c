/*
 * The benchmark report: reads the sweep's CSV (bench/sweep.c) and writes
 * plots as PNG, drawn with the library's own font and PNG writer, a
 * comparison sheet per mesh rendered by the library (the original and its
 * reductions coloured by their distance to it), and a Markdown report
 * embedding them.
 *
 *   report [CSV] [--out DIR] [--panel PX]
 *
 * CSV defaults to bench/report/sweep.csv; DIR (default bench) receives
 * REPORT.md and the PNG files in DIR/report/. Plots are drawn at twice their size and
 * box-filtered down (anti-aliasing).
 */
#include "benchutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- the CSV ---------------------------------------------------------------- */

#define MAX_ROWS 4096
#define MAX_MESHES 32

typedef struct row {
    char mesh[64], alg[64];
    int threads;
    double target;
    double in_tris, out_tris, runs;
    double t_med, t_min, t_max, tps, peak, haus, rms, simil; /* NAN: empty */
} row;

typedef struct report {
    row rows[MAX_ROWS];
    int n_rows;
    char machine[512], date[64], settings[256];
    char mesh_name[MAX_MESHES][64], mesh_source[MAX_MESHES][4200];
    int n_meshes;
} report;

/* Copy a NUL-terminated string, cut to fit. */
static void copy(char *dst, size_t cap, const char *src)
{
    size_t n = strlen(src);
    if (n >= cap)
        n = cap - 1;
    memcpy(dst, src, n);
    dst[n] = '\0';
}

/* The columns, by name: the sweep's CSV and bench_simplify's (whose
 * columns are in another order, with no vertex_similarity) both read. */
enum {
    COL_MESH, COL_ALG, COL_THREADS, COL_TARGET, COL_IN, COL_OUT, COL_RUNS, COL_TMED, COL_TMIN,
    COL_TMAX, COL_TPS, COL_PEAK, COL_HAUS, COL_RMS, COL_SIMIL, COL_COUNT
};
static const char *const col_name[COL_COUNT] = {
    "mesh", "algorithm", "threads", "target", "input_triangles", "output_triangles", "runs",
    "time_median", "time_min", "time_max", "triangles_per_second", "peak_bytes_per_triangle",
    "hausdorff_rel", "rms_rel", "vertex_similarity"};

#define MAX_FIELDS 64

/* Split a line at its commas in place; returns the field count. */
static int split(char *line, char **fields)
{
    int n = 0;
    for (char *p = line; n < MAX_FIELDS;) {
        fields[n++] = p;
        char *end = strchr(p, ',');
        if (!end)
            break;
        *end = '\0';
        p = end + 1;
    }
    return n;
}

static double num(char **fields, int n, int col)
{
    if (col < 0 || col >= n || !*fields[col])
        return NAN;
    return strtod(fields[col], NULL);
}

static int read_csv(const char *path, report *r)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "report: cannot read %s\n", path);
        return -1;
    }
    char line[8192];
    int header = 0;
    int col[COL_COUNT];
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = '\0';
        if (line[0] == '#') {
            if (!strncmp(line, "# machine: ", 11))
                copy(r->machine, sizeof r->machine, line + 11);
            else if (!strncmp(line, "# date: ", 8))
                copy(r->date, sizeof r->date, line + 8);
            else if (!strncmp(line, "# runs: ", 8))
                copy(r->settings, sizeof r->settings, line + 2);
            else if (!strncmp(line, "# mesh ", 7) && r->n_meshes < MAX_MESHES) {
                char *name = line + 7, *sp = strchr(name, ' ');
                if (sp) {
                    *sp = '\0';
                    copy(r->mesh_name[r->n_meshes], 64, name);
                    copy(r->mesh_source[r->n_meshes], 4200, sp + 1);
                    r->n_meshes++;
                }
            }
            continue;
        }
        char *fields[MAX_FIELDS];
        if (!header) {
            if (strncmp(line, "mesh,algorithm,threads,target,", 30) != 0) {
                fprintf(stderr, "report: %s: not a sweep CSV (header '%s')\n", path, line);
                fclose(f);
                return -1;
            }
            int n = split(line, fields);
            for (int c = 0; c < COL_COUNT; c++) {
                col[c] = -1;
                for (int i = 0; i < n; i++)
                    if (!strcmp(fields[i], col_name[c]))
                        col[c] = i;
            }
            header = 1;
            continue;
        }
        if (!line[0] || r->n_rows == MAX_ROWS)
            continue;
        row *w = &r->rows[r->n_rows++];
        int n = split(line, fields);
        copy(w->mesh, sizeof w->mesh, n > col[COL_MESH] ? fields[col[COL_MESH]] : "");
        copy(w->alg, sizeof w->alg, n > col[COL_ALG] ? fields[col[COL_ALG]] : "");
        w->threads = (int)num(fields, n, col[COL_THREADS]);
        w->target = num(fields, n, col[COL_TARGET]);
        w->in_tris = num(fields, n, col[COL_IN]);
        w->out_tris = num(fields, n, col[COL_OUT]);
        w->runs = num(fields, n, col[COL_RUNS]);
        w->t_med = num(fields, n, col[COL_TMED]);
        w->t_min = num(fields, n, col[COL_TMIN]);
        w->t_max = num(fields, n, col[COL_TMAX]);
        w->tps = num(fields, n, col[COL_TPS]);
        w->peak = num(fields, n, col[COL_PEAK]);
        w->haus = num(fields, n, col[COL_HAUS]);
        w->rms = num(fields, n, col[COL_RMS]);
        w->simil = num(fields, n, col[COL_SIMIL]);
    }
    fclose(f);
    if (!header || r->n_rows == 0) {
        fprintf(stderr, "report: %s has no rows\n", path);
        return -1;
    }
    return 0;
}

static const row *find(const report *r, const char *mesh, const char *alg, int threads,
                       double target)
{
    for (int i = 0; i < r->n_rows; i++) {
        const row *w = &r->rows[i];
        if (!strcmp(w->mesh, mesh) && !strcmp(w->alg, alg) && w->threads == threads &&
            fabs(w->target - target) < 1e-9)
            return w;
    }
    return NULL;
}

/* Distinct values, in order of first appearance. */
static int distinct_algs(const report *r, const char *mesh, const char **out, int cap)
{
    int n = 0;
    for (int i = 0; i < r->n_rows; i++) {
        if (mesh && strcmp(r->rows[i].mesh, mesh))
            continue;
        int seen = 0;
        for (int k = 0; k < n; k++)
            seen |= !strcmp(out[k], r->rows[i].alg);
        if (!seen && n < cap)
            out[n++] = r->rows[i].alg;
    }
    return n;
}

static int distinct_targets(const report *r, double *out, int cap)
{
    int n = 0;
    for (int i = 0; i < r->n_rows; i++) {
        int seen = 0;
        for (int k = 0; k < n; k++)
            seen |= fabs(out[k] - r->rows[i].target) < 1e-9;
        if (!seen && n < cap)
            out[n++] = r->rows[i].target;
    }
    return n;
}

/* The algorithms that ran at more than one thread count. */
static int is_threaded(const report *r, const char *alg)
{
    for (int i = 0; i < r->n_rows; i++)
        if (!strcmp(r->rows[i].alg, alg) && r->rows[i].threads > 1)
            return 1;
    return 0;
}

/* ---- drawing ------------------------------------------------------------------ */

#define SS 2 /* plots are drawn at SS x their size, then box-filtered */

typedef struct canvas {
    int w, h; /* drawing size (SS x the image) */
    uint8_t *px;
} canvas;

static const uint32_t palette[] = {0x1f5fbf, 0xd9480f, 0x2b8a3e, 0x862e9c,
                                   0xf59f00, 0x0b7285, 0xc2255c, 0x5c940d,
                                   0x495057, 0xf08c00};
#define PALETTE_N ((int)(sizeof palette / sizeof *palette))

static void put(canvas *c, int x, int y, uint32_t col)
{
    if (x < 0 || y < 0 || x >= c->w || y >= c->h)
        return;
    uint8_t *p = c->px + 4 * ((size_t)y * c->w + x);
    p[0] = (uint8_t)(col >> 16), p[1] = (uint8_t)(col >> 8), p[2] = (uint8_t)col, p[3] = 255;
}

static void rect(canvas *c, double x0, double y0, double x1, double y1, uint32_t col)
{
    for (int y = (int)floor(y0); y < (int)ceil(y1); y++)
        for (int x = (int)floor(x0); x < (int)ceil(x1); x++)
            put(c, x, y, col);
}

/* A thick segment: every pixel within w/2 of it. */
static void line(canvas *c, double x0, double y0, double x1, double y1, double w, uint32_t col)
{
    double r = w / 2, dx = x1 - x0, dy = y1 - y0, l2 = dx * dx + dy * dy;
    int xa = (int)floor(fmin(x0, x1) - r), xb = (int)ceil(fmax(x0, x1) + r);
    int ya = (int)floor(fmin(y0, y1) - r), yb = (int)ceil(fmax(y0, y1) + r);
    for (int y = ya; y <= yb; y++)
        for (int x = xa; x <= xb; x++) {
            double px = x + 0.5 - x0, py = y + 0.5 - y0;
            double t = l2 > 0 ? (px * dx + py * dy) / l2 : 0;
            t = t < 0 ? 0 : t > 1 ? 1 : t;
            double ex = px - t * dx, ey = py - t * dy;
            if (ex * ex + ey * ey <= r * r)
                put(c, x, y, col);
        }
}

static void dashed(canvas *c, double x0, double y0, double x1, double y1, double w, uint32_t col)
{
    double len = hypot(x1 - x0, y1 - y0), dash = 8 * SS;
    for (double s = 0; s < len; s += 2 * dash) {
        double e = fmin(s + dash, len);
        line(c, x0 + (x1 - x0) * s / len, y0 + (y1 - y0) * s / len, x0 + (x1 - x0) * e / len,
             y0 + (y1 - y0) * e / len, w, col);
    }
}

static void disc(canvas *c, double x, double y, double r, uint32_t col)
{
    line(c, x, y, x, y, 2 * r, col);
}

static void text(canvas *c, double x, double y, const char *s, int scale, uint32_t col)
{
    mr_draw_text(c->px, c->w, c->h, 0, (int)x, (int)y, s, scale, col);
}

static int text_w(const char *s, int scale)
{
    int w;
    mr_text_size(s, scale, &w, NULL);
    return w;
}

static int canvas_init(canvas *c, int w, int h)
{
    c->w = w * SS;
    c->h = h * SS;
    c->px = malloc((size_t)c->w * c->h * 4);
    if (!c->px)
        return -1;
    rect(c, 0, 0, c->w, c->h, 0xffffff);
    return 0;
}

static int canvas_save(canvas *c, const char *path)
{
    int w = c->w / SS, h = c->h / SS;
    uint8_t *out = malloc((size_t)w * h * 4);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < 4; k++) {
                int sum = 0;
                for (int sy = 0; sy < SS; sy++)
                    for (int sx = 0; sx < SS; sx++)
                        sum += c->px[4 * ((size_t)(y * SS + sy) * c->w + x * SS + sx) + k];
                out[4 * ((size_t)y * w + x) + k] = (uint8_t)((sum + SS * SS / 2) / (SS * SS));
            }
    mr_error err;
    mr_status st = mr_png_write(path, out, w, h, &err);
    free(out);
    free(c->px);
    c->px = NULL;
    if (st != MR_OK) {
        fprintf(stderr, "report: %s\n", err.message);
        return -1;
    }
    return 0;
}

/* ---- plots --------------------------------------------------------------------- */

#define MAX_SERIES 24
#define MAX_POINTS 16

typedef struct series {
    char label[96];
    double x[MAX_POINTS], y[MAX_POINTS];
    int n;
    int dashed;
} series;

typedef struct plot {
    const char *title, *xlabel, *ylabel;
    int xlog, ylog;
    series s[MAX_SERIES];
    int ns;
    int ideal;              /* draw y = x (speedup) */
    int xint;               /* x is a count: whole-number ticks */
} plot;

typedef struct axis {
    double lo, hi;
    int log;
    int integer; /* ticks at whole numbers only (thread counts) */
    double a, b; /* pixel = a + b * value (or log10 value) */
} axis;

static double ax_map(const axis *ax, double v)
{
    return ax->a + ax->b * (ax->log ? log10(v) : v);
}

static void ax_range(axis *ax, double lo, double hi, int log_scale)
{
    ax->log = log_scale;
    if (log_scale) {
        ax->lo = pow(10, floor(log10(lo) + 1e-9));
        ax->hi = pow(10, ceil(log10(hi) - 1e-9));
        if (ax->hi <= ax->lo)
            ax->hi = ax->lo * 10;
    } else {
        double span = hi - lo > 0 ? hi - lo : fabs(hi) > 0 ? fabs(hi) : 1;
        double step = pow(10, floor(log10(span / 5)));
        if (span / step > 10)
            step *= 2;
        if (span / step > 10)
            step *= 2.5;
        ax->lo = floor(lo / step) * step;
        ax->hi = ceil(hi / step) * step;
        if (ax->hi <= ax->lo)
            ax->hi = ax->lo + step;
    }
}

/* Tick values; returns their count. */
static int ax_ticks(const axis *ax, double *t, int cap)
{
    int n = 0;
    if (ax->log) {
        int decades = (int)lround(log10(ax->hi / ax->lo));
        for (double d = ax->lo; d <= ax->hi * 1.0001 && n < cap; d *= 10) {
            t[n++] = d;
            if (decades <= 2 && d * 10 <= ax->hi * 1.0001) {
                if (n < cap)
                    t[n++] = 2 * d;
                if (n < cap)
                    t[n++] = 5 * d;
            }
        }
    } else {
        double span = ax->hi - ax->lo, step = pow(10, floor(log10(span / 5)));
        if (span / step > 10)
            step *= 2;
        if (span / step > 10)
            step *= 2.5;
        if (ax->integer && step < 1)
            step = 1;
        for (double v = ax->lo; v <= ax->hi + step * 1e-6 && n < cap; v += step)
            t[n++] = fabs(v) < step * 1e-9 ? 0 : v;
    }
    return n;
}

static void fmt_tick(double v, char *buf, size_t cap)
{
    if (v != 0 && (fabs(v) >= 1e5 || fabs(v) < 1e-3))
        snprintf(buf, cap, "%.0e", v);
    else
        snprintf(buf, cap, "%g", v);
}

static int draw_plot(const plot *p, const char *path)
{
    const int W = 800, H = 500;
    canvas c;
    if (canvas_init(&c, W, H) != 0)
        return -1;
    const int ts = 3;               /* text scale on the canvas: 1.5x after filtering */
    const int tts = 2 * SS;         /* title */
    /* Plot area (canvas pixels); the legend on the right as wide as its
     * longest label needs. */
    double legend = 200 * SS;
    for (int i = 0; i < p->ns; i++)
        legend = fmax(legend, 42 * SS + text_w(p->s[i].label, SS) + 12 * SS);
    double L = 80 * SS, R = W * SS - legend, T = 50 * SS, B = (H - 60) * SS;

    double xl = INFINITY, xh = -INFINITY, yl = INFINITY, yh = -INFINITY;
    for (int i = 0; i < p->ns; i++)
        for (int k = 0; k < p->s[i].n; k++) {
            double x = p->s[i].x[k], y = p->s[i].y[k];
            if (!isfinite(x) || !isfinite(y) || (p->xlog && x <= 0) || (p->ylog && y <= 0))
                continue;
            xl = fmin(xl, x), xh = fmax(xh, x), yl = fmin(yl, y), yh = fmax(yh, y);
        }
    if (!isfinite(xl)) {
        xl = yl = 1;
        xh = yh = 2;
    }
    if (p->ideal)
        yh = fmax(yh, xh), yl = fmin(yl, 1);
    if (!p->ylog && yl > 0)
        yl = 0;
    axis ax, ay;
    memset(&ax, 0, sizeof ax);
    memset(&ay, 0, sizeof ay);
    ax.integer = p->xint;
    ax_range(&ax, xl, xh, p->xlog);
    ax_range(&ay, yl, yh, p->ylog);
    double fx0 = ax.log ? log10(ax.lo) : ax.lo, fx1 = ax.log ? log10(ax.hi) : ax.hi;
    double fy0 = ay.log ? log10(ay.lo) : ay.lo, fy1 = ay.log ? log10(ay.hi) : ay.hi;
    ax.b = (R - L) / (fx1 - fx0);
    ax.a = L - ax.b * fx0;
    ay.b = -(B - T) / (fy1 - fy0);
    ay.a = B - ay.b * fy0;

    /* Grid, ticks, labels. */
    double tk[64];
    char buf[64];
    int n = ax_ticks(&ax, tk, 64);
    for (int i = 0; i < n; i++) {
        double x = ax_map(&ax, tk[i]);
        line(&c, x, T, x, B, SS, 0xe6e6e6);
        line(&c, x, B, x, B + 5 * SS, SS, 0x404040);
        fmt_tick(tk[i], buf, sizeof buf);
        text(&c, x - text_w(buf, ts) / 2.0, B + 9 * SS, buf, ts, 0x303030);
    }
    n = ax_ticks(&ay, tk, 64);
    for (int i = 0; i < n; i++) {
        double y = ax_map(&ay, tk[i]);
        line(&c, L, y, R, y, SS, 0xe6e6e6);
        line(&c, L - 5 * SS, y, L, y, SS, 0x404040);
        fmt_tick(tk[i], buf, sizeof buf);
        text(&c, L - 9 * SS - text_w(buf, ts), y - 5 * SS, buf, ts, 0x303030);
    }
    line(&c, L, B, R, B, 1.5 * SS, 0x404040);
    line(&c, L, T, L, B, 1.5 * SS, 0x404040);
    text(&c, L, 12 * SS, p->title, tts, 0x202020);
    text(&c, L, T - 16 * SS, p->ylabel, ts, 0x303030);
    text(&c, (L + R) / 2 - text_w(p->xlabel, ts) / 2.0, B + 30 * SS, p->xlabel, ts, 0x303030);

    if (p->ideal) {
        double x0 = fmax(ax.lo, ay.lo), x1 = fmin(ax.hi, ay.hi);
        dashed(&c, ax_map(&ax, x0), ax_map(&ay, x0), ax_map(&ax, x1), ax_map(&ay, x1), 1.5 * SS,
               0x909090);
    }
    /* Series and legend. */
    for (int i = 0; i < p->ns; i++) {
        const series *s = &p->s[i];
        uint32_t col = palette[i % PALETTE_N];
        double px = 0, py = 0;
        int have = 0;
        for (int k = 0; k < s->n; k++) {
            if (!isfinite(s->y[k]) || (p->ylog && s->y[k] <= 0))
                continue;
            double x = ax_map(&ax, s->x[k]), y = ax_map(&ay, s->y[k]);
            if (have)
                (s->dashed ? dashed : line)(&c, px, py, x, y, 2.5 * SS, col);
            disc(&c, x, y, 4 * SS, col);
            px = x, py = y, have = 1;
        }
        double ly = T + i * 18 * SS;
        line(&c, R + 14 * SS, ly + 5 * SS, R + 36 * SS, ly + 5 * SS, 2.5 * SS, col);
        disc(&c, R + 25 * SS, ly + 5 * SS, 4 * SS, col);
        text(&c, R + 42 * SS, ly, s->label, SS, 0x202020);
    }
    if (p->ideal) {
        double ly = T + p->ns * 18 * SS;
        dashed(&c, R + 14 * SS, ly + 5 * SS, R + 36 * SS, ly + 5 * SS, 1.5 * SS, 0x909090);
        text(&c, R + 42 * SS, ly, "ideal", SS, 0x202020);
    }
    return canvas_save(&c, path);
}

/* Grouped bars: one group per mesh, one bar per algorithm (log scale). */
static int draw_bars(const char *title, const char *ylabel, const char **groups, int ng,
                     const char **labels, int nl, const double *v /* ng x nl */,
                     const char *path)
{
    const int W = 800, H = 500;
    canvas c;
    if (canvas_init(&c, W, H) != 0)
        return -1;
    const int ts = 3, tts = 4;
    double L = 80 * SS, R = (W - 200) * SS, T = 50 * SS, B = (H - 60) * SS;
    double lo = INFINITY, hi = -INFINITY;
    for (int i = 0; i < ng * nl; i++)
        if (isfinite(v[i]) && v[i] > 0)
            lo = fmin(lo, v[i]), hi = fmax(hi, v[i]);
    if (!isfinite(lo))
        lo = 1, hi = 10;
    axis ay;
    memset(&ay, 0, sizeof ay);
    ax_range(&ay, lo, hi, 1);
    double f0 = log10(ay.lo), f1 = log10(ay.hi);
    ay.b = -(B - T) / (f1 - f0);
    ay.a = B - ay.b * f0;
    double tk[64];
    char buf[64];
    int n = ax_ticks(&ay, tk, 64);
    for (int i = 0; i < n; i++) {
        double y = ax_map(&ay, tk[i]);
        line(&c, L, y, R, y, SS, 0xe6e6e6);
        fmt_tick(tk[i], buf, sizeof buf);
        text(&c, L - 9 * SS - text_w(buf, ts), y - 5 * SS, buf, ts, 0x303030);
    }
    double gw = (R - L) / ng, bw = gw * 0.8 / nl;
    for (int g = 0; g < ng; g++) {
        for (int k = 0; k < nl; k++) {
            double val = v[g * nl + k];
            if (!isfinite(val) || val <= 0)
                continue;
            double x = L + g * gw + gw * 0.1 + k * bw;
            rect(&c, x + SS, ax_map(&ay, val), x + bw - SS, B, palette[k % PALETTE_N]);
        }
        text(&c, L + g * gw + gw / 2 - text_w(groups[g], ts) / 2.0, B + 9 * SS, groups[g], ts,
             0x303030);
    }
    line(&c, L, B, R, B, 1.5 * SS, 0x404040);
    line(&c, L, T, L, B, 1.5 * SS, 0x404040);
    text(&c, L, 12 * SS, title, tts, 0x202020);
    text(&c, L, T - 16 * SS, ylabel, ts, 0x303030);
    for (int k = 0; k < nl; k++) {
        double ly = T + k * 18 * SS;
        rect(&c, R + 14 * SS, ly, R + 34 * SS, ly + 10 * SS, palette[k % PALETTE_N]);
        text(&c, R + 42 * SS, ly, labels[k], SS, 0x202020);
    }
    return canvas_save(&c, path);
}

/* ---- comparison sheets ------------------------------------------------------------ */

static int load_source(const char *source, mr_mesh *m)
{
    mr_error err;
    mr_mesh_init(m);
    size_t tris;
    unsigned long long seed;
    if (sscanf(source, "generate:scan:%zu:%llu", &tris, &seed) == 2) {
        if (mr_generate(MR_GEN_SCAN, tris, seed, m, &err) != MR_OK)
            goto fail;
    } else if (!strncmp(source, "file:", 5)) {
        if (mr_mesh_read(source + 5, NULL, m, &err) != MR_OK)
            goto fail;
    } else {
        fprintf(stderr, "report: unknown mesh source '%s'\n", source);
        return -1;
    }
    if (mr_mesh_remove_degenerate(m, 0, NULL, &err) != MR_OK ||
        mr_mesh_remove_unreferenced(m, NULL, &err) != MR_OK)
        goto fail;
    return 0;
fail:
    fprintf(stderr, "report: %s\n", err.message);
    mr_mesh_free(m);
    return -1;
}

static int write_sheet(const report *r, int mi, const double *targets, int nt, int panel,
                       const char *path)
{
    mr_mesh in;
    if (load_source(r->mesh_source[mi], &in) != 0)
        return -1;
    const char *name = r->mesh_name[mi];
    mr_error err;
    mr_stats st;
    if (mr_stats_compute(in.positions, 0, in.vertex_count, in.indices, in.triangle_count, &st,
                         &err) != MR_OK) {
        mr_mesh_free(&in);
        return -1;
    }
    mr_simplified out[8];
    float *heat[8] = {0};
    char caption[9][160], cnt[32];
    mr_sheet_panel panels[9];
    double top = 0;
    int np = 0, rc = 0;
    snprintf(caption[0], sizeof caption[0], "%s (original)\n%.0f triangles", name,
             (double)in.triangle_count);
    panels[np++] = (mr_sheet_panel){in.positions, in.vertex_count, in.indices,
                                    in.triangle_count, caption[0], NULL, NULL};
    /* Reductions from the largest target to the smallest. */
    for (int k = 0; k < nt && k < 8; k++) {
        mr_simplify_options o;
        mr_simplify_options_default(&o);
        o.target_ratio = targets[k];
        if (mr_simplify(in.positions, 0, in.vertex_count, in.indices, in.triangle_count, &o,
                        &out[k], &err) != MR_OK) {
            fprintf(stderr, "report: %s\n", err.message);
            rc = -1;
            nt = k;
            break;
        }
        heat[k] = malloc(sizeof(float) * (out[k].triangle_count + 1));
        double mx = 0;
        if (mr_surface_distances(in.positions, in.vertex_count, in.indices, in.triangle_count,
                                 out[k].positions, out[k].vertex_count, out[k].indices,
                                 out[k].triangle_count, 0, heat[k], &mx, &err) != MR_OK) {
            fprintf(stderr, "report: %s\n", err.message);
            rc = -1;
            nt = k + 1;
            break;
        }
        top = fmax(top, mx);
        const row *w = find(r, name, "meshreduce-full", 1, targets[k]);
        snprintf(cnt, sizeof cnt, "%zu", out[k].triangle_count);
        if (w && isfinite(w->haus))
            snprintf(caption[k + 1], sizeof caption[k + 1],
                     "%g%% of the vertices\n%s triangles\nHausdorff %.3f%% RMS %.4f%%",
                     100 * targets[k], cnt, 100 * w->haus, 100 * w->rms);
        else
            snprintf(caption[k + 1], sizeof caption[k + 1], "%g%% of the vertices\n%s triangles",
                     100 * targets[k], cnt);
        panels[np++] = (mr_sheet_panel){out[k].positions, out[k].vertex_count, out[k].indices,
                                        out[k].triangle_count, caption[k + 1], heat[k], NULL};
    }
    if (rc == 0) {
        mr_sheet_options so;
        mr_sheet_options_default(&so);
        so.render.width = so.render.height = panel;
        so.text_scale = 1;
        double diag = st.bbox_diagonal > 0 ? st.bbox_diagonal : 1;
        so.scalar_max = top > 0 ? top : 1e-6 * diag;
        char hi[32];
        snprintf(hi, sizeof hi, "%.3g%%", 100 * so.scalar_max / diag);
        so.colorbar_label = "distance to the original (% of its bbox diagonal), "
                            "meshreduce-full (default options)";
        so.colorbar_min_label = "0";
        so.colorbar_max_label = hi;
        uint8_t *img;
        int w, h;
        if (mr_render_sheet(panels, (size_t)np, &so, &img, &w, &h, &err) != MR_OK ||
            mr_png_write(path, img, w, h, &err) != MR_OK) {
            fprintf(stderr, "report: %s\n", err.message);
            rc = -1;
        } else {
            free(img);
        }
    }
    for (int k = 0; k < nt; k++) {
        mr_simplified_free(&out[k]);
        free(heat[k]);
    }
    mr_mesh_free(&in);
    return rc;
}

/* ---- the report ------------------------------------------------------------------- */

static void fmt(char *buf, size_t cap, double v, const char *f, double scale)
{
    if (isfinite(v))
        snprintf(buf, cap, f, v * scale);
    else
        snprintf(buf, cap, "-");
}

int main(int argc, char **argv)
{
    const char *csv = "bench/report/sweep.csv", *out = "bench";
    int panel = 380;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc)
            out = argv[++i];
        else if (!strcmp(argv[i], "--panel") && i + 1 < argc)
            panel = atoi(argv[++i]);
        else if (argv[i][0] != '-')
            csv = argv[i];
        else {
            fprintf(stderr, "usage: report [CSV] [--out DIR] [--panel PX]\n");
            return 2;
        }
    }
    static report r;
    if (read_csv(csv, &r) != 0)
        return 1;
    char dir[4200], cmd[8500], path[4400];
    snprintf(dir, sizeof dir, "%s/report", out);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", dir);
    if (system(cmd) != 0) {
        fprintf(stderr, "report: cannot create %s\n", dir);
        return 1;
    }
    double targets[8] = {0};
    int nt = distinct_targets(&r, targets, 8);
    if (nt == 0) {
        fprintf(stderr, "report: %s has no targets\n", csv);
        return 1;
    }
    /* Largest target first. */
    for (int i = 0; i < nt; i++)
        for (int j = i + 1; j < nt; j++)
            if (targets[j] > targets[i]) {
                double t = targets[i];
                targets[i] = targets[j];
                targets[j] = t;
            }
    /* The target the thread plots use: the one nearest 10 %. */
    double mid = targets[0];
    for (int i = 1; i < nt; i++)
        if (fabs(log(targets[i] / 0.1)) < fabs(log(mid / 0.1)))
            mid = targets[i];
    const char *algs[32];
    int na = distinct_algs(&r, NULL, algs, 32);
    int rc = 0;

    /* Time and speedup vs threads: every threaded algorithm on every mesh. */
    static plot pt, ps;
    char title_t[128], title_s[128];
    snprintf(title_t, sizeof title_t, "Time vs threads (to %g%% of the vertices)", 100 * mid);
    snprintf(title_s, sizeof title_s, "Speedup vs threads (to %g%% of the vertices)", 100 * mid);
    memset(&pt, 0, sizeof pt);
    memset(&ps, 0, sizeof ps);
    pt.title = title_t, pt.xlabel = "threads", pt.ylabel = "seconds (median)", pt.ylog = 1;
    ps.title = title_s, ps.xlabel = "threads", ps.ylabel = "speedup over 1 thread";
    ps.ideal = 1;
    pt.xint = ps.xint = 1;
    for (int m = 0; m < r.n_meshes; m++)
        for (int a = 0; a < na; a++) {
            if (!is_threaded(&r, algs[a]) || pt.ns == MAX_SERIES)
                continue;
            series *st = &pt.s[pt.ns], *ss = &ps.s[ps.ns];
            snprintf(st->label, sizeof st->label, "%s %s", r.mesh_name[m], algs[a]);
            snprintf(ss->label, sizeof ss->label, "%s %s", r.mesh_name[m], algs[a]);
            const row *one = find(&r, r.mesh_name[m], algs[a], 1, mid);
            for (int t = 1; t <= 256 && st->n < MAX_POINTS; t++) {
                const row *w = find(&r, r.mesh_name[m], algs[a], t, mid);
                if (!w)
                    continue;
                st->x[st->n] = t;
                st->y[st->n++] = w->t_med;
                ss->x[ss->n] = t;
                ss->y[ss->n++] = one ? one->t_med / w->t_med : NAN;
            }
            if (st->n) {
                pt.ns++;
                ps.ns++;
            }
        }
    snprintf(path, sizeof path, "%s/time-threads.png", dir);
    rc |= draw_plot(&pt, path);
    snprintf(path, sizeof path, "%s/speedup-threads.png", dir);
    rc |= draw_plot(&ps, path);

    /* Error vs reduction, per mesh: every algorithm at 1 thread. */
    for (int m = 0; m < r.n_meshes; m++) {
        static plot pe;
        char title[128];
        snprintf(title, sizeof title, "%s: error vs reduction (1 thread)", r.mesh_name[m]);
        memset(&pe, 0, sizeof pe);
        pe.title = title;
        pe.xlabel = "vertices kept (fraction of the input)";
        pe.ylabel = "Hausdorff distance, % of the bbox diagonal";
        pe.xlog = pe.ylog = 1;
        const char *ma[32];
        int nma = distinct_algs(&r, r.mesh_name[m], ma, 32);
        for (int a = 0; a < nma && pe.ns < MAX_SERIES; a++) {
            series *s = &pe.s[pe.ns];
            snprintf(s->label, sizeof s->label, "%s", ma[a]);
            for (int k = nt - 1; k >= 0; k--) {
                const row *w = find(&r, r.mesh_name[m], ma[a], 1, targets[k]);
                if (w && isfinite(w->haus)) {
                    s->x[s->n] = targets[k];
                    s->y[s->n++] = 100 * w->haus;
                }
            }
            if (s->n)
                pe.ns++;
        }
        snprintf(path, sizeof path, "%s/error-%s.png", dir, r.mesh_name[m]);
        rc |= draw_plot(&pe, path);
    }

    /* Ours vs peers: time at the middle target, 1 thread. */
    {
        const char *groups[MAX_MESHES];
        double *v = malloc(sizeof(double) * (size_t)(r.n_meshes * na + 1));
        for (int m = 0; m < r.n_meshes; m++) {
            groups[m] = r.mesh_name[m];
            for (int a = 0; a < na; a++) {
                const row *w = find(&r, r.mesh_name[m], algs[a], 1, mid);
                v[m * na + a] = w ? w->t_med : NAN;
            }
        }
        char title[128];
        snprintf(title, sizeof title, "Ours vs peers: time to %g%% (1 thread)", 100 * mid);
        snprintf(path, sizeof path, "%s/peers.png", dir);
        rc |= draw_bars(title, "seconds (median, log scale)", groups, r.n_meshes, algs, na, v,
                        path);
        free(v);
    }

    /* A comparison sheet per mesh. */
    for (int m = 0; m < r.n_meshes; m++) {
        snprintf(path, sizeof path, "%s/sheet-%s.png", dir, r.mesh_name[m]);
        printf("report: sheet %s\n", path);
        fflush(stdout);
        rc |= write_sheet(&r, m, targets, nt, panel, path);
    }

    /* REPORT.md, written beside its destination and renamed. */
    char md[4400], tmp[4500];
    snprintf(md, sizeof md, "%s/REPORT.md", out);
    snprintf(tmp, sizeof tmp, "%s.partial", md);
    FILE *f = fopen(tmp, "w");
    if (!f) {
        fprintf(stderr, "report: cannot write %s\n", tmp);
        return 1;
    }
    fprintf(f, "# meshreduce benchmark report\n\n");
    fprintf(f, "Machine: %s  \nDate of the sweep: %s  \nSettings: %s\n\n",
            r.machine[0] ? r.machine : "unknown", r.date[0] ? r.date : "unknown",
            r.settings[0] ? r.settings : "-");
    fprintf(f, "Regenerate everything (sweep, plots, sheets, this file) with `make report`; "
               "the sweep alone is `build/bench/sweep` (see bench/sweep.c for the method), "
               "this report `build/bench/report`. Times are medians of the runs; Hausdorff "
               "and RMS are symmetric surface distances (mr_compare) as %% of the input's "
               "bounding-box diagonal; vertex similarity is the share of output vertices "
               "that the sequential greedy reference of the same collapse kind also has.\n\n");
    fprintf(f, "Meshes:");
    for (int m = 0; m < r.n_meshes; m++) {
        /* a shared mesh by its file name: the path is this machine's */
        const char *src = r.mesh_source[m];
        const char *slash = strrchr(src, '/');
        if (strncmp(src, "file:", 5) == 0 && slash)
            fprintf(f, "%s `%s` (../shared/data/%s)", m ? "," : "", r.mesh_name[m], slash + 1);
        else
            fprintf(f, "%s `%s` (%s)", m ? "," : "", r.mesh_name[m], src);
    }
    fprintf(f, ".\n\n## Threads\n\n![time vs threads](report/time-threads.png)\n\n"
               "![speedup vs threads](report/speedup-threads.png)\n\n"
               "## Ours vs peers\n\n![ours vs peers](report/peers.png)\n\n"
               "## Quality\n\n");
    for (int m = 0; m < r.n_meshes; m++)
        fprintf(f, "![error vs reduction, %s](report/error-%s.png)\n\n", r.mesh_name[m],
                r.mesh_name[m]);
    fprintf(f, "## Comparison sheets\n\nEach reduction (meshreduce-full, default options) "
               "coloured by the distance of its faces to the original surface "
               "(largest over the corners and four inner points of each face).\n\n");
    for (int m = 0; m < r.n_meshes; m++)
        fprintf(f, "![%s](report/sheet-%s.png)\n\n", r.mesh_name[m], r.mesh_name[m]);
    fprintf(f, "## All rows\n\n| mesh | target | algorithm | threads | output triangles | "
               "median s | min s | max s | M triangles/s | peak B/triangle | Hausdorff %% | "
               "RMS %% | similarity |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (int i = 0; i < r.n_rows; i++) {
        const row *w = &r.rows[i];
        char a[8][32];
        fmt(a[0], 32, w->t_med, "%.4f", 1);
        fmt(a[1], 32, w->t_min, "%.4f", 1);
        fmt(a[2], 32, w->t_max, "%.4f", 1);
        fmt(a[3], 32, w->tps, "%.2f", 1e-6);
        fmt(a[4], 32, w->peak, "%.0f", 1);
        fmt(a[5], 32, w->haus, "%.4f", 100);
        fmt(a[6], 32, w->rms, "%.5f", 100);
        fmt(a[7], 32, w->simil, "%.3f", 1);
        fprintf(f, "| %s | %g%% | %s | %d | %.0f | %s | %s | %s | %s | %s | %s | %s | %s |\n",
                w->mesh, 100 * w->target, w->alg, w->threads, w->out_tris, a[0], a[1], a[2],
                a[3], a[4], a[5], a[6], a[7]);
    }
    if (fclose(f) != 0 || rename(tmp, md) != 0) {
        fprintf(stderr, "report: cannot write %s\n", md);
        return 1;
    }
    printf("report: %s, plots and sheets in %s\n", md, dir);
    return rc ? 1 : 0;
}
