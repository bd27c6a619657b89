/* meshreduce info FILE: counts, bounds and topology of a mesh. */
#include "cli.h"

#include <string.h>

static const char usage[] =
    "usage: meshreduce info FILE [--json] [-q]\n"
    "\n"
    "Print a mesh's counts, bounding box, boundary edges and loops, non-manifold\n"
    "edges and vertices, connected components, Euler characteristic and genus.\n"
    "The topology is the surface's: vertices that a file splits at one position only\n"
    "for their attributes (UV seams, hard edges) count as one surface point, and the\n"
    "splits are reported apart; parts that only touch at a point stay apart.\n"
    "\n"
    "  --json        one JSON object instead of the table\n"
    "  -q, --quiet   accepted, as by every command; info prints no progress or\n"
    "                summary to silence (the table or JSON is its output)\n";

/* Genus of an orientable manifold from chi = 2C - 2g - b; -1 when the
 * formula does not apply (non-manifold or point cloud). */
static long long genus_of(const mr_stats *s)
{
    if (!s->manifold || s->triangle_count == 0)
        return -1;
    long long twice = 2 * (long long)s->components - s->euler_characteristic -
                      (long long)s->boundary_loops;
    return twice >= 0 && twice % 2 == 0 ? twice / 2 : -1;
}

