/* meshreduce demo: the main job on the embedded default mesh, with timings. */
#include "cli.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char usage[] =
    "usage: meshreduce demo [--triangles N] [--dir DIR] [-q]\n"
    "\n"
    "Generate the default scan-like mesh (about 1M triangles), write it as\n"
    "binary PLY and OBJ, read both back, check them, clean the mesh, print its\n"
    "statistics, simplify it to 10% of its vertices and measure the surface\n"
    "distance of the result, with the time of every step; last, a before/after\n"
    "comparison sheet (compare.png, the reduction coloured by its distance to\n"
    "the original).\n"
    "\n"
    "  --triangles N   size of the generated mesh (default 1M)\n"
    "  --dir DIR       where the files go (default out/demo)\n"
    "  -q, --quiet     no report of the steps (the files are still written;\n"
    "                  errors still print)\n";

/* -q: the steps are done but not reported. */
static bool quiet;

/* mkdir -p */
static int make_dirs(const char *path)
{
    char buf[4096];
    size_t n = strlen(path);
    if (n >= sizeof buf)
        return -1;
    memcpy(buf, path, n + 1);
    for (size_t i = 1; i <= n; i++) {
        if (buf[i] != '/' && buf[i] != '\0')
            continue;
        char c = buf[i];
        buf[i] = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
            return -1;
        buf[i] = c;
    }
    return 0;
}

static void step(const char *what, double seconds, const char *detail)
{
    if (!quiet)
        printf("  %-28s %8.3f s   %s\n", what, seconds, detail);
}

/* Write `m` to path and read it back, timing both; the copy must match. */
static int round_trip(const mr_mesh *m, const char *path, const char *label)
{
    mr_error err;
    char detail[128], size[32], what[64];
    double t0 = cli_now();
    if (mr_mesh_write(path, m, NULL, &err) != MR_OK)
        return cli_fail_err(&err);
    double t1 = cli_now();
    unsigned long long bytes = cli_file_size(path);
    snprintf(detail, sizeof detail, "%s, %.0f MB/s", cli_bytes(size, sizeof size, bytes),
             (double)bytes / 1e6 / (t1 - t0));
    snprintf(what, sizeof what, "write %s", label);
    step(what, t1 - t0, detail);

    mr_mesh back;
    t0 = cli_now();
    if (mr_mesh_read(path, NULL, &back, &err) != MR_OK)
        return cli_fail_err(&err);
    t1 = cli_now();
    bool same = back.vertex_count == m->vertex_count &&
                back.triangle_count == m->triangle_count &&
                !memcmp(back.positions, m->positions, m->vertex_count * 3 * sizeof(float)) &&
                !memcmp(back.indices, m->indices, m->triangle_count * 3 * sizeof(uint32_t));
    mr_mesh_free(&back);
    snprintf(detail, sizeof detail, "%.0f MB/s, %s", (double)bytes / 1e6 / (t1 - t0),
             same ? "identical to what was written" : "DIFFERS from what was written");
    snprintf(what, sizeof what, "read %s", label);
    step(what, t1 - t0, detail);
    return same ? CLI_OK : cli_fail("%s: did not read back as written", path);
}

/* The main job: simplify to 10 % of the vertices, then measure how far the
 * result lies from the original surface. Errors name `src`, the file the
 * mesh was written to, or the reduction's own. */
static int simplify_and_compare(const mr_mesh *mesh, const char *src, const char *dir)
{
    mr_error err;
    char detail[160], a[32], b[32];
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 0.10;
    mr_mesh low;
    mr_simplify_stats s;
    double t0 = cli_now();
    if (mr_mesh_simplify(mesh, &o, &low, NULL, &s, &err) != MR_OK)
        return cli_fail_in(src, "simplify", &err);
    double t1 = cli_now();
    snprintf(detail, sizeof detail, "%s vertices, %s triangles, %.2f M input triangles/s",
             cli_count(a, sizeof a, low.vertex_count), cli_count(b, sizeof b, low.triangle_count),
             (double)mesh->triangle_count / 1e6 / (t1 - t0));
    step("simplify to 10% (QEM)", t1 - t0, detail);

    char path[4096];
    snprintf(path, sizeof path, "%s/scan-10pct.ply", dir);
    mr_status st = mr_mesh_write(path, &low, NULL, &err);
    if (st != MR_OK) {
        mr_mesh_free(&low);
        return cli_fail_err(&err);
    }
    mr_compare_options co;
    mr_compare_options_default(&co);
    co.samples = 200000;
    mr_compare_result r;
    t0 = cli_now();
    st = mr_compare(mesh->positions, mesh->vertex_count, mesh->indices, mesh->triangle_count,
                    low.positions, low.vertex_count, low.indices, low.triangle_count, &co, &r,
                    &err);
    t1 = cli_now();
    mr_mesh_free(&low);
    if (st != MR_OK)
        return cli_fail("%s, %s: %s", src, path, err.message);
    snprintf(detail, sizeof detail, "hausdorff %.4f %%, rms %.4f %% of the bbox diagonal",
             100.0 * r.hausdorff_rel, 100.0 * r.rms_rel);
    step("surface distance", t1 - t0, detail);
    return CLI_OK;
}

