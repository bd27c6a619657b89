/* meshreduce cluster IN -o OUT: grid vertex clustering. */
#include "cli.h"

#include <math.h>
#include <string.h>

static const char usage[] =
    "usage: meshreduce cluster IN -o OUT (--cell C | --target-vertices N) [options]\n"
    "\n"
    "Reduce a mesh or point cloud by grid clustering (Rossignac-Borrel): all\n"
    "vertices in one cubic cell become one vertex, placed by the cell's summed\n"
    "triangle quadrics (Lindstrom) or at the mean of its points; collapsed and\n"
    "duplicate triangles are removed. Fast, parallel, independent of vertex order,\n"
    "the same at any thread count. Normals, texture coordinates and colors are\n"
    "averaged per cell.\n"
    "\n"
    "options:\n"
    "  -o, --output FILE       output file (required)\n"
    "  --cell C                cell edge length (absolute, > 0)\n"
    "  --cell-rel F            cell edge as a fraction of the bounding-box diagonal\n"
    "  --target-vertices N     the cell size whose grid has about N occupied cells\n"
    "  --threads N             worker threads (default: all cores)\n"
    "  --stats                 print counts, the cell size and the time per phase\n"
    "  --json                  print them as one JSON object on stdout\n"
    "  -q, --quiet             print nothing on success\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP;

static int run(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    bool stats = false, json = false, quiet = false;
    double cell_rel = 0;
    mr_cluster_options o;
    mr_cluster_options_default(&o);
    mr_write_options w;
    mr_write_options_default(&w);
    for (int i = 1; i < argc;) {
        const char *v;
        double x;
        uint64_t n;
        if (cli_output_option(argc, argv, &i, &w))
            continue;
        if (cli_value(argc, argv, &i, "-o", &v) || cli_value(argc, argv, &i, "--output", &v)) {
            if (!v)
                return cli_usage_error("cluster", "-o needs a file name");
            out = v;
        } else if (cli_value(argc, argv, &i, "--cell", &v)) {
            if (!cli_parse_double(v, &x) || !(x > 0) || isinf(x))
                return cli_usage_error("cluster", "--cell needs a finite number > 0");
            o.cell = x;
        } else if (cli_value(argc, argv, &i, "--cell-rel", &v)) {
            if (!cli_parse_double(v, &x) || !(x > 0) || isinf(x))
                return cli_usage_error("cluster", "--cell-rel needs a finite number > 0");
            cell_rel = x;
        } else if (cli_value(argc, argv, &i, "--target-vertices", &v)) {
            if (!cli_parse_count(v, &n) || n == 0)
                return cli_usage_error("cluster", "--target-vertices needs a positive count");
            o.target_vertices = (size_t)n;
        } else if (cli_flag(argc, argv, &i, "--stats")) {
            stats = true;
        } else if (cli_flag(argc, argv, &i, "--json")) {
            json = true;
        } else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet")) {
            quiet = true;
        } else if (argv[i][0] == '-' && argv[i][1] != '\0') {
            return cli_usage_error("cluster", "unknown option '%s'", argv[i]);
        } else if (in) {
            return cli_usage_error("cluster", "one input file at a time (use -o for the "
                                              "output)");
        } else {
            in = argv[i++];
        }
    }
    if (!in)
        return cli_usage_error("cluster", "no input file given");
    if (!out)
        return cli_usage_error("cluster", "no output file given (-o FILE)");
    if (o.cell == 0 && cell_rel == 0 && o.target_vertices == 0)
        return cli_usage_error("cluster", "no cell size given (--cell, --cell-rel or "
                                          "--target-vertices)");
    int rc = cli_check_output_path("cluster", out);
    if (rc != CLI_OK)
        return rc;

    mr_mesh mesh, result;
    mr_error err;
    double t0 = cli_now();
    if (mr_mesh_read(in, NULL, &mesh, &err) != MR_OK)
        return cli_fail_err(&err);
    double t_read = cli_now() - t0;
    if (cell_rel > 0 && mesh.vertex_count > 0) {
        mr_stats s;
        if (mr_stats_compute(mesh.positions, 0, mesh.vertex_count, NULL, 0, &s, &err) != MR_OK) {
            mr_mesh_free(&mesh);
            return cli_fail_err(&err);
        }
        o.cell = cell_rel * s.bbox_diagonal;
    }
    mr_cluster_stats s;
    mr_status st = mr_mesh_cluster(&mesh, &o, &result, &s, &err);
    mr_mesh_free(&mesh);
    if (st != MR_OK)
        return cli_fail_err(&err);
    t0 = cli_now();
    st = mr_mesh_write(out, &result, &w, &err);
    double t_write = cli_now() - t0;
    mr_mesh_free(&result);
    if (st != MR_OK)
        return cli_fail_err(&err);

    char a[32], b[32];
    if (json) {
        printf("{\"input\": ");
        cli_json_string(stdout, in);
        printf(", \"output\": ");
        cli_json_string(stdout, out);
        printf(", \"cell\": %.17g, \"cells\": %zu, \"input_vertices\": %zu, "
               "\"input_triangles\": %zu, \"output_vertices\": %zu, \"output_triangles\": %zu, "
               "\"seconds\": {\"read\": %.6f, \"cells\": %.6f, \"representatives\": %.6f, "
               "\"triangles\": %.6f, \"total\": %.6f, \"write\": %.6f}}\n",
               s.cell, s.cells, s.input_vertices, s.input_triangles, s.output_vertices,
               s.output_triangles, t_read, s.seconds_cells, s.seconds_representatives,
               s.seconds_triangles, s.seconds_total, t_write);
    }
    if (stats) {
        fprintf(stderr, "vertices   %s -> %s\n", cli_count(a, sizeof a, s.input_vertices),
                cli_count(b, sizeof b, s.output_vertices));
        fprintf(stderr, "triangles  %s -> %s\n", cli_count(a, sizeof a, s.input_triangles),
                cli_count(b, sizeof b, s.output_triangles));
        fprintf(stderr, "cell       %.9g (%s occupied cells)\n", s.cell,
                cli_count(a, sizeof a, s.cells));
        fprintf(stderr, "time       read %.3f s, cells %.3f s, representatives %.3f s, "
                        "triangles %.3f s, write %.3f s\n",
                t_read, s.seconds_cells, s.seconds_representatives, s.seconds_triangles,
                t_write);
    } else if (!quiet && !json) {
        fprintf(stderr, "%s: %s vertices, %s triangles (cell %.6g, clustered in %.3f s)\n", out,
                cli_count(a, sizeof a, s.output_vertices),
                cli_count(b, sizeof b, s.output_triangles), s.cell, s.seconds_total);
    }
    return CLI_OK;
}

const cli_command cli_cmd_cluster = {"cluster", "grid vertex clustering (fast, order-free)", run,
                                     usage};
