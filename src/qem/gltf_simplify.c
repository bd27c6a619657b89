/* mr_simplify_gltf: a glTF document's triangle primitives simplified one
 * by one (mr_mesh_simplify), the document written back around them
 * (io/gltf.c). */
#include "../io/gltf.h"
#include "../core/internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* n shares of `total` in proportion to w[] (largest remainders, ties to
 * the first), none below 1 where total is not 0. */
static void split(size_t total, const size_t *w, size_t n, size_t *share)
{
    double all = 0;
    for (size_t i = 0; i < n; i++)
        all += (double)w[i];
    size_t given = 0;
    double *rest = mr_alloc_array(n + 1, sizeof *rest);
    for (size_t i = 0; i < n; i++) {
        const double exact = all > 0 ? (double)total * (double)w[i] / all : 0;
        share[i] = (size_t)floor(exact);
        if (rest)
            rest[i] = exact - floor(exact);
        given += share[i];
    }
    while (rest && given < total) {
        size_t best = 0;
        for (size_t i = 1; i < n; i++)
            if (rest[i] > rest[best])
                best = i;
        share[best]++;
        rest[best] = -1;
        given++;
    }
    free(rest);
    for (size_t i = 0; total && i < n; i++)
        share[i] = share[i] ? share[i] : 1;
}

typedef struct span {
    const mr_simplify_options *o;
    double base, part;
} span;

static int span_progress(double f, void *user)
{
    const span *s = user;
    return s->o->progress(s->base + s->part * f, s->o->progress_user);
}

/* Grow the box lo..hi by m's positions. */
static void grow_box(const mr_mesh *m, double lo[3], double hi[3])
{
    for (size_t v = 0; v < m->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            const double x = m->positions[3 * v + (size_t)k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
}

static double box_diagonal(const double lo[3], const double hi[3])
{
    return lo[0] <= hi[0] ? sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) +
                                 (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                 (hi[2] - lo[2]) * (hi[2] - lo[2]))
                          : 0;
}

/* The bounding-box diagonal of m's positions. */
static double mesh_diagonal(const mr_mesh *m)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    grow_box(m, lo, hi);
    return box_diagonal(lo, hi);
}

/* The primitives of a loaded document as meshes (m[i]; n of them), and the
 * diagonal of all their positions. */
static mr_status load_primitives(const mr_gltf *g, const char *in_path, mr_mesh *m, size_t n,
                                 double *diagonal, mr_error *err)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t all_t = 0;
    for (size_t i = 0; i < n; i++) {
        const mr_status st = mr_gltf_primitive_mesh(g, i, &m[i], err);
        if (st != MR_OK)
            return st;
        all_t += m[i].triangle_count;
        grow_box(&m[i], lo, hi);
    }
    if (n == 0 || all_t == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, in_path, "its meshes hold no triangles");
    *diagonal = box_diagonal(lo, hi);
    return MR_OK;
}

