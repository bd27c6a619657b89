/* meshreduce compare REF TEST: surface distances between two meshes. */
#include "cli.h"

#include <string.h>

#include "../src/core/omp_compat.h"

static const char usage[] =
    "usage: meshreduce compare REF TEST [--samples N] [--seed S] [--json] [-q]\n"
    "\n"
    "Measure how far the surface of TEST is from that of REF (e.g. a mesh and its\n"
    "reduction), Metro-style: the points of each surface (its vertices and N\n"
    "area-uniform samples) and the exact distance from each to the other surface.\n"
    "Prints the Hausdorff distance (the largest of both one-sided maxima), the RMS\n"
    "and mean distance over the points of both directions, each one-sided maximum\n"
    "and RMS, and the modified Hausdorff distance (RMS over REF's vertices of the\n"
    "distance to the nearest vertex of TEST); absolute and as a percentage of\n"
    "REF's bounding-box diagonal. Where both meshes have normals, texture\n"
    "coordinates or colors, their deviation at the matched points too (each\n"
    "point's nearest point on the other surface, both interpolated there): the\n"
    "normals' angle in degrees, the UV distance, the RGBA distance; RMS and\n"
    "largest (at a seam the largest is the seam's jump). With texture\n"
    "coordinates, the texture deviation too: from each point, the distance to the\n"
    "nearest point of the other surface with the same UV (how far the texture\n"
    "moved on the surface, free of the seams' jumps), over the points whose UV\n"
    "the other map covers within 5 % of the diagonal. The same meshes, samples\n"
    "and seed give the same figures on any number of threads.\n"
    "\n"
    "  --samples N   surface samples per mesh besides its vertices (default 1M;\n"
    "                0 = vertices only)\n"
    "  --seed S      sampling seed (default 1)\n"
    "  --json        one JSON object instead of the table\n"
    "  -q, --quiet   accepted, as by every command; compare prints no progress or\n"
    "                summary to silence (the table or JSON is its output)\n";

typedef struct compare_args {
    const char *ref, *test;
    uint64_t samples, seed;
    bool json;
} compare_args;

/* Returns -1 when the arguments are fine, else the exit status. */
static int parse(int argc, char **argv, compare_args *a)
{
    for (int i = 1; i < argc;) {
        const char *v = NULL;
        if (cli_flag(argc, argv, &i, "--json")) {
            a->json = true;
        } else if (cli_flag(argc, argv, &i, "-q") || cli_flag(argc, argv, &i, "--quiet")) {
            /* nothing to silence */
        } else if (cli_value(argc, argv, &i, "--samples", &v)) {
            if (!v || !cli_parse_count(v, &a->samples) || a->samples > ((uint64_t)1 << 40))
                return cli_usage_error("compare", "--samples needs a count up to 1T, "
                                                  "like 1000000 or 2M");
        } else if (cli_value(argc, argv, &i, "--seed", &v)) {
            if (!v || !cli_parse_count(v, &a->seed))
                return cli_usage_error("compare", "--seed needs a non-negative integer");
        } else if (argv[i][0] == '-' && argv[i][1] != '\0') {
            return cli_usage_error("compare", "unknown option '%s'", argv[i]);
        } else if (!a->ref) {
            a->ref = argv[i++];
        } else if (!a->test) {
            a->test = argv[i++];
        } else {
            return cli_usage_error("compare", "two files at a time ('%s' is a third)",
                                   argv[i]);
        }
    }
    if (!a->test)
        return cli_usage_error("compare", "needs two files: REF TEST");
    return -1;
}

static int read_mesh(const char *path, mr_mesh *m)
{
    mr_error err;
    if (mr_mesh_read(path, NULL, m, &err) != MR_OK)
        return cli_fail_err(&err);
    if (m->triangle_count == 0) {
        mr_mesh_free(m);
        return cli_fail("%s: has no triangles (a point cloud): nothing to compare", path);
    }
    return CLI_OK;
}

/* A failed comparison: the library calls the meshes "reference mesh" and
 * "test mesh"; the user knows them by their files. */