static void print_table(const char *path, const mr_mesh *m, const mr_stats *s,
                        double seconds)
{
    char a[32], b[32], c[32];
    unsigned long long size = cli_file_size(path);
    mr_format fmt = mr_format_from_path(path);
    printf("%-22s %s\n", "file", path);
    printf("%-22s %s, %s, read in %.3f s\n", "format", cli_format_name(fmt),
           cli_bytes(a, sizeof a, size), seconds);
    printf("%-22s %s (%s referenced, %s unreferenced)\n", "vertices",
           cli_count(a, sizeof a, s->vertex_count),
           cli_count(b, sizeof b, s->referenced_vertices),
           cli_count(c, sizeof c, s->unreferenced_vertices));
    if (s->split_vertices)
        printf("%-22s %s surface points; %s vertices repeat one at its position "
               "(attribute seams, cuts)\n",
               "", cli_count(a, sizeof a, s->surface_vertices),
               cli_count(b, sizeof b, s->split_vertices));
    printf("%-22s %s", "triangles", cli_count(a, sizeof a, s->triangle_count));
    if (s->triangle_count == 0)
        printf(" (point cloud)");
    printf("\n");
    const unsigned at = mr_mesh_attributes(m);
    printf("%-22s", "attributes");
    static const struct {
        unsigned flag;
        const char *name;
    } names[] = {{MR_ATTR_NORMALS, "normals"},       {MR_ATTR_TEXCOORDS, "texcoords"},
                 {MR_ATTR_TEXCOORDS1, "texcoords1"}, {MR_ATTR_TEXCOORDS2, "texcoords2"},
                 {MR_ATTR_TEXCOORDS3, "texcoords3"}, {MR_ATTR_TANGENTS, "tangents"},
                 {MR_ATTR_COLORS, "colors"},         {MR_ATTR_SKIN, "joints+weights"}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (at & names[i].flag)
            printf(" %s", names[i].name);
    printf("%s\n", at & ~MR_ATTR_MATERIALS ? "" : " none");
    if (m->materials)
        printf("%-22s %zu\n", "materials", mr_mesh_material_count(m));
    printf("%-22s %s\n", "edges", cli_count(a, sizeof a, s->edge_count));
    printf("%-22s %s in %s loop%s\n", "boundary edges",
           cli_count(a, sizeof a, s->boundary_edges),
           cli_count(b, sizeof b, s->boundary_loops), s->boundary_loops == 1 ? "" : "s");
    printf("%-22s %s\n", "non-manifold edges", cli_count(a, sizeof a, s->nonmanifold_edges));
    printf("%-22s %s\n", "non-manifold vertices",
           cli_count(a, sizeof a, s->nonmanifold_vertices));
    printf("%-22s %s\n", "misoriented edges", cli_count(a, sizeof a, s->misoriented_edges));
    printf("%-22s %s degenerate, %s duplicate\n", "bad triangles",
           cli_count(a, sizeof a, s->degenerate_triangles),
           cli_count(b, sizeof b, s->duplicate_triangles));
    printf("%-22s %s\n", "components", cli_count(a, sizeof a, s->components));
    printf("%-22s %lld\n", "euler characteristic", s->euler_characteristic);
    long long g = genus_of(s);
    if (g >= 0)
        printf("%-22s %lld\n", "genus", g);
    printf("%-22s %s, %s%s\n", "topology", s->closed ? "closed" : "open",
           s->manifold ? "manifold" : "non-manifold",
           !s->manifold ? "" : s->oriented ? ", consistently oriented"
                                           : ", not consistently oriented");
    printf("%-22s [%.6g, %.6g, %.6g] .. [%.6g, %.6g, %.6g]\n", "bounding box", s->bbox_min[0],
           s->bbox_min[1], s->bbox_min[2], s->bbox_max[0], s->bbox_max[1], s->bbox_max[2]);
    printf("%-22s %.6g\n", "bbox diagonal", s->bbox_diagonal);
    printf("%-22s %.6g\n", "surface area", s->surface_area);
}

static void print_json(const char *path, const mr_mesh *m, const mr_stats *s, double seconds)
{
    printf("{\"file\": ");
    cli_json_string(stdout, path);
    printf(", \"format\": \"%s\", \"bytes\": %llu, \"read_seconds\": %.6f",
           cli_format_name(mr_format_from_path(path)), cli_file_size(path), seconds);
    printf(", \"vertices\": %zu, \"referenced_vertices\": %zu, \"unreferenced_vertices\": %zu",
           s->vertex_count, s->referenced_vertices, s->unreferenced_vertices);
    printf(", \"surface_vertices\": %zu, \"split_vertices\": %zu", s->surface_vertices,
           s->split_vertices);
    printf(", \"triangles\": %zu, \"degenerate_triangles\": %zu, \"duplicate_triangles\": %zu",
           s->triangle_count, s->degenerate_triangles, s->duplicate_triangles);
    printf(", \"normals\": %s, \"texcoords\": %s, \"colors\": %s",
           m->normals ? "true" : "false", m->texcoords ? "true" : "false",
           m->colors ? "true" : "false");
    int sets = m->texcoords ? 1 : 0;
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        sets += m->more_texcoords[k] != NULL;
    printf(", \"texcoord_sets\": %d, \"tangents\": %s, \"skin\": %s, \"materials\": %zu", sets,
           m->tangents ? "true" : "false", m->joints ? "true" : "false",
           m->materials ? mr_mesh_material_count(m) : 0);
    printf(", \"edges\": %zu, \"boundary_edges\": %zu, \"boundary_loops\": %zu", s->edge_count,
           s->boundary_edges, s->boundary_loops);
    printf(", \"nonmanifold_edges\": %zu, \"nonmanifold_vertices\": %zu",
           s->nonmanifold_edges, s->nonmanifold_vertices);
    printf(", \"misoriented_edges\": %zu", s->misoriented_edges);
    printf(", \"components\": %zu, \"euler_characteristic\": %lld", s->components,
           s->euler_characteristic);
    long long g = genus_of(s);
    if (g >= 0)
        printf(", \"genus\": %lld", g);
    else
        printf(", \"genus\": null");
    printf(", \"closed\": %s, \"manifold\": %s, \"oriented\": %s", s->closed ? "true" : "false",
           s->manifold ? "true" : "false", s->oriented ? "true" : "false");
    printf(", \"bbox_min\": [%.9g, %.9g, %.9g], \"bbox_max\": [%.9g, %.9g, %.9g]",
           s->bbox_min[0], s->bbox_min[1], s->bbox_min[2], s->bbox_max[0], s->bbox_max[1],
           s->bbox_max[2]);
    printf(", \"bbox_diagonal\": %.9g, \"surface_area\": %.9g}\n", s->bbox_diagonal,
           s->surface_area);
}

static int run(int argc, char **argv)
{
    const char *path = NULL;
    bool json = false;
    for (int i = 1; i < argc;) {
        if (cli_flag(argc, argv, &i, "--json"))
            json = true;
        else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet"))
            continue; /* nothing to silence */
        else if (argv[i][0] == '-' && argv[i][1] != '\0')
            return cli_usage_error("info", "unknown option '%s'", argv[i]);
        else if (path)
            return cli_usage_error("info", "one file at a time ('%s' and '%s' given)", path,
                                   argv[i]);
        else
            path = argv[i++];
    }
    if (!path)
        return cli_usage_error("info", "no input file given");

    mr_mesh mesh;
    mr_error err;
    double t0 = cli_now();
    if (mr_mesh_read(path, NULL, &mesh, &err) != MR_OK)
        return cli_fail_err(&err);
    double seconds = cli_now() - t0;

    mr_stats stats;
    if (mr_stats_compute(mesh.positions, 0, mesh.vertex_count, mesh.indices,
                         mesh.triangle_count, &stats, &err) != MR_OK) {
        mr_mesh_free(&mesh);
        return cli_fail_in(path, NULL, &err);
    }
    if (json)
        print_json(path, &mesh, &stats, seconds);
    else
        print_table(path, &mesh, &stats, seconds);
    mr_mesh_free(&mesh);
    return CLI_OK;
}

const cli_command cli_cmd_info = {"info", "counts, bounds and topology of a mesh", run, usage};