mr_status mr_simplify_gltf(const char *in_path, const char *out_path,
                           const mr_simplify_options *options, mr_gltf_simplify_stats *stats,
                           mr_error *err)
{
    mr_error_clear(err);
    if (!in_path || !out_path || !options)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no path or options given");
    if (options->vertex_lock)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, in_path,
                             "vertex locks (by vertex id) are not supported for a glTF "
                             "document's primitives");
    mr_gltf_simplify_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    mr_gltf *g;
    mr_status st = mr_gltf_load_file(in_path, &g, err);
    if (st != MR_OK)
        return st;
    const size_t n = mr_gltf_primitive_count(g);
    mr_mesh *m = mr_calloc_array(n + 1, sizeof *m);
    size_t *tri = mr_calloc_array(n + 1, sizeof *tri), *share_t = mr_calloc_array(n + 1, sizeof *share_t),
           *share_v = mr_calloc_array(n + 1, sizeof *share_v);
    if (!m || !tri || !share_t || !share_v)
        st = mr_fail_nomem(err, in_path, n * 64);
    /* every primitive's mesh: the counts the targets are split by, and
     * the box a relative error bound is relative to */
    double diagonal = 0;
    if (st == MR_OK)
        st = load_primitives(g, in_path, m, n, &diagonal, err);
    size_t all_t = 0;
    for (size_t i = 0; i < n && st == MR_OK; i++) {
        tri[i] = m[i].triangle_count;
        all_t += tri[i];
    }
    if (st == MR_OK && options->target_triangles > all_t)
        st = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, in_path,
                           "target of %zu triangles exceeds the document's %zu",
                           options->target_triangles, all_t);
    if (st == MR_OK) {
        split(options->target_triangles, tri, n, share_t);
        split(options->target_vertices, tri, n, share_v);
    }
    mr_simplify_stats *sum = &stats->simplify;
    sum->target_reached = 1;
    double done = 0;
    for (size_t i = 0; i < n && st == MR_OK; i++) {
        if (m[i].triangle_count == 0)
            continue;
        mr_simplify_options o = *options;
        o.target_triangles = share_t[i] < m[i].triangle_count ? share_t[i] : m[i].triangle_count;
        o.target_vertices = share_v[i];
        /* absolute in each run; the largest error back relative below */
        if (!o.error_absolute)
            o.max_error *= diagonal;
        o.error_absolute = 1;
        span sp = {options, done / (double)all_t, (double)m[i].triangle_count / (double)all_t};
        if (options->progress) {
            o.progress = span_progress;
            o.progress_user = &sp;
        }
        done += (double)m[i].triangle_count;
        mr_mesh out;
        uint32_t *origin = NULL;
        mr_simplify_stats s;
        st = mr_mesh_simplify(&m[i], &o, &out, &origin, &s, err);
        if (st != MR_OK) {
            size_t mesh, prim;
            mr_gltf_primitive_at(g, i, &mesh, &prim);
            if (st != MR_ERR_CANCELLED) {
                char msg[sizeof err->message];
                snprintf(msg, sizeof msg, "%s", err->message);
                st = mr_fail_plain(err, st, NULL, "meshes[%zu].primitives[%zu]: %s", mesh, prim,
                                   msg);
            }
            break;
        }
        st = mr_gltf_replace(g, i, &out, origin, err);
        mr_mesh_free(&out);
        free(origin);
        sum->input_vertices += s.input_vertices;
        sum->locked_vertices += s.locked_vertices;
        sum->input_triangles += s.input_triangles;
        sum->output_vertices += s.output_vertices;
        sum->output_points += s.output_points;
        sum->output_triangles += s.output_triangles;
        sum->collapses += s.collapses;
        sum->pruned_parts += s.pruned_parts;
        if (!s.target_reached && sum->target_reached) {
            sum->target_reached = 0;
            sum->stop = s.stop;
        }
        sum->max_error = s.max_error > sum->max_error ? s.max_error : sum->max_error;
        sum->seconds_setup += s.seconds_setup;
        sum->seconds_collapse += s.seconds_collapse;
        sum->seconds_output += s.seconds_output;
        stats->primitives++;
        mr_mesh_free(&m[i]);
    }
    if (st == MR_OK && !options->error_absolute && diagonal > 0)
        sum->max_error /= diagonal;
    if (st == MR_OK)
        st = mr_gltf_write(g, out_path, err);
    stats->dropped_tangents = mr_gltf_dropped_tangents(g);
    for (size_t i = 0; m && i < n; i++)
        mr_mesh_free(&m[i]);
    free(m);
    free(tri);
    free(share_t);
    free(share_v);
    mr_gltf_free(g);
    return st;
}

