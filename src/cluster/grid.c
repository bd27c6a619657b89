/*
 * Fixed-radius neighbour search on a uniform grid.
 *
 * Points are binned into cubic cells of edge >= eps and sorted by cell key
 * (a stable radix sort, so the layout is the same at any thread count). The
 * key packs z, y, x from the high bits down, so the three cells x-1 .. x+1 of one row of the 3x3x3
 * neighbourhood are consecutive keys and their points one contiguous range
 * of the sorted array: each cell needs nine range look-ups, not 27, and
 * the candidate scan runs over sorted, contiguous positions.
 *
 * The graph is built in two passes over the same search: the first counts
 * each point's larger and smaller neighbours (the smaller count is P-Weld's
 * dependency count), a prefix sum places the lists, the second fills them.
 * Searching twice costs less than storing the lists twice (per-thread
 * buffers copied into place), and no allocation happens per point.
 */
#include "grid.h"

#include "../mesh/adjacency.h"

#ifdef _OPENMP
#include <omp.h>
#endif

#define PARALLEL_MIN 16384

bool mr_points_bounds(const float *pos, size_t n, int threads, double lo[3], double hi[3],
                      size_t *bad)
{
    double l0 = INFINITY, l1 = INFINITY, l2 = INFINITY;
    double h0 = -INFINITY, h1 = -INFINITY, h2 = -INFINITY;
    size_t first_bad = SIZE_MAX;
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN) \
    reduction(min : l0, l1, l2, first_bad) reduction(max : h0, h1, h2)
    for (size_t i = 0; i < n; i++) {
        const float *p = pos + 3 * i;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
            if (i < first_bad)
                first_bad = i;
            continue;
        }
        l0 = fmin(l0, p[0]), l1 = fmin(l1, p[1]), l2 = fmin(l2, p[2]);
        h0 = fmax(h0, p[0]), h1 = fmax(h1, p[1]), h2 = fmax(h2, p[2]);
    }
    lo[0] = l0, lo[1] = l1, lo[2] = l2;
    hi[0] = h0, hi[1] = h1, hi[2] = h2;
    if (n == 0)
        for (int k = 0; k < 3; k++)
            lo[k] = hi[k] = 0;
    *bad = first_bad;
    return first_bad == SIZE_MAX;
}

void mr_grid_init(mr_grid *grid, const double lo[3], const double hi[3], double cell)
{
    double extent = 0;
    for (int k = 0; k < 3; k++) {
        grid->lo[k] = lo[k];
        extent = fmax(extent, hi[k] - lo[k]);
    }
    /* At most 2^20 cells per axis: a tiny radius on a large model would
     * otherwise overflow the key; larger cells only add candidates. */
    double min_cell = extent / (double)(1u << 20);
    if (!(cell >= min_cell))
        cell = min_cell;
    if (!(cell > 0))
        cell = 1;
    grid->cell = cell;
    for (int k = 0; k < 3; k++) {
        double d = floor((hi[k] - lo[k]) / cell) + 1;
        grid->dims[k] = d < (double)(1u << 21) ? (uint64_t)d : (uint64_t)1 << 21;
        grid->bits[k] = mr_index_bits((size_t)grid->dims[k]);
    }
}

/* Sorted points: cell runs and their keys. */
typedef struct sorted_points {
    size_t n, cells;
    uint32_t *ids;     /* n: point of each sorted slot */
    float *pos;        /* 3n: positions in sorted order */
    uint64_t *keys;    /* cells: key of each occupied cell, ascending */
    uint32_t *first;   /* cells + 1: first sorted slot of each cell */
} sorted_points;

static void sorted_free(sorted_points *s)
{
    free(s->ids);
    free(s->pos);
    free(s->keys);
    free(s->first);
}

/* First occupied cell with key >= k. */
static size_t lower_cell(const sorted_points *s, uint64_t k)
{
    size_t a = 0, b = s->cells;
    while (a < b) {
        size_t m = a + (b - a) / 2;
        if (s->keys[m] < k)
            a = m + 1;
        else
            b = m;
    }
    return a;
}

typedef struct search {
    const mr_grid *grid;
    const sorted_points *s;
    double eps2;
    int strict;
} search;

static inline bool within(const search *q, const float *a, const float *b)
{
    double dx = (double)a[0] - (double)b[0];
    double dy = (double)a[1] - (double)b[1];
    double dz = (double)a[2] - (double)b[2];
    double d2 = dx * dx + dy * dy + dz * dz;
    return q->strict ? d2 < q->eps2 : d2 <= q->eps2;
}

/*
 * The up-to-nine sorted-slot ranges that hold the 3x3x3 neighbourhood of
 * cell c. Returns how many. The first key of the row at offset (dy, dz) is
 * key(c) + const - (x > 0), which never decreases as c grows, so a run of
 * consecutive cells finds its rows with nine cursors that only move
 * forward (cur[], set by a binary search on a run's first cell, when
 * have[] is 0) instead of a binary search per row and cell.
 */
