/*
 * Which vertices are one point of the surface.
 *
 * Files split a vertex where its attributes differ across the surface: a
 * UV seam or a hard edge gives one position two (or more) vertices, so the
 * index topology shows a cut where the surface has none. Other files keep
 * parts apart that only touch: two closed shells sharing one point, a
 * double-sided sheet, a stack of separately indexed pieces. Both look the
 * same to a weld by position; only the triangles tell them apart.
 *
 * The rule: two vertices at bitwise-equal positions are one surface point
 * when an edge joins their triangles across the split -- the two
 * triangles of a geometric edge (its ends taken by position) that use
 * different vertices for it, wound against each other as neighbours are
 * and not folded flat onto each other (that is two coincident sheets) --
 * and the vertices so joined form one manifold fan (a disk, or a half-disk
 * on an open boundary). An edge with three or more triangles by position
 * joins nothing; a join that would leave a fan which is not one manifold
 * fan is undone (and the joins of its neighbours are checked again, until
 * none changes).
 *
 * This is the one function that decides the surface topology for the
 * simplifier, the statistics and the format conversion.
 */
#include "adjacency.h"
#include "weld_map.h"

typedef struct seam_edge {
    uint64_t key; /* (lower position id << 32) | higher, the geometric edge */
    uint32_t he;  /* half-edge 3t + j: from corner j to corner j + 1 */
} seam_edge;

static int seam_edge_cmp(const void *pa, const void *pb)
{
    const seam_edge *a = pa, *b = pb;
    if (a->key != b->key)
        return a->key < b->key ? -1 : 1;
    return a->he < b->he ? -1 : a->he > b->he;
}

static void normal_of(const float *positions, const uint32_t *tri, double n[3])
{
    double p[3][3];
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 3; j++)
            p[k][j] = positions[3 * (size_t)tri[k] + j];
    const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double v[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
}

/* Do the triangles of half-edges h0 and h1 (one edge, run both ways) lie
 * folded onto each other -- opposite normals, within a degree? That is two
 * coincident sheets (a double-sided one, glued along its border), not one
 * surface split by attributes: no surface turns back on itself so. */
static bool folded(const float *positions, const uint32_t *indices, uint32_t h0, uint32_t h1)
{
    double n0[3], n1[3];
    normal_of(positions, indices + (h0 - h0 % 3), n0);
    normal_of(positions, indices + (h1 - h1 % 3), n1);
    const double d = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
    const double l2 = (n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]) *
                      (n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]);
    const double cos_1deg = 0.99984769515639127;
    return d < 0 && d * d >= cos_1deg * cos_1deg * l2;
}

