/*
 * Cleanup passes on the owning mesh. Each keeps the relative order of what
 * stays, works in O(n log n) on flat arrays, and validates the mesh first
 * (an index out of range is MR_ERR_INVALID_ARGUMENT naming the triangle,
 * and the mesh is left as it was).
 *
 * Welding: two vertices are equal when the bit patterns of their positions
 * (and, with require_same_attributes, of every attribute array the mesh
 * has) are equal, reading -0 as +0 (the two zeros compare equal as numbers;
 * a writer may produce either). NaNs compare by their bits. The first
 * vertex of each class stays, with its attributes; the later ones are
 * removed from the vertex arrays whether triangles used them or not, and
 * every other vertex, referenced or not, stays in order. Welding can make
 * triangles degenerate (two of their corners welded); it does not remove
 * them: that is mr_mesh_remove_degenerate's job.
 *
 * Degenerate and duplicate triangles: a triangle is degenerate when it uses
 * a vertex twice; a duplicate is a non-degenerate triangle over the same
 * three vertices as an earlier one, in any order or orientation. The count
 * of duplicates matches mr_stats.duplicate_triangles.
 */
#include "adjacency.h"
#include "weld_map.h"

#define PARALLEL_MIN 65536

static mr_status check_mesh(const mr_mesh *mesh, mr_error *err)
{
    if (!mesh)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "mesh is NULL");
    if (mesh->vertex_count > 0 && !mesh->positions)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "mesh has %zu vertices but no positions", mesh->vertex_count);
    if (mesh->triangle_count > 0 && !mesh->indices)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "mesh has %zu triangles but no indices", mesh->triangle_count);
    return mr_check_indices(mesh->indices, mesh->triangle_count, mesh->vertex_count, err);
}

/*
 * Drop the vertices with keep[v] == 0 and renumber the rest in order. On
 * entry new_id[v] is the vertex that v becomes: itself for a kept vertex,
 * an earlier kept vertex for a merged one (a dropped vertex that no
 * triangle uses may point at itself). Triangles are remapped to the new
 * numbering; attributes move with the positions.
 */
static void compact_vertices(mr_mesh *mesh, uint32_t *new_id, const uint8_t *keep)
{
    const size_t vc = mesh->vertex_count;
    uint32_t next = 0;
    for (size_t v = 0; v < vc; v++) {
        if (keep[v])
            new_id[v] = next++;
        else
            /* the target is <= v: its new id is already known, or it is
             * v itself, unused */
            new_id[v] = new_id[new_id[v]];
    }
    const size_t n = 3 * mesh->triangle_count;
    uint32_t *idx = mesh->indices;
#pragma omp parallel for schedule(static) if (n > PARALLEL_MIN)
    for (size_t c = 0; c < n; c++)
        idx[c] = new_id[idx[c]];
    for (size_t v = 0; v < vc; v++)
        if (!keep[v])
            new_id[v] = UINT32_MAX;
    mr_mesh_compact_vertices(mesh, new_id, next);
}

mr_status mr_mesh_remove_unreferenced(mr_mesh *mesh, size_t *removed, mr_error *err)
{
    if (removed)
        *removed = 0;
    mr_status st = check_mesh(mesh, err);
    if (st != MR_OK)
        return st;
    const size_t vc = mesh->vertex_count;
    if (mesh->triangle_count == 0 || vc == 0)
        return MR_OK; /* a point cloud keeps all its points */

    uint8_t *keep = mr_calloc_array(vc, 1);
    uint32_t *new_id = mr_alloc_array(vc, sizeof *new_id);
    if (!keep || !new_id) {
        free(keep);
        free(new_id);
        return mr_fail_nomem(err, NULL, vc * 5);
    }
    const size_t n = 3 * mesh->triangle_count;
    for (size_t c = 0; c < n; c++)
        keep[mesh->indices[c]] = 1;
    size_t dropped = 0;
    for (size_t v = 0; v < vc; v++) {
        new_id[v] = (uint32_t)v;
        dropped += !keep[v];
    }
    if (dropped)
        compact_vertices(mesh, new_id, keep);
    free(keep);
    free(new_id);
    if (removed)
        *removed = dropped;
    return MR_OK;
}

/* ---- welding --------------------------------------------------------------- */

