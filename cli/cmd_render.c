/* meshreduce render IN... -o OUT.png: pictures of meshes, comparison sheets, heat maps. */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "usage: meshreduce render IN... -o OUT.png [--view iso|front|side|top]\n"
    "                         [--yaw DEG] [--pitch DEG] [--size WxH] [--wire]\n"
    "                         [--supersample K] [--point-size PX] [--error-to REF]\n"
    "                         [--error-max PCT] [--samples N] [--columns N]\n"
    "                         [--title TEXT] [--plain] [--json] [-q]\n"
    "\n"
    "Render meshes with a software rasterizer: z-buffered, flat-shaded triangles\n"
    "lit from the camera, an orthographic camera framed on the bounding box,\n"
    "supersampled anti-aliasing; point clouds as shaded splats. The PNG is the\n"
    "same, byte for byte, at any thread count.\n"
    "\n"
    "A surface is drawn as its file shows it: a glTF's materials (base colour and\n"
    "base-colour texture), an OBJ's usemtl materials from its mtllib files (Kd and\n"
    "map_Kd), and vertex colours of any format; textures are PNG or JPEG, sampled\n"
    "bilinearly at the texture coordinates. A mesh without them is light\n"
    "grey-blue. A heat map (--error-to) colours by distance instead.\n"
    "\n"
    "One input gives one picture. Several inputs give a comparison sheet: one\n"
    "panel per input, all from the same camera, each captioned with its file,\n"
    "its size and its distance to the reference (REF, or else the first input:\n"
    "symmetric Hausdorff and RMS distance, % of the reference's bounding-box\n"
    "diagonal).\n"
    "\n"
    "  -o OUT.png        the image (written completely or not at all)\n"
    "  --view V          iso (default), front (along -z), side (along -x),\n"
    "                    top (along -y)\n"
    "  --yaw, --pitch    degrees: turn about +y from the front view, then look\n"
    "                    down (either or both, 0 for one not given; not with\n"
    "                    --view)\n"
    "  --size WxH        image size (default 1024x768), or panel size of a sheet\n"
    "                    (default 400x400)\n"
    "  --wire            draw the triangle edges\n"
    "  --supersample K   K x K samples per pixel (default 3, 1 = none, up to 8)\n"
    "  --point-size PX   splat radius for point clouds (default: from density)\n"
    "  --error-to REF    colour each input by its distance to the surface of REF\n"
    "                    (heat map, per face: the largest distance over its\n"
    "                    corners and four inner points), with a colour bar; the\n"
    "                    output is a sheet even for one input\n"
    "  --error-max PCT   top of the colour scale in % of REF's diagonal\n"
    "                    (default: the largest distance found; needs --error-to)\n"
    "  --samples N       surface samples for the caption's distances (default 100k)\n"
    "  --columns N       panels per row of a sheet (default: all in one row)\n"
    "  --title TEXT      a title line above a sheet's panels\n"
    "  --plain           one colour for every surface: no materials, textures or\n"
    "                    vertex colours (nor their files read)\n"
    "  --json            print what was written as one JSON object\n"
    "  -q, --quiet       no summary line on success (errors and --json still\n"
    "                    print)\n";

#define MAX_INPUTS 64

typedef struct render_args {
    const char *inputs[MAX_INPUTS];
    int n_inputs;
    const char *out, *error_to, *title;
    mr_render_options ro;
    int size_given, columns;
    double error_max_pct;
    uint64_t samples;
    bool json, quiet, plain;
} render_args;

static int parse_size(const char *v, int *w, int *h)
{
    char *end;
    long a = strtol(v, &end, 10);
    if (end == v || (*end != 'x' && *end != 'X'))
        return -1;
    const char *s = end + 1;
    long b = strtol(s, &end, 10);
    if (end == s || *end != '\0' || a < 1 || b < 1 || a > 16384 || b > 16384)
        return -1;
    *w = (int)a;
    *h = (int)b;
    return 0;
}

static bool ends_with_png(const char *path)
{
    size_t n = strlen(path);
    return n > 4 && (!strcmp(path + n - 4, ".png") || !strcmp(path + n - 4, ".PNG"));
}

