/* meshreduce convert IN OUT and meshreduce clean IN -o OUT. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

/* The cleanup steps, in the order that makes each one's result final. */
typedef struct clean_steps {
    bool weld, weld_attributes, keep_degenerate, keep_duplicates, keep_unreferenced,
        keep_winding;
} clean_steps;

/* What the steps did, for the report. */
typedef struct clean_counts {
    size_t welded, degenerate, unreferenced, flipped, nonorientable;
} clean_counts;

static int clean_mesh(const char *path, mr_mesh *m, const clean_steps *c, clean_counts *n)
{
    mr_error err;
    if (c->weld && mr_mesh_weld_exact(m, c->weld_attributes, &n->welded, &err) != MR_OK)
        return cli_fail_in(path, NULL, &err);
    if (!c->keep_degenerate &&
        mr_mesh_remove_degenerate(m, !c->keep_duplicates, &n->degenerate, &err) != MR_OK)
        return cli_fail_in(path, NULL, &err);
    if (!c->keep_unreferenced && mr_mesh_remove_unreferenced(m, &n->unreferenced, &err) != MR_OK)
        return cli_fail_in(path, NULL, &err);
    if (!c->keep_winding && mr_mesh_orient(m, &n->flipped, &n->nonorientable, &err) != MR_OK)
        return cli_fail_in(path, NULL, &err);
    return CLI_OK;
}

static void print_counts(const clean_counts *n)
{
    char a[32], b[32], d[32];
    fprintf(stderr,
            "cleaned: %s vertices welded, %s degenerate or duplicate triangles and %s "
            "unreferenced vertices removed\n",
            cli_count(a, sizeof a, n->welded), cli_count(b, sizeof b, n->degenerate),
            cli_count(d, sizeof d, n->unreferenced));
    if (n->flipped)
        fprintf(stderr, "cleaned: %s triangles flipped to their neighbours' winding\n",
                cli_count(a, sizeof a, n->flipped));
    if (n->nonorientable)
        fprintf(stderr, "cleaned: %s part%s cannot be oriented (left as %s)\n",
                cli_count(a, sizeof a, n->nonorientable), n->nonorientable == 1 ? "" : "s",
                n->nonorientable == 1 ? "it is" : "they are");
}

/* What convert and clean do between reading and writing. */
typedef struct clean_job {
    clean_steps steps;
    bool clean; /* run the steps; else the mesh is written as read */
    cli_choice weld_option; /* --no-weld and --weld-attributes exclude each other */
    clean_counts counts;
    mr_obj_materials mats;  /* an OBJ into an OBJ: its materials (convert) */
    mr_write_options *write; /* where they go: the io's write options */
} clean_job;

/* The attributes the output leaves out (--no-normals, --no-texcoords,
 * --no-colors) go before the write, and with them the vertex splits that
 * only they caused (a UV seam, once the texture coordinates are dropped):
 * the vertices of one surface point that no longer differ are merged. */
static int drop_unwritten(const cli_io *io, mr_mesh *m)
{
    bool dropped = false;
    if (m->normals && !io->write.write_normals) {
        free(m->normals);
        m->normals = NULL;
        dropped = true;
    }
    if (m->texcoords && !io->write.write_texcoords) {
        free(m->texcoords);
        m->texcoords = NULL;
        dropped = true;
    }
    if (m->colors && !io->write.write_colors) {
        free(m->colors);
        m->colors = NULL;
        dropped = true;
    }
    mr_error err;
    if (dropped && mr_mesh_weld_seams(m, NULL, &err) != MR_OK)
        return cli_fail_in(io->in, NULL, &err);
    return CLI_OK;
}

static int work(const cli_io *io, mr_mesh *mesh, mr_mesh *result, void *user)
{
    clean_job *job = user;
    int rc = drop_unwritten(io, mesh);
    if (rc == CLI_OK && job->clean)
        rc = clean_mesh(io->in, mesh, &job->steps, &job->counts);
    if (rc == CLI_OK) {
        *result = *mesh;
        mr_mesh_init(mesh);
        /* the usemtl groups, face for face as read */
        if (job->write)
            cli_obj_materials_use(job->write, &job->mats, result, io->in);
    }
    return rc;
}

/* Printed only once the output is written: what was cleaned, then what
 * was written. */
static void print_summary(const cli_io *io, const mr_mesh *result, const cli_times *t,
                          void *user)
{
    const clean_job *job = user;
    if (job->clean)
        print_counts(&job->counts);
    cli_summary(io->out, result->vertex_count, result->triangle_count,
                "read %.3f s, %s%.3f s, write %.3f s", t->read, job->clean ? "clean " : "",
                job->clean ? t->work : 0.0, t->write);
}

static const cli_job clean_and_write = {work, NULL, NULL, print_summary};

static const char convert_usage[] =
    "usage: meshreduce convert IN OUT [options]\n"
    "\n"
    "Convert a mesh or point cloud between OBJ, PLY, STL, XYZ and glTF (.gltf,\n"
    ".glb; formats by extension). A glTF file into glTF keeps its document\n"
    "(scene, nodes, materials, skins, animations; its buffers joined into one);\n"
    "read into another format, a glTF scene is its triangles in world space.\n"
    "Vertex order and triangles are kept as read; when --no-normals,\n"
    "--no-texcoords or --no-colors drops an attribute, the vertices that only it\n"
    "split (a UV seam) are merged back into one.\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP
    "  --clean          also clean the mesh as `meshreduce clean` does (weld exact\n"
    "                   duplicates; remove degenerate, duplicate triangles and\n"
    "                   unreferenced vertices; make the winding consistent)\n"
    "  -q, --quiet      no summary on success (errors still print)\n";

