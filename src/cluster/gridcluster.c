/*
 * Grid clustering (Rossignac and Borrel 1993) with Lindstrom's quadric
 * representative (out-of-core simplification, 2000).
 *
 * Every vertex falls into a cubic cell; cells are found by a stable radix
 * sort of the cell keys, so cluster ids follow the key order and every sum
 * below runs over its members in a fixed order: the result is the same at
 * any thread count. A triangle whose corners land in three different cells
 * survives (remapped); its area-weighted plane quadric is added to each of
 * the three cells, again through a sort (cell, triangle) rather than
 * floating-point atomics, so the accumulation order is fixed. A cell's
 * vertex minimises its quadric through a pseudo-inverse about the mean of
 * its points (directions the quadric does not constrain stay at the mean)
 * and is clamped into the cell.
 */
#include "grid.h"

#define PARALLEL_MIN 16384

void mr_cluster_options_default(mr_cluster_options *options)
{
    memset(options, 0, sizeof *options);
}

typedef struct cells {
    size_t count;
    uint64_t *keys;   /* n, sorted; then the key of each cell (count) */
    uint32_t *ids;    /* n: vertices in key order */
    uint32_t *first;  /* count + 1 */
} cells;

static void cells_free(cells *c)
{
    free(c->keys);
    free(c->ids);
    free(c->first);
    memset(c, 0, sizeof *c);
}

/* Bin and sort; when first is wanted, also the cell runs (keys then hold
 * one key per cell). */
static mr_status bin(const float *pos, size_t n, const mr_grid *g, int threads, int runs,
                     cells *c, mr_error *err)
{
    memset(c, 0, sizeof *c);
    c->keys = mr_alloc_array(n, sizeof *c->keys);
    c->ids = mr_alloc_array(n, sizeof *c->ids);
    if (!c->keys || !c->ids) {
        cells_free(c);
        return mr_fail_nomem(err, NULL, n * 12);
    }
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t i = 0; i < n; i++) {
        c->keys[i] = mr_grid_key(g, pos + 3 * i);
        c->ids[i] = (uint32_t)i;
    }
    mr_status s = mr_radix_sort_u64(c->keys, c->ids, n, mr_grid_key_bits(g), threads, err);
    if (s != MR_OK) {
        cells_free(c);
        return s;
    }
    size_t count = 0;
    for (size_t i = 0; i < n; i++)
        count += i == 0 || c->keys[i] != c->keys[i - 1];
    c->count = count;
    if (!runs)
        return MR_OK;
    c->first = mr_alloc_array(count + 1, sizeof *c->first);
    if (!c->first) {
        cells_free(c);
        return mr_fail_nomem(err, NULL, (count + 1) * 4);
    }
    for (size_t i = 0, k = 0; i < n; i++)
        if (i == 0 || c->keys[i] != c->keys[i - 1]) {
            c->keys[k] = c->keys[i];
            c->first[k++] = (uint32_t)i;
        }
    c->first[count] = (uint32_t)n;
    return MR_OK;
}

/* Jacobi eigen-decomposition of a symmetric 3x3 matrix: a becomes
 * diagonal (the eigenvalues), v the eigenvectors (columns). */