mr_status mr_surface_points(const float *positions, size_t vertex_count,
                            const uint32_t *indices, size_t triangle_count, uint32_t *point,
                            size_t *split_vertices, mr_error *err)
{
    if (split_vertices)
        *split_vertices = 0;
    if (!point || (vertex_count && !positions) || (triangle_count && !indices))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "surface points: NULL array");
    mr_status st = mr_check_indices(indices, triangle_count, vertex_count, err);
    if (st != MR_OK)
        return st;
    const size_t vc = vertex_count, tc = triangle_count;
    for (size_t v = 0; v < vc; v++)
        point[v] = (uint32_t)v;
    if (vc < 2 || tc == 0)
        return MR_OK;

    uint32_t *geo = mr_alloc_array(vc, sizeof *geo);
    uint32_t *size = mr_calloc_array(vc, sizeof *size);
    seam_edge *edges = NULL;
    uint32_t *members = NULL, *mstart = NULL, *corners = NULL, *cstart = NULL;
    mr_fan_entry *fan = NULL;
    uint8_t *seen = NULL;
    if (!geo || !size) {
        st = mr_fail_nomem(err, NULL, vc * 8);
        goto done;
    }
    if ((st = mr_weld_positions(positions, vc, geo, err)) != MR_OK)
        goto done;
    for (size_t v = 0; v < vc; v++)
        size[geo[v]]++;
    /* Only half-edges with an end at a shared position can be split: at
     * most two for each corner there. */
    size_t ne = 0;
    for (size_t c = 0; c < 3 * tc; c++)
        ne += 2 * (size[geo[indices[c]]] > 1);
    if (ne == 0)
        goto done;
    edges = mr_alloc_array(ne, sizeof *edges);
    if (!edges) {
        st = mr_fail_nomem(err, NULL, ne * sizeof *edges);
        goto done;
    }
    ne = 0;
    for (size_t t = 0; t < tc; t++) {
        const uint32_t *tri = indices + 3 * t;
        const uint32_t g0 = geo[tri[0]], g1 = geo[tri[1]], g2 = geo[tri[2]];
        if (g0 == g1 || g1 == g2 || g0 == g2)
            continue; /* degenerate by position: no edges */
        for (uint32_t j = 0; j < 3; j++) {
            const uint32_t a = geo[tri[j]], b = geo[tri[mr_local_next(j)]];
            if (size[a] < 2 && size[b] < 2)
                continue;
            const uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
            edges[ne].key = (uint64_t)lo << 32 | hi;
            edges[ne].he = (uint32_t)(3 * t + j);
            ne++;
        }
    }
    qsort(edges, ne, sizeof *edges, seam_edge_cmp);

    /* Join across every geometric edge of exactly two triangles, wound
     * against each other, that do not share the edge's vertices. */
    for (size_t i = 0; i < ne;) {
        size_t k = i + 1;
        while (k < ne && edges[k].key == edges[i].key)
            k++;
        if (k - i == 2) {
            const uint32_t h0 = edges[i].he, h1 = edges[i + 1].he;
            const uint32_t a = indices[h0], x = indices[h0 - h0 % 3 + mr_local_next(h0 % 3)];
            const uint32_t b = indices[h1], y = indices[h1 - h1 % 3 + mr_local_next(h1 % 3)];
            if (geo[a] == geo[y] && geo[x] == geo[b] && (a != y || x != b) &&
                !folded(positions, indices, h0, h1)) {
                mr_uf_union(point, a, y);
                mr_uf_union(point, x, b);
            }
        }
        i = k;
    }
    for (size_t v = 0; v < vc; v++)
        point[v] = mr_uf_find(point, (uint32_t)v);

    /* The joined vertices, grouped by point (counting sort), and their
     * corners. */
    size_t nm = 0;
    for (size_t v = 0; v < vc; v++)
        size[v] = 0;
    for (size_t v = 0; v < vc; v++)
        if (point[v] != v) {
            size[point[v]]++;
            nm++;
        }
    if (nm == 0)
        goto done;
    for (size_t v = 0; v < vc; v++)
        if (point[v] == v && size[v])
            nm++; /* the representative itself */
    members = mr_alloc_array(nm, sizeof *members);
    mstart = mr_alloc_array(vc + 1, sizeof *mstart);
    cstart = mr_calloc_array(nm + 1, sizeof *cstart);
    if (!members || !mstart || !cstart) {
        st = mr_fail_nomem(err, NULL, nm * 8 + vc * 4);
        goto done;
    }
    /* mstart[r]: where point r's members begin (only for points with
     * joined members); members in increasing index order. */
    uint32_t pos = 0;
    for (size_t v = 0; v < vc; v++) {
        mstart[v] = pos;
        if (point[v] == v && size[v])
            pos += size[v] + 1;
    }
    mstart[vc] = pos;
    for (size_t v = 0; v < vc; v++)
        size[v] = 0;
    for (size_t v = 0; v < vc; v++) {
        const uint32_t r = point[v];
        if (mstart[r + 1] > mstart[r])
            members[mstart[r] + size[r]++] = (uint32_t)v;
    }
    /* slot of each member in members[] (reusing geo, no longer needed) */
    for (size_t v = 0; v < vc; v++)
        geo[v] = UINT32_MAX;
    for (size_t i = 0; i < nm; i++)
        geo[members[i]] = (uint32_t)i;
    for (size_t c = 0; c < 3 * tc; c++)
        if (geo[indices[c]] != UINT32_MAX)
            cstart[geo[indices[c]] + 1]++;
    for (size_t i = 0; i < nm; i++)
        cstart[i + 1] += cstart[i];
    corners = mr_alloc_array(cstart[nm] ? cstart[nm] : 1, sizeof *corners);
    uint32_t *fill = size; /* per member slot */
    if (!corners) {
        st = mr_fail_nomem(err, NULL, (size_t)cstart[nm] * 4);
        goto done;
    }
    for (size_t i = 0; i < nm; i++)
        fill[i] = cstart[i];
    size_t widest = 0;
    for (size_t c = 0; c < 3 * tc; c++) {
        const uint32_t i = geo[indices[c]];
        if (i != UINT32_MAX)
            corners[fill[i]++] = (uint32_t)c;
    }
    for (size_t v = 0; v < vc; v++)
        if (mstart[v + 1] > mstart[v]) {
            size_t n = cstart[mstart[v + 1]] - cstart[mstart[v]];
            widest = n > widest ? n : widest;
        }
    fan = mr_alloc_array(widest ? widest : 1, sizeof *fan);
    seen = mr_alloc_array(widest ? widest : 1, 1);
    if (!fan || !seen) {
        st = mr_fail_nomem(err, NULL, widest * 9);
        goto done;
    }

    /* Undo the joins whose fan is not one manifold fan, until none is. */
    for (bool changed = true; changed;) {
        changed = false;
        for (size_t r = 0; r < vc; r++) {
            const uint32_t m0 = mstart[r], m1 = mstart[r + 1];
            if (m1 == m0 || point[members[m0]] != members[m0] || point[members[m0 + 1]] == members[m0 + 1])
                continue; /* no joined point here (or already undone) */
            size_t n = 0;
            for (uint32_t c = cstart[m0]; c < cstart[m1]; c++) {
                const uint32_t h = corners[c], j = h % 3, *tri = indices + (h - j);
                const uint32_t p0 = point[tri[0]], p1 = point[tri[1]], p2 = point[tri[2]];
                if (p0 == p1 || p1 == p2 || p0 == p2)
                    continue; /* no edges: the simplifier and stats drop it */
                fan[n].next = point[tri[mr_local_next(j)]];
                fan[n].prev = point[tri[mr_local_prev(j)]];
                n++;
            }
            if (mr_fan_classify((uint32_t)r, fan, n, seen) < 0) {
                for (uint32_t i = m0; i < m1; i++)
                    point[members[i]] = members[i];
                changed = true;
            }
        }
    }
    if (split_vertices) {
        size_t n = 0;
        for (size_t v = 0; v < vc; v++)
            n += point[v] != v;
        *split_vertices = n;
    }
done:
    free(geo);
    free(size);
    free(edges);
    free(members);
    free(mstart);
    free(corners);
    free(cstart);
    free(fan);
    free(seen);
    return st;
}