/* Before/after: the mesh and its reduction side by side from one camera,
 * the reduction coloured by its distance to the original surface. */
static int write_sheet(const mr_mesh *mesh, const char *dir, char *out, size_t out_size)
{
    mr_error err;
    char low_path[4096], caption[2][160], a[32], detail[160];
    snprintf(low_path, sizeof low_path, "%s/scan-10pct.ply", dir);
    snprintf(out, out_size, "%s/compare.png", dir);
    double t0 = cli_now();
    mr_mesh low;
    if (mr_mesh_read(low_path, NULL, &low, &err) != MR_OK)
        return cli_fail_err(&err);
    float *heat = malloc(sizeof(float) * (low.triangle_count ? low.triangle_count : 1));
    double heat_max = 0;
    mr_stats s;
    mr_status st = heat ? MR_OK : MR_ERR_NO_MEMORY;
    if (!heat)
        snprintf(err.message, sizeof err.message, "out of memory");
    if (st == MR_OK)
        st = mr_surface_distances(mesh->positions, mesh->vertex_count, mesh->indices,
                                  mesh->triangle_count, low.positions, low.vertex_count,
                                  low.indices, low.triangle_count, 0, heat, &heat_max, &err);
    if (st == MR_OK)
        st = mr_stats_compute(mesh->positions, 0, mesh->vertex_count, mesh->indices,
                              mesh->triangle_count, &s, &err);
    uint8_t *img = NULL;
    int w = 0, h = 0;
    if (st == MR_OK) {
        double diag = s.bbox_diagonal > 0 ? s.bbox_diagonal : 1;
        snprintf(caption[0], sizeof caption[0], "original\n%s triangles",
                 cli_count(a, sizeof a, mesh->triangle_count));
        snprintf(caption[1], sizeof caption[1], "10%% of the vertices (QEM)\n%s triangles",
                 cli_count(a, sizeof a, low.triangle_count));
        mr_sheet_panel panels[2] = {
            {.positions = mesh->positions, .vertex_count = mesh->vertex_count,
             .indices = mesh->indices, .triangle_count = mesh->triangle_count,
             .caption = caption[0]},
            {.positions = low.positions, .vertex_count = low.vertex_count,
             .indices = low.indices, .triangle_count = low.triangle_count,
             .caption = caption[1], .face_scalar = heat}};
        mr_sheet_options so;
        mr_sheet_options_default(&so);
        so.scalar_max = heat_max > 0 ? heat_max : 1e-6 * diag;
        char hi[32];
        snprintf(hi, sizeof hi, "%.3g%%", 100 * so.scalar_max / diag);
        so.colorbar_label = "distance to the original (% of its bbox diagonal)";
        so.colorbar_min_label = "0";
        so.colorbar_max_label = hi;
        st = mr_render_sheet(panels, 2, &so, &img, &w, &h, &err);
    }
    int rc = st == MR_OK ? CLI_OK : cli_fail_in(out, NULL, &err);
    bool no_png = false;
    if (st == MR_OK && mr_png_write(out, img, w, h, &err) != MR_OK) {
        /* A build without libpng: the demo's other steps stand. */
        no_png = err.status == MR_ERR_UNSUPPORTED;
        if (!no_png)
            rc = cli_fail_err(&err);
    }
    free(img);
    free(heat);
    mr_mesh_free(&low);
    if (rc != CLI_OK)
        return rc;
    if (no_png) {
        snprintf(detail, sizeof detail, "rendered, not written: PNG output was not built");
        out[0] = '\0'; /* no file to name */
    }
    else
        snprintf(detail, sizeof detail, "%dx%d, heat map of the distance to the original", w, h);
    step("comparison sheet", cli_now() - t0, detail);
    return CLI_OK;
}