/* Returns -1 when the arguments are fine, else the exit status. */
static int parse(int argc, char **argv, render_args *a)
{
    /* The camera is one choice: a named view, or the angles. */
    static const char camera[] = "one camera: --view, or --yaw and --pitch";
    cli_choice view = {NULL}, yaw = {NULL}, pitch = {NULL};
    int rc;
    for (int i = 1; i < argc;) {
        const char *v = NULL;
        double d;
        long long n;
        if (cli_flag(argc, argv, &i, "--wire")) {
            a->ro.wire = 1;
        } else if (cli_flag(argc, argv, &i, "--plain")) {
            a->plain = true;
        } else if (cli_flag(argc, argv, &i, "--json")) {
            a->json = true;
        } else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet")) {
            a->quiet = true;
        } else if (cli_value(argc, argv, &i, "-o", &v) || cli_value(argc, argv, &i, "--output", &v)) {
            if (!v)
                return cli_usage_error("render", "-o needs a PNG path");
            if (a->out)
                return cli_usage_error("render", "-o is given twice ('%s' and '%s'): one "
                                                 "image at a time", a->out, v);
            a->out = v;
        } else if (cli_value(argc, argv, &i, "--view", &v)) {
            if (!v || mr_view_from_name(v, &a->ro.view) != 0)
                return cli_usage_error("render", "--view is iso, front, side or top");
            if ((rc = cli_choose(&view, "render", "--view", camera)) != CLI_OK)
                return rc;
            if (yaw.given || pitch.given)
                return cli_choose(yaw.given ? &yaw : &pitch, "render", "--view", camera);
        } else if (cli_value(argc, argv, &i, "--yaw", &v)) {
            if (!v || !cli_parse_double(v, &a->ro.yaw))
                return cli_usage_error("render", "--yaw needs an angle in degrees");
            if ((rc = cli_choose(view.given ? &view : &yaw, "render", "--yaw", camera)) !=
                CLI_OK)
                return rc;
        } else if (cli_value(argc, argv, &i, "--pitch", &v)) {
            if (!v || !cli_parse_double(v, &a->ro.pitch))
                return cli_usage_error("render", "--pitch needs an angle in degrees");
            if ((rc = cli_choose(view.given ? &view : &pitch, "render", "--pitch", camera)) !=
                CLI_OK)
                return rc;
        } else if (cli_value(argc, argv, &i, "--size", &v)) {
            if (!v || parse_size(v, &a->ro.width, &a->ro.height) != 0)
                return cli_usage_error("render", "--size needs WIDTHxHEIGHT, each 1 to 16384 "
                                                 "pixels, like 1024x768");
            a->size_given = 1;
        } else if (cli_value(argc, argv, &i, "--supersample", &v)) {
            if (!v || !cli_parse_int(v, &n) || n < 1 || n > 8)
                return cli_usage_error("render", "--supersample needs a count from 1 to 8");
            a->ro.supersample = (int)n;
        } else if (cli_value(argc, argv, &i, "--point-size", &v)) {
            if (!v || !cli_parse_double(v, &d) || d <= 0 || d > 100)
                return cli_usage_error("render", "--point-size needs pixels, above 0 up to 100");
            a->ro.point_radius = d;
        } else if (cli_value(argc, argv, &i, "--error-to", &v)) {
            if (!v)
                return cli_usage_error("render", "--error-to needs a reference mesh");
            a->error_to = v;
        } else if (cli_value(argc, argv, &i, "--error-max", &v)) {
            if (!v || !cli_parse_double(v, &d) || d <= 0)
                return cli_usage_error("render", "--error-max needs a positive percentage");
            a->error_max_pct = d;
        } else if (cli_value(argc, argv, &i, "--samples", &v)) {
            if (!v || !cli_parse_count(v, &a->samples) || a->samples > ((uint64_t)1 << 32))
                return cli_usage_error("render", "--samples needs a count, like 100k");
        } else if (cli_value(argc, argv, &i, "--columns", &v)) {
            if (!v || !cli_parse_int(v, &n) || n < 1 || n > MAX_INPUTS)
                return cli_usage_error("render", "--columns needs a count from 1 to %d",
                                       MAX_INPUTS);
            a->columns = (int)n;
        } else if (cli_value(argc, argv, &i, "--title", &v)) {
            if (!v)
                return cli_usage_error("render", "--title needs a text");
            a->title = v;
        } else if (argv[i][0] == '-' && argv[i][1] != '\0') {
            return cli_usage_error("render", "unknown option '%s'", argv[i]);
        } else {
            if (a->n_inputs == MAX_INPUTS)
                return cli_usage_error("render", "at most %d inputs", MAX_INPUTS);
            a->inputs[a->n_inputs++] = argv[i++];
        }
    }
    if (yaw.given || pitch.given)
        a->ro.view = MR_VIEW_CUSTOM;
    if (a->error_max_pct > 0 && !a->error_to)
        return cli_usage_error("render", "--error-max sets the colour scale of --error-to "
                                         "REF, which is not given");
    if (a->n_inputs == 0)
        return cli_usage_error("render", "needs at least one input mesh");
    if (!a->out)
        return cli_usage_error("render", "needs an output: -o OUT.png");
    if (!ends_with_png(a->out))
        return cli_usage_error("render", "the output must be a .png file ('%s')", a->out);
    return -1;
}