mr_status mr_mesh_weld_exact(mr_mesh *mesh, int require_same_attributes, size_t *removed,
                             mr_error *err)
{
    if (removed)
        *removed = 0;
    mr_status st = check_mesh(mesh, err);
    if (st != MR_OK)
        return st;
    const size_t vc = mesh->vertex_count;
    if (vc < 2)
        return MR_OK;

    mr_weld_layout l = {{mesh->positions}, {3}, 1};
    if (require_same_attributes) {
        const float *arrays[3] = {mesh->normals, mesh->texcoords, mesh->colors};
        const unsigned widths[3] = {3, 2, 4};
        for (unsigned k = 0; k < 3; k++) {
            if (arrays[k]) {
                l.arrays[l.count] = arrays[k];
                l.widths[l.count++] = widths[k];
            }
        }
    }

    uint32_t *target = mr_alloc_array(vc, sizeof *target);
    uint8_t *keep = mr_calloc_array(vc, 1);
    size_t merged = 0;
    if (!target || !keep)
        st = mr_fail_nomem(err, NULL, vc * 5);
    else
        st = mr_weld_map(&l, vc, target, keep, &merged, err);
    if (st == MR_OK && merged)
        compact_vertices(mesh, target, keep);
    if (st == MR_OK && removed)
        *removed = merged;
    free(target);
    free(keep);
    return st;
}

mr_status mr_mesh_weld_seams(mr_mesh *mesh, size_t *removed, mr_error *err)
{
    if (removed)
        *removed = 0;
    mr_status st = check_mesh(mesh, err);
    if (st != MR_OK)
        return st;
    const size_t vc = mesh->vertex_count;
    if (vc < 2 || mesh->triangle_count == 0)
        return MR_OK;
    mr_weld_layout l = {{mesh->positions}, {3}, 1};
    const float *arrays[3] = {mesh->normals, mesh->texcoords, mesh->colors};
    const unsigned widths[3] = {3, 2, 4};
    for (unsigned k = 0; k < 3; k++)
        if (arrays[k]) {
            l.arrays[l.count] = arrays[k];
            l.widths[l.count++] = widths[k];
        }
    uint32_t *point = mr_alloc_array(vc, sizeof *point);
    uint32_t *ids = mr_alloc_array(vc, sizeof *ids);
    uint32_t *reps = mr_alloc_array(vc, sizeof *reps);
    uint8_t *keep = mr_calloc_array(vc, 1);
    size_t split = 0, merged = 0;
    if (!point || !ids || !reps || !keep) {
        st = mr_fail_nomem(err, NULL, vc * 13);
        goto done;
    }
    st = mr_surface_points(mesh->positions, vc, mesh->indices, mesh->triangle_count, point,
                           &split, err);
    if (st != MR_OK || split == 0)
        goto done;
    /* The vertices of each surface point, in index order (a counting sort
     * by point: the point is the smallest index of its vertices). */
    uint32_t *start = reps; /* reused below as mr_weld_run's scratch */
    for (size_t v = 0; v < vc; v++)
        start[v] = 0;
    for (size_t v = 0; v < vc; v++)
        start[point[v]]++;
    uint32_t sum = 0;
    for (size_t v = 0; v < vc; v++) {
        const uint32_t n = start[v];
        start[v] = sum;
        sum += n;
    }
    for (size_t v = 0; v < vc; v++)
        ids[start[point[v]]++] = (uint32_t)v;
    /* ids now holds each point's vertices from its (old) start on; the
     * runs are where consecutive entries share a point. */
    for (size_t i = 0; i < vc;) {
        size_t j = i + 1;
        while (j < vc && point[ids[j]] == point[ids[i]])
            j++;
        mr_weld_run(&l, ids + i, j - i, point, keep, reps, &merged);
        i = j;
    }
    if (merged)
        compact_vertices(mesh, point, keep);
    if (removed)
        *removed = merged;
done:
    free(point);
    free(ids);
    free(reps);
    free(keep);
    return st;
}

/* ---- degenerate and duplicate triangles ------------------------------------ */

static inline void sort3(const uint32_t *tri, uint32_t s[3])
{
    uint32_t a = tri[0], b = tri[1], c = tri[2], t;
    if (a > b) { t = a; a = b; b = t; }
    if (b > c) { t = b; b = c; c = t; }
    if (a > b) { t = a; a = b; b = t; }
    s[0] = a;
    s[1] = b;
    s[2] = c;
}

/* Flag (drop[t] = 1) each non-degenerate triangle whose vertex set equals
 * that of an earlier one: sort by the two smallest vertices, then settle
 * the largest within each (short) run. */
