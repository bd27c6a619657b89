/* meshreduce weld IN -o OUT: exact epsilon welding (vertex clustering). */
#include "cli.h"

#include <math.h>
#include <string.h>

static const char usage[] =
    "usage: meshreduce weld IN -o OUT (--eps E | --eps-rel F | --reduce P) [options]\n"
    "\n"
    "Merge every vertex within distance E of an earlier, still unclustered vertex\n"
    "into that vertex's cluster, visiting vertices in a fixed order; each cluster\n"
    "becomes one vertex at the mean of its members (normals, texture coordinates\n"
    "and colors averaged too) and triangles are remapped. The result is the same\n"
    "for every algorithm and thread count, and the clusters are those of Open3D's\n"
    "merge_close_vertices (with --strict). Works on meshes and point clouds\n"
    "(PLY/OBJ with vertices only, .xyz).\n"
    "\n"
    "radius (exactly one):\n"
    "  --eps E               absolute radius, E >= 0 (0 welds exact duplicates)\n"
    "  --eps-rel F           radius as a fraction of the bounding-box diagonal\n"
    "  --reduce P            find the smallest radius that removes P %% of the\n"
    "                        vertices (bisection; the radius used is reported)\n"
    "\n"
    "options:\n"
    "  -o, --output FILE     output file (required)\n"
    "  --algorithm A         serial (S-Weld), pweld, pweld-async (default)\n"
    "  --order index|grade   visiting order: vertex index (default, as Open3D) or\n"
    "                        decreasing visual importance (Low and Tan 1997)\n"
    "  --strict              merge only pairs closer than E (Open3D's comparison)\n"
    "  --drop-degenerate     remove triangles that collapse (kept by default)\n"
    "  --threads N           worker threads (default: all cores)\n"
    "  --stats               print counts, the radius and the time of each phase\n"
    "  --json                print them as one JSON object on stdout\n"
    "  -q, --quiet           no summary on success (--stats and --json still print)\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP;

static const char *algorithm_name(mr_weld_algorithm a)
{
    switch (a) {
    case MR_WELD_SERIAL: return "serial";
    case MR_WELD_PWELD: return "pweld";
    case MR_WELD_PWELD_ASYNC: return "pweld-async";
    default: return "auto";
    }
}

/* "0.1" or "10%" -> 10 (a percentage) */
static bool parse_percent(const char *s, double *out)
{
    char buf[64];
    size_t n = s ? strlen(s) : 0;
    if (n == 0 || n >= sizeof buf)
        return false;
    memcpy(buf, s, n + 1);
    if (buf[n - 1] == '%')
        buf[n - 1] = '\0';
    return cli_parse_double(buf, out);
}

/* The options, the radius asked for and the statistics of one run. */
typedef struct weld_job {
    mr_weld_options o;
    int radius_kind; /* 1 eps, 2 eps-rel, 3 reduce */
    double radius;
    cli_choice radius_option; /* which of them was given */
    double t_find; /* seconds of the radius search (--reduce) */
    mr_weld_stats s;
} weld_job;

static const char radius_group[] = "one radius: --eps, --eps-rel or --reduce";

static int option(int argc, char **argv, int *i, void *user)
{
    weld_job *job = user;
    const char *v;
    double x;
    int rc;
    if (cli_value(argc, argv, i, "--eps", &v)) {
        if (!cli_parse_double(v, &x) || !(x >= 0) || isinf(x))
            return cli_usage_error("weld", "--eps needs a finite number >= 0, got '%s'",
                                   v ? v : "");
        if ((rc = cli_choose(&job->radius_option, "weld", "--eps", radius_group)) != CLI_OK)
            return rc;
        job->radius_kind = 1, job->radius = x;
    } else if (cli_value(argc, argv, i, "--eps-rel", &v)) {
        if (!cli_parse_double(v, &x) || !(x >= 0) || isinf(x))
            return cli_usage_error("weld", "--eps-rel needs a finite number >= 0, got '%s'",
                                   v ? v : "");
        if ((rc = cli_choose(&job->radius_option, "weld", "--eps-rel", radius_group)) != CLI_OK)
            return rc;
        job->radius_kind = 2, job->radius = x;
    } else if (cli_value(argc, argv, i, "--reduce", &v)) {
        if (!parse_percent(v, &x) || !(x >= 0 && x < 100))
            return cli_usage_error("weld", "--reduce needs a percentage in [0, 100), "
                                           "got '%s'",
                                   v ? v : "");
        if ((rc = cli_choose(&job->radius_option, "weld", "--reduce", radius_group)) != CLI_OK)
            return rc;
        job->radius_kind = 3, job->radius = x;
    } else if (cli_value(argc, argv, i, "--algorithm", &v)) {
        if (v && !strcmp(v, "serial"))
            job->o.algorithm = MR_WELD_SERIAL;
        else if (v && !strcmp(v, "pweld"))
            job->o.algorithm = MR_WELD_PWELD;
        else if (v && !strcmp(v, "pweld-async"))
            job->o.algorithm = MR_WELD_PWELD_ASYNC;
        else
            return cli_usage_error("weld", "--algorithm is serial, pweld or pweld-async");
    } else if (cli_value(argc, argv, i, "--order", &v)) {
        if (v && !strcmp(v, "index"))
            job->o.order = MR_WELD_ORDER_INDEX;
        else if (v && !strcmp(v, "grade"))
            job->o.order = MR_WELD_ORDER_GRADE;
        else
            return cli_usage_error("weld", "--order is index or grade");
    } else if (cli_flag(argc, argv, i, "--strict")) {
        job->o.strict = 1;
    } else if (cli_flag(argc, argv, i, "--drop-degenerate")) {
        job->o.drop_degenerate = 1;
    } else {
        return CLI_NO_MATCH;
    }
    return CLI_OK;
}

