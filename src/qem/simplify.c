/*
 * Quadric-error simplification (Garland & Heckbert 1997): the entry point
 * mr_simplify, and what both entry points share (entry.h): the strategy
 * chosen by the options, the run in its stages, the strategy's state.
 *
 * The layers below: the core (core/: the working mesh, quadrics, costs,
 * plans, the validity test and the collapse, set-up, output, the surface
 * fit), which knows no strategy, and the strategies on it (strategies/:
 * greedy, the sequential reference; batched, the default; partitioned and
 * partitioned-boundary; parallel/queued.c, the concurrent queues), which
 * decide which collapses run when and read only the plan. mr_mesh_simplify
 * (mesh_simplify.c) drives the same phases with attribute hooks.
 */
#include "entry.h"
#include "strategies/parallel/filter_layout.h"

#include "../core/omp_compat.h"

void mr_simplify_options_default(mr_simplify_options *o)
{
    memset(o, 0, sizeof *o);
    o->collapse = MR_COLLAPSE_FULL;
    o->strategy = MR_STRATEGY_BATCHED;
    o->boundary_weight = 1.0;
    o->max_normal_turn = 60.0 * 3.14159265358979323846 / 180.0;
    o->filter_levels = 0;     /* from the thread count */
    o->multiqueue_factor = 2;
    o->partitions = 0;        /* MR_PARTITIONS_DEFAULT */
    o->normal_weight = MR_NORMAL_WEIGHT;
    o->uv_weight = MR_UV_WEIGHT;
    o->color_weight = MR_COLOR_WEIGHT;
}

/* ---- the strategy --------------------------------------------------------- */

const mr_strategy_ops *mr_simplify_strategy(const mr_simplifier *s)
{
    switch (s->plan.strategy) {
    case MR_STRATEGY_GREEDY: return &mr_strategy_greedy;
    case MR_STRATEGY_PARTITIONED: return &mr_strategy_partitioned;
    case MR_STRATEGY_PARTITIONED_BOUNDARY: return &mr_strategy_partitioned_boundary;
    case MR_STRATEGY_BATCHED: return &mr_strategy_batched;
    default: return &mr_strategy_queued;
    }
}

/* The options' checks that belong to the strategies. */
static mr_status check_strategy(const mr_simplify_options *o, mr_error *err)
{
    if (!o)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: options are required (a target must be set)");
    if (o->strategy < MR_STRATEGY_GREEDY || o->strategy > MR_STRATEGY_PARTITIONED_BOUNDARY)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: unknown strategy %d", (int)o->strategy);
    if (mr_strategy_is_queued(o->strategy) && o->collapse == MR_COLLAPSE_FULL)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: the concurrent-queue strategies (ppq, rppq, fppq, "
                             "multiqueue) make half-edge collapses only: set "
                             "MR_COLLAPSE_HALF (--collapse half)");
    if (mr_strategy_is_queued(o->strategy) && o->filter_levels > MR_FILTER_MAX_LEVELS)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: %u filter levels: at most %d", o->filter_levels,
                             MR_FILTER_MAX_LEVELS);
    if (o->strategy >= MR_STRATEGY_PARTITIONED && o->partitions > MR_PARTITIONS_MAX)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "simplify: %u partitions: at most %d", o->partitions,
                             MR_PARTITIONS_MAX);
    return MR_OK;
}

mr_status mr_simplify_setup(mr_simplifier *s, const float *positions, size_t stride,
                            size_t vertex_count, const uint32_t *indices,
                            size_t triangle_count, const mr_simplify_options *o,
                            const mr_vertex_marks *marks, mr_error *err)
{
    memset(s, 0, sizeof *s);
    mr_status st = check_strategy(o, err);
    if (st != MR_OK)
        return st;
    mr_simplify_plan plan;
    memset(&plan, 0, sizeof plan);
    plan.strategy = (int)o->strategy;
    /* the pass strategies work the triangles block by block */
    plan.spatial_order =
        o->strategy == MR_STRATEGY_BATCHED || o->strategy >= MR_STRATEGY_PARTITIONED;
    /* the vertex queues rank vertices by quadric cost (mr_simplifier_plan) */
    plan.edge_plans = !mr_strategy_is_queued(o->strategy);
    plan.filter_levels = o->filter_levels;
    plan.multiqueue_factor = o->multiqueue_factor;
    plan.partitions = o->partitions;
    return mr_simplifier_init(s, positions, stride, vertex_count, indices, triangle_count, o,
                              &plan, marks, err);
}

mr_status mr_simplifier_fill_queue(mr_simplifier *s, mr_error *err)
{
    return mr_simplify_strategy(s)->start(s, err);
}

void mr_simplify_release_run(mr_simplifier *s)
{
    mr_simplify_strategy(s)->release(s);
    mr_simplifier_release_quadrics(s);
}

void mr_simplify_discard(mr_simplifier *s)
{
    if (s->state)
        mr_simplify_strategy(s)->release(s);
    mr_simplifier_free(s);
}