/* The last path component, for captions. */
static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

typedef struct panel_data {
    mr_look look;          /* look.mesh: the mesh */
    float *heat;           /* per face (or point), or NULL */
    double heat_max;
    int has_error;         /* hausdorff/rms below are measured */
    int one_sided;         /* a point cloud: its distances to the reference only */
    double hausdorff_rel, rms_rel;
    char caption[512];
} panel_data;

static int read_mesh(const char *path, mr_mesh *m)
{
    mr_error err;
    mr_mesh_init(m);
    if (mr_mesh_read(path, NULL, m, &err) != MR_OK)
        return cli_fail_err(&err);
    if (m->vertex_count == 0) {
        mr_mesh_free(m);
        return cli_fail("%s: has no vertices: nothing to render", path);
    }
    return CLI_OK;
}

/* A panel's mesh with its look (its materials, textures and vertex
 * colours), or the mesh alone with --plain. */
static int read_look(const char *path, bool plain, mr_look *look)
{
    mr_error err;
    memset(look, 0, sizeof *look);
    if (plain)
        return read_mesh(path, &look->mesh);
    if (mr_look_read(path, look, &err) != MR_OK)
        return cli_fail_err(&err);
    const mr_mesh *m = &look->mesh;
    if (m->vertex_count == 0) {
        mr_look_free(look);
        return cli_fail("%s: has no vertices: nothing to render", path);
    }
    return CLI_OK;
}

/* The look's arrays into render options (or a sheet panel's fields). */
#define SET_LOOK(dst, lk)                                   \
    do {                                                    \
        (dst).texcoords = (lk).mesh.texcoords;              \
        (dst).vertex_colors = (lk).mesh.colors;             \
        (dst).face_material = (lk).face_material;           \
        (dst).materials = (lk).materials;                   \
        (dst).material_count = (lk).material_count;         \
    } while (0)

/* The distances of panel p (read from `path`) to the reference, prepared
 * once for every panel (its hierarchy, its samples), whose bounding box has
 * diagonal diag: the heat values (when asked) and the caption's error
 * figures. Errors name the panel's file. */
static int measure(const mr_reference *ref, double diag, const char *path, panel_data *p,
                   int heat)
{
    mr_error err;
    const mr_mesh *m = &p->look.mesh;
    size_t n = m->triangle_count ? m->triangle_count : m->vertex_count;
    float *d = NULL;
    if (heat || !m->triangle_count) {
        d = malloc(sizeof(float) * (n ? n : 1));
        if (!d)
            return cli_fail("%s: out of memory for its distances to the reference", path);
        if (mr_surface_distances_with(ref, m->positions, m->vertex_count, m->indices,
                                      m->triangle_count, d, &p->heat_max, &err) != MR_OK) {
            free(d);
            return cli_fail_in(path, NULL, &err);
        }
    }
    diag = diag > 0 ? diag : 1;
    if (m->triangle_count) {
        mr_compare_result r;
        if (mr_compare_with(ref, m->positions, m->vertex_count, m->indices, m->triangle_count,
                            &r, &err) != MR_OK) {
            free(d);
            return cli_fail_in(path, NULL, &err);
        }
        p->hausdorff_rel = r.hausdorff / diag;
        p->rms_rel = r.rms / diag;
    } else {
        double sum = 0, mx = 0;
        for (size_t i = 0; i < n; i++) {
            sum += (double)d[i] * d[i];
            mx = d[i] > mx ? d[i] : mx;
        }
        p->hausdorff_rel = mx / diag;
        p->rms_rel = sqrt(sum / (double)n) / diag;
        p->one_sided = 1;
    }
    p->has_error = 1;
    if (heat)
        p->heat = d;
    else
        free(d);
    return CLI_OK;
}

