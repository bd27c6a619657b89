/*
 * The end of a run, shared by every strategy: why it stopped, the pruning
 * of small parts (options.prune), and the output arrays of mr_simplify
 * (mr_mesh_simplify writes its own, wedge by wedge).
 */
#include "simplifier.h"

#include <math.h>

#define NONE MR_COLLAPSE_NONE

/*
 * Why the run stopped, when no count target was met, from the costs of
 * the edges left (no validity test: the strategies stop only once every
 * collapse within the bound has been found invalid): one within reach but
 * for the error bound means the bound stopped it; else one that may happen
 * at all means the validity tests refused the rest; else every edge has
 * locked (or two pinned) ends. One pass over the triangles, O(E), only
 * when a target is missed.
 */
static mr_simplify_stop stop_reason(const mr_simplifier *s, const mr_simplify_goal *g)
{
    if (mr_simplifier_reached(s))
        return MR_STOP_TARGET;
    const mr_collapse_mesh *m = &s->m;
    bool movable = false;
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *tri = m->tris + 3 * t;
        if (tri[0] == NONE)
            continue;
        for (int j = 0; j < 3; j++) {
            uint32_t r, k;
            double target[3];
            const double cost = mr_simplifier_plan_edge(s, tri[j], tri[(j + 1) % 3], &r, &k,
                                                        target);
            if (cost < INFINITY && cost > g->limit)
                return MR_STOP_MAX_ERROR;
            movable |= cost < INFINITY;
        }
    }
    return movable ? MR_STOP_REFUSED : MR_STOP_LOCKED;
}

/* Is the part of box a (diagonal da, ta triangles) larger than that of
 * box b: by diagonal, then triangles, then the lower corner of the box;
 * at last by root id (parts equal in all of these are copies of one
 * shape at one place). The same answer whatever the vertex order. */
static bool larger_part(const float *a, double da, uint32_t ta, uint32_t ra, const float *b,
                        double db, uint32_t tb, uint32_t rb)
{
    if (da != db)
        return da > db;
    if (ta != tb)
        return ta > tb;
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k])
            return a[k] < b[k];
    return ra < rb;
}