mr_status mr_simplify_gltf_lods(const char *in_path, const char *out_path,
                                const double *fractions, size_t count,
                                const mr_simplify_options *options, size_t samples,
                                mr_lod_level *levels, mr_error *err)
{
    mr_error_clear(err);
    if (!in_path || !out_path || !options || !fractions || !levels || count == 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "no path, options, fractions or levels given");
    for (size_t k = 0; k < count; k++) {
        memset(&levels[k], 0, sizeof levels[k]);
        mr_mesh_init(&levels[k].mesh);
    }
    if (options->vertex_lock)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, in_path,
                             "vertex locks (by vertex id) are not supported for a glTF "
                             "document's primitives");
    mr_gltf *g;
    mr_status st = mr_gltf_load_file(in_path, &g, err);
    if (st != MR_OK)
        return st;
    const size_t n = mr_gltf_primitive_count(g);
    mr_mesh *m = mr_calloc_array(n + 1, sizeof *m), *level = mr_calloc_array(n + 1, sizeof *level);
    mr_lod_level **lv = mr_calloc_array(n + 1, sizeof *lv);
    const uint32_t **origin = mr_calloc_array(n + 1, sizeof *origin);
    double diagonal = 0;
    if (!m || !level || !lv || !origin)
        st = mr_fail_nomem(err, in_path, n * 64);
    else
        st = load_primitives(g, in_path, m, n, &diagonal, err);
    /* each primitive's chain, in its mesh's space */
    for (size_t i = 0; i < n && st == MR_OK; i++) {
        lv[i] = mr_calloc_array(count, sizeof *lv[i]);
        if (!lv[i]) {
            st = mr_fail_nomem(err, in_path, count * sizeof *lv[i]);
            break;
        }
        if (m[i].triangle_count == 0)
            continue;
        mr_simplify_options o = *options;
        if (!o.error_absolute) /* relative to the document's diagonal */
            o.max_error *= diagonal;
        o.error_absolute = 1;
        o.progress = NULL;
        st = mr_mesh_lods(&m[i], fractions, count, &o, samples, lv[i], err);
        if (st != MR_OK) {
            size_t mesh, prim;
            mr_gltf_primitive_at(g, i, &mesh, &prim);
            char msg[sizeof err->message];
            snprintf(msg, sizeof msg, "%s", err->message);
            st = mr_fail_plain(err, st, in_path, "meshes[%zu].primitives[%zu]: %s", mesh, prim,
                               msg);
        }
    }
    /* each level: the largest distance over the primitives, relative to
     * the document's diagonal; its meshes and nodes added */
    double worst = 0;
    for (size_t k = 0; k < count && st == MR_OK; k++) {
        mr_lod_level *l = &levels[k];
        l->stats.target_reached = 1;
        for (size_t i = 0; i < n; i++) {
            const mr_lod_level *p = &lv[i][k];
            level[i] = m[i].triangle_count ? p->mesh : m[i];
            level[i].triangle_count = m[i].triangle_count ? p->mesh.triangle_count : 0;
            origin[i] = p->origin;
            if (!m[i].triangle_count)
                continue;
            const double d = mesh_diagonal(&m[i]) / (diagonal > 0 ? diagonal : 1);
            l->hausdorff_rel = fmax(l->hausdorff_rel, p->hausdorff_rel * d);
            l->rms_rel = fmax(l->rms_rel, p->rms_rel * d);
            l->target_triangles += p->target_triangles;
            mr_simplify_stats *s = &l->stats;
            s->input_triangles += p->stats.input_triangles;
            s->input_vertices += p->stats.input_vertices;
            s->output_triangles += p->stats.output_triangles;
            s->output_vertices += p->stats.output_vertices;
            s->output_points += p->stats.output_points;
            s->collapses += p->stats.collapses;
            s->seconds_setup += p->stats.seconds_setup;
            s->seconds_collapse += p->stats.seconds_collapse;
            s->seconds_output += p->stats.seconds_output;
            if (!p->stats.target_reached && s->target_reached) {
                s->target_reached = 0;
                s->stop = p->stats.stop;
            }
        }
        worst = fmax(worst, l->hausdorff_rel);
        l->error_rel = worst;
        st = mr_gltf_add_lod(g, level, origin, k + 1, worst, err);
    }
    if (st == MR_OK)
        st = mr_gltf_write(g, out_path, err);
    for (size_t i = 0; i < n; i++) {
        if (lv && lv[i])
            mr_lod_levels_free(lv[i], count);
        free(lv ? lv[i] : NULL);
        if (m)
            mr_mesh_free(&m[i]);
    }
    free(lv);
    free(m);
    free(level);
    free(origin);
    mr_gltf_free(g);
    return st;
}