static int run(int argc, char **argv)
{
    uint64_t triangles = 1000000;
    const char *dir = "out/demo";
    for (int i = 1; i < argc;) {
        const char *v;
        if (cli_value(argc, argv, &i, "--triangles", &v)) {
            if (!cli_parse_count(v, &triangles) || triangles == 0)
                return cli_usage_error("demo", "--triangles needs a positive count");
        } else if (cli_value(argc, argv, &i, "--dir", &v)) {
            if (!v)
                return cli_usage_error("demo", "--dir needs a directory");
            dir = v;
        } else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet")) {
            quiet = true;
        } else
            return cli_usage_error("demo", "unknown argument '%s'", argv[i]);
    }
    if (make_dirs(dir) != 0)
        return cli_fail("%s: cannot create directory: %s", dir, strerror(errno));

    char a[32], b[32], detail[128];
    mr_error err;
    mr_mesh mesh;
    double total0 = cli_now();
    if (!quiet)
        printf("meshreduce %s demo: the default scan-like mesh\n", mr_version());

    char ply[4096], obj[4096];
    snprintf(ply, sizeof ply, "%s/scan.ply", dir);
    snprintf(obj, sizeof obj, "%s/scan.obj", dir);
    double t0 = cli_now();
    if (mr_generate(MR_GEN_SCAN, (size_t)triangles, 1, &mesh, &err) != MR_OK)
        return cli_fail_in(ply, NULL, &err); /* the file it was to be */
    double t1 = cli_now();
    snprintf(detail, sizeof detail, "%s vertices, %s triangles",
             cli_count(a, sizeof a, mesh.vertex_count),
             cli_count(b, sizeof b, mesh.triangle_count));
    step("generate scan", t1 - t0, detail);

    int rc = round_trip(&mesh, ply, "binary PLY");
    if (rc == CLI_OK)
        rc = round_trip(&mesh, obj, "OBJ");
    if (rc != CLI_OK) {
        mr_mesh_free(&mesh);
        return rc;
    }

    size_t welded = 0, degenerate = 0, unreferenced = 0;
    t0 = cli_now();
    if (mr_mesh_weld_exact(&mesh, 0, &welded, &err) != MR_OK ||
        mr_mesh_remove_degenerate(&mesh, 1, &degenerate, &err) != MR_OK ||
        mr_mesh_remove_unreferenced(&mesh, &unreferenced, &err) != MR_OK) {
        mr_mesh_free(&mesh);
        return cli_fail_in(ply, NULL, &err);
    }
    t1 = cli_now();
    snprintf(detail, sizeof detail, "%zu welded, %zu bad triangles, %zu unused vertices",
             welded, degenerate, unreferenced);
    step("clean", t1 - t0, detail);

    mr_stats s;
    t0 = cli_now();
    if (mr_stats_compute(mesh.positions, 0, mesh.vertex_count, mesh.indices,
                         mesh.triangle_count, &s, &err) != MR_OK) {
        mr_mesh_free(&mesh);
        return cli_fail_in(ply, NULL, &err);
    }
    t1 = cli_now();
    snprintf(detail, sizeof detail, "%s, %s, %zu component%s, euler %lld",
             s.closed ? "closed" : "open", s.manifold ? "manifold" : "non-manifold",
             s.components, s.components == 1 ? "" : "s", s.euler_characteristic);
    step("statistics", t1 - t0, detail);

    rc = simplify_and_compare(&mesh, ply, dir);
    char sheet[4200];
    if (rc == CLI_OK)
        rc = write_sheet(&mesh, dir, sheet, sizeof sheet);
    mr_mesh_free(&mesh);
    if (rc != CLI_OK || quiet)
        return rc;
    printf("  %-28s %8.3f s\n", "total", cli_now() - total0);
    printf("files: %s %s %s/scan-10pct.ply\n", ply, obj, dir);
    if (sheet[0])
        printf("comparison sheet: %s\n", sheet);
    return CLI_OK;
}

const cli_command cli_cmd_demo = {"demo", "the main job on the default generated mesh", run,
                                  usage};