static int compare_failed(const compare_args *a, const mr_error *err)
{
    static const char *const names[2] = {"reference mesh", "test mesh"};
    const char *msg = err->message[0] ? err->message : mr_status_string(err->status);
    for (int k = 0; k < 2; k++) {
        size_t n = strlen(names[k]);
        if (!strncmp(msg, names[k], n) && (msg[n] == ':' || msg[n] == ' '))
            return cli_fail("%s%s", k ? a->test : a->ref, msg + n);
    }
    return cli_fail("%s, %s: %s", a->ref, a->test, msg);
}

static int threads_used(void)
{
    return omp_get_max_threads();
}

static void print_row(const char *name, double v, double diagonal)
{
    if (diagonal > 0)
        printf("  %-24s %14.7g   %10.6f %%\n", name, v, 100 * v / diagonal);
    else
        printf("  %-24s %14.7g\n", name, v);
}

static void print_table(const compare_args *a, const mr_mesh *ref, const mr_mesh *test,
                        const mr_compare_result *r, const mr_attribute_error *e, double read_s,
                        double compare_s)
{
    char x[32], y[32], z[32];
    printf("%-18s %s (%s triangles, %s vertices)\n", "reference", a->ref,
           cli_count(x, sizeof x, ref->triangle_count),
           cli_count(y, sizeof y, ref->vertex_count));
    printf("%-18s %s (%s triangles, %s vertices)\n", "test", a->test,
           cli_count(x, sizeof x, test->triangle_count),
           cli_count(y, sizeof y, test->vertex_count));
    printf("%-18s %s on the reference, %s on the test (%s samples each, seed %llu)\n",
           "points", cli_count(x, sizeof x, r->ref_points), cli_count(y, sizeof y, r->test_points),
           cli_count(z, sizeof z, a->samples), (unsigned long long)a->seed);
    printf("%-18s %.7g\n\n", "bbox diagonal", r->diagonal);
    printf("  %-24s %14s   %12s\n", "distance", "absolute", "% of diagonal");
    print_row("hausdorff", r->hausdorff, r->diagonal);
    print_row("  reference -> test max", r->ref_to_test_max, r->diagonal);
    print_row("  test -> reference max", r->test_to_ref_max, r->diagonal);
    print_row("rms", r->rms, r->diagonal);
    print_row("  reference -> test rms", r->ref_to_test_rms, r->diagonal);
    print_row("  test -> reference rms", r->test_to_ref_rms, r->diagonal);
    print_row("mean", r->mean, r->diagonal);
    print_row("modified hausdorff", r->modified_hausdorff, r->diagonal);
    if (e->attributes) {
        printf("\n  %-24s %14s   %12s   (at matched surface points)\n", "attribute", "rms",
               "max");
        if (e->attributes & MR_ATTR_NORMALS)
            printf("  %-24s %14.7g   %12.7g\n", "normal angle (degrees)", e->normal_rms,
                   e->normal_max);
        if (e->attributes & MR_ATTR_TEXCOORDS)
            printf("  %-24s %14.7g   %12.7g\n", "texcoord distance", e->texcoord_rms,
                   e->texcoord_max);
        if (e->attributes & MR_ATTR_COLORS)
            printf("  %-24s %14.7g   %12.7g\n", "color distance (rgba)", e->color_rms,
                   e->color_max);
        if (e->attributes & MR_ATTR_TEXCOORDS) {
            printf("\n  texture deviation (the distance to the point of equal UV; %.1f %% of "
                   "the points, the others' UV not covered)\n",
                   e->points ? 100.0 * (double)e->texture_points / (double)e->points : 0.0);
            print_row("texture rms", e->texture_rms, r->diagonal);
            print_row("texture max", e->texture_max, r->diagonal);
        }
    }
    printf("\n%-18s compare %.3f s, read %.3f s, %d thread%s\n", "time", compare_s, read_s,
           threads_used(), threads_used() == 1 ? "" : "s");
}

