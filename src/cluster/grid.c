/*
 * Fixed-radius neighbour search: a sweep over rows of a uniform grid.
 *
 * The two shorter axes of the bounding box are cut into cells of edge
 * >= eps; a row is one cell of that 2D grid, a column of space along the
 * longest (sweep) axis. Points are sorted by row and, within a row, by
 * their sweep coordinate quantised to 1/16 cell (one stable radix sort of
 * a packed key, so the layout is the same at any thread count). A point's
 * candidates are the points of the 3x3 neighbouring rows whose quantised
 * coordinate is within eps of its own: a window per row that slides
 * forward as the point moves along its row. Against the 3x3x3 cells of
 * edge eps this tests about 2/3 of the candidates, and a row look-up (nine
 * forward-only cursors) serves every point of the row, where small radii
 * leave cells with one point each and made the per-cell look-ups the
 * bulk of the work.
 *
 * The graph is built in one search: each thread appends the lists of
 * larger neighbours of the points it searches to its own buffer and
 * writes each point's two counts; a prefix sum places the lists and a
 * parallel pass moves them into place, sorted. The full symmetric graph
 * is never stored.
 */
#include "grid.h"

#include "../mesh/adjacency.h"

#ifdef _OPENMP
#include <omp.h>
#else
static inline int omp_get_thread_num(void) { return 0; }
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
        /* finite here: plain comparisons, not calls to fmin/fmax */
        const double x = p[0], y = p[1], z = p[2];
        l0 = x < l0 ? x : l0, l1 = y < l1 ? y : l1, l2 = z < l2 ? z : l2;
        h0 = x > h0 ? x : h0, h1 = y > h1 ? y : h1, h2 = z > h2 ? z : h2;
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

/* ---- the neighbour graph --------------------------------------------------- */

/*
 * Points sorted for the sweep: by row (the cell coordinates along the two
 * binned axes a1, a2), then by the sweep coordinate quantised to 1/2^s of
 * a cell. The rows of one key are a contiguous run of the sorted array.
 */
typedef struct sweep {
    size_t n, rows;
    uint32_t *ids;       /* n: point of each sorted slot */
    float *pos;          /* 3n: positions in sorted order */
    uint32_t *q;         /* n: quantised sweep coordinate (ascending per row) */
    uint64_t *keys;      /* rows: key of each occupied row, ascending */
    uint32_t *first;     /* rows + 1: first sorted slot of each row */
    unsigned bits1;      /* a row key is (c2 << bits1) | c1 */
    uint64_t dims1, dims2;
    uint64_t reach;      /* window half-width, in quanta */
    double eps2;
    int strict;
} sweep;

static void sweep_free(sweep *s)
{
    free(s->ids);
    free(s->pos);
    free(s->q);
    free(s->keys);
    free(s->first);
}

/* First occupied row with key >= k. */
static size_t lower_row(const sweep *s, uint64_t k)
{
    size_t a = 0, b = s->rows;
    while (a < b) {
        size_t m = a + (b - a) / 2;
        if (s->keys[m] < k)
            a = m + 1;
        else
            b = m;
    }
    return a;
}

static inline bool within(const sweep *s, const float *a, const float *b)
{
    double dx = (double)a[0] - (double)b[0];
    double dy = (double)a[1] - (double)b[1];
    double dz = (double)a[2] - (double)b[2];
    double d2 = dx * dx + dy * dy + dz * dz;
    return s->strict ? d2 < s->eps2 : d2 <= s->eps2;
}

/* A thread's larger-neighbour lists, in the order it searched its blocks. */
typedef struct edge_buf {
    uint32_t *data;
    size_t len, cap;
} edge_buf;

static bool buf_push(edge_buf *b, uint32_t v)
{
    if (b->len == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 4096;
        uint32_t *p = mr_realloc_array(b->data, cap, sizeof *p);
        if (!p)
            return false;
        b->data = p;
        b->cap = cap;
    }
    b->data[b->len++] = v;
    return true;
}

/*
 * Search the rows r0 .. r1-1: for every point, its larger neighbours are
 * appended to `buf` (in sorted-slot order of the points), their count goes
 * to off[id + 1] and the count of its smaller ones to depend[id]. The
 * candidates of a point are the points of the 3x3 neighbouring rows whose
 * quantised sweep coordinate lies within `reach` of its own: one window
 * per row, whose ends only move forward as the point moves along its row.
 * The row look-ups use nine cursors that only move forward too: the key
 * of the row at offset (d1, d2) grows with the row's own key.
 */
