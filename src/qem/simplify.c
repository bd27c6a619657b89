/*
 * Quadric-error simplification (Garland & Heckbert 1997): the entry point
 * (mr_simplify) and the dispatcher that alone picks the strategy.
 *
 * The simplifier core -- the working mesh, quadrics, costs, plans, the
 * validity test and the collapse -- is shared by every strategy: setup.c
 * (options, mesh, quadrics, targets), cost.c (costs, plans, validity, the
 * collapse) and output.c (why a run stopped, pruning, output). A strategy
 * owns only its own queue or candidate arrays and decides which collapses
 * run when: greedy.c (MR_STRATEGY_GREEDY, the sequential reference: one
 * collapse at a time from a heap) and batched.c (MR_STRATEGY_BATCHED, the
 * default: passes over all edges); partitioned.c (MR_STRATEGY_PARTITIONED:
 * slabs of vertices applying their interior collapses concurrently) and
 * parallel/queued.c (the concurrent-queue strategies) are the others. mr_mesh_simplify (mesh_simplify.c)
 * drives the same phases with attribute hooks.
 */
#include "core/simplifier.h"

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
}

void mr_simplified_free(mr_simplified *r)
{
    if (!r)
        return;
    free(r->positions);
    free(r->indices);
    free(r->origin);
    memset(r, 0, sizeof *r);
}

/* ---- the strategy --------------------------------------------------------- */

/* Start the strategy: its queue or candidate arrays, filled from the
 * mesh as set up (mr_mesh_simplify's seams included). Deterministic: the
 * same input and options give the same queue. On failure the simplifier
 * must still be freed; on success mr_simplifier_run must follow (the
 * greedy strategy's state is released at the end of its run). */
mr_status mr_simplifier_fill_queue(mr_simplifier *s, mr_error *err)
{
    if (s->batched)
        return mr_simplifier_batched_init(s, err);
    if (s->queued)
        return mr_simplifier_queued_init(s, err);
    if (s->partitioned)
        return mr_simplifier_partitioned_init(s, err);
    return mr_simplifier_greedy_init(s, err);
}

mr_status mr_simplifier_cancelled(mr_error *err)
{
    return mr_fail_plain(err, MR_ERR_CANCELLED, NULL,
                         "simplify: cancelled by the progress callback");
}

static size_t run_strategy(mr_simplifier *s, const mr_simplify_options *o, double *max_error)
{
    return s->batched          ? mr_simplifier_run_batched(s, o, max_error)
           : s->queued         ? mr_simplifier_run_queued(s, o, max_error)
           : s->boundary_aware ? mr_simplifier_run_partitioned_boundary(s, o, max_error)
           : s->partitioned    ? mr_simplifier_run_partitioned(s, o, max_error)
                               : mr_simplifier_run_greedy(s, o, max_error);
}

static void add_profiles(mr_simplifier *s, const mr_queued_profile *q,
                         const mr_partition_profile *p)
{
    s->profile.pops += q->pops;
    s->profile.locks += q->locks;
    s->profile.lock_failures += q->lock_failures;
    s->profile.checks += q->checks;
    s->profile.updates += q->updates;
    s->profile.compactions += q->compactions;
    s->pprofile.passes += p->passes;
    s->pprofile.interior += p->interior;
    s->pprofile.boundary += p->boundary;
    s->pprofile.boundary_seq += p->boundary_seq;
    s->pprofile.tail += p->tail;
    s->pprofile.rebalances += p->rebalances;
    s->pprofile.deferred += p->deferred;
    for (int i = 0; i < 4; i++)
        s->pprofile.trigger[i] += p->trigger[i];
}

/*
 * The strategy's run, in up to two stages. The first keeps the corners
 * (MR_VF_CORNER: may_go_onto's rule) in place; when it ends short of the
 * targets -- every other collapse within the error bound made or refused
 * -- the corners are released and the strategy goes on from there with
 * its queue filled anew, so a corner moves only where the target cannot
 * be reached without it. Without corners (a closed mesh, ragged
 * boundaries) the run is one stage.
 */
size_t mr_simplifier_run(mr_simplifier *s, const mr_simplify_options *o, double *max_error)
{
    size_t done = run_strategy(s, o, max_error);
    mr_simplify_goal g;
    mr_simplifier_targets(s, o, &g);
    if (s->corners && !s->cancelled && !mr_simplifier_reached(s, &g)) {
        mr_simplifier_release_corners(s);
        const mr_queued_profile q = s->profile;
        const mr_partition_profile p = s->pprofile;
        /* The vertex queues' state went with their first stage: filled
         * anew from clean lists (a lazy run leaves deleted triangles in
         * them). No memory for it: the run ends there. */
        bool go = s->batched || s->partitioned;
        if (!go) {
            mr_collapse_mesh *m = &s->m;
            for (size_t v = 0; v < m->vertex_count; v++)
                mr_collapse_clean(m, (uint32_t)v);
            mr_error ignored;
            go = mr_simplifier_fill_queue(s, &ignored) == MR_OK;
        }
        if (go) {
            double e2;
            done += run_strategy(s, o, &e2);
            *max_error = e2 > *max_error ? e2 : *max_error;
            add_profiles(s, &q, &p);
        }
    }
    mr_simplifier_progress(s, o, 1.0);
    if (s->memoryless) /* its costs are no distances */
        *max_error = mr_simplifier_error(s, o, mr_simplifier_vertex_error(s));
    mr_simplifier_finish(s, o, *max_error);
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
    mr_status st = mr_simplifier_init(&s, positions, stride, vertex_count, indices,
                                      triangle_count, options, NULL, err);
    if (st != MR_OK)
        return st;
    free(s.order); /* the output follows the working order */
    s.order = NULL;
    st = mr_simplifier_fill_queue(&s, err);
    if (st != MR_OK) {
        mr_simplifier_free(&s);
        return st;
    }
    const double t1 = mr_now_seconds();
    double max_error;
    size_t collapses = mr_simplifier_run(&s, options, &max_error);
    if (options->quality == MR_QUALITY_BEST && !s.cancelled) {
        mr_simplifier_release_run(&s);
        st = mr_simplifier_refine(&s, options, positions, stride, indices, triangle_count, err);
        if (st != MR_OK) {
            mr_simplifier_free(&s);
            return st;
        }
    }
    const double t2 = mr_now_seconds();
    if (s.cancelled) {
        mr_simplifier_free(&s);
        return mr_simplifier_cancelled(err);
    }
    /* Only the mesh is needed from here: release the rest before the
     * output is allocated (it would set the peak). The greedy strategy's
     * heap went at the end of its run. */
    mr_simplifier_release_run(&s);
    st = mr_simplifier_output(&s, positions, stride, out, err);
    const size_t input_vertices = s.input_vertices, blocked = s.blocked_vertices;
    const mr_simplify_stop stop = s.stop;
    const size_t pruned = s.pruned;
    mr_queued_profile_stats(&s.profile, &out->stats);
    mr_partition_profile_stats(&s.pprofile, &out->stats);
    mr_simplifier_free(&s);
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
