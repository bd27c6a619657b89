/* meshreduce convert IN OUT and meshreduce clean IN -o OUT. */
#include "cli.h"

#include <string.h>

/* The cleanup steps, in the order that makes each one's result final. */
typedef struct clean_steps {
    bool weld, weld_attributes, keep_degenerate, keep_duplicates, keep_unreferenced;
} clean_steps;

static int clean_mesh(mr_mesh *m, const clean_steps *c, bool quiet)
{
    mr_error err;
    size_t welded = 0, degenerate = 0, unreferenced = 0;
    if (c->weld && mr_mesh_weld_exact(m, c->weld_attributes, &welded, &err) != MR_OK)
        return cli_fail_err(&err);
    if (!c->keep_degenerate &&
        mr_mesh_remove_degenerate(m, !c->keep_duplicates, &degenerate, &err) != MR_OK)
        return cli_fail_err(&err);
    if (!c->keep_unreferenced && mr_mesh_remove_unreferenced(m, &unreferenced, &err) != MR_OK)
        return cli_fail_err(&err);
    if (!quiet) {
        char a[32], b[32], d[32];
        fprintf(stderr,
                "cleaned: %s vertices welded, %s degenerate or duplicate triangles and %s "
                "unreferenced vertices removed\n",
                cli_count(a, sizeof a, welded), cli_count(b, sizeof b, degenerate),
                cli_count(d, sizeof d, unreferenced));
    }
    return CLI_OK;
}

static int read_clean_write(const char *in, const char *out, const mr_write_options *w,
                            const clean_steps *clean, bool quiet)
{
    mr_mesh mesh;
    mr_error err;
    double t0 = cli_now();
    if (mr_mesh_read(in, NULL, &mesh, &err) != MR_OK)
        return cli_fail_err(&err);
    double t1 = cli_now();
    int rc = clean ? clean_mesh(&mesh, clean, quiet) : CLI_OK;
    double t2 = cli_now();
    if (rc == CLI_OK && mr_mesh_write(out, &mesh, w, &err) != MR_OK)
        rc = cli_fail_err(&err);
    double t3 = cli_now();
    if (rc == CLI_OK && !quiet) {
        char a[32], b[32];
        fprintf(stderr, "%s: %s vertices, %s triangles (read %.3f s, %s%.3f s, write %.3f s)\n",
                out, cli_count(a, sizeof a, mesh.vertex_count),
                cli_count(b, sizeof b, mesh.triangle_count), t1 - t0,
                clean ? "clean " : "", clean ? t2 - t1 : 0.0, t3 - t2);
    }
    mr_mesh_free(&mesh);
    return rc;
}

static const char convert_usage[] =
    "usage: meshreduce convert IN OUT [options]\n"
    "\n"
    "Convert a mesh or point cloud between OBJ, PLY, STL and XYZ (formats by\n"
    "extension). Vertex order and triangles are kept as read.\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP
    "  --clean          also weld exact duplicates and remove degenerate,\n"
    "                   duplicate triangles and unreferenced vertices\n"
    "  -q, --quiet      print nothing on success\n";

static int run_convert(int argc, char **argv)
{
    const char *paths[2] = {NULL, NULL};
    int npaths = 0;
    bool quiet = false, clean = false;
    mr_write_options w;
    mr_write_options_default(&w);
    for (int i = 1; i < argc;) {
        if (cli_output_option(argc, argv, &i, &w))
            continue;
        if (cli_flag(argc, argv, &i, "--clean"))
            clean = true;
        else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet"))
            quiet = true;
        else if (argv[i][0] == '-' && argv[i][1] != '\0')
            return cli_usage_error("convert", "unknown option '%s'", argv[i]);
        else if (npaths == 2)
            return cli_usage_error("convert", "too many files ('%s')", argv[i]);
        else
            paths[npaths++] = argv[i++];
    }
    if (npaths < 2)
        return cli_usage_error("convert", "needs an input and an output file");
    int rc = cli_check_output_path("convert", paths[1]);
    if (rc != CLI_OK)
        return rc;
    clean_steps steps = {.weld = true};
    return read_clean_write(paths[0], paths[1], &w, clean ? &steps : NULL, quiet);
}

static const char clean_usage[] =
    "usage: meshreduce clean IN -o OUT [options]\n"
    "\n"
    "Repair a mesh for processing: weld vertices at bitwise-equal positions,\n"
    "remove triangles that repeat a vertex, duplicate triangles (either\n"
    "orientation) and vertices no triangle uses. The order of what stays is kept.\n"
    "\n"
    "  -o, --output FILE       output file (required)\n"
    "  --no-weld               do not weld duplicate positions\n"
    "  --weld-attributes       weld only vertices whose normals, texture\n"
    "                          coordinates and colors are equal too (keeps seams)\n"
    "  --keep-duplicates       keep duplicate triangles\n"
    "  --keep-degenerate       keep triangles that repeat a vertex\n"
    "  --keep-unreferenced     keep unreferenced vertices\n"
    "  -q, --quiet             print nothing on success\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP;

static int run_clean(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    bool quiet = false;
    clean_steps c = {.weld = true};
    mr_write_options w;
    mr_write_options_default(&w);
    for (int i = 1; i < argc;) {
        const char *v;
        if (cli_output_option(argc, argv, &i, &w))
            continue;
        if (cli_value(argc, argv, &i, "-o", &v) || cli_value(argc, argv, &i, "--output", &v)) {
            if (!v)
                return cli_usage_error("clean", "-o needs a file name");
            out = v;
        } else if (cli_flag(argc, argv, &i, "--no-weld"))
            c.weld = false;
        else if (cli_flag(argc, argv, &i, "--weld-attributes"))
            c.weld_attributes = true;
        else if (cli_flag(argc, argv, &i, "--keep-duplicates"))
            c.keep_duplicates = true;
        else if (cli_flag(argc, argv, &i, "--keep-degenerate"))
            c.keep_degenerate = true;
        else if (cli_flag(argc, argv, &i, "--keep-unreferenced"))
            c.keep_unreferenced = true;
        else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet"))
            quiet = true;
        else if (argv[i][0] == '-' && argv[i][1] != '\0')
            return cli_usage_error("clean", "unknown option '%s'", argv[i]);
        else if (in)
            return cli_usage_error("clean", "one input file at a time (use -o for the output)");
        else
            in = argv[i++];
    }
    if (!in)
        return cli_usage_error("clean", "no input file given");
    if (!out)
        return cli_usage_error("clean", "no output file given (-o FILE)");
    int rc = cli_check_output_path("clean", out);
    if (rc != CLI_OK)
        return rc;
    return read_clean_write(in, out, &w, &c, quiet);
}

const cli_command cli_cmd_convert = {"convert", "convert between OBJ, PLY, STL and XYZ",
                                     run_convert, convert_usage};
const cli_command cli_cmd_clean = {"clean", "weld duplicates, drop degenerate and unused",
                                   run_clean, clean_usage};
