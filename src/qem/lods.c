/* mr_mesh_lods: a chain of levels of detail, each simplified from the one
 * before and measured against the input. */
#include "../core/internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void mr_lod_levels_free(mr_lod_level *levels, size_t count)
{
    for (size_t i = 0; levels && i < count; i++) {
        mr_mesh_free(&levels[i].mesh);
        free(levels[i].origin);
        levels[i].origin = NULL;
    }
}

mr_status mr_mesh_lods(const mr_mesh *in, const double *fractions, size_t count,
                       const mr_simplify_options *options, size_t samples,
                       mr_lod_level *levels, mr_error *err)
{
    mr_error_clear(err);
    if (!in || !fractions || !levels || !options || count == 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "levels of detail: no mesh, fractions, options or levels given");
    for (size_t i = 0; i < count; i++) {
        memset(&levels[i], 0, sizeof levels[i]);
        mr_mesh_init(&levels[i].mesh);
    }
    if (options->target_ratio != 0 || options->target_vertices || options->target_triangles ||
        options->until_error)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "levels of detail: the levels are the targets (no ratio, vertex "
                             "or triangle target besides)");
    for (size_t i = 0; i < count; i++)
        if (!(fractions[i] > 0 && fractions[i] < 1) || (i && !(fractions[i] < fractions[i - 1])))
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                                 "levels of detail: level %zu's fraction %g is not in (0, 1) "
                                 "below the level before's",
                                 i + 1, fractions[i]);
    if (in->triangle_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL, "levels of detail: the mesh has no triangles");
    mr_compare_options co;
    mr_compare_options_default(&co);
    if (samples)
        co.samples = samples;
    co.threads = options->threads;
    mr_reference *ref = NULL;
    mr_status st = mr_reference_build(in->positions, in->vertex_count, in->indices,
                                      in->triangle_count, &co, &ref, err);
    double worst = 0;
    for (size_t i = 0; i < count && st == MR_OK; i++) {
        mr_lod_level *l = &levels[i];
        const mr_mesh *from = i ? &levels[i - 1].mesh : in;
        mr_simplify_options o = *options;
        const double t = fractions[i] * (double)in->triangle_count;
        l->target_triangles = t < 1 ? 1 : (size_t)llround(t);
        o.target_triangles = l->target_triangles < from->triangle_count ? l->target_triangles
                                                                         : from->triangle_count;
        uint32_t *origin = NULL;
        st = mr_mesh_simplify(from, &o, &l->mesh, &origin, &l->stats, err);
        if (st != MR_OK)
            break;
        if (i) { /* through the level before to the input */
            const uint32_t *prev = levels[i - 1].origin;
            for (size_t v = 0; v < l->mesh.vertex_count; v++)
                origin[v] = prev[origin[v]];
        }
        l->origin = origin;
        mr_compare_result r;
        st = mr_compare_with(ref, l->mesh.positions, l->mesh.vertex_count, l->mesh.indices,
                             l->mesh.triangle_count, &r, err);
        if (st != MR_OK)
            break;
        l->hausdorff_rel = r.hausdorff_rel;
        l->rms_rel = r.rms_rel;
        worst = r.hausdorff_rel > worst ? r.hausdorff_rel : worst;
        l->error_rel = worst;
    }
    mr_reference_free(ref);
    return st;
}
