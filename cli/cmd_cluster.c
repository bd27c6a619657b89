/* meshreduce cluster IN -o OUT: grid vertex clustering. */
#include "cli.h"
#include "../src/ooc/comm.h"

#include <math.h>
#include <string.h>
#include <sys/stat.h>

static const char usage[] =
    "usage: meshreduce cluster IN -o OUT (--cell C | --cell-rel F | --target-vertices N)\n"
    "                          [options]\n"
    "\n"
    "Reduce a mesh or point cloud by grid clustering (Rossignac-Borrel): all\n"
    "vertices in one cubic cell become one vertex, placed by the cell's summed\n"
    "triangle quadrics (Lindstrom) or at the mean of its points; collapsed and\n"
    "duplicate triangles are removed. Fast, parallel, independent of vertex order,\n"
    "the same at any thread count. Normals, texture coordinates and colors are\n"
    "averaged per cell. A file is read in passes (Lindstrom's out-of-core\n"
    "clustering: 4 bytes a vertex beside what the output needs; the same file as\n"
    "when read whole; --json's read and write times are then in its total): a\n"
    "binary PLY file in place, a binary STL file welded and an OBJ file parsed\n"
    "into temporary files when its clustering in memory would not fit --memory\n"
    "(about 64 bytes a triangle; else, and ascii files, read whole). An OBJ file\n"
    "streamed is clustered by its v lines, positions only (give --no-normals\n"
    "--no-texcoords --no-colors where it has more). Standard input is read whole.\n"
    "meshreduce-mpi shares the passes out over its ranks, the same bytes.\n"
    "\n"
    "cell size (exactly one):\n"
    "  --cell C                cell edge length (absolute, > 0)\n"
    "  --cell-rel F            cell edge as a fraction of the bounding-box diagonal\n"
    "                          (the input must not be a single point)\n"
    "  --target-vertices N     the cell size whose grid has about N occupied cells;\n"
    "                          N >= 1: clustering has no error bound to stop at, so\n"
    "                          there is no 0 = 'as far as allowed' as simplify's\n"
    "                          --triangles 0 (one cell would leave no triangle)\n"
    "\n"
    "options:\n"
    "  -o, --output FILE       output file (required)\n"
    "  --threads N             worker threads (default: all cores)\n"
    "  --stats                 print counts, the cell size and the time per phase\n"
    "  --json                  print them as one JSON object on stdout\n"
    "  -q, --quiet             no summary on success (--stats and --json still print)\n"
    "\n"
    "files larger than memory:\n"
    "  --memory SIZE           memory budget (default 4G; K, M, G, T are powers of\n"
    "                          1024): whether an OBJ or STL file is streamed, and\n"
    "                          the STL weld's sorts\n"
    "  --temp-dir DIR          temporary files (default: $TMPDIR, else the output's\n"
    "                          directory); they have no name, so nothing is left\n"
    "                          behind however the process ends (see simplify --help)\n"
    "  --temp-budget SIZE      fail with a clear error rather than let the temporary\n"
    "                          files pass SIZE (default: no limit)\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP;

/* The options, the relative cell size asked for and the statistics of one
 * run. */
typedef struct cluster_job {
    mr_cluster_options o;
    double cell_rel;
    cli_choice size_option; /* --cell, --cell-rel or --target-vertices */
    mr_out_of_core_options ooc;
    mr_cluster_stats s;
} cluster_job;

static const char size_group[] = "one cell size: --cell, --cell-rel or --target-vertices";

