/*
 * Mesh statistics: counts, topology (edges, manifoldness, boundary loops,
 * components, Euler characteristic) and geometry (bounding box, area).
 *
 * Conventions, beyond those of meshreduce.h:
 *   - degenerate triangles (a repeated index) have no edges: they count in
 *     triangle_count, F of the Euler characteristic, referenced_vertices and
 *     components, but not in the edge, fan, boundary or duplicate counts (a
 *     sliver a a b would otherwise look like a two-sided edge a b);
 *   - duplicate triangles are counted among the non-degenerate ones;
 *   - euler_characteristic = referenced_vertices - edge_count +
 *     triangle_count, with every triangle as given (degenerate and
 *     duplicate ones included);
 *   - a fan of a vertex is a maximal set of its triangles connected through
 *     edges at the vertex that have exactly two triangles; a vertex with
 *     two or more fans (two cones touching at their tips, a bowtie) is
 *     non-manifold, like every vertex of a non-manifold edge;
 *   - closed and manifold are 0 for a mesh without a single edge (empty,
 *     point cloud, only degenerate triangles);
 *   - the bounding box and its diagonal cover every vertex, referenced or
 *     not; NaN coordinates are skipped; a mesh without vertices has an
 *     all-zero box;
 *   - a boundary loop is a connected chain of boundary edges, where the
 *     chains meeting at a vertex are kept apart when they border different
 *     fans of it (two holes touching at a vertex are two loops). On
 *     non-manifold input a chain that ends at a non-manifold edge still
 *     counts as one loop.
 * Arguments: stride 0 means 12 bytes; a stride below 12 bytes is
 * MR_ERR_INVALID_ARGUMENT, as are NULL arrays with non-zero counts and an
 * index out of range (the message names the triangle).
 *
 * Every result is identical for every thread count: integer counts do not
 * depend on the order of work, and the area is summed in fixed blocks.
 */
#include "adjacency.h"

#include <math.h>

#include "../core/omp_compat.h"

#define PARALLEL_MIN 65536
#define AREA_BLOCK 8192

/* Per-vertex flags of the topology pass. */
enum {
    V_REFERENCED = 1u << 0,       /* used by a degenerate triangle (the vertices
                                     of the others have a fan) */
    V_NONMANIFOLD_EDGE = 1u << 1, /* touches an edge with three or more triangles */
    V_ONE_FAN = 1u << 2,
    V_MANY_FANS = 1u << 3
};

static inline void load_position(const float *positions, size_t stride, size_t i, double p[3])
{
    float f[3];
    /* memcpy: a caller's stride need not keep floats aligned. */
    memcpy(f, (const char *)positions + i * stride, sizeof f);
    p[0] = f[0];
    p[1] = f[1];
    p[2] = f[2];
}

/* ---- geometry -------------------------------------------------------------- */

static void compute_bbox(const float *positions, size_t stride, size_t n, mr_stats *s)
{
    double x0 = INFINITY, y0 = INFINITY, z0 = INFINITY;
    double x1 = -INFINITY, y1 = -INFINITY, z1 = -INFINITY;
#pragma omp parallel for schedule(static) if (n > PARALLEL_MIN) \
    reduction(min : x0, y0, z0) reduction(max : x1, y1, z1)
    for (size_t i = 0; i < n; i++) {
        double p[3];
        load_position(positions, stride, i, p);
        /* Written as comparisons so that NaN never wins. */
        if (p[0] < x0) x0 = p[0];
        if (p[1] < y0) y0 = p[1];
        if (p[2] < z0) z0 = p[2];
        if (p[0] > x1) x1 = p[0];
        if (p[1] > y1) y1 = p[1];
        if (p[2] > z1) z1 = p[2];
    }
    if (!(x0 <= x1 && y0 <= y1 && z0 <= z1))
        return; /* no vertex, or only NaN: leave the zeros */
    s->bbox_min[0] = x0;
    s->bbox_min[1] = y0;
    s->bbox_min[2] = z0;
    s->bbox_max[0] = x1;
    s->bbox_max[1] = y1;
    s->bbox_max[2] = z1;
    double dx = x1 - x0, dy = y1 - y0, dz = z1 - z0;
    s->bbox_diagonal = sqrt(dx * dx + dy * dy + dz * dz);
}