static void print_json(const compare_args *a, const mr_mesh *ref, const mr_mesh *test,
                       const mr_compare_result *r, const mr_attribute_error *e, double read_s,
                       double compare_s)
{
    printf("{\"reference\": ");
    cli_json_string(stdout, a->ref);
    printf(", \"test\": ");
    cli_json_string(stdout, a->test);
    printf(", \"reference_triangles\": %zu, \"test_triangles\": %zu", ref->triangle_count,
           test->triangle_count);
    printf(", \"samples\": %llu, \"seed\": %llu, \"reference_points\": %zu"
           ", \"test_points\": %zu",
           (unsigned long long)a->samples, (unsigned long long)a->seed, r->ref_points,
           r->test_points);
    printf(", \"diagonal\": %.17g", r->diagonal);
    printf(", \"hausdorff\": %.17g, \"rms\": %.17g, \"mean\": %.17g", r->hausdorff, r->rms,
           r->mean);
    printf(", \"reference_to_test_max\": %.17g, \"test_to_reference_max\": %.17g",
           r->ref_to_test_max, r->test_to_ref_max);
    printf(", \"reference_to_test_rms\": %.17g, \"test_to_reference_rms\": %.17g",
           r->ref_to_test_rms, r->test_to_ref_rms);
    printf(", \"modified_hausdorff\": %.17g", r->modified_hausdorff);
    printf(", \"hausdorff_rel\": %.17g, \"rms_rel\": %.17g, \"mean_rel\": %.17g"
           ", \"modified_hausdorff_rel\": %.17g",
           r->hausdorff_rel, r->rms_rel, r->mean_rel, r->modified_hausdorff_rel);
    if (e->attributes & MR_ATTR_NORMALS)
        printf(", \"normal_rms_degrees\": %.17g, \"normal_max_degrees\": %.17g", e->normal_rms,
               e->normal_max);
    if (e->attributes & MR_ATTR_TEXCOORDS)
        printf(", \"texcoord_rms\": %.17g, \"texcoord_max\": %.17g, \"texture_rms\": %.17g, "
               "\"texture_max\": %.17g, \"texture_rms_rel\": %.17g, \"texture_max_rel\": %.17g, "
               "\"texture_points\": %zu, \"attribute_points\": %zu",
               e->texcoord_rms, e->texcoord_max, e->texture_rms, e->texture_max,
               e->texture_rms_rel, e->texture_max_rel, e->texture_points, e->points);
    if (e->attributes & MR_ATTR_COLORS)
        printf(", \"color_rms\": %.17g, \"color_max\": %.17g", e->color_rms, e->color_max);
    printf(", \"threads\": %d, \"read_seconds\": %.6f, \"compare_seconds\": %.6f}\n",
           threads_used(), read_s, compare_s);
}

static int run(int argc, char **argv)
{
    compare_args a = {NULL, NULL, 1000000, 1, false};
    int rc = parse(argc, argv, &a);
    if (rc >= 0)
        return rc;

    mr_mesh ref, test;
    mr_mesh_init(&ref);
    mr_mesh_init(&test);
    double t0 = cli_now();
    if ((rc = read_mesh(a.ref, &ref)) != CLI_OK)
        return rc;
    if ((rc = read_mesh(a.test, &test)) != CLI_OK) {
        mr_mesh_free(&ref);
        return rc;
    }
    double t1 = cli_now();

    mr_compare_options opt;
    mr_compare_options_default(&opt);
    opt.samples = (size_t)a.samples;
    opt.seed = a.seed;
    mr_compare_result r;
    mr_error err;
    mr_status st = mr_compare(ref.positions, ref.vertex_count, ref.indices, ref.triangle_count,
                              test.positions, test.vertex_count, test.indices,
                              test.triangle_count, &opt, &r, &err);
    /* the attributes both have, at the same points */
    mr_attribute_error e;
    memset(&e, 0, sizeof e);
    if (st == MR_OK && (mr_mesh_attributes(&ref) & mr_mesh_attributes(&test) & MR_ATTR_BASIC))
        st = mr_compare_attributes(&ref, &test, &opt, &e, &err);
    double t2 = cli_now();
    if (st == MR_OK) {
        if (a.json)
            print_json(&a, &ref, &test, &r, &e, t1 - t0, t2 - t1);
        else
            print_table(&a, &ref, &test, &r, &e, t1 - t0, t2 - t1);
    }
    mr_mesh_free(&ref);
    mr_mesh_free(&test);
    return st == MR_OK ? CLI_OK : compare_failed(&a, &err);
}

const cli_command cli_cmd_compare = {"compare", "surface distances between two meshes", run,
                                     usage};