static mr_status flag_duplicates(const mr_mesh *mesh, uint8_t *drop, mr_error *err)
{
    const size_t tc = mesh->triangle_count;
    const unsigned shift = mr_index_bits(mesh->vertex_count);
    const unsigned key_bits = 2 * shift;
    /* Degenerate triangles get the all-ones key, after every real pair. */
    const uint64_t none = key_bits >= 64 ? UINT64_MAX : (UINT64_C(1) << key_bits) - 1;
    uint64_t *keys = mr_alloc_array(tc, sizeof *keys);
    uint32_t *ids = mr_alloc_array(tc, sizeof *ids);
    uint64_t *pairs = NULL;
    mr_status st = MR_OK;
    if (!keys || !ids) {
        st = mr_fail_nomem(err, NULL, tc * 12);
        goto done;
    }
    const uint32_t *idx = mesh->indices;
#pragma omp parallel for schedule(static) if (tc > PARALLEL_MIN)
    for (size_t t = 0; t < tc; t++) {
        uint32_t s[3];
        sort3(idx + 3 * t, s);
        keys[t] = drop[t] ? none : ((uint64_t)s[0] << shift) | s[1];
        ids[t] = (uint32_t)t;
    }
    if ((st = mr_radix_sort_u64(keys, ids, tc, key_bits, 0, err)) != MR_OK)
        goto done;
    size_t cap = 0;
    for (size_t i = 0; i < tc && keys[i] != none;) {
        size_t j = i + 1;
        while (j < tc && keys[j] == keys[i])
            j++;
        size_t k = j - i;
        if (k >= 2) {
            if (k > cap) {
                uint64_t *p = mr_realloc_array(pairs, k, sizeof *p);
                if (!p) {
                    st = mr_fail_nomem(err, NULL, k * sizeof *p);
                    goto done;
                }
                pairs = p;
                cap = k;
            }
            for (size_t m = 0; m < k; m++) {
                uint32_t s[3];
                sort3(idx + 3 * (size_t)ids[i + m], s);
                pairs[m] = ((uint64_t)s[2] << 32) | ids[i + m];
            }
            mr_mark_repeats(pairs, k, drop);
        }
        i = j;
    }
done:
    free(keys);
    free(ids);
    free(pairs);
    return st;
}

mr_status mr_mesh_remove_degenerate(mr_mesh *mesh, int remove_duplicates, size_t *removed,
                                    mr_error *err)
{
    if (removed)
        *removed = 0;
    mr_status st = check_mesh(mesh, err);
    if (st != MR_OK)
        return st;
    const size_t tc = mesh->triangle_count;
    if (tc == 0)
        return MR_OK;
    uint8_t *drop = mr_alloc_array(tc, 1);
    if (!drop)
        return mr_fail_nomem(err, NULL, tc);
    uint32_t *idx = mesh->indices;
#pragma omp parallel for schedule(static) if (tc > PARALLEL_MIN)
    for (size_t t = 0; t < tc; t++)
        drop[t] = mr_triangle_is_degenerate(idx + 3 * t);
    if (remove_duplicates && (st = flag_duplicates(mesh, drop, err)) != MR_OK) {
        free(drop);
        return st;
    }
    size_t kept = 0;
    for (size_t t = 0; t < tc; t++) {
        if (drop[t])
            continue;
        if (kept != t) {
            memcpy(idx + 3 * kept, idx + 3 * t, 3 * sizeof *idx);
            if (mesh->materials)
                mesh->materials[kept] = mesh->materials[t];
        }
        kept++;
    }
    free(drop);
    mesh->triangle_count = kept;
    if (removed)
        *removed = tc - kept;
    return MR_OK;
}

/* ---- orientation ---------------------------------------------------------- */

/*
 * Each corner's half-edge links its triangle to the triangle across it
 * (when the edge has exactly two): across[c] = (t << 1) | same, where same
 * says both run the edge the same way, i.e. one of the two must flip for
 * them to agree. A breadth-first walk over those links from each part's
 * first triangle gives every triangle its flip relative to that one; a
 * link that disagrees with the walk makes the part non-orientable.
 */