static double triangle_area(const float *positions, size_t stride, const uint32_t *tri)
{
    double a[3], b[3], c[3];
    load_position(positions, stride, tri[0], a);
    load_position(positions, stride, tri[1], b);
    load_position(positions, stride, tri[2], c);
    return mr_triangle_area(a, b, c);
}

/* Sum of triangle areas. Each fixed block of triangles is summed in order and
 * the block sums are added in order, so the rounding is the same whatever
 * the thread count. */
static mr_status compute_area(const float *positions, size_t stride, const uint32_t *indices,
                              size_t tc, double *area, mr_error *err)
{
    const size_t nb = (tc + AREA_BLOCK - 1) / AREA_BLOCK;
    double *partial = mr_alloc_array(nb, sizeof *partial);
    if (!partial)
        return mr_fail_nomem(err, NULL, nb * sizeof *partial);
#pragma omp parallel for schedule(static) if (tc > PARALLEL_MIN)
    for (size_t b = 0; b < nb; b++) {
        size_t end = (b + 1) * AREA_BLOCK < tc ? (b + 1) * AREA_BLOCK : tc;
        double sum = 0;
        for (size_t t = b * AREA_BLOCK; t < end; t++)
            sum += triangle_area(positions, stride, indices + 3 * t);
        partial[b] = sum;
    }
    double total = 0;
    for (size_t b = 0; b < nb; b++)
        total += partial[b];
    free(partial);
    *area = total;
    return MR_OK;
}

/* ---- topology -------------------------------------------------------------- */

/*
 * The topology pass, in phases that each run in parallel where the work is
 * large:
 *   1. scan the edge table: count edges, boundary and non-manifold edges and
 *      duplicates at two-triangle edges, and join the two triangles'
 *      corners at each end of a two-triangle edge into one fan (a
 *      union-find over corners);
 *   2. only when there are boundary or non-manifold edges: a sequential scan
 *      that lists the boundary half-edges and handles the runs of three or
 *      more half-edges (kept out of phase 1 so that it needs no allocation);
 *   3. fans per vertex (the roots of the union-find), referenced vertices;
 *   4. boundary loops, from the fans at the ends of the boundary edges;
 *   5. components, from a union-find over vertices.
 */
typedef struct topo {
    const uint32_t *indices;
    size_t tc, vc;
    bool par;            /* several threads: atomic union-find and flags */
    mr_edge_table et;
    uint32_t *fan;       /* union-find over corners: one set per fan of a vertex */
    uint8_t *vflags;     /* V_* per vertex */
    uint32_t *boundary;  /* corners of the boundary half-edges */
    size_t boundary_count;
} topo;

static void topo_free(topo *tp)
{
    mr_edge_table_free(&tp->et);
    free(tp->fan);
    free(tp->vflags);
    free(tp->boundary);
}

static inline void uf_union(uint32_t *parent, uint32_t a, uint32_t b, bool shared)
{
    if (shared)
        mr_uf_union_shared(parent, a, b);
    else
        mr_uf_union(parent, a, b);
}

/* flags |= bits; returns the flags before. */
static inline uint8_t flag_or(uint8_t *flags, uint8_t bits, bool shared)
{
    if (shared)
        return __atomic_fetch_or(flags, bits, __ATOMIC_RELAXED);
    uint8_t old = *flags;
    *flags = old | bits;
    return old;
}

/* The corner of half-edge c's triangle that sits at vertex v (one of the
 * half-edge's two ends). */
