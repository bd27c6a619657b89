/* A tiny program built against an installed meshreduce: it generates a
 * sphere, simplifies it to half its vertices and prints the counts. Exits
 * nonzero when anything fails or the version does not match the header. */
#include <meshreduce.h>
#include <stdio.h>
#include <string.h>

int main(void)
{
    if (strcmp(mr_version(), MR_VERSION_STRING) != 0) {
        fprintf(stderr, "library %s, header %s\n", mr_version(), MR_VERSION_STRING);
        return 1;
    }
    mr_mesh mesh, out;
    mr_mesh_init(&mesh);
    mr_mesh_init(&out);
    mr_error err;
    if (mr_generate(MR_GEN_SPHERE, 2000, 1, &mesh, &err) != MR_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = 0.5;
    mr_simplify_stats s;
    if (mr_mesh_simplify(&mesh, &o, &out, NULL, &s, &err) != MR_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    printf("consumer ok: %zu -> %zu triangles\n", mesh.triangle_count, out.triangle_count);
    int ok = out.triangle_count > 0 && out.triangle_count < mesh.triangle_count;
    mr_mesh_free(&mesh);
    mr_mesh_free(&out);
    return ok ? 0 : 1;
}
