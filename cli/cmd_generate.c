/* meshreduce generate KIND: the built-in procedural meshes. */
#include "cli.h"

#include <string.h>

static const char usage[] =
    "usage: meshreduce generate KIND -o FILE [--triangles N] [--seed S] [options]\n"
    "\n"
    "Write a procedural mesh. Deterministic: the same kind, size and seed give\n"
    "the same file on every machine and thread count.\n"
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
    "  -q, --quiet         print nothing on success\n";

static int run(int argc, char **argv)
{
    const char *kind_name = NULL, *out = NULL;
    uint64_t triangles = 1000000, seed = 1;
    bool quiet = false;
    mr_write_options w;
    mr_write_options_default(&w);
    for (int i = 1; i < argc;) {
        const char *v;
        if (cli_value(argc, argv, &i, "-o", &v) || cli_value(argc, argv, &i, "--output", &v)) {
            if (!v)
                return cli_usage_error("generate", "-o needs a file name");
            out = v;
        } else if (cli_value(argc, argv, &i, "--triangles", &v)) {
            if (!cli_parse_count(v, &triangles) || triangles == 0)
                return cli_usage_error("generate", "--triangles needs a positive count, "
                                                   "got '%s'", v ? v : "");
        } else if (cli_value(argc, argv, &i, "--seed", &v)) {
            if (!cli_parse_count(v, &seed))
                return cli_usage_error("generate", "--seed needs a non-negative integer, "
                                                   "got '%s'", v ? v : "");
        } else if (cli_flag(argc, argv, &i, "--ascii"))
            w.encoding = MR_ENCODING_ASCII;
        else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet"))
            quiet = true;
        else if (argv[i][0] == '-' && argv[i][1] != '\0')
            return cli_usage_error("generate", "unknown option '%s'", argv[i]);
        else if (kind_name)
            return cli_usage_error("generate", "one kind at a time");
        else
            kind_name = argv[i++];
    }
    mr_generator kind;
    if (!kind_name)
        return cli_usage_error("generate", "no kind given (sphere, torus or scan)");
    if (mr_generator_from_name(kind_name, &kind) != 0)
        return cli_usage_error("generate", "unknown kind '%s' (sphere, torus or scan)",
                               kind_name);
    if (!out)
        return cli_usage_error("generate", "no output file given (-o FILE)");
    int rc = cli_check_output_path("generate", out);
    if (rc != CLI_OK)
        return rc;

    mr_mesh mesh;
    mr_error err;
    double t0 = cli_now();
    if (mr_generate(kind, (size_t)triangles, seed, &mesh, &err) != MR_OK)
        return cli_fail_err(&err);
    double t1 = cli_now();
    if (mr_mesh_write(out, &mesh, &w, &err) != MR_OK) {
        mr_mesh_free(&mesh);
        return cli_fail_err(&err);
    }
    double t2 = cli_now();
    if (!quiet) {
        char a[32], b[32], c[32];
        fprintf(stderr, "%s: %s %s vertices, %s triangles, %s (generate %.3f s, write %.3f s)\n",
                out, mr_generator_name(kind), cli_count(a, sizeof a, mesh.vertex_count),
                cli_count(b, sizeof b, mesh.triangle_count),
                cli_bytes(c, sizeof c, cli_file_size(out)), t1 - t0, t2 - t1);
    }
    mr_mesh_free(&mesh);
    return CLI_OK;
}

const cli_command cli_cmd_generate = {"generate", "write a procedural sphere, torus or scan",
                                      run, usage};