static inline uint32_t corner_at(const uint32_t *indices, uint32_t c, uint32_t v)
{
    return indices[c] == v ? c : mr_corner_next(c);
}

static inline uint32_t opposite(const uint32_t *indices, uint64_t entry)
{
    return indices[mr_corner_prev(mr_edge_corner(entry))];
}

/* Phase 1. Duplicates: two triangles over the same vertices share all three
 * edges, in particular the edge between their two smallest vertices;
 * counting only at that edge (opposite vertex > hi) counts each duplicate
 * once. */
static void scan_edges(topo *tp, mr_stats *s)
{
    const mr_edge_table *et = &tp->et;
    const uint32_t *idx = tp->indices;
    const bool par = tp->par;
    const size_t vc = et->vertex_count;
    size_t edges = 0, boundary_edges = 0, nonmanifold = 0, dups = 0, misoriented = 0;
#pragma omp parallel for schedule(dynamic, 4096) if (par) \
    reduction(+ : edges, boundary_edges, nonmanifold, dups, misoriented)
    for (size_t v = 0; v < vc; v++) {
        const uint32_t lo = (uint32_t)v;
        for (size_t i = et->offsets[lo], j; i < et->offsets[lo + 1]; i = j) {
            j = mr_edge_run_end(et, lo, i);
            const uint64_t *run = et->entries + i;
            edges++;
            if (j - i == 1) {
                boundary_edges++;
            } else if (j - i == 2) {
                const uint32_t hi = mr_edge_hi(run[0]);
                const uint32_t c0 = mr_edge_corner(run[0]), c1 = mr_edge_corner(run[1]);
                /* One fan across the edge, whatever the two orientations. */
                uf_union(tp->fan, corner_at(idx, c0, lo), corner_at(idx, c1, lo), par);
                uf_union(tp->fan, corner_at(idx, c0, hi), corner_at(idx, c1, hi), par);
                const uint32_t o0 = opposite(idx, run[0]), o1 = opposite(idx, run[1]);
                dups += o0 == o1 && o0 > hi;
                misoriented += mr_edge_same_way(idx, c0, c1, lo);
            } else {
                nonmanifold++;
            }
        }
    }
    s->edge_count = edges;
    s->boundary_edges = boundary_edges;
    s->nonmanifold_edges = nonmanifold;
    s->duplicate_triangles = dups;
    s->misoriented_edges = misoriented;
}

/* Phase 2: boundary half-edges, vertices of non-manifold edges, duplicates
 * among the triangles of a non-manifold edge. */
static mr_status scan_special_edges(topo *tp, mr_stats *s, mr_error *err)
{
    const mr_edge_table *et = &tp->et;
    const uint32_t *idx = tp->indices;
    uint64_t *scratch = NULL;
    size_t cap = 0, nb = 0;
    tp->boundary = mr_alloc_array(s->boundary_edges, sizeof *tp->boundary);
    if (!tp->boundary)
        return mr_fail_nomem(err, NULL, s->boundary_edges * sizeof *tp->boundary);
    for (uint32_t lo = 0; lo < et->vertex_count; lo++) {
        for (size_t i = et->offsets[lo], j; i < et->offsets[lo + 1]; i = j) {
            j = mr_edge_run_end(et, lo, i);
            const size_t k = j - i;
            const uint64_t *run = et->entries + i;
            if (k == 1) {
                tp->boundary[nb++] = mr_edge_corner(run[0]);
                continue;
            }
            if (k == 2)
                continue;
            const uint32_t hi = mr_edge_hi(run[0]);
            tp->vflags[lo] |= V_NONMANIFOLD_EDGE;
            tp->vflags[hi] |= V_NONMANIFOLD_EDGE;
            if (k > cap) {
                size_t n = k > 2 * cap ? k : 2 * cap;
                uint64_t *p = mr_realloc_array(scratch, n, sizeof *p);
                if (!p) {
                    free(scratch);
                    return mr_fail_nomem(err, NULL, n * sizeof *p);
                }
                scratch = p;
                cap = n;
            }
            size_t m = 0;
            for (size_t e = 0; e < k; e++) {
                uint32_t o = opposite(idx, run[e]);
                if (o > hi)
                    scratch[m++] = ((uint64_t)o << 32) | (mr_edge_corner(run[e]) / 3);
            }
            s->duplicate_triangles += mr_mark_repeats(scratch, m, NULL);
        }
    }
    free(scratch);
    tp->boundary_count = nb;
    return MR_OK;
}

