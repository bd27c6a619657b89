/*
 * The benchmark report: reads the sweep's CSV (bench/sweep.c) and writes a
 * comparison sheet per mesh rendered by the library (the original and its
 * reductions coloured by their distance to it) and a Markdown report that
 * embeds them and the plots, which bench/plots.py draws from the same CSV
 * with matplotlib (make report runs both).
 *
 *   report [CSV] [--out DIR] [--panel PX]
 *
 * CSV defaults to bench/report/sweep.csv; DIR (default bench) receives
 * REPORT.md and the sheets in DIR/report/.
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
    panels[np++] = (mr_sheet_panel){.positions = in.positions, .vertex_count = in.vertex_count,
                                    .indices = in.indices, .triangle_count = in.triangle_count,
                                    .caption = caption[0]};
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
        panels[np++] = (mr_sheet_panel){.positions = out[k].positions,
                                        .vertex_count = out[k].vertex_count,
                                        .indices = out[k].indices,
                                        .triangle_count = out[k].triangle_count,
                                        .caption = caption[k + 1], .face_scalar = heat[k]};
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
    int rc = 0;

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
               "the plots `bench/plots.py` (matplotlib), the sheets and this file "
               "`build/bench/report`. Times are medians of the runs; Hausdorff "
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