static int option(int argc, char **argv, int *i, void *user)
{
    cluster_job *job = user;
    const char *v;
    double x;
    uint64_t n;
    int rc;
    if (cli_value(argc, argv, i, "--cell", &v)) {
        if (!cli_parse_double(v, &x) || !(x > 0) || isinf(x))
            return cli_usage_error("cluster", "--cell needs a finite number > 0");
        if ((rc = cli_choose(&job->size_option, "cluster", "--cell", size_group)) != CLI_OK)
            return rc;
        job->o.cell = x;
    } else if (cli_value(argc, argv, i, "--cell-rel", &v)) {
        if (!cli_parse_double(v, &x) || !(x > 0) || isinf(x))
            return cli_usage_error("cluster", "--cell-rel needs a finite number > 0");
        if ((rc = cli_choose(&job->size_option, "cluster", "--cell-rel", size_group)) != CLI_OK)
            return rc;
        job->cell_rel = x;
    } else if (cli_value(argc, argv, i, "--target-vertices", &v)) {
        if (!cli_parse_count(v, &n) || n == 0)
            return cli_usage_error("cluster", "--target-vertices needs a count of at least 1 "
                                              "(no error bound ends a clustering: see --help)");
        if ((rc = cli_choose(&job->size_option, "cluster", "--target-vertices", size_group)) !=
            CLI_OK)
            return rc;
        job->o.target_vertices = (size_t)n;
    } else if (cli_value(argc, argv, i, "--memory", &v)) {
        if (!cli_parse_size(v, &n) || n == 0)
            return cli_usage_error("cluster", "--memory needs a size such as 512M or 4G");
        job->ooc.memory = n;
    } else if (cli_value(argc, argv, i, "--temp-dir", &v)) {
        if (!v || !*v)
            return cli_usage_error("cluster", "--temp-dir needs a directory");
        job->ooc.temp_dir = v;
    } else if (cli_value(argc, argv, i, "--temp-budget", &v)) {
        if (!cli_parse_size(v, &n) || n == 0)
            return cli_usage_error("cluster", "--temp-budget needs a size such as 10G");
        job->ooc.temp_budget = n;
    } else {
        return CLI_NO_MATCH;
    }
    return CLI_OK;
}

static int work(const cli_io *io, mr_mesh *mesh, mr_mesh *result, void *user)
{
    cluster_job *job = user;
    mr_error err;
    if (job->cell_rel > 0 && mesh->vertex_count > 0) {
        double diagonal;
        int rc = cli_bbox_diagonal(io->in, mesh, &diagonal);
        if (rc != CLI_OK)
            return rc;
        job->o.cell = job->cell_rel * diagonal;
        /* A fraction of nothing is no size: say so about the file, rather
         * than let the library refuse a cell size the user never gave. */
        char a[32];
        if (diagonal == 0)
            return cli_fail("%s: all %s vertices are at one point, so --cell-rel %g of its "
                            "bounding-box diagonal (0) is no cell size; give --cell or "
                            "--target-vertices",
                            io->in, cli_count(a, sizeof a, mesh->vertex_count), job->cell_rel);
        if (!(job->o.cell > 0) || isinf(job->o.cell))
            return cli_fail("%s: --cell-rel %g of its bounding-box diagonal %g is no usable "
                            "cell size; give --cell",
                            io->in, job->cell_rel, diagonal);
    }
    if (mr_mesh_cluster(mesh, &job->o, result, &job->s, &err) != MR_OK)
        return cli_fail_in(io->in, NULL, &err);
    return CLI_OK;
}

static void print_json(const cli_io *io, const mr_mesh *result, const cli_times *t,
                       void *user)
{
    const mr_cluster_stats *s = &((const cluster_job *)user)->s;
    cli_json_io(io);
    printf(", \"cell\": %.17g, \"cells\": %zu, \"input_vertices\": %zu, "
           "\"input_triangles\": %zu, \"output_vertices\": %zu, \"output_triangles\": %zu, "
           "\"seconds\": {\"read\": %.6f, \"cells\": %.6f, \"representatives\": %.6f, "
           "\"triangles\": %.6f, \"total\": %.6f, \"write\": %.6f}, \"streamed\": %s, "
           "\"temp_bytes_peak\": %llu}\n",
           s->cell, s->cells, s->input_vertices, s->input_triangles, s->output_vertices,
           s->output_triangles, t->read, s->seconds_cells, s->seconds_representatives,
           s->seconds_triangles, s->seconds_total, t->write, s->streamed ? "true" : "false",
           (unsigned long long)s->temp_bytes_peak);
}