/* Phase 3: a fan is a set of the union-find, so a vertex has as many fans
 * as root corners. Every vertex of a non-degenerate triangle has at least
 * one; those of degenerate triangles are marked referenced directly. */
static void count_fans(topo *tp)
{
    const uint32_t *idx = tp->indices;
    const uint32_t *fan = tp->fan;
    uint8_t *vflags = tp->vflags;
    const bool par = tp->par;
    const size_t tc = tp->tc;
#pragma omp parallel for schedule(static) if (par)
    for (size_t t = 0; t < tc; t++) {
        const uint32_t *tri = idx + 3 * t;
        if (mr_triangle_is_degenerate(tri)) {
            for (unsigned k = 0; k < 3; k++)
                flag_or(&vflags[tri[k]], V_REFERENCED, par);
            continue;
        }
        for (unsigned k = 0; k < 3; k++) {
            if (fan[3 * t + k] != 3 * t + k)
                continue;
            if (flag_or(&vflags[tri[k]], V_ONE_FAN, par) & V_ONE_FAN)
                flag_or(&vflags[tri[k]], V_MANY_FANS, par);
        }
    }
}

static void count_vertices(const topo *tp, mr_stats *s)
{
    size_t referenced = 0, nonmanifold = 0;
    const size_t vc = tp->vc;
    const uint8_t *vflags = tp->vflags;
#pragma omp parallel for schedule(static) if (vc > PARALLEL_MIN) \
    reduction(+ : referenced, nonmanifold)
    for (size_t v = 0; v < vc; v++) {
        referenced += (vflags[v] & (V_REFERENCED | V_ONE_FAN)) != 0;
        nonmanifold += (vflags[v] & (V_NONMANIFOLD_EDGE | V_MANY_FANS)) != 0;
    }
    s->referenced_vertices = referenced;
    s->unreferenced_vertices = vc - referenced;
    s->nonmanifold_vertices = nonmanifold;
}

/* Phase 4. Boundary loops: a graph whose nodes are the fans at the ends of
 * boundary edges (a vertex where two holes meet has one fan per hole) and
 * whose links are the boundary edges. Around a manifold boundary vertex a
 * fan has exactly two boundary edges, so every component is one loop; no
 * walking, no choice at branching vertices, no dependence on orientation.
 * The fans are sets of the corner union-find, which is not needed after
 * phase 3: joining the sets across the boundary edges in that same forest
 * leaves one set per loop, and loops = nodes - successful joins. */
static mr_status count_boundary_loops(topo *tp, mr_stats *s, mr_error *err)
{
    const size_t b = tp->boundary_count;
    if (b == 0)
        return MR_OK;
    uint32_t *ends = mr_alloc_array(2 * b, sizeof *ends);
    uint8_t *seen = mr_calloc_array(3 * tp->tc / 8 + 1, 1); /* bit per corner */
    if (!ends || !seen) {
        free(ends);
        free(seen);
        return mr_fail_nomem(err, NULL, 2 * b * sizeof *ends + 3 * tp->tc / 8);
    }
    size_t nodes = 0, joins = 0;
    for (size_t i = 0; i < 2 * b; i++) {
        uint32_t c = tp->boundary[i / 2];
        uint32_t r = mr_uf_find(tp->fan, i % 2 ? mr_corner_next(c) : c);
        ends[i] = r;
        if (!(seen[r / 8] & (1u << (r % 8)))) {
            seen[r / 8] |= (uint8_t)(1u << (r % 8));
            nodes++;
        }
    }
    for (size_t i = 0; i < b; i++) {
        uint32_t u = mr_uf_find(tp->fan, ends[2 * i]);
        uint32_t v = mr_uf_find(tp->fan, ends[2 * i + 1]);
        if (u != v) {
            mr_uf_union(tp->fan, u, v);
            joins++;
        }
    }
    s->boundary_loops = nodes - joins;
    free(ends);
    free(seen);
    return MR_OK;
}