static void jacobi3(double a[3][3], double v[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            v[i][k] = i == k;
    for (int sweep = 0; sweep < 32; sweep++) {
        double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (off < 1e-30)
            break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (fabs(a[p][q]) < 1e-300)
                    continue;
                double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
                double t = (theta >= 0 ? 1 : -1) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 3; k++) {
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; k++) {
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 3; k++) {
                    double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
    }
}

/* Quadric of one triangle: area * (n n^T, n d, d^2) for its unit normal
 * n and plane offset d, as 10 numbers a00 a01 a02 a11 a12 a22 b0 b1 b2 c. */
void mr_cluster_triangle_quadric(const float *p0, const float *p1, const float *p2,
                                 double q[10])
{
    double u[3], w[3], nrm[3];
    for (int k = 0; k < 3; k++) {
        u[k] = (double)p1[k] - p0[k];
        w[k] = (double)p2[k] - p0[k];
    }
    nrm[0] = u[1] * w[2] - u[2] * w[1];
    nrm[1] = u[2] * w[0] - u[0] * w[2];
    nrm[2] = u[0] * w[1] - u[1] * w[0];
    double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
    memset(q, 0, 10 * sizeof *q);
    if (!(len > 0))
        return;
    double area = 0.5 * len;
    for (int k = 0; k < 3; k++)
        nrm[k] /= len;
    double d = -(nrm[0] * p0[0] + nrm[1] * p0[1] + nrm[2] * p0[2]);
    q[0] = area * nrm[0] * nrm[0], q[1] = area * nrm[0] * nrm[1], q[2] = area * nrm[0] * nrm[2];
    q[3] = area * nrm[1] * nrm[1], q[4] = area * nrm[1] * nrm[2], q[5] = area * nrm[2] * nrm[2];
    q[6] = area * nrm[0] * d, q[7] = area * nrm[1] * d, q[8] = area * nrm[2] * d;
    q[9] = area * d * d;
}

/* Minimiser of x^T A x + 2 b^T x about the mean m: x = m + A+ (-b - A m),
 * with eigenvalues below 1e-3 of the largest treated as zero. */
static void quadric_point(const double q[10], const double m[3], double x[3])
{
    double a[3][3] = {{q[0], q[1], q[2]}, {q[1], q[3], q[4]}, {q[2], q[4], q[5]}};
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = -q[6 + i] - (a[i][0] * m[0] + a[i][1] * m[1] + a[i][2] * m[2]);
    double v[3][3];
    jacobi3(a, v);
    double lmax = fmax(fabs(a[0][0]), fmax(fabs(a[1][1]), fabs(a[2][2])));
    for (int i = 0; i < 3; i++)
        x[i] = m[i];
    if (!(lmax > 0))
        return;
    for (int e = 0; e < 3; e++) {
        double l = a[e][e];
        if (fabs(l) < 1e-3 * lmax)
            continue;
        double proj = (v[0][e] * r[0] + v[1][e] * r[1] + v[2][e] * r[2]) / l;
        for (int i = 0; i < 3; i++)
            x[i] += proj * v[i][e];
    }
}

void mr_cluster_represent(const mr_grid *grid, uint64_t key, const double q[10],
                          const double pos_sum[3], const double nrm_sum[3],
                          const double uv_sum[2], const double col_sum[4], double count,
                          const double lo[3], const double hi[3], mr_mesh *out, size_t cc)
{
    double mean[3];
    for (int e = 0; e < 3; e++)
        mean[e] = pos_sum[e] / count;
    double x[3];
    quadric_point(q, mean, x);
    /* keep it inside its cell, and the cells at the far side of the grid
     * inside the input's bounding box (which a cell may cross, even past
     * the float range) */
    uint64_t ix[3];
    mr_grid_unpack(grid, key, ix);
    for (int e = 0; e < 3; e++) {
        double c0 = grid->lo[e] + (double)ix[e] * grid->cell, c1 = c0 + grid->cell;
        x[e] = fmin(fmax(x[e], fmax(c0, lo[e])), fmin(c1, hi[e]));
        out->positions[3 * cc + (size_t)e] = (float)x[e];
    }
    if (out->normals)
        for (int e = 0; e < 3; e++)
            out->normals[3 * cc + (size_t)e] = (float)(nrm_sum[e] / count);
    if (out->texcoords)
        for (int e = 0; e < 2; e++)
            out->texcoords[2 * cc + (size_t)e] = (float)(uv_sum[e] / count);
    if (out->colors)
        for (int e = 0; e < 4; e++)
            out->colors[4 * cc + (size_t)e] = (float)(col_sum[e] / count);
}

/* ---- the cell size for a target count -------------------------------------- */

/*
 * The search evaluates occupied-cell counts K(c) at cell sizes c and steers
 * by their logarithms: a surface's K falls about as c^-2, so from a first
 * guess (the box's surface area over the target: c0 = sqrt(A / N)) a
 * secant step in (log c, log K), kept inside the bracket of what is known
 * (bisection when it would leave it), meets the target within a few
 * evaluations. It stops within MR_SEARCH_TOLERANCE of N, or after
 * MR_SEARCH_STEPS, with the count nearest N (ties: the larger count). The
 * evaluations depend on the box and the counts alone, so every caller that
 * counts the same cells (in memory, from a file) finds the same cell.
 */
#define MR_SEARCH_TOLERANCE 0.02
#define MR_SEARCH_STEPS 16

size_t mr_cluster_sample_stride(size_t n, size_t target)
{
    /* a cell of the target's grid holds n / target points on average; a
     * sample that leaves it about 256 of them misses few cells (those the
     * surface only grazes), which the clustering's own count then checks */
    const size_t s = target ? n / (256 * target) : 1;
    return s < 1 ? 1 : s > 16 ? 16 : s;
}

bool mr_cluster_count_close(size_t count, size_t target)
{
    return fabs((double)count - (double)target) <= MR_SEARCH_TOLERANCE * (double)target;
}

mr_status mr_cluster_search(const double lo[3], const double hi[3], size_t target,
                            double start, mr_cell_count_fn count, void *user, double *cell_out,
                            mr_error *err)
{
    const double dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
    const double extent = fmax(dx, fmax(dy, dz));
    if (!(extent > 0)) {
        *cell_out = 1; /* every vertex at one point: one cell whatever the size */
        return MR_OK;
    }
    const double xmin = log(extent * 1e-7), xmax = log(extent * 2);
    const double area = 2 * (dx * dy + dy * dz + dz * dx);
    double x = start > 0             ? log(start)
               : area > 0            ? 0.5 * log(area / (double)target)
                                     : log(extent / (double)target);
    x = fmin(fmax(x, xmin), xmax);
    const double y_goal = log((double)target);
    /* bracket: a below (K >= N), b above (K < N) */
    double a = xmin, b = xmax;
    bool have_prev = false;
    double xp = 0, yp = 0, best_x = x;
    size_t best_k = 0;
    for (int step = 0; step < MR_SEARCH_STEPS; step++) {
        size_t k;
        mr_status st = count(exp(x), user, &k, err);
        if (st != MR_OK)
            return st;
        const double miss = fabs((double)k - (double)target), best_miss =
            fabs((double)best_k - (double)target);
        if (step == 0 || miss < best_miss || (miss == best_miss && k > best_k)) {
            best_k = k;
            best_x = x;
        }
        if (mr_cluster_count_close(k, target))
            break;
        if (k >= target)
            a = x > a ? x : a;
        else
            b = x < b ? x : b;
        const double y = log(k > 0 ? (double)k : 0.5);
        double slope = -2; /* a surface's */
        if (have_prev && x != xp) {
            const double sl = (y - yp) / (x - xp);
            if (sl < -0.25 && sl > -8)
                slope = sl;
        }
        double xn = x + (y_goal - y) / slope;
        if (!(xn > a && xn < b))
            xn = 0.5 * (a + b); /* outside what is known: bisect */
        if (fabs(xn - x) < 1e-9 || b - a < 1e-9)
            break; /* nothing left between: the count jumps over the target */
        xp = x;
        yp = y;
        have_prev = true;
        x = xn;
    }
    *cell_out = exp(best_x);
    return MR_OK;
}

/* K(c) of points in memory (every stride-th of n): binned and sorted as
 * for the clustering, or on bitmaps where the grid is small. */
typedef struct in_core_count {
    const float *pos;
    size_t n, stride;
    int threads;
    const double *lo, *hi;
} in_core_count;

static mr_status count_in_core(double cell, void *user, size_t *k, mr_error *err)
{
    const in_core_count *ic = user;
    mr_grid grid;
    mr_grid_init(&grid, ic->lo, ic->hi, cell);
    const size_t total = mr_grid_cells_total(&grid);
    const size_t n = (ic->n + ic->stride - 1) / ic->stride;
    if (total <= MR_GRID_BITMAP_CELLS) { /* a bit per cell of the grid */
        const size_t words = (total + 63) / 64;
        uint64_t *bits = mr_calloc_array(words * (size_t)ic->threads, sizeof *bits);
        if (!bits)
            return mr_fail_nomem(err, NULL, words * 8 * (size_t)ic->threads);
        mr_grid_mark(&grid, ic->pos, n, ic->stride, ic->threads, bits, words);
        *k = mr_grid_marked(bits, words, ic->threads);
        free(bits);
        return MR_OK;
    }
    float *sample = NULL;
    const float *pos = ic->pos;
    if (ic->stride > 1) {
        if (!(sample = mr_alloc_array(n, 3 * sizeof *sample)))
            return mr_fail_nomem(err, NULL, n * 12);
        for (size_t i = 0; i < n; i++)
            memcpy(sample + 3 * i, ic->pos + 3 * ic->stride * i, 12);
        pos = sample;
    }
    cells c;
    mr_status s = bin(pos, n, &grid, ic->threads, 0, &c, err);
    *k = c.count;
    cells_free(&c);
    free(sample);
    return s;
}

mr_status mr_mesh_cluster(const mr_mesh *in, const mr_cluster_options *options, mr_mesh *out,
                          mr_cluster_stats *stats, mr_error *err)
{
    mr_cluster_options defaults;
    if (!options) {
        mr_cluster_options_default(&defaults);
        options = &defaults;
    }
    mr_cluster_stats st;
    memset(&st, 0, sizeof st);
    if (stats)
        *stats = st;
    if (!in || !out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "mesh is NULL");
    mr_mesh_init(out);
    const size_t n = in->vertex_count, tc = in->triangle_count;
    if (n == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL, "no vertices to cluster");
    if (!in->positions)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "positions is NULL");
    if (n >= UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu vertices: more than 32-bit indices can address", n);
    if (options->target_vertices == 0 && options->cell_rel == 0 &&
        !(options->cell > 0 && isfinite(options->cell)))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "grid cell size must be a finite number > 0 when no target "
                             "vertex count is set, got %g",
                             options->cell);
    if (tc > 0 && !in->indices)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "%zu triangles but no indices",
                             tc);
    mr_status s = mr_check_indices(in->indices, tc, n, err);
    if (s != MR_OK)
        return s;
    const int threads = mr_thread_count(options->threads);
    const double t0 = mr_now_seconds();
    st.input_vertices = n;
    st.input_triangles = tc;

    double lo[3], hi[3];
    size_t bad;
    if (!mr_points_bounds(in->positions, n, threads, lo, hi, &bad))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "vertex %zu has a non-finite coordinate", bad);
    mr_grid grid;
    cells c;
    double cell = options->cell;
    if (options->target_vertices == 0 && options->cell_rel > 0) {
        const double dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
        const double diagonal = sqrt(dx * dx + dy * dy + dz * dz);
        cell = options->cell_rel * diagonal;
        if (diagonal == 0)
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                                 "all %zu vertices are at one point, so a cell of %g of the "
                                 "bounding-box diagonal (0) is no cell size; give a cell or a "
                                 "target vertex count",
                                 n, options->cell_rel);
        if (!(cell > 0) || isinf(cell))
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                                 "a cell of %g of the bounding-box diagonal (%g) is no usable "
                                 "cell size",
                                 options->cell_rel, diagonal);
    }
    /* A target: searched on a sample where the cells will be coarse, then
     * checked by the clustering's own binning; searched on every vertex,
     * from there, if the sample missed it. */
    const size_t target = options->target_vertices;
    size_t stride = target ? mr_cluster_sample_stride(n, target) : 1;
    if (target) {
        in_core_count ic = {in->positions, n, stride, threads, lo, hi};
        if ((s = mr_cluster_search(lo, hi, target, 0, count_in_core, &ic, &cell, err)) != MR_OK)
            return s;
    }
    mr_grid_init(&grid, lo, hi, cell);
    if ((s = bin(in->positions, n, &grid, threads, 1, &c, err)) != MR_OK)
        return s;
    if (target && stride > 1 && !mr_cluster_count_close(c.count, target)) {
        cells_free(&c);
        in_core_count ic = {in->positions, n, 1, threads, lo, hi};
        if ((s = mr_cluster_search(lo, hi, target, cell, count_in_core, &ic, &cell, err)) !=
            MR_OK)
            return s;
        mr_grid_init(&grid, lo, hi, cell);
        if ((s = bin(in->positions, n, &grid, threads, 1, &c, err)) != MR_OK)
            return s;
    }
    st.cell = grid.cell;
    const size_t k = c.count;
    st.cells = k;
    uint32_t *label = mr_alloc_array(n, sizeof *label);
    uint64_t *pairs = NULL;
    uint32_t *ptri = NULL, *tri_out = NULL;
    double *quad = NULL;
    size_t np = 0;
    unsigned attrs = mr_mesh_attributes(in) & MR_ATTR_BASIC;
    if (!label || (s = mr_mesh_alloc(out, k, 0, attrs, err)) != MR_OK) {
        if (!label)
            s = mr_fail_nomem(err, NULL, n * 4);
        goto done;
    }