static int neighbour_ranges(const search *q, size_t c, size_t cur[9], bool have[9],
                            uint32_t lo[9], uint32_t hi[9])
{
    const mr_grid *g = q->grid;
    const sorted_points *s = q->s;
    uint64_t xyz[3];
    mr_grid_unpack(g, s->keys[c], xyz);
    const uint64_t x = xyz[0], y = xyz[1], z = xyz[2];
    uint64_t x0 = x > 0 ? x - 1 : 0, x1 = x + 1 < g->dims[0] ? x + 1 : x;
    int count = 0;
    for (int dz = -1; dz <= 1; dz++) {
        if ((dz < 0 && z == 0) || (dz > 0 && z + 1 >= g->dims[2]))
            continue;
        for (int dy = -1; dy <= 1; dy++) {
            if ((dy < 0 && y == 0) || (dy > 0 && y + 1 >= g->dims[1]))
                continue;
            const int r = (dz + 1) * 3 + (dy + 1);
            uint64_t row = mr_grid_pack(g, 0, y + (uint64_t)dy, z + (uint64_t)dz);
            uint64_t first = row + x0;
            size_t a;
            if (!have[r]) {
                a = lower_cell(s, first);
                have[r] = true;
            } else {
                a = cur[r];
                while (a < s->cells && s->keys[a] < first)
                    a++;
            }
            cur[r] = a;
            size_t b = a;
            while (b < s->cells && s->keys[b] <= row + x1)
                b++;
            if (b > a) {
                lo[count] = s->first[a];
                hi[count] = s->first[b];
                count++;
            }
        }
    }
    return count;
}

/* Cells per work item of the graph passes: long enough runs for the
 * cursors, short enough to balance uneven cells. */
#define CELL_BLOCK 512