static double box_diagonal(const float *b)
{
    const double dx = (double)b[3] - b[0], dy = (double)b[4] - b[1], dz = (double)b[5] - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/*
 * Drop the connected parts whose bounding-box diagonal (normalised) is at
 * most `bound` -- removing them moves the surface by no more -- but never
 * the largest part, by that same diagonal (larger_part): pruning never
 * leaves nothing. Returns the number of parts dropped. A part is a set of
 * live triangles joined through shared vertices.
 */
static size_t prune(mr_simplifier *s, double bound)
{
    mr_collapse_mesh *m = &s->m;
    const size_t vc = m->vertex_count, tc = m->triangle_count;
    uint32_t *parent = mr_alloc_array(vc, sizeof *parent);
    float *box = mr_alloc_array(vc, 6 * sizeof *box);
    uint32_t *tris = mr_calloc_array(vc, sizeof *tris);
    size_t dropped = 0;
    if (!parent || !box || !tris)
        goto done; /* out of memory: nothing pruned */
    mr_uf_init(parent, vc);
    for (size_t t = 0; t < tc; t++) {
        const uint32_t *tri = m->tris + 3 * t;
        if (tri[0] != NONE) {
            mr_uf_union(parent, tri[0], tri[1]);
            mr_uf_union(parent, tri[0], tri[2]);
        }
    }
    for (size_t v = 0; v < vc; v++) {
        float *b = box + 6 * v;
        b[0] = b[1] = b[2] = INFINITY;
        b[3] = b[4] = b[5] = -INFINITY;
    }
    for (size_t v = 0; v < vc; v++) {
        if (m->flags[v] & MR_VF_REMOVED)
            continue;
        float *b = box + 6 * (size_t)mr_uf_find(parent, (uint32_t)v);
        const float *p = m->pos + 3 * v;
        for (int k = 0; k < 3; k++) {
            b[k] = p[k] < b[k] ? p[k] : b[k];
            b[3 + k] = p[k] > b[3 + k] ? p[k] : b[3 + k];
        }
    }
    for (size_t t = 0; t < tc; t++)
        if (m->tris[3 * t] != NONE)
            tris[mr_uf_find(parent, m->tris[3 * t])]++;
    uint32_t largest = NONE;
    double largest_diagonal = 0;
    for (size_t v = 0; v < vc; v++) {
        if (!tris[v])
            continue;
        const double d = box_diagonal(box + 6 * v);
        if (largest == NONE || larger_part(box + 6 * v, d, tris[v], (uint32_t)v,
                                           box + 6 * (size_t)largest, largest_diagonal,
                                           tris[largest], largest)) {
            largest = (uint32_t)v;
            largest_diagonal = d;
        }
    }
    /* tris[r] becomes the verdict: 1 = drop part r */
    for (size_t v = 0; v < vc; v++) {
        if (!tris[v])
            continue;
        tris[v] = v != largest && box_diagonal(box + 6 * v) <= bound;
        dropped += tris[v];
    }
    if (!dropped)
        goto done;
    for (size_t t = 0; t < tc; t++) {
        uint32_t *tri = m->tris + 3 * t;
        if (tri[0] != NONE && tris[mr_uf_find(parent, tri[0])]) {
            tri[0] = tri[1] = tri[2] = NONE;
            m->live_triangles--;
        }
    }
    for (size_t v = 0; v < vc; v++)
        if (!(m->flags[v] & MR_VF_REMOVED) && tris[mr_uf_find(parent, (uint32_t)v)]) {
            m->flags[v] |= MR_VF_REMOVED;
            if (m->dead)
                m->dead[v] = 0;
            m->count[v] = 0;
            m->live_vertices--;
        }
done:
    free(parent);
    free(box);
    free(tris);
    return dropped;
}

void mr_simplifier_finish(mr_simplifier *s, double max_error)
{
    s->stop = stop_reason(s, &s->plan.goal);
    s->pruned = 0;
    if (s->plan.prune) {
        /* the error bound, or the largest error the collapses made */
        const double e = s->plan.error_bound > 0 ? s->plan.error_bound
                                                 : mr_simplifier_normalised(s, max_error);
        s->pruned = prune(s, e);
        if (s->pruned && mr_simplifier_reached(s))
            s->stop = MR_STOP_TARGET; /* the pruning reached it */
    }
}

mr_status mr_simplifier_cancelled(mr_error *err)
{
    return mr_fail_plain(err, MR_ERR_CANCELLED, NULL,
                         "simplify: cancelled by the progress callback");
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

/* ---- output ---------------------------------------------------------------- */

/* Counts c[0..n) become their exclusive prefix sums; returns the total. */
static size_t exclusive_prefix(size_t *c, size_t n)
{
    size_t sum = 0;
    for (size_t i = 0; i < n; i++) {
        const size_t x = c[i];
        c[i] = sum;
        sum += x;
    }
    return sum;
}

mr_status mr_simplifier_output(const mr_simplifier *s, const float *positions, size_t stride,
                               mr_simplified *out, mr_error *err)
{
    const mr_collapse_mesh *m = &s->m;
    if (stride == 0)
        stride = 3 * sizeof(float);
    const size_t vc = m->vertex_count, nv = m->live_vertices, nt = m->live_triangles;
    uint32_t *remap = mr_alloc_array(vc, sizeof *remap);
    out->positions = mr_alloc_array(3 * nv, sizeof *out->positions);
    out->indices = mr_alloc_array(3 * nt, sizeof *out->indices);
    out->origin = mr_alloc_array(nv, sizeof *out->origin);
    if (!remap || !out->positions || !out->indices || !out->origin) {
        free(remap);
        mr_simplified_free(out);
        return mr_fail_nomem(err, NULL, nv * 16 + nt * 12);
    }
    /* Blocks of a fixed size, counted, then filled from their prefix sums
     * (the same output on any number of threads). */
    enum { BLOCK = 65536 };
    const size_t tc = m->triangle_count;
    const size_t nbv = (vc + BLOCK - 1) / BLOCK, nbt = (tc + BLOCK - 1) / BLOCK;
    size_t *boff = mr_alloc_array(nbv + nbt + 2, sizeof *boff);
    if (!boff) {
        free(remap);
        mr_simplified_free(out);
        return mr_fail_nomem(err, NULL, (nbv + nbt) * sizeof *boff);
    }
    size_t *toff = boff + nbv + 1;
    const int nthreads = s->plan.threads > 0 ? s->plan.threads : 1;
    const bool par = nthreads > 1 && vc + tc > 4 * (size_t)BLOCK;
    size_t n = 0, t = 0;
#pragma omp parallel num_threads(nthreads) if (par)
    {
#pragma omp for schedule(static)
        for (ptrdiff_t b = 0; b < (ptrdiff_t)nbv; b++) {
            const size_t v1 = (size_t)(b + 1) * BLOCK < vc ? (size_t)(b + 1) * BLOCK : vc;
            size_t c = 0;
            for (size_t v = (size_t)b * BLOCK; v < v1; v++)
                c += !(m->flags[v] & MR_VF_REMOVED);
            boff[b] = c;
        }
#pragma omp single
        n = exclusive_prefix(boff, nbv);
#pragma omp for schedule(static)
        for (ptrdiff_t b = 0; b < (ptrdiff_t)nbv; b++) {
            const size_t v1 = (size_t)(b + 1) * BLOCK < vc ? (size_t)(b + 1) * BLOCK : vc;
            size_t at = boff[b];
            for (size_t v = (size_t)b * BLOCK; v < v1; v++) {
                remap[v] = NONE;
                if (m->flags[v] & MR_VF_REMOVED)
                    continue;
                remap[v] = (uint32_t)at;
                out->origin[at] = (uint32_t)v;
                float *p = out->positions + 3 * at;
                if (m->flags[v] & MR_VF_MOVED)
                    mr_simplifier_position(s, (uint32_t)v, p);
                else
                    memcpy(p, (const char *)positions + v * stride, 3 * sizeof(float));
                at++;
            }
        }
#pragma omp for schedule(static)
        for (ptrdiff_t b = 0; b < (ptrdiff_t)nbt; b++) {
            const size_t i1 = (size_t)(b + 1) * BLOCK < tc ? (size_t)(b + 1) * BLOCK : tc;
            size_t c = 0;
            for (size_t i = (size_t)b * BLOCK; i < i1; i++)
                c += m->tris[3 * i] != NONE;
            toff[b] = c;
        }
#pragma omp single
        t = exclusive_prefix(toff, nbt);
#pragma omp for schedule(static)
        for (ptrdiff_t b = 0; b < (ptrdiff_t)nbt; b++) {
            const size_t i1 = (size_t)(b + 1) * BLOCK < tc ? (size_t)(b + 1) * BLOCK : tc;
            size_t at = toff[b];
            for (size_t i = (size_t)b * BLOCK; i < i1; i++) {
                const uint32_t *tri = m->tris + 3 * i;
                if (tri[0] == NONE)
                    continue;
                for (int k = 0; k < 3; k++)
                    out->indices[3 * at + k] = remap[tri[k]];
                at++;
            }
        }
    }
    free(boff);
    free(remap);
    out->vertex_count = n;
    out->triangle_count = t;
    return MR_OK;
}

void mr_simplifier_quadric_out(const mr_simplifier *s, uint32_t v, const float *run_pos,
                               const float out_pos[3], double unit, mr_quadricf *dst)
{
    /* to the unit: lengths times f (the inverse of the set-up's scaling) */
    const double f = 1.0 / (unit * s->scale), f2 = f * f;
    mr_quadric q;
    mr_quadric_load(&q, &s->q[v]);
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = ((double)out_pos[k] - s->centre[k]) * s->scale - run_pos[3 * (size_t)v + k];
    if (d[0] != 0 || d[1] != 0 || d[2] != 0)
        mr_quadric_shift(&q, d);
    q.a00 *= f2, q.a01 *= f2, q.a02 *= f2, q.a11 *= f2, q.a12 *= f2, q.a22 *= f2;
    q.b0 *= f2 * f, q.b1 *= f2 * f, q.b2 *= f2 * f;
    q.c *= f2 * f2;
    q.w *= f2;
    mr_quadric_store(dst, &q);
}