static int convert_option(int argc, char **argv, int *i, void *user)
{
    if (!cli_flag(argc, argv, i, "--clean"))
        return CLI_NO_MATCH;
    ((clean_job *)user)->clean = true;
    return CLI_OK;
}

static int run_convert(int argc, char **argv)
{
    cli_io io;
    cli_io_init(&io, "convert", CLI_ACCEPT_WRITE);
    clean_job job = {.steps = {.weld = true}, .clean = false};
    int rc = cli_io_parse(&io, argc, argv, convert_option, &job);
    if (rc == CLI_OK)
        rc = cli_check_output_path(io.cmd, io.out, io.write.format);
    const mr_format out_format =
        io.write.format != MR_FORMAT_AUTO ? io.write.format : mr_format_from_path(io.out);
    if (rc == CLI_OK && !job.clean && mr_format_from_path(io.in) == MR_FORMAT_GLTF &&
        out_format == MR_FORMAT_GLTF) {
        /* the document itself, not its scene as one mesh */
        const double t0 = cli_now();
        size_t prims;
        mr_error err;
        if (mr_convert_gltf(io.in, io.out, &prims, &err) != MR_OK)
            return cli_fail_err(&err);
        if (!io.quiet)
            fprintf(stderr, "%s: the glTF document, %zu triangle primitive%s (written in %.3f s)\n",
                    io.out, prims, prims == 1 ? "" : "s", cli_now() - t0);
        return CLI_OK;
    }
    /* an OBJ into an OBJ keeps its mtllib and usemtl groups (the faces
     * as read; --clean drops triangles, and the groups with them) */
    if (rc == CLI_OK && !job.clean)
        rc = cli_obj_materials(&io, &job.mats);
    job.write = &io.write;
    if (rc == CLI_OK)
        rc = cli_run_job(&io, &clean_and_write, &job);
    mr_obj_materials_free(&job.mats);
    return rc;
}

static const char clean_usage[] =
    "usage: meshreduce clean IN -o OUT [options]\n"
    "\n"
    "Repair a mesh for processing: weld vertices at bitwise-equal positions,\n"
    "remove triangles that repeat a vertex, duplicate triangles (either\n"
    "orientation) and vertices no triangle uses, and wind every triangle like\n"
    "its neighbours (each connected part keeps its majority winding; the\n"
    "simplifier cannot move a vertex whose triangles disagree). The order of\n"
    "what stays is kept.\n"
    "\n"
    "  -o, --output FILE       output file (required)\n"
    "  --no-weld               do not weld duplicate positions\n"
    "  --weld-attributes       weld only vertices whose normals, texture\n"
    "                          coordinates and colors are equal too (keeps seams;\n"
    "                          not with --no-weld)\n"
    "  --keep-duplicates       keep duplicate triangles\n"
    "  --keep-degenerate       keep triangles that repeat a vertex (duplicate\n"
    "                          triangles too: both go in one step)\n"
    "  --keep-unreferenced     keep unreferenced vertices\n"
    "  --keep-winding          leave every triangle's winding as it is\n"
    "  -q, --quiet             no report on success (errors still print); the\n"
    "                          report comes only once OUT is written\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP;

static int clean_option(int argc, char **argv, int *i, void *user)
{
    clean_job *job = user;
    clean_steps *c = &job->steps;
    static const char group[] = "--weld-attributes sets how to weld, --no-weld not to weld";
    const char *a = argv[*i];
    if (!strcmp(a, "--no-weld") || !strcmp(a, "--weld-attributes")) {
        int rc = cli_choose_flag(&job->weld_option, "clean", a, group);
        if (rc != CLI_OK)
            return rc;
    }
    if (cli_flag(argc, argv, i, "--no-weld"))
        c->weld = false;
    else if (cli_flag(argc, argv, i, "--weld-attributes"))
        c->weld_attributes = true;
    else if (cli_flag(argc, argv, i, "--keep-duplicates"))
        c->keep_duplicates = true;
    else if (cli_flag(argc, argv, i, "--keep-degenerate"))
        c->keep_degenerate = true;
    else if (cli_flag(argc, argv, i, "--keep-unreferenced"))
        c->keep_unreferenced = true;
    else if (cli_flag(argc, argv, i, "--keep-winding"))
        c->keep_winding = true;
    else
        return CLI_NO_MATCH;
    return CLI_OK;
}

static int run_clean(int argc, char **argv)
{
    cli_io io;
    cli_io_init(&io, "clean", CLI_ACCEPT_OUTPUT | CLI_ACCEPT_WRITE);
    clean_job job = {.steps = {.weld = true}, .clean = true};
    int rc = cli_io_parse(&io, argc, argv, clean_option, &job);
    if (rc == CLI_OK)
        rc = cli_check_output_path(io.cmd, io.out, io.write.format);
    return rc == CLI_OK ? cli_run_job(&io, &clean_and_write, &job) : rc;
}

const cli_command cli_cmd_convert = {"convert", "convert between OBJ, PLY, STL, XYZ and glTF",
                                     run_convert, convert_usage};
const cli_command cli_cmd_clean = {"clean", "weld duplicates, drop degenerate and unused, fix winding",
                                   run_clean, clean_usage};