mr_status mr_radius_graph_build(mr_radius_graph *g, const float *pos, size_t n, double eps,
                                int strict, int threads, mr_error *err)
{
    memset(g, 0, sizeof *g);
    g->n = n;
    if (n > UINT32_MAX - 1)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu points: more than 32-bit indices can address", n);
    g->offsets = mr_calloc_array(n + 1, sizeof *g->offsets);
    g->depend = mr_alloc_array(n, sizeof *g->depend);
    if (!g->offsets || !g->depend) {
        mr_radius_graph_free(g);
        return mr_fail_nomem(err, NULL, n * 12);
    }
    g->bytes = (n + 1) * sizeof *g->offsets + n * sizeof *g->depend;
    /* Strictly closer than 0 is never true: the graph has no edge. */
    if (n == 0 || (strict && eps == 0)) {
        for (size_t i = 0; i < n; i++)
            atomic_init(&g->depend[i], 0);
        g->adj = mr_alloc_array(0, sizeof *g->adj);
        g->peak_bytes = g->bytes;
        if (!g->adj) {
            mr_radius_graph_free(g);
            return mr_fail_nomem(err, NULL, 1);
        }
        return MR_OK;
    }

    mr_status st = MR_OK;
    size_t transient = 0;
    double lo[3], hi[3];
    size_t bad;
    mr_points_bounds(pos, n, threads, lo, hi, &bad);
    mr_grid grid;
    /* A hair above eps: a pair at distance exactly eps then never lands two
     * cells apart through the rounding of the cell coordinates. */
    mr_grid_init(&grid, lo, hi, eps * (1.0 + 1e-8));

    sorted_points s = {n, 0, NULL, NULL, NULL, NULL};
    uint64_t *keys = mr_alloc_array(n, sizeof *keys);
    s.ids = mr_alloc_array(n, sizeof *s.ids);
    s.pos = mr_alloc_array(3 * n, sizeof *s.pos);
    if (!keys || !s.ids || !s.pos) {
        st = mr_fail_nomem(err, NULL, n * 24);
        goto done;
    }
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t i = 0; i < n; i++) {
        keys[i] = mr_grid_key(&grid, pos + 3 * i);
        s.ids[i] = (uint32_t)i;
    }
    /* radix scratch is 12 bytes per point */
    transient = n * (sizeof *keys + sizeof *s.ids + 3 * sizeof *s.pos + 12);
    if ((st = mr_radix_sort_u64(keys, s.ids, n, mr_grid_key_bits(&grid), err)) != MR_OK)
        goto done;

    size_t cells = 0;
    for (size_t i = 0; i < n; i++)
        cells += i == 0 || keys[i] != keys[i - 1];
    s.cells = cells;
    s.keys = mr_alloc_array(cells, sizeof *s.keys);
    s.first = mr_alloc_array(cells + 1, sizeof *s.first);
    if (!s.keys || !s.first) {
        st = mr_fail_nomem(err, NULL, cells * 12);
        goto done;
    }
    for (size_t i = 0, c = 0; i < n; i++)
        if (i == 0 || keys[i] != keys[i - 1]) {
            s.keys[c] = keys[i];
            s.first[c++] = (uint32_t)i;
        }
    s.first[cells] = (uint32_t)n;
    free(keys);
    keys = NULL;
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t i = 0; i < n; i++)
        memcpy(s.pos + 3 * i, pos + 3 * (size_t)s.ids[i], 3 * sizeof(float));

    search q = {&grid, &s, eps * eps, strict};
    const size_t blocks = (cells + CELL_BLOCK - 1) / CELL_BLOCK;
    size_t *off = g->offsets;

    /* Pass 1: counts. offsets[i + 1] = larger neighbours of i. */
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t blk = 0; blk < blocks; blk++) {
      size_t cur[9];
      bool have[9] = {false};
      const size_t c_end = (blk + 1) * CELL_BLOCK < cells ? (blk + 1) * CELL_BLOCK : cells;
      for (size_t c = blk * CELL_BLOCK; c < c_end; c++) {
        uint32_t rlo[9], rhi[9];
        int nr = neighbour_ranges(&q, c, cur, have, rlo, rhi);
        for (uint32_t a = s.first[c]; a < s.first[c + 1]; a++) {
            const float *pa = s.pos + 3 * (size_t)a;
            uint32_t ia = s.ids[a];
            uint32_t larger = 0, smaller = 0;
            for (int r = 0; r < nr; r++)
                for (uint32_t b = rlo[r]; b < rhi[r]; b++) {
                    if (b == a || !within(&q, pa, s.pos + 3 * (size_t)b))
                        continue;
                    if (s.ids[b] > ia)
                        larger++;
                    else
                        smaller++;
                }
            off[(size_t)ia + 1] = larger;
            atomic_init(&g->depend[ia], (int32_t)smaller);
        }
      }
    }
    for (size_t i = 0; i < n; i++)
        off[i + 1] += off[i];
    g->edge_count = off[n];
    g->adj = mr_alloc_array(g->edge_count, sizeof *g->adj);
    if (!g->adj) {
        st = mr_fail_nomem(err, NULL, g->edge_count * sizeof *g->adj);
        goto done;
    }
    g->bytes += g->edge_count * sizeof *g->adj;
    transient = n * (sizeof *s.ids + 3 * sizeof *s.pos) + cells * 12;
    g->peak_bytes = g->bytes + transient;

    /* Pass 2: the lists, each sorted so that every consumer walks the
     * members of a cluster in index order. */
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t blk = 0; blk < blocks; blk++) {
      size_t cur[9];
      bool have[9] = {false};
      const size_t c_end = (blk + 1) * CELL_BLOCK < cells ? (blk + 1) * CELL_BLOCK : cells;
      for (size_t c = blk * CELL_BLOCK; c < c_end; c++) {
        uint32_t rlo[9], rhi[9];
        int nr = neighbour_ranges(&q, c, cur, have, rlo, rhi);
        for (uint32_t a = s.first[c]; a < s.first[c + 1]; a++) {
            const float *pa = s.pos + 3 * (size_t)a;
            uint32_t ia = s.ids[a];
            uint32_t *list = g->adj + off[ia];
            size_t len = 0;
            for (int r = 0; r < nr; r++)
                for (uint32_t b = rlo[r]; b < rhi[r]; b++)
                    if (s.ids[b] > ia && within(&q, pa, s.pos + 3 * (size_t)b))
                        list[len++] = s.ids[b];
            /* lists are short (a few entries) except for radii that span
             * much of the model: insertion sort, a heap sort beyond that */
            if (len <= 48) {
                for (size_t i = 1; i < len; i++) {
                    uint32_t v = list[i];
                    size_t j = i;
                    for (; j > 0 && list[j - 1] > v; j--)
                        list[j] = list[j - 1];
                    list[j] = v;
                }
            } else {
                for (size_t k = len / 2; k-- > 0;)
                    for (size_t r = k;;) {
                        size_t ch = 2 * r + 1;
                        if (ch >= len)
                            break;
                        if (ch + 1 < len && list[ch + 1] > list[ch])
                            ch++;
                        if (list[r] >= list[ch])
                            break;
                        uint32_t t = list[r];
                        list[r] = list[ch];
                        list[ch] = t;
                        r = ch;
                    }
                for (size_t end = len; end-- > 1;) {
                    uint32_t t = list[0];
                    list[0] = list[end];
                    list[end] = t;
                    for (size_t r = 0;;) {
                        size_t ch = 2 * r + 1;
                        if (ch >= end)
                            break;
                        if (ch + 1 < end && list[ch + 1] > list[ch])
                            ch++;
                        if (list[r] >= list[ch])
                            break;
                        uint32_t u = list[r];
                        list[r] = list[ch];
                        list[ch] = u;
                        r = ch;
                    }
                }
            }
        }
      }
    }

done:
    if (transient + g->bytes > g->peak_bytes)
        g->peak_bytes = transient + g->bytes;
    free(keys);
    sorted_free(&s);
    if (st != MR_OK)
        mr_radius_graph_free(g);
    return st;
}

void mr_radius_graph_free(mr_radius_graph *g)
{
    if (!g)
        return;
    free(g->offsets);
    free(g->adj);
    free((void *)g->depend);
    memset(g, 0, sizeof *g);
}