/*
 * The strategy's run, in up to three stages. The first keeps the corners
 * (MR_VF_CORNER: may_go_onto's rule) in place and the attribute rules
 * (mr_mesh_simplify's seams) whole. When it ends short of the targets --
 * every other collapse within the error bound made or refused -- the
 * corners are released and the strategy goes on from there (with its
 * queue filled anew where its state went with the stage before); when
 * that too ends short, the attribute rules are loosened (attr_release)
 * and it goes on again. So a corner moves only where the target cannot
 * be reached without moving it, and a seam vertex leaves its seam only
 * where it cannot be reached with the seams. (The other order, seams
 * before corners, gave the Khronos Fox at gltfpack's 10 % a Hausdorff
 * distance 30 % larger.) A stage with nothing to release (no seams; a
 * closed mesh or ragged boundaries: no corners) is left out.
 */
static size_t next_stage(mr_simplifier *s, const mr_strategy_ops *run, double *worst)
{
    /* the lists clean for a fresh start (a lazy run leaves deleted
     * triangles in them); no memory for it: the run ends there */
    bool go = !run->one_run;
    if (!go) {
        mr_collapse_mesh *m = &s->m;
        for (size_t v = 0; v < m->vertex_count; v++)
            mr_collapse_clean(m, (uint32_t)v);
        mr_error ignored;
        go = run->start(s, &ignored) == MR_OK;
    }
    if (!go)
        return 0;
    double w2;
    const size_t done = run->run(s, &w2);
    *worst = w2 > *worst ? w2 : *worst;
    return done;
}

size_t mr_simplify_run(mr_simplifier *s, double *max_error)
{
    const mr_strategy_ops *run = mr_simplify_strategy(s);
    double worst;
    size_t done = run->run(s, &worst);
    if (s->corners && !s->cancelled && !mr_simplifier_reached(s)) {
        mr_simplifier_release_corners(s);
        done += next_stage(s, run, &worst);
    }
    if (s->attr_release && !s->cancelled && !mr_simplifier_reached(s) && s->attr_release(s))
        done += next_stage(s, run, &worst);
    mr_simplifier_progress(s, 1.0);
    /* in the memoryless mode the costs are no distances */
    *max_error = mr_simplifier_error(s, s->memoryless ? mr_simplifier_vertex_error(s) : worst);
    mr_simplifier_finish(s, *max_error);
    return done;
}

const char *mr_simplify_stop_string(mr_simplify_stop stop)
{
    switch (stop) {
    case MR_STOP_TARGET: return "the target was reached";
    case MR_STOP_MAX_ERROR: return "every further collapse would exceed the error bound";
    case MR_STOP_LOCKED:
        return "every remaining vertex is locked (non-manifold or misoriented fans, "
               "locked borders or vertices, seam ends)";
    case MR_STOP_REFUSED:
        return "every remaining collapse is refused by the topology or normal tests (it "
               "would join two sides of the surface, remove a part's last triangles, or "
               "flip or turn a triangle past the normal limit)";
    }
    return "unknown";
}

static mr_status simplify(const float *positions, size_t stride, size_t vertex_count,
                          const uint32_t *indices, size_t triangle_count,
                          const mr_simplify_options *options, mr_simplified *out, mr_error *err)
{
    if (!out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "simplify: no output");
    memset(out, 0, sizeof *out);
    const double t0 = mr_now_seconds();
    mr_simplifier s;
    mr_status st = mr_simplify_setup(&s, positions, stride, vertex_count, indices,
                                     triangle_count, options, NULL, err);
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
    if (options->quality == MR_QUALITY_BEST && !s.cancelled) {
        mr_simplify_release_run(&s);
        st = mr_simplifier_refine(&s, positions, stride, indices, triangle_count, err);
        if (st != MR_OK) {
            mr_simplify_discard(&s);
            return st;
        }
    }
    const double t2 = mr_now_seconds();
    if (s.cancelled) {
        mr_simplify_discard(&s);
        return mr_simplifier_cancelled(err);
    }
    /* Only the mesh is needed from here: release the rest before the
     * output is allocated (it would set the peak). The vertex queues'
     * state went at the end of their run. */
    mr_simplify_release_run(&s);
    st = mr_simplifier_output(&s, positions, stride, out, err);
    const size_t input_vertices = s.input_vertices, blocked = s.blocked_vertices;
    const mr_simplify_stop stop = s.stop;
    const size_t pruned = s.pruned;
    out->stats = s.profile; /* the strategy's counts; the rest below */
    mr_simplify_discard(&s);
    if (st != MR_OK)
        return st;
    const double t3 = mr_now_seconds();
    mr_simplify_stats *stats = &out->stats;
    stats->input_vertices = input_vertices;
    stats->locked_vertices = blocked;
    stats->input_triangles = triangle_count;
    stats->output_vertices = out->vertex_count;
    stats->output_points = out->vertex_count;
    stats->output_triangles = out->triangle_count;
    stats->stop = stop;
    stats->target_reached = stop <= MR_STOP_MAX_ERROR || options->until_error;
    stats->pruned_parts = pruned;
    stats->collapses = collapses;
    stats->max_error = max_error;
    stats->seconds_setup = t1 - t0;
    stats->seconds_collapse = t2 - t1;
    stats->seconds_output = t3 - t2;
    return MR_OK;
}

mr_status mr_simplify(const float *positions, size_t stride, size_t vertex_count,
                      const uint32_t *indices, size_t triangle_count,
                      const mr_simplify_options *options, mr_simplified *out, mr_error *err)
{
    const int dynamic = mr_omp_fixed_teams(); /* teams as asked for */
    const mr_status st =
        simplify(positions, stride, vertex_count, indices, triangle_count, options, out, err);
    mr_omp_restore_teams(dynamic);
    return st;
}