static bool search_rows(const sweep *s, size_t r0, size_t r1, size_t *off,
                        _Atomic int32_t *depend, edge_buf *buf)
{
    size_t cur[9];
    bool have[9] = {false};
    const uint64_t mask1 = (UINT64_C(1) << s->bits1) - 1;
    const uint64_t reach = s->reach;
    for (size_t r = r0; r < r1; r++) {
        const uint64_t c1 = s->keys[r] & mask1, c2 = s->keys[r] >> s->bits1;
        uint32_t lo[9], hi[9], end[9];
        int nr = 0;
        for (int d2 = -1; d2 <= 1; d2++) {
            if ((d2 < 0 && c2 == 0) || (d2 > 0 && c2 + 1 >= s->dims2))
                continue;
            for (int d1 = -1; d1 <= 1; d1++) {
                if ((d1 < 0 && c1 == 0) || (d1 > 0 && c1 + 1 >= s->dims1))
                    continue;
                const int k = (d2 + 1) * 3 + (d1 + 1);
                const uint64_t want = ((c2 + (uint64_t)(int64_t)d2) << s->bits1) |
                                      (c1 + (uint64_t)(int64_t)d1);
                size_t a;
                if (!have[k]) {
                    a = lower_row(s, want);
                    have[k] = true;
                } else {
                    a = cur[k];
                    while (a < s->rows && s->keys[a] < want)
                        a++;
                }
                cur[k] = a;
                if (a < s->rows && s->keys[a] == want) {
                    lo[nr] = hi[nr] = s->first[a];
                    end[nr] = s->first[a + 1];
                    nr++;
                }
            }
        }
        for (uint32_t a = s->first[r]; a < s->first[r + 1]; a++) {
            const uint64_t qa = s->q[a];
            const float *pa = s->pos + 3 * (size_t)a;
            const uint32_t ia = s->ids[a];
            uint32_t larger = 0, smaller = 0;
            for (int k = 0; k < nr; k++) {
                uint32_t l = lo[k], h = hi[k];
                while (l < end[k] && (uint64_t)s->q[l] + reach < qa)
                    l++;
                if (h < l)
                    h = l;
                while (h < end[k] && (uint64_t)s->q[h] <= qa + reach)
                    h++;
                lo[k] = l;
                hi[k] = h;
                for (uint32_t b = l; b < h; b++) {
                    if (b == a || !within(s, pa, s->pos + 3 * (size_t)b))
                        continue;
                    const uint32_t ib = s->ids[b];
                    if (ib > ia) {
                        if (!buf_push(buf, ib))
                            return false;
                        larger++;
                    } else {
                        smaller++;
                    }
                }
            }
            off[(size_t)ia + 1] = larger;
            atomic_init(&depend[ia], (int32_t)smaller);
        }
    }
    return true;
}

/* Lists are short (a few entries) except for radii that span much of the
 * model: insertion sort, a heap sort beyond that. */
