/* meshreduce generate KIND: the built-in procedural meshes. */
#include "cli.h"

#include <string.h>

static const char usage[] =
    "usage: meshreduce generate KIND -o FILE [--triangles N] [--seed S] [options]\n"
    "\n"
    "Write a procedural mesh. Deterministic: the same kind, size and seed give\n"
    "the same file on every machine and thread count. A sphere or a scan written\n"
    "as PLY is streamed into the file in bounded memory (about 30 MB at any size,\n"
    "up to 4.29 billion triangles, the 32-bit indices' limit); the torus and the\n"
    "other formats are made in memory first.\n"
    "\n"
    "kinds:\n"
    "  sphere   geodesic sphere (closed, genus 0)\n"
    "  torus    torus with round holes cut into it (open: several boundary loops)\n"
    "  scan     closed noisy scan-like surface with detail at every scale\n"
    "\n"
    "  -o, --output FILE   output file (.obj .ply .stl .xyz)\n"
    "  --triangles N       about N triangles (default 1M; accepts 250k, 4M, 1e7)\n"
    "  --seed S            seed of the random detail (default 1)\n"
    "  --ascii             text PLY/STL instead of binary\n"
    "  -q, --quiet         no summary on success (errors still print)\n";

/* The mesh to make. */
typedef struct generate_job {
    mr_generator kind;
    uint64_t triangles, seed;
} generate_job;

static int work(const cli_io *io, mr_mesh *mesh, mr_mesh *result, void *user)
{
    const generate_job *job = user;
    mr_error err;
    if (mr_generate(job->kind, (size_t)job->triangles, job->seed, result, &err) != MR_OK)
        return cli_fail_in(io->out, NULL, &err); /* the file it was to be */
    return CLI_OK;
}

static void print_summary(const cli_io *io, const mr_mesh *result, const cli_times *t,
                          void *user)
{
    const generate_job *job = user;
    char a[32], b[32], c[32];
    fprintf(stderr, "%s: %s %s vertices, %s triangles, %s (generate %.3f s, write %.3f s)\n",
            io->out, mr_generator_name(job->kind), cli_count(a, sizeof a, result->vertex_count),
            cli_count(b, sizeof b, result->triangle_count),
            cli_bytes(c, sizeof c, cli_file_size(io->out)), t->work, t->write);
}

static int run(int argc, char **argv)
{
    const char *kind_name = NULL;
    generate_job job = {.triangles = 1000000, .seed = 1};
    cli_io io;
    cli_io_init(&io, "generate", CLI_ACCEPT_OUTPUT);
    for (int i = 1; i < argc;) {
        const char *v;
        int rc = cli_io_option(&io, argc, argv, &i);
        if (rc == CLI_OK)
            continue;
        if (rc != CLI_NO_MATCH)
            return rc;
        if (cli_value(argc, argv, &i, "--triangles", &v)) {
            if (!cli_parse_count(v, &job.triangles) || job.triangles == 0)
                return cli_usage_error("generate", "--triangles needs a positive count, "
                                                   "got '%s'", v ? v : "");
        } else if (cli_value(argc, argv, &i, "--seed", &v)) {
            if (!cli_parse_count(v, &job.seed))
                return cli_usage_error("generate", "--seed needs a non-negative integer, "
                                                   "got '%s'", v ? v : "");
        } else if (cli_flag(argc, argv, &i, "--ascii"))
            io.write.encoding = MR_ENCODING_ASCII;
        else if (argv[i][0] == '-' && argv[i][1] != '\0')
            return cli_usage_error("generate", "unknown option '%s'", argv[i]);
        else if (kind_name)
            return cli_usage_error("generate", "one kind at a time");
        else
            kind_name = argv[i++];
    }
    if (!kind_name)
        return cli_usage_error("generate", "no kind given (sphere, torus or scan)");
    if (mr_generator_from_name(kind_name, &job.kind) != 0)
        return cli_usage_error("generate", "unknown kind '%s' (sphere, torus or scan)",
                               kind_name);
    if (!io.out)
        return cli_usage_error("generate", "no output file given (-o FILE)");
    int rc = cli_check_output_path(io.cmd, io.out, io.write.format);
    if (rc != CLI_OK)
        return rc;
    mr_format fmt = io.write.format != MR_FORMAT_AUTO ? io.write.format
                                                      : mr_format_from_path(io.out);
    if (fmt == MR_FORMAT_PLY && job.kind != MR_GEN_TORUS) {
        /* streamed into the file, block by block: any size in bounded
         * memory, the same bytes as the mesh made first */
        const double t0 = cli_now();
        size_t nv, nt;
        mr_error err;
        if (mr_generate_file(job.kind, (size_t)job.triangles, job.seed, io.out, &io.write, &nv,
                             &nt, &err) != MR_OK)
            return cli_fail_err(&err);
        if (!io.quiet) {
            char a[32], b[32], c[32];
            fprintf(stderr, "%s: %s %s vertices, %s triangles, %s (generated and written in "
                            "%.3f s)\n",
                    io.out, mr_generator_name(job.kind), cli_count(a, sizeof a, nv),
                    cli_count(b, sizeof b, nt), cli_bytes(c, sizeof c, cli_file_size(io.out)),
                    cli_now() - t0);
        }
        return CLI_OK;
    }
    /* io.in stays NULL: nothing is read, the work makes the mesh. */
    static const cli_job steps = {work, NULL, NULL, print_summary};
    return cli_run_job(&io, &steps, &job);
}

const cli_command cli_cmd_generate = {"generate", "write a procedural sphere, torus or scan",
                                      run, usage};