/* Phase 5. Components of triangles connected through shared vertices:
 * union-find over vertices, one set per component; unreferenced vertices
 * stay singletons and are not counted. */
static mr_status count_components(topo *tp, mr_stats *s, mr_error *err)
{
    const size_t vc = tp->vc, tc = tp->tc;
    const bool par = tp->par;
    uint32_t *parent = mr_alloc_array(vc, sizeof *parent);
    if (!parent)
        return mr_fail_nomem(err, NULL, vc * sizeof *parent);
    mr_uf_init(parent, vc);
    const uint32_t *idx = tp->indices;
#pragma omp parallel for schedule(static) if (par)
    for (size_t t = 0; t < tc; t++) {
        uf_union(parent, idx[3 * t], idx[3 * t + 1], par);
        uf_union(parent, idx[3 * t], idx[3 * t + 2], par);
    }
    size_t components = 0;
    const uint8_t *vflags = tp->vflags;
#pragma omp parallel for schedule(static) if (vc > PARALLEL_MIN) reduction(+ : components)
    for (size_t v = 0; v < vc; v++)
        components += parent[v] == v && (vflags[v] & (V_REFERENCED | V_ONE_FAN));
    free(parent);
    s->components = components;
    return MR_OK;
}

static mr_status compute_topology(const uint32_t *indices, size_t tc, size_t vc, mr_stats *s,
                                  mr_error *err)
{
    topo tp;
    memset(&tp, 0, sizeof tp);
    tp.indices = indices;
    tp.tc = tc;
    tp.vc = vc;
    tp.par = tc > PARALLEL_MIN && omp_get_max_threads() > 1;
    mr_status st = mr_edge_table_build(&tp.et, indices, tc, vc, err);
    if (st != MR_OK)
        goto done;
    tp.fan = mr_alloc_array(3 * tc, sizeof *tp.fan);
    tp.vflags = mr_calloc_array(vc, sizeof *tp.vflags);
    if (!tp.fan || !tp.vflags) {
        st = mr_fail_nomem(err, NULL, 3 * tc * sizeof *tp.fan + vc);
        goto done;
    }
    mr_uf_init(tp.fan, 3 * tc);

    size_t degenerate = 0;
#pragma omp parallel for schedule(static) reduction(+ : degenerate) if (tp.par)
    for (size_t t = 0; t < tc; t++)
        degenerate += mr_triangle_is_degenerate(indices + 3 * t);
    s->degenerate_triangles = degenerate;

    scan_edges(&tp, s);
    if (s->boundary_edges || s->nonmanifold_edges)
        if ((st = scan_special_edges(&tp, s, err)) != MR_OK)
            goto done;
    mr_edge_table_free(&tp.et); /* the largest array: give it back early */
    count_fans(&tp);
    count_vertices(&tp, s);
    if ((st = count_boundary_loops(&tp, s, err)) != MR_OK)
        goto done;
    free(tp.fan);
    tp.fan = NULL;
    st = count_components(&tp, s, err);
done:
    topo_free(&tp);
    return st;
}

/* The topology of the surface: vertices that are one surface point
 * (mr_surface_points) count once. The vertex counts stay those of the
 * vertex arrays; surface_vertices and split_vertices tell the difference. */