#pragma omp parallel for schedule(static) num_threads(threads) if (k > 1024)
    for (size_t cc = 0; cc < k; cc++)
        for (uint32_t i = c.first[cc]; i < c.first[cc + 1]; i++)
            label[c.ids[i]] = (uint32_t)cc;
    st.seconds_cells = mr_now_seconds() - t0;

    /* surviving triangles and the (cell, triangle) pairs of their quadrics */
    double t1 = mr_now_seconds();
    size_t survivors = 0;
    for (size_t t = 0; t < tc; t++) {
        const uint32_t *tri = in->indices + 3 * t;
        uint32_t a = label[tri[0]], b = label[tri[1]], d = label[tri[2]];
        survivors += a != b && b != d && a != d;
    }
    tri_out = mr_alloc_array(survivors, 3 * sizeof *tri_out);
    pairs = mr_alloc_array(3 * survivors, sizeof *pairs);
    ptri = mr_alloc_array(3 * survivors, sizeof *ptri);
    quad = mr_calloc_array(k, 10 * sizeof *quad);
    if (!tri_out || !pairs || !ptri || !quad) {
        s = mr_fail_nomem(err, NULL, survivors * 36 + k * 80);
        goto done;
    }
    for (size_t t = 0, o = 0; t < tc; t++) {
        const uint32_t *tri = in->indices + 3 * t;
        uint32_t a = label[tri[0]], b = label[tri[1]], d = label[tri[2]];
        if (a == b || b == d || a == d)
            continue;
        tri_out[3 * o] = a, tri_out[3 * o + 1] = b, tri_out[3 * o + 2] = d;
        for (int q = 0; q < 3; q++) {
            pairs[3 * o + (size_t)q] = tri_out[3 * o + (size_t)q];
            ptri[3 * o + (size_t)q] = (uint32_t)t;
        }
        o++;
    }
    np = 3 * survivors;
    if ((s = mr_radix_sort_u64(pairs, ptri, np, mr_index_bits(k), threads, err)) != MR_OK)
        goto done;

    /* per cell: quadric sum (pairs sorted by cell, triangles ascending),
     * mean of positions and attributes, and the representative */
    {
        const float *P = in->positions;
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads) if (k > 1024)
        for (size_t cc = 0; cc < k; cc++) {
            double *q = quad + 10 * cc;
            /* the pairs of cell cc: a binary search for its first one */
            size_t a = 0, b = np;
            while (a < b) {
                size_t m = a + (b - a) / 2;
                if (pairs[m] < cc)
                    a = m + 1;
                else
                    b = m;
            }
            for (size_t i = a; i < np && pairs[i] == cc; i++) {
                const uint32_t *tri = in->indices + 3 * (size_t)ptri[i];
                double tq[10];
                mr_cluster_triangle_quadric(P + 3 * (size_t)tri[0], P + 3 * (size_t)tri[1],
                                            P + 3 * (size_t)tri[2], tq);
                for (int e = 0; e < 10; e++)
                    q[e] += tq[e];
            }
            double mean[3] = {0, 0, 0}, nrm[3] = {0, 0, 0}, uv[2] = {0, 0},
                   col[4] = {0, 0, 0, 0};
            const double cnt = (double)(c.first[cc + 1] - c.first[cc]);
            for (uint32_t i = c.first[cc]; i < c.first[cc + 1]; i++) {
                size_t v = c.ids[i];
                for (int e = 0; e < 3; e++)
                    mean[e] += P[3 * v + (size_t)e];
                if (in->normals)
                    for (int e = 0; e < 3; e++)
                        nrm[e] += in->normals[3 * v + (size_t)e];
                if (in->texcoords)
                    for (int e = 0; e < 2; e++)
                        uv[e] += in->texcoords[2 * v + (size_t)e];
                if (in->colors)
                    for (int e = 0; e < 4; e++)
                        col[e] += in->colors[4 * v + (size_t)e];
            }
            mr_cluster_represent(&grid, c.keys[cc], q, mean, nrm, uv, col, cnt, lo, hi, out,
                                 cc);
        }
    }
    st.seconds_representatives = mr_now_seconds() - t1;

    t1 = mr_now_seconds();
    free(out->indices); /* the placeholder mr_mesh_alloc made for 0 triangles */
    out->indices = tri_out;
    out->triangle_count = survivors;
    tri_out = NULL;
    if ((s = mr_mesh_remove_degenerate(out, 1, NULL, err)) != MR_OK)
        goto done;
    if (tc > 0 && (s = mr_mesh_remove_unreferenced(out, NULL, err)) != MR_OK)
        goto done;
    st.seconds_triangles = mr_now_seconds() - t1;
    st.output_vertices = out->vertex_count;
    st.output_triangles = out->triangle_count;

done:
    free(label);
    free(pairs);
    free(ptri);
    free(quad);
    free(tri_out);
    cells_free(&c);
    if (s != MR_OK)
        mr_mesh_free(out);
    st.seconds_total = mr_now_seconds() - t0;
    if (stats)
        *stats = st;
    return s;
}