static void print_stats(const cli_io *io, const mr_mesh *result, const cli_times *t,
                        void *user)
{
    const mr_cluster_stats *s = &((const cluster_job *)user)->s;
    char a[32], b[32];
    fprintf(stderr, "vertices   %s -> %s\n", cli_count(a, sizeof a, s->input_vertices),
            cli_count(b, sizeof b, s->output_vertices));
    fprintf(stderr, "triangles  %s -> %s\n", cli_count(a, sizeof a, s->input_triangles),
            cli_count(b, sizeof b, s->output_triangles));
    fprintf(stderr, "cell       %.9g (%s occupied cells)\n", s->cell,
            cli_count(a, sizeof a, s->cells));
    if (s->streamed)
        fprintf(stderr, "read       in passes%s%s\n", s->temp_bytes_peak ? ", temporary files " : "",
                s->temp_bytes_peak ? cli_bytes(a, sizeof a, s->temp_bytes_peak) : "");
    fprintf(stderr, "time       read %.3f s, cells %.3f s, representatives %.3f s, "
                    "triangles %.3f s, write %.3f s\n",
            t->read, s->seconds_cells, s->seconds_representatives, s->seconds_triangles,
            t->write);
}

static void print_summary(const cli_io *io, const mr_mesh *result, const cli_times *t,
                          void *user)
{
    const mr_cluster_stats *s = &((const cluster_job *)user)->s;
    cli_summary(io->out, s->output_vertices, s->output_triangles,
                "cell %.6g, clustered in %.3f s", s->cell, s->seconds_total);
}

static int run(int argc, char **argv)
{
    cli_io io;
    cli_io_init(&io, "cluster", CLI_ACCEPT_OUTPUT | CLI_ACCEPT_WRITE | CLI_ACCEPT_REPORT);
    cluster_job job = {.cell_rel = 0};
    mr_cluster_options_default(&job.o);
    mr_out_of_core_options_default(&job.ooc);
    int rc = cli_io_parse(&io, argc, argv, option, &job);
    if (rc != CLI_OK)
        return rc;
    if (job.o.cell == 0 && job.cell_rel == 0 && job.o.target_vertices == 0)
        return cli_usage_error("cluster", "no cell size given (--cell, --cell-rel or "
                                          "--target-vertices)");
    if ((rc = cli_check_output_path(io.cmd, io.out, io.write.format)) != CLI_OK)
        return rc;
    static const cli_job steps = {work, print_json, print_stats, print_summary};
    struct stat sb;
    if (stat(io.in, &sb) == 0 && S_ISREG(sb.st_mode)) {
        /* a file: read in passes (memory that grows with the output), the
         * same bytes as the mesh read whole; meshreduce-mpi: on its ranks */
        job.o.cell_rel = job.cell_rel;
        const double t0 = cli_now();
        mr_error err;
        if (ooc_cluster_file(io.in, io.out, &job.o, &job.ooc, &io.write, cli_comm, &job.s,
                             &err) != MR_OK)
            return cli_fail_err(&err);
        if (cli_comm && cli_comm->rank != 0)
            return CLI_OK;
        const cli_times t = {0, cli_now() - t0, 0}; /* reading and writing inside */
        if (io.json)
            print_json(&io, NULL, &t, &job);
        if (io.stats)
            print_stats(&io, NULL, &t, &job);
        else if (!io.quiet && !io.json)
            print_summary(&io, NULL, &t, &job);
        return CLI_OK;
    }
    if (cli_comm && cli_comm->rank != 0)
        return CLI_OK; /* standard input: rank 0 reads it */
    return cli_run_job(&io, &steps, &job);
}

const cli_command cli_cmd_cluster = {"cluster", "grid vertex clustering (fast, order-free)", run,
                                     usage};