mr_status mr_mesh_orient(mr_mesh *mesh, size_t *flipped, size_t *nonorientable,
                         mr_error *err)
{
    if (flipped)
        *flipped = 0;
    if (nonorientable)
        *nonorientable = 0;
    mr_status st = check_mesh(mesh, err);
    if (st != MR_OK)
        return st;
    const size_t tc = mesh->triangle_count;
    if (tc == 0)
        return MR_OK;
    uint32_t *idx = mesh->indices;
    mr_edge_table et;
    if ((st = mr_edge_table_build(&et, idx, tc, mesh->vertex_count, err)) != MR_OK)
        return st;
    const uint32_t NO_LINK = UINT32_MAX;
    uint32_t *across = mr_alloc_array(3 * tc, sizeof *across);
    uint32_t *queue = mr_alloc_array(tc, sizeof *queue); /* one part, in walk order */
    uint8_t *flip = mr_alloc_array(tc, 1);               /* 2: not reached yet */
    if (!across || !queue || !flip) {
        st = mr_fail_nomem(err, NULL, tc * 17);
        goto done;
    }
    for (size_t c = 0; c < 3 * tc; c++)
        across[c] = NO_LINK;
    for (uint32_t lo = 0; lo < et.vertex_count; lo++) {
        for (size_t i = et.offsets[lo], j; i < et.offsets[lo + 1]; i = j) {
            j = mr_edge_run_end(&et, lo, i);
            if (j - i != 2)
                continue;
            const uint32_t c0 = mr_edge_corner(et.entries[i]);
            const uint32_t c1 = mr_edge_corner(et.entries[i + 1]);
            const uint32_t same = mr_edge_same_way(idx, c0, c1, lo);
            across[c0] = (c1 / 3) << 1 | same;
            across[c1] = (c0 / 3) << 1 | same;
        }
    }
    mr_edge_table_free(&et);
    memset(flip, 2, tc);
    size_t total_flipped = 0, bad_parts = 0;
    for (size_t seed = 0; seed < tc; seed++) {
        if (flip[seed] != 2)
            continue;
        size_t head = 0, tail = 0;
        bool orientable = true, closed = true;
        flip[seed] = 0;
        queue[tail++] = (uint32_t)seed;
        while (head < tail) {
            const uint32_t t = queue[head++];
            for (uint32_t k = 0; k < 3; k++) {
                const uint32_t link = across[3 * (size_t)t + k];
                if (link == NO_LINK) {
                    closed = false;
                    continue;
                }
                const uint32_t u = link >> 1;
                const uint8_t want = (uint8_t)(flip[t] ^ (link & 1));
                if (flip[u] == 2) {
                    flip[u] = want;
                    queue[tail++] = u;
                } else if (flip[u] != want) {
                    orientable = false;
                }
            }
        }
        if (!orientable) {
            bad_parts++;
            continue;
        }
        /* A closed part faces out (positive volume); an open one keeps the
         * winding of most of its triangles (ties: the seed's). */
        uint8_t invert;
        if (closed) {
            double volume = 0;
            for (size_t i = 0; i < tail; i++) {
                const uint32_t *tri = idx + 3 * (size_t)queue[i];
                const float *a = mesh->positions + 3 * (size_t)tri[0];
                const float *b = mesh->positions + 3 * (size_t)tri[flip[queue[i]] ? 2 : 1];
                const float *c = mesh->positions + 3 * (size_t)tri[flip[queue[i]] ? 1 : 2];
                const double ab[3] = {(double)b[0] - a[0], (double)b[1] - a[1],
                                      (double)b[2] - a[2]};
                const double ac[3] = {(double)c[0] - a[0], (double)c[1] - a[1],
                                      (double)c[2] - a[2]};
                /* 6 x the signed volume of the tetrahedron (origin, a, b,
                 * c): a . (ab x ac) */
                volume += a[0] * (ab[1] * ac[2] - ab[2] * ac[1]) +
                          a[1] * (ab[2] * ac[0] - ab[0] * ac[2]) +
                          a[2] * (ab[0] * ac[1] - ab[1] * ac[0]);
            }
            invert = volume < 0;
        } else {
            size_t ones = 0;
            for (size_t i = 0; i < tail; i++)
                ones += flip[queue[i]];
            invert = 2 * ones > tail;
        }
        for (size_t i = 0; i < tail; i++) {
            const uint32_t t = queue[i];
            if ((flip[t] ^ invert) == 0)
                continue;
            uint32_t *tri = idx + 3 * (size_t)t;
            const uint32_t x = tri[1];
            tri[1] = tri[2];
            tri[2] = x;
            total_flipped++;
        }
    }
    if (flipped)
        *flipped = total_flipped;
    if (nonorientable)
        *nonorientable = bad_parts;
done:
    mr_edge_table_free(&et);
    free(across);
    free(queue);
    free(flip);
    return st;
}