static mr_status surface_topology(const float *positions, size_t stride,
                                  const uint32_t *indices, size_t tc, size_t vc, mr_stats *s,
                                  mr_error *err)
{
    float *packed = NULL;
    uint32_t *point = mr_alloc_array(vc, sizeof *point);
    if (!point)
        return mr_fail_nomem(err, NULL, vc * sizeof *point);
    if (stride != 3 * sizeof(float)) {
        packed = mr_alloc_array(vc, 3 * sizeof *packed);
        if (!packed) {
            free(point);
            return mr_fail_nomem(err, NULL, vc * 12);
        }
        for (size_t v = 0; v < vc; v++)
            memcpy(packed + 3 * v, (const char *)positions + v * stride, 12);
    }
    size_t split = 0;
    mr_status st = mr_surface_points(packed ? packed : positions, vc, indices, tc, point,
                                     &split, err);
    free(packed);
    uint32_t *welded = NULL;
    if (st == MR_OK && split) {
        welded = mr_alloc_array(3 * tc, sizeof *welded);
        if (!welded)
            st = mr_fail_nomem(err, NULL, 3 * tc * sizeof *welded);
        else
            for (size_t c = 0; c < 3 * tc; c++)
                welded[c] = point[indices[c]];
    }
    if (st == MR_OK)
        st = compute_topology(welded ? welded : indices, tc, vc, s, err);
    free(welded);
    if (st == MR_OK) {
        s->surface_vertices = s->referenced_vertices;
        if (split) {
            /* the vertex arrays' own count of referenced vertices */
            uint8_t *used = (uint8_t *)point; /* reused: vc bytes */
            memset(used, 0, vc);
            for (size_t c = 0; c < 3 * tc; c++)
                used[indices[c]] = 1;
            size_t referenced = 0;
            for (size_t v = 0; v < vc; v++)
                referenced += used[v];
            s->split_vertices = referenced - s->surface_vertices;
            s->referenced_vertices = referenced;
            s->unreferenced_vertices = vc - referenced;
        }
    }
    free(point);
    return st;
}

mr_status mr_stats_compute(const float *positions, size_t stride, size_t vertex_count,
                           const uint32_t *indices, size_t triangle_count, mr_stats *stats,
                           mr_error *err)
{
    if (!stats)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "stats is NULL");
    memset(stats, 0, sizeof *stats);
    if (vertex_count > 0 && !positions)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "positions is NULL for %zu vertices", vertex_count);
    if (triangle_count > 0 && !indices)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "indices is NULL for %zu triangles", triangle_count);
    if (stride == 0)
        stride = 3 * sizeof(float);
    if (stride < 3 * sizeof(float))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "position stride %zu is less than 12 bytes", stride);
    mr_status st = mr_check_indices(indices, triangle_count, vertex_count, err);
    if (st != MR_OK)
        return st;

    mr_stats s;
    memset(&s, 0, sizeof s);
    s.vertex_count = vertex_count;
    s.triangle_count = triangle_count;
    s.unreferenced_vertices = vertex_count;
    compute_bbox(positions, stride, vertex_count, &s);
    if (triangle_count > 0) {
        if ((st = compute_area(positions, stride, indices, triangle_count, &s.surface_area,
                               err)) != MR_OK)
            return st;
        if ((st = surface_topology(positions, stride, indices, triangle_count, vertex_count,
                                   &s, err)) != MR_OK)
            return st;
    } else {
        s.surface_vertices = 0;
    }
    s.euler_characteristic = (long long)s.surface_vertices - (long long)s.edge_count +
                             (long long)s.triangle_count;
    s.closed = s.edge_count > 0 && s.boundary_edges == 0 && s.nonmanifold_edges == 0;
    s.manifold = s.edge_count > 0 && s.nonmanifold_edges == 0 && s.nonmanifold_vertices == 0;
    s.oriented = s.manifold && s.misoriented_edges == 0;
    *stats = s;
    return MR_OK;
}
