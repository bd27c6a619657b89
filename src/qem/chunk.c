/*
 * mr_simplify_chunk (chunk.h): mr_simplify's phases on a chunk of a larger
 * mesh -- its cut vertices locked and marked (mr_vertex_marks), its
 * quadrics carried in from the chunks it was made of -- keeping the
 * quadrics through the run so that the survivors' go out with them.
 */
#include "chunk.h"
#include "entry.h"

#include "../core/omp_compat.h"

#include <math.h>

void mr_chunk_result_free(mr_chunk_result *r)
{
    if (!r)
        return;
    mr_simplified_free(&r->mesh);
    free(r->quadrics);
    free(r->normals);
    free(r->texcoords);
    free(r->colors);
    r->quadrics = NULL;
    r->normals = r->texcoords = r->colors = NULL;
}

/* The output vertices' quadrics: each survivor's, moved from where the
 * run left it (pos, normalised) to its output position, in the chunk's
 * unit. */
static mr_status out_quadrics(const mr_simplifier *s, const float *pos, double unit,
                              mr_chunk_result *out, mr_error *err)
{
    const mr_simplified *o = &out->mesh;
    out->quadrics = mr_alloc_array(o->vertex_count ? o->vertex_count : 1, sizeof *out->quadrics);
    if (!out->quadrics)
        return mr_fail_nomem(err, NULL, o->vertex_count * sizeof *out->quadrics);
    for (size_t i = 0; i < o->vertex_count; i++)
        mr_simplifier_quadric_out(s, o->origin[i], pos, o->positions + 3 * i, unit,
                                  &out->quadrics[i]);
    return MR_OK;
}

static mr_status simplify_chunk(const mr_chunk *c, const mr_simplify_options *options,
                                mr_chunk_result *out, mr_error *err)
{
    const double t0 = mr_now_seconds();
    const size_t vc = c->vertex_count, tc = c->triangle_count;
    uint8_t *flags = mr_alloc_array(vc ? vc : 1, 1);
    if (!flags)
        return mr_fail_nomem(err, NULL, vc);
    for (size_t v = 0; v < vc; v++)
        flags[v] = (c->cut[v] || (c->locked && c->locked[v])) ? MR_VF_LOCKED : 0;
    mr_simplify_options o = *options;
    o.vertex_lock = NULL;
    const mr_vertex_marks marks = {.flags = flags,
                                   .cut = c->cut,
                                   .quadrics = c->quadrics,
                                   .was_cut = c->was_cut,
                                   .unit = c->unit};
    mr_simplifier s;
    mr_status st = mr_simplify_setup(&s, c->positions, 0, vc, c->indices, tc, &o, &marks, err);
    free(flags);
    if (st != MR_OK)
        return st;
    free(s.order); /* the output follows the working order */
    s.order = NULL;
    st = mr_simplifier_fill_queue(&s, err);
    if (st != MR_OK) {
        mr_simplify_discard(&s);
        return st;
    }
    const double t1 = mr_now_seconds();
    double max_error;
    size_t collapses = mr_simplify_run(&s, &max_error);
    /* the strategy's state goes; the quadrics stay for the output */
    mr_simplify_strategy(&s)->release(&s);
    float *before = NULL; /* where the collapses left the vertices */
    if (o.quality == MR_QUALITY_BEST && !s.cancelled) {
        before = mr_alloc_array(3 * vc, sizeof *before);
        if (!before) {
            mr_simplify_discard(&s);
            return mr_fail_nomem(err, NULL, 12 * vc);
        }
        memcpy(before, s.m.pos, 12 * vc);
        st = mr_simplifier_refine(&s, c->positions, 0, c->indices, tc, err);
        if (st != MR_OK) {
            free(before);
            mr_simplify_discard(&s);
            return st;
        }
    }
    const double t2 = mr_now_seconds();
    if (s.cancelled) {
        free(before);
        mr_simplify_discard(&s);
        return mr_simplifier_cancelled(err);
    }
    st = mr_simplifier_output(&s, c->positions, 0, &out->mesh, err);
    if (st == MR_OK)
        st = out_quadrics(&s, before ? before : s.m.pos, c->unit, out, err);
    free(before);
    const size_t input_vertices = s.input_vertices, blocked = s.blocked_vertices;
    const mr_simplify_stop stop = s.stop;
    const size_t pruned = s.pruned;
    mr_simplify_stats *stats = &out->mesh.stats;
    *stats = s.profile;
    mr_simplify_discard(&s);
    if (st != MR_OK) {
        mr_chunk_result_free(out);
        return st;
    }
    stats->input_vertices = input_vertices;
    stats->locked_vertices = blocked;
    stats->input_triangles = tc;
    stats->output_vertices = out->mesh.vertex_count;
    stats->output_points = out->mesh.vertex_count;
    stats->output_triangles = out->mesh.triangle_count;
    stats->stop = stop;
    stats->target_reached = stop <= MR_STOP_MAX_ERROR || options->until_error;
    stats->pruned_parts = pruned;
    stats->collapses = collapses;
    stats->max_error = max_error;
    stats->seconds_setup = t1 - t0;
    stats->seconds_collapse = t2 - t1;
    stats->seconds_output = mr_now_seconds() - t2;
    return MR_OK;
}

/* A chunk of wedges: mr_mesh_simplify's path with the chunk's marks. */
static mr_status simplify_attributed(const mr_chunk *c, const mr_simplify_options *options,
                                     mr_chunk_result *out, mr_error *err)
{
    const mr_mesh in = {.vertex_count = c->vertex_count,
                        .triangle_count = c->triangle_count,
                        .positions = (float *)c->positions,
                        .normals = (float *)c->normals,
                        .texcoords = (float *)c->texcoords,
                        .colors = (float *)c->colors,
                        .indices = (uint32_t *)c->indices};
    mr_simplify_options o = *options;
    o.vertex_lock = NULL;
    const mr_mesh_chunk_marks marks = {.cut = c->cut,
                                       .locked = c->locked,
                                       .quadrics = c->quadrics,
                                       .was_cut = c->was_cut,
                                       .unit = c->unit,
                                       .quadrics_out = &out->quadrics};
    mr_mesh m;
    uint32_t *origin = NULL;
    mr_simplify_stats stats;
    const mr_status st = mr_mesh_simplify_chunk(&in, &o, &marks, &m, &origin, &stats, err);
    if (st != MR_OK)
        return st;
    out->mesh.vertex_count = m.vertex_count;
    out->mesh.triangle_count = m.triangle_count;
    out->mesh.positions = m.positions;
    out->mesh.indices = m.indices;
    out->mesh.origin = origin;
    out->mesh.stats = stats;
    out->normals = m.normals;
    out->texcoords = m.texcoords;
    out->colors = m.colors;
    return MR_OK;
}

mr_status mr_simplify_chunk(const mr_chunk *chunk, const mr_simplify_options *options,
                            mr_chunk_result *out, mr_error *err)
{
    if (!out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "simplify: no output");
    memset(out, 0, sizeof *out);
    if (!chunk || !chunk->cut || !options)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: a chunk needs its cut and options");
    if (!(chunk->unit > 0))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: a chunk's quadric unit must be > 0");
    if (chunk->wedges || chunk->normals || chunk->texcoords || chunk->colors)
        return simplify_attributed(chunk, options, out, err);
    const int dynamic = mr_omp_fixed_teams();
    const mr_status st = simplify_chunk(chunk, options, out, err);
    mr_omp_restore_teams(dynamic);
    return st;
}