static void sort_list(uint32_t *list, size_t len)
{
    if (len <= 48) {
        for (size_t i = 1; i < len; i++) {
            uint32_t v = list[i];
            size_t j = i;
            for (; j > 0 && list[j - 1] > v; j--)
                list[j] = list[j - 1];
            list[j] = v;
        }
        return;
    }
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

/* Rows per work item of the search: long enough runs for the cursors,
 * short enough to balance uneven rows. */
#define ROW_BLOCK 256

/* Sub-cells per cell along the sweep axis (as a power of two): the window
 * is then at most eps + 2/2^s cells wide on each side. */
#define SWEEP_SUB_BITS 4

/*
 * Sort the points for the sweep. The sweep axis is the longest side of the
 * bounding box (on a surface, rows along it are long); rows are cells of
 * edge `cell` >= eps in the other two axes, so two points within eps are
 * in rows at most one apart on each; the sweep coordinate is quantised to
 * cell / 2^s, so two points within eps are at most `reach` quanta apart.
 * Coordinates are scaled by reciprocals (no division per point); the
 * cell's margin over eps covers their rounding.
 */
static mr_status sweep_build(sweep *s, const float *pos, size_t n, double eps, int strict,
                             int threads, size_t *transient, mr_error *err)
{
    memset(s, 0, sizeof *s);
    s->n = n;
    double lo[3], hi[3];
    size_t bad;
    mr_points_bounds(pos, n, threads, lo, hi, &bad);
    mr_grid grid;
    /* A hair above eps: a pair at distance exactly eps then never lands two
     * cells apart through the rounding of the cell coordinates. */
    mr_grid_init(&grid, lo, hi, eps * (1.0 + 1e-8));
    unsigned ax = 0;
    for (unsigned k = 1; k < 3; k++)
        if (hi[k] - lo[k] > hi[ax] - lo[ax])
            ax = k;
    const unsigned a1 = ax == 0 ? 1 : 0, a2 = ax == 2 ? 1 : 2;
    const unsigned used = grid.bits[ax] + grid.bits[a1] + grid.bits[a2];
    const unsigned sub = used + SWEEP_SUB_BITS <= 64 ? SWEEP_SUB_BITS : 64 - used;
    const unsigned qbits = grid.bits[ax] + sub;
    const uint64_t qdims = grid.dims[ax] << sub;
    const double inv_cell = 1.0 / grid.cell, inv_q = (double)(UINT64_C(1) << sub) / grid.cell;
    double reach = ceil(eps * inv_q * (1 + 1e-7)) + 1;
    s->reach = reach < (double)qdims ? (uint64_t)reach : qdims;
    s->bits1 = grid.bits[a1];
    s->dims1 = grid.dims[a1];
    s->dims2 = grid.dims[a2];
    s->eps2 = eps * eps;
    s->strict = strict;

    uint64_t *keys = mr_alloc_array(n, sizeof *keys);
    s->ids = mr_alloc_array(n, sizeof *s->ids);
    s->pos = mr_alloc_array(n, 3 * sizeof *s->pos);
    s->q = mr_alloc_array(n, sizeof *s->q);
    if (!keys || !s->ids || !s->pos || !s->q) {
        free(keys);
        return mr_fail_nomem(err, NULL, n * 28);
    }
    const double l0 = lo[ax], l1 = lo[a1], l2 = lo[a2];
    const uint64_t d0 = qdims, d1 = grid.dims[a1], d2 = grid.dims[a2];
    const unsigned shift2 = qbits + grid.bits[a1];
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t i = 0; i < n; i++) {
        const float *p = pos + 3 * i;
        double t0 = ((double)p[ax] - l0) * inv_q;
        double t1 = ((double)p[a1] - l1) * inv_cell;
        double t2 = ((double)p[a2] - l2) * inv_cell;
        uint64_t q = t0 > 0 ? (uint64_t)t0 : 0, c1 = t1 > 0 ? (uint64_t)t1 : 0,
                 c2 = t2 > 0 ? (uint64_t)t2 : 0;
        q = q < d0 ? q : d0 - 1;
        c1 = c1 < d1 ? c1 : d1 - 1;
        c2 = c2 < d2 ? c2 : d2 - 1;
        keys[i] = (c2 << shift2) | (c1 << qbits) | q;
        s->ids[i] = (uint32_t)i;
    }
    /* radix scratch is 12 bytes per point */
    *transient = n * (sizeof *keys + sizeof *s->ids + 3 * sizeof *s->pos + sizeof *s->q + 12);
    mr_status st = mr_radix_sort_u64(keys, s->ids, n, shift2 + grid.bits[a2], err);
    if (st != MR_OK) {
        free(keys);
        return st;
    }
    size_t rows = 0;
    for (size_t i = 0; i < n; i++)
        rows += i == 0 || (keys[i] >> qbits) != (keys[i - 1] >> qbits);
    s->rows = rows;
    s->keys = mr_alloc_array(rows, sizeof *s->keys);
    s->first = mr_alloc_array(rows + 1, sizeof *s->first);
    if (!s->keys || !s->first) {
        free(keys);
        return mr_fail_nomem(err, NULL, rows * 12);
    }
    for (size_t i = 0, r = 0; i < n; i++)
        if (i == 0 || (keys[i] >> qbits) != (keys[i - 1] >> qbits)) {
            s->keys[r] = keys[i] >> qbits;
            s->first[r++] = (uint32_t)i;
        }
    s->first[rows] = (uint32_t)n;
    const uint64_t qmask = (UINT64_C(1) << qbits) - 1;
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t i = 0; i < n; i++) {
        s->q[i] = (uint32_t)(keys[i] & qmask);
        memcpy(s->pos + 3 * i, pos + 3 * (size_t)s->ids[i], 3 * sizeof(float));
    }
    free(keys);
    return MR_OK;
}