static void make_caption(const char *path, panel_data *p, int is_reference)
{
    char count[32], err_line[160] = "";
    const mr_mesh *m = &p->look.mesh;
    if (p->has_error)
        snprintf(err_line, sizeof err_line, "\n%s %.3f%%  RMS %.3f%%",
                 p->one_sided ? "max" : "Hausdorff", 100 * p->hausdorff_rel, 100 * p->rms_rel);
    else if (is_reference)
        snprintf(err_line, sizeof err_line, "\nreference");
    snprintf(p->caption, sizeof p->caption, "%.60s\n%s %s%s", base_name(path),
             cli_count(count, sizeof count, m->triangle_count ? m->triangle_count
                                                              : m->vertex_count),
             m->triangle_count ? "triangles" : "points", err_line);
}

static int run(int argc, char **argv)
{
    render_args a;
    memset(&a, 0, sizeof a);
    mr_render_options_default(&a.ro);
    a.samples = 100000;
    int rc = parse(argc, argv, &a);
    if (rc >= 0)
        return rc;

    const int sheet = a.n_inputs > 1 || a.error_to;
    if (sheet && !a.size_given) {
        a.ro.width = 400;
        a.ro.height = 400;
    }
    double t0 = cli_now();
    panel_data *p = calloc((size_t)a.n_inputs, sizeof *p);
    mr_mesh ref;
    mr_mesh_init(&ref);
    if (!p)
        return cli_fail("%s: out of memory", a.out);
    for (int i = 0; i < a.n_inputs && rc < 0; i++)
        if (read_look(a.inputs[i], a.plain, &p[i].look) != CLI_OK)
            rc = CLI_FAIL;

    /* The reference: --error-to, else the first input of a sheet. */
    const mr_mesh *refm = NULL;
    const char *ref_path = NULL;
    if (rc < 0 && a.error_to) {
        if (read_mesh(a.error_to, &ref) != CLI_OK)
            rc = CLI_FAIL;
        else if (ref.triangle_count == 0)
            rc = cli_fail("%s: the reference has no triangles (a point cloud): no surface to "
                          "measure against",
                          a.error_to);
        refm = &ref;
        ref_path = a.error_to;
    } else if (rc < 0 && sheet && p[0].look.mesh.triangle_count) {
        refm = &p[0].look.mesh;
        ref_path = a.inputs[0];
    }
    /* The reference, prepared once (its bounding box, its hierarchy and
     * samples) for every panel that is measured against it. */
    mr_error err;
    mr_reference *rref = NULL;
    double diag = 0;
    if (rc < 0 && refm && sheet) {
        mr_stats s;
        if (mr_stats_compute(refm->positions, 0, refm->vertex_count, refm->indices,
                             refm->triangle_count, &s, &err) != MR_OK)
            rc = cli_fail_in(ref_path, NULL, &err);
        diag = s.bbox_diagonal;
        mr_compare_options co;
        mr_compare_options_default(&co);
        co.samples = (size_t)a.samples;
        if (rc < 0 && mr_reference_build(refm->positions, refm->vertex_count, refm->indices,
                                         refm->triangle_count, &co, &rref, &err) != MR_OK)
            rc = cli_fail_in(ref_path, NULL, &err);
    }
    /* Every panel but the reference's gets its distances; an input that is
     * the --error-to file itself is shown plain, as the reference. */
    double heat_max = 0;
    for (int i = 0; i < a.n_inputs && rc < 0 && sheet; i++) {
        int is_ref = a.error_to ? !strcmp(a.inputs[i], a.error_to) : i == 0;
        if (refm && !is_ref &&
            measure(rref, diag, a.inputs[i], &p[i], a.error_to != NULL) != CLI_OK)
            rc = CLI_FAIL;
        if (p[i].heat && p[i].heat_max > heat_max)
            heat_max = p[i].heat_max;
        make_caption(a.inputs[i], &p[i], is_ref && refm);
    }
    mr_reference_free(rref);

    uint8_t *img = NULL;
    int w = 0, h = 0;
    if (rc < 0 && sheet) {
        mr_sheet_options so;
        mr_sheet_options_default(&so);
        so.render = a.ro;
        so.columns = a.columns;
        so.title = a.title;
        mr_sheet_panel panels[MAX_INPUTS];
        for (int i = 0; i < a.n_inputs; i++) {
            const mr_mesh *m = &p[i].look.mesh;
            panels[i] = (mr_sheet_panel){.positions = m->positions,
                                         .vertex_count = m->vertex_count,
                                         .indices = m->indices,
                                         .triangle_count = m->triangle_count,
                                         .caption = p[i].caption, .face_scalar = p[i].heat};
            SET_LOOK(panels[i], p[i].look);
        }
        char label[512], lo[32], hi[64];
        if (a.error_to) {
            double top = a.error_max_pct > 0 ? a.error_max_pct / 100 * diag : heat_max;
            if (!(top > 0))
                top = diag > 0 ? 1e-6 * diag : 1;
            so.scalar_min = 0;
            so.scalar_max = top;
            snprintf(label, sizeof label, "distance to %.200s (%% of its bbox diagonal %.4g)",
                     base_name(ref_path), diag);
            snprintf(lo, sizeof lo, "0");
            snprintf(hi, sizeof hi, "%.3g%%", diag > 0 ? 100 * top / diag : 0.0);
            so.colorbar_label = label;
            so.colorbar_min_label = lo;
            so.colorbar_max_label = hi;
        }
        if (mr_render_sheet(panels, (size_t)a.n_inputs, &so, &img, &w, &h, &err) != MR_OK)
            rc = cli_fail_in(a.out, NULL, &err); /* the sheet it was to be */
    } else if (rc < 0) {
        w = a.ro.width;
        h = a.ro.height;
        img = malloc((size_t)w * (size_t)h * 4);
        if (!img)
            rc = cli_fail("%s: out of memory for a %dx%d image", a.out, w, h);
        else {
            const mr_mesh *m = &p[0].look.mesh;
            SET_LOOK(a.ro, p[0].look);
            if (mr_render(m->positions, m->vertex_count, m->indices, m->triangle_count, &a.ro,
                          img, 0, &err) != MR_OK)
                rc = cli_fail_in(a.inputs[0], "render", &err);
        }
    }
    if (rc < 0 && mr_png_write(a.out, img, w, h, &err) != MR_OK)
        rc = cli_fail_err(&err);
    double t1 = cli_now();
    if (rc < 0) {
        if (a.json) {
            printf("{\"output\": ");
            cli_json_string(stdout, a.out);
            printf(", \"width\": %d, \"height\": %d, \"seconds\": %.6f, \"panels\": [", w, h,
                   t1 - t0);
            for (int i = 0; i < a.n_inputs; i++) {
                printf("%s{\"file\": ", i ? ", " : "");
                cli_json_string(stdout, a.inputs[i]);
                printf(", \"vertices\": %zu, \"triangles\": %zu", p[i].look.mesh.vertex_count,
                       p[i].look.mesh.triangle_count);
                if (p[i].has_error)
                    printf(", \"hausdorff_rel\": %.9g, \"rms_rel\": %.9g", p[i].hausdorff_rel,
                           p[i].rms_rel);
                printf("}");
            }
            printf("]");
            if (a.error_to)
                printf(", \"heat_max\": %.9g", heat_max);
            printf("}\n");
        } else if (!a.quiet) {
            printf("wrote %s (%dx%d, %d panel%s) in %.3f s\n", a.out, w, h, a.n_inputs,
                   a.n_inputs == 1 ? "" : "s", t1 - t0);
        }
        rc = CLI_OK;
    }
    free(img);
    for (int i = 0; i < a.n_inputs; i++) {
        mr_look_free(&p[i].look);
        free(p[i].heat);
    }
    free(p);
    mr_mesh_free(&ref);
    return rc;
}

const cli_command cli_cmd_render = {"render", "pictures, comparison sheets and heat maps (PNG)",
                                    run, usage};