/* Settle the radius (absolute, relative to the bounding box, or searched
 * for) and weld. */
static int work(const cli_io *io, mr_mesh *mesh, mr_mesh *result, void *user)
{
    weld_job *job = user;
    mr_error err;
    if (job->radius_kind == 1) {
        job->o.eps = job->radius;
    } else if (job->radius_kind == 2) {
        double diagonal;
        if (mesh->vertex_count == 0)
            return cli_fail("%s: no vertices to weld", io->in);
        int rc = cli_bbox_diagonal(io->in, mesh, &diagonal);
        if (rc != CLI_OK)
            return rc;
        job->o.eps = job->radius * diagonal;
    } else {
        double t0 = cli_now();
        if (mr_weld_find_eps(mesh->positions, 0, mesh->vertex_count, job->radius / 100.0,
                             &job->o, &job->o.eps, NULL, &err) != MR_OK)
            return cli_fail_in(io->in, NULL, &err);
        job->t_find = cli_now() - t0;
    }
    if (mr_mesh_weld(mesh, &job->o, result, NULL, &job->s, &err) != MR_OK)
        return cli_fail_in(io->in, NULL, &err);
    return CLI_OK;
}

static void print_stats(const cli_io *io, const mr_mesh *result, const cli_times *t,
                        void *user)
{
    const weld_job *job = user;
    const mr_weld_stats *s = &job->s;
    char a[32], b[32];
    fprintf(stderr, "vertices   %s -> %s (%.3f%% removed)\n",
            cli_count(a, sizeof a, s->input_vertices), cli_count(b, sizeof b, s->output_vertices),
            s->input_vertices ? 100.0 * (double)(s->input_vertices - s->output_vertices) /
                                    (double)s->input_vertices
                              : 0.0);
    fprintf(stderr, "triangles  %s -> %s\n", cli_count(a, sizeof a, s->input_triangles),
            cli_count(b, sizeof b, s->output_triangles));
    fprintf(stderr, "eps        %.9g (%s pairs within it)\n", s->eps,
            cli_count(a, sizeof a, s->graph_edges));
    fprintf(stderr, "algorithm  %s, %d threads, %u rounds\n", algorithm_name(s->algorithm),
            s->threads, s->rounds);
    fprintf(stderr, "time       read %.3f s, eps search %.3f s, order %.3f s, graph %.3f s, "
                    "mapping %.3f s, reduction %.3f s, retriangulation %.3f s, write %.3f s\n",
            t->read, job->t_find, s->seconds_order, s->seconds_graph, s->seconds_mapping,
            s->seconds_reduction, s->seconds_retriangulation, t->write);
    fprintf(stderr, "memory     %.1f bytes per input vertex (working set)\n",
            s->input_vertices ? (double)s->peak_bytes / (double)s->input_vertices : 0.0);
}

static void print_json(const cli_io *io, const mr_mesh *result, const cli_times *t,
                       void *user)
{
    const weld_job *job = user;
    const mr_weld_stats *s = &job->s;
    cli_json_io(io);
    printf(", \"algorithm\": \"%s\", \"threads\": %d, \"eps\": %.17g, \"input_vertices\": %zu, "
           "\"input_triangles\": %zu, \"output_vertices\": %zu, \"output_triangles\": %zu, "
           "\"graph_edges\": %zu, \"rounds\": %u, \"peak_bytes_per_vertex\": %.2f, "
           "\"seconds\": {\"read\": %.6f, \"eps_search\": %.6f, \"order\": %.6f, "
           "\"graph\": %.6f, \"mapping\": %.6f, \"reduction\": %.6f, "
           "\"retriangulation\": %.6f, \"total\": %.6f, \"write\": %.6f}}\n",
           algorithm_name(s->algorithm), s->threads, s->eps, s->input_vertices,
           s->input_triangles, s->output_vertices, s->output_triangles, s->graph_edges,
           s->rounds,
           s->input_vertices ? (double)s->peak_bytes / (double)s->input_vertices : 0.0, t->read,
           job->t_find, s->seconds_order, s->seconds_graph, s->seconds_mapping,
           s->seconds_reduction, s->seconds_retriangulation, s->seconds_total, t->write);
}

static void print_summary(const cli_io *io, const mr_mesh *result, const cli_times *t,
                          void *user)
{
    const mr_weld_stats *s = &((const weld_job *)user)->s;
    cli_summary(io->out, s->output_vertices, s->output_triangles, "eps %.9g, welded in %.3f s",
                s->eps, s->seconds_total);
}

static int run(int argc, char **argv)
{
    cli_io io;
    cli_io_init(&io, "weld", CLI_ACCEPT_OUTPUT | CLI_ACCEPT_WRITE | CLI_ACCEPT_REPORT);
    weld_job job = {.radius_kind = 0};
    mr_weld_options_default(&job.o);
    int rc = cli_io_parse(&io, argc, argv, option, &job);
    if (rc != CLI_OK)
        return rc;
    if (!job.radius_kind)
        return cli_usage_error("weld", "no radius given (--eps, --eps-rel or --reduce)");
    if ((rc = cli_check_output_path(io.cmd, io.out, io.write.format)) != CLI_OK)
        return rc;
    static const cli_job steps = {work, print_json, print_stats, print_summary};
    return cli_run_job(&io, &steps, &job);
}

const cli_command cli_cmd_weld = {"weld", "merge vertices within a radius (exact, parallel)",
                                  run, usage};