mr_status mr_radius_graph_build(mr_radius_graph *g, const float *pos, size_t n, double eps,
                                int strict, int threads, mr_error *err)
{
    memset(g, 0, sizeof *g);
    g->n = n;
    if (n > UINT32_MAX - 1)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu points: more than 32-bit indices can address", n);
    if (threads < 1)
        threads = 1;
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

    size_t transient = 0;
    sweep s;
    edge_buf *bufs = NULL;
    uint32_t *blk_buf = NULL;
    size_t *blk_pos = NULL;
    mr_status st = sweep_build(&s, pos, n, eps, strict, threads, &transient, err);
    if (st != MR_OK)
        goto done;
    transient = n * (sizeof *s.ids + 3 * sizeof *s.pos + sizeof *s.q) + s.rows * 12;

    /* One search: each thread appends the larger-neighbour lists of the
     * blocks it takes to its own buffer; a block remembers which buffer
     * and where. */
    const size_t blocks = (s.rows + ROW_BLOCK - 1) / ROW_BLOCK;
    bufs = mr_calloc_array((size_t)threads, sizeof *bufs);
    blk_buf = mr_alloc_array(blocks, sizeof *blk_buf);
    blk_pos = mr_alloc_array(blocks, sizeof *blk_pos);
    if (!bufs || !blk_buf || !blk_pos) {
        st = mr_fail_nomem(err, NULL, blocks * 12);
        goto done;
    }
    size_t *off = g->offsets;
    _Atomic int failed;
    atomic_init(&failed, 0);
#pragma omp parallel num_threads(threads) if (n > PARALLEL_MIN)
    {
        edge_buf *mine = &bufs[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 1)
        for (size_t blk = 0; blk < blocks; blk++) {
            blk_buf[blk] = (uint32_t)omp_get_thread_num();
            blk_pos[blk] = mine->len;
            if (atomic_load_explicit(&failed, memory_order_relaxed))
                continue;
            const size_t r1 = (blk + 1) * ROW_BLOCK < s.rows ? (blk + 1) * ROW_BLOCK : s.rows;
            if (!search_rows(&s, blk * ROW_BLOCK, r1, off, g->depend, mine))
                atomic_store_explicit(&failed, 1, memory_order_relaxed);
        }
    }
    size_t buffered = 0;
    for (int t = 0; t < threads; t++)
        buffered += bufs[t].cap * sizeof *bufs[t].data;
    if (atomic_load(&failed)) {
        st = mr_fail_nomem(err, NULL, buffered);
        goto done;
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
    transient += buffered + blocks * (sizeof *blk_buf + sizeof *blk_pos);
    g->peak_bytes = g->bytes + transient;

    /* Move the lists into place, each sorted so that every consumer walks
     * the members of a cluster in index order. */
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t blk = 0; blk < blocks; blk++) {
        const uint32_t *src = bufs[blk_buf[blk]].data + blk_pos[blk];
        const size_t r1 = (blk + 1) * ROW_BLOCK < s.rows ? (blk + 1) * ROW_BLOCK : s.rows;
        for (uint32_t a = s.first[blk * ROW_BLOCK]; a < s.first[r1]; a++) {
            const uint32_t ia = s.ids[a];
            const size_t len = off[(size_t)ia + 1] - off[ia];
            if (len == 0)
                continue;
            memcpy(g->adj + off[ia], src, len * sizeof *src);
            src += len;
            sort_list(g->adj + off[ia], len);
        }
    }

done:
    if (transient + g->bytes > g->peak_bytes)
        g->peak_bytes = transient + g->bytes;
    if (bufs)
        for (int t = 0; t < threads; t++)
            free(bufs[t].data);
    free(bufs);
    free(blk_buf);
    free(blk_pos);
    sweep_free(&s);
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
