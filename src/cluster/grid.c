/*
 * Fixed-radius neighbour search: a sweep over rows of a uniform grid.
 *
 * The two shorter axes of the bounding box are cut into cells of edge
 * ROW_CELLS * eps; a row is one cell of that 2D grid, a column of space
 * along the longest (sweep) axis. Points are sorted by row and, within a
 * row, by their sweep coordinate quantised to 1/32 cell (one stable radix
 * sort of a packed key, so the layout is the same at any thread count).
 * A point's candidates in a row are those whose quantised coordinate is
 * within eps of its own: a window per row that slides forward as the
 * point moves along its row.
 *
 * Each pair is tested once, from the point whose row comes first (or,
 * in one row, from the earlier point): the search looks at the rest of
 * its own row and at most four of the eight neighbouring rows, those
 * after it in row order, and of these only the ones within eps of the
 * point (a row is three radii wide, so most points need none or one).
 * At welding radii a row cell of edge eps holds about one point, and
 * setting up its neighbour windows cost more than the distance tests;
 * rows three radii wide hold a few dozen, and the one-sided search
 * halves both the windows and the tests.
 *
 * Each thread appends the pairs it finds to its own buffer. Then each
 * thread owns a slice of the ids and walks all the buffers: it counts
 * the larger and the smaller neighbours of its ids, a prefix sum places
 * the lists, it fills its ids' lists and sorts them. No counter is
 * shared, so there is no atomic read-modify-write.
 * The full symmetric graph is never stored.
 */
#include "grid.h"

#include "../mesh/adjacency.h"

#include "../core/omp_compat.h"

#define PARALLEL_MIN 16384

/* First id of the slice that thread `me` of `nt` owns. */
static inline uint32_t own_lo(size_t n, uint32_t me, uint32_t nt)
{
    return (uint32_t)(n * me / nt);
}

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <float.h>

bool mr_points_bounds(const float *pos, size_t n, int threads, double lo[3], double hi[3],
                      size_t *bad)
{
    /* Bounds in float (exact: they are input values) and a flag for any
     * coordinate that is not finite, in a loop that vectorises; only a
     * bad coordinate makes the search for the first offender. */
    float l0 = INFINITY, l1 = INFINITY, l2 = INFINITY;
    float h0 = -INFINITY, h1 = -INFINITY, h2 = -INFINITY;
    int nonfinite = 0;
#pragma omp parallel for simd schedule(static) num_threads(threads) if (n > PARALLEL_MIN) \
    reduction(min : l0, l1, l2) reduction(max : h0, h1, h2) reduction(| : nonfinite)
    for (size_t i = 0; i < n; i++) {
        const float x = pos[3 * i], y = pos[3 * i + 1], z = pos[3 * i + 2];
        /* NaN fails every comparison, infinity the bound */
        nonfinite |= !(fabsf(x) <= FLT_MAX) | !(fabsf(y) <= FLT_MAX) | !(fabsf(z) <= FLT_MAX);
        l0 = x < l0 ? x : l0, l1 = y < l1 ? y : l1, l2 = z < l2 ? z : l2;
        h0 = x > h0 ? x : h0, h1 = y > h1 ? y : h1, h2 = z > h2 ? z : h2;
    }
    lo[0] = l0, lo[1] = l1, lo[2] = l2;
    hi[0] = h0, hi[1] = h1, hi[2] = h2;
    if (n == 0)
        for (int k = 0; k < 3; k++)
            lo[k] = hi[k] = 0;
    *bad = SIZE_MAX;
    if (!nonfinite)
        return true;
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(pos[i])) {
            *bad = i / 3;
            break;
        }
    return false;
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

/* ---- occupied cells ---------------------------------------------------------- */

size_t mr_grid_cells_total(const mr_grid *g)
{
    const double t = (double)g->dims[0] * (double)g->dims[1] * (double)g->dims[2];
    return t < (double)SIZE_MAX / 2 ? (size_t)t : SIZE_MAX / 2;
}

void mr_grid_mark(const mr_grid *g, const float *pos, size_t n, size_t stride, int threads,
                  uint64_t *bits, size_t words)
{
    /* a bitmap a thread (its own range of points, plain stores) */
    const int team = threads > 1 && n > 65536 ? threads : 1;
    const uint64_t dx = g->dims[0], dxy = g->dims[0] * g->dims[1];
#pragma omp parallel num_threads(team) if (team > 1)
    {
        const int me = omp_get_thread_num(), nt = omp_get_num_threads();
        uint64_t *mine = bits + (size_t)me * words;
        const size_t i0 = n * (size_t)me / (size_t)nt, i1 = n * (size_t)(me + 1) / (size_t)nt;
        for (size_t i = i0; i < i1; i++) {
            uint64_t c[3];
            mr_grid_unpack(g, mr_grid_key(g, pos + 3 * stride * i), c);
            const uint64_t at = c[0] + dx * c[1] + dxy * c[2];
            mine[at >> 6] |= UINT64_C(1) << (at & 63);
        }
    }
}

size_t mr_grid_marked(const uint64_t *bits, size_t words, int threads)
{
    size_t k = 0;
    const ptrdiff_t nw = (ptrdiff_t)words;
#pragma omp parallel for schedule(static) num_threads(threads) reduction(+ : k) \
    if (threads > 1 && nw > 65536)
    for (ptrdiff_t w = 0; w < nw; w++) {
        uint64_t u = 0;
        for (int t = 0; t < threads; t++)
            u |= bits[(size_t)t * words + (size_t)w];
        k += (size_t)__builtin_popcountll(u);
    }
    return k;
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
    float *px, *py, *pz; /* n + PAD each: coordinates in sorted order */
    float eps2f;         /* float bound above every squared distance <= eps^2 */
    float eps2_in;       /* float bound below them (or -1: none is sure) */
    uint32_t *q;         /* n: quantised sweep coordinate (ascending per row) */
    uint64_t *keys;      /* rows: key of each occupied row, ascending */
    uint32_t *first;     /* rows + 1: first sorted slot of each row */
    unsigned bits1;      /* a row key is (c2 << bits1) | c1 */
    uint64_t dims1, dims2;
    uint64_t reach;      /* window half-width, in quanta */
    double eps2;
    int strict;
    unsigned a1, a2;     /* the binned axes */
    double lo1, lo2;     /* grid origin on them */
    double inv_cell;
    double near;         /* eps / cell plus rounding margin */
} sweep;

static void sweep_free(sweep *s)
{
    free(s->ids);
    free(s->px);
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

/* The exact test: squared distance in double, as the header promises. */
static inline bool within(const sweep *s, uint32_t a, uint32_t b)
{
    double dx = (double)s->px[a] - (double)s->px[b];
    double dy = (double)s->py[a] - (double)s->py[b];
    double dz = (double)s->pz[a] - (double)s->pz[b];
    double d2 = dx * dx + dy * dy + dz * dz;
    return s->strict ? d2 < s->eps2 : d2 <= s->eps2;
}

/* A thread's pairs within the radius, each as (smaller id, larger id), in
 * the order it searched its blocks. */
typedef struct edge_buf {
    uint32_t *data;
    size_t len, cap;
} edge_buf;

static bool buf_pair(edge_buf *b, uint32_t x, uint32_t y)
{
    if (b->len + 2 > b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 8192;
        uint32_t *p = mr_realloc_array(b->data, cap, sizeof *p);
        if (!p)
            return false;
        b->data = p;
        b->cap = cap;
    }
    b->data[b->len++] = x < y ? x : y;
    b->data[b->len++] = x < y ? y : x;
    return true;
}

/* Padding after each coordinate array: the 4-wide test reads up to 3
 * entries past a window's end (and ignores them). */
#define PAD 4

/*
 * A group: up to four consecutive points of one row, tested together
 * against one candidate at a time. A float filter passes every pair the
 * exact test can accept (eps2f sits above their float distances'
 * rounding) and marks the pairs that are surely within (below eps2_in);
 * the exact test decides the few in between.
 */
typedef struct group {
    uint32_t first, count;
#if defined(__SSE2__)
    __m128 x, y, z, e2, e2in;
#endif
} group;

static inline void group_init(group *G, const sweep *s, uint32_t first, uint32_t count)
{
    G->first = first;
    G->count = count;
#if defined(__SSE2__)
    G->x = _mm_loadu_ps(s->px + first);
    G->y = _mm_loadu_ps(s->py + first);
    G->z = _mm_loadu_ps(s->pz + first);
    G->e2 = _mm_set1_ps(s->eps2f);
    G->e2in = _mm_set1_ps(s->eps2_in);
#else
    (void)s;
#endif
}

/* Candidates tested before their hits are appended. */
#define HIT_BATCH 64

/*
 * Append the pairs (first + k, b) within eps for the candidates b in
 * [b0, b1) and the lanes k in `lanes`; in the group's own row (`own`) a
 * candidate pairs only with the lanes before it. The tests record their
 * hits without a branch (a hit is one candidate in five: a branch on it
 * mispredicts often); the pairs are then appended from the records.
 */
static inline bool group_range(const sweep *s, const group *G, uint32_t b0, uint32_t b1,
                               unsigned lanes, bool own, edge_buf *buf)
{
    uint64_t rec[HIT_BATCH];
    while (b0 < b1) {
        const uint32_t e = b1 - b0 > HIT_BATCH ? b0 + HIT_BATCH : b1;
        unsigned nrec = 0;
        for (uint32_t b = b0; b < e; b++) {
            const uint32_t ahead = b - G->first;
            const unsigned use = own && ahead < 4 ? lanes & ((1u << ahead) - 1) : lanes;
#if defined(__SSE2__)
            const __m128 dx = _mm_sub_ps(G->x, _mm_set1_ps(s->px[b]));
            const __m128 dy = _mm_sub_ps(G->y, _mm_set1_ps(s->py[b]));
            const __m128 dz = _mm_sub_ps(G->z, _mm_set1_ps(s->pz[b]));
            const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                                         _mm_mul_ps(dz, dz));
            const unsigned m = (unsigned)_mm_movemask_ps(_mm_cmple_ps(d2, G->e2)) & use;
            const unsigned sure = (unsigned)_mm_movemask_ps(_mm_cmple_ps(d2, G->e2in)) & m;
#else
            const unsigned m = use, sure = 0;
#endif
            rec[nrec] = (uint64_t)b << 8 | sure << 4 | m;
            nrec += m != 0;
        }
        for (unsigned i = 0; i < nrec; i++) {
            const uint32_t b = (uint32_t)(rec[i] >> 8), ib = s->ids[b];
            const unsigned sure = (unsigned)(rec[i] >> 4) & 15;
            unsigned m = (unsigned)rec[i] & 15;
            while (m) {
                const unsigned k = (unsigned)__builtin_ctz(m);
                m &= m - 1;
                const uint32_t a = G->first + k;
                if (((sure >> k) & 1 || within(s, a, b)) && !buf_pair(buf, s->ids[a], ib))
                    return false;
            }
        }
        b0 = e;
    }
    return true;
}

/*
 * Search the rows r0 .. r1-1 and append every pair within the radius to
 * `buf` as (smaller id, larger id). A point's partners are the points
 * after it in its own row and the points of the rows after its row, among
 * (d1, d2) = (+1, 0), (-1, +1), (0, +1), (+1, +1). The points of a row
 * are taken four at a time: the group's candidates in a row are those
 * whose quantised sweep coordinate lies within `reach` of the group's
 * span, one window per row whose ends only move forward along the row,
 * and a neighbouring row is searched only when some point of the group
 * lies within eps of it. Every candidate is tested against the whole
 * group at once; a pair is still tested once only, from its point that
 * comes first. The row look-ups use cursors that only move forward: the
 * key of the row at offset (d1, d2) grows with the row's own key.
 */
static bool search_rows(const sweep *s, size_t r0, size_t r1, edge_buf *buf)
{
    /* the four rows after a row, as (d1, d2) */
    static const int fd1[4] = {1, -1, 0, 1}, fd2[4] = {0, 1, 1, 1};
    size_t cur[4];
    bool have[4] = {false, false, false, false};
    const uint64_t mask1 = (UINT64_C(1) << s->bits1) - 1;
    const uint64_t reach = s->reach;
    const double near = s->near, far = 1 - s->near;
    for (size_t r = r0; r < r1; r++) {
        const uint64_t c1 = s->keys[r] & mask1, c2 = s->keys[r] >> s->bits1;
        uint32_t lo[4], hi[4], end[4];
        bool on[4];
        for (int k = 0; k < 4; k++) {
            on[k] = false;
            if ((fd1[k] < 0 && c1 == 0) || (fd1[k] > 0 && c1 + 1 >= s->dims1) ||
                c2 + (uint64_t)fd2[k] >= s->dims2)
                continue;
            const uint64_t want =
                ((c2 + (uint64_t)fd2[k]) << s->bits1) | (c1 + (uint64_t)(int64_t)fd1[k]);
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
                lo[k] = hi[k] = s->first[a];
                end[k] = s->first[a + 1];
                on[k] = true;
            }
        }
        const uint32_t row_end = s->first[r + 1];
        uint32_t own_hi = s->first[r];
        for (uint32_t g = s->first[r]; g < row_end; g += 4) {
            const uint32_t count = row_end - g < 4 ? row_end - g : 4;
            const unsigned valid = (1u << count) - 1;
            const uint64_t qmin = s->q[g], qmax = s->q[g + count - 1];
            group G;
            group_init(&G, s, g, count);
            /* the rest of its own row: candidate b pairs with the lanes
             * before it */
            if (own_hi <= g)
                own_hi = g + 1;
            while (own_hi < row_end && (uint64_t)s->q[own_hi] <= qmax + reach)
                own_hi++;
            if (!group_range(s, &G, g + 1, own_hi, valid, true, buf))
                return false;
            /* the rows some point of the group is near */
            bool left = false, right = false, up = false;
            for (uint32_t a = g; a < g + count; a++) {
                const float pa[3] = {s->px[a], s->py[a], s->pz[a]};
                const double f1 = ((double)pa[s->a1] - s->lo1) * s->inv_cell - (double)c1;
                const double f2 = ((double)pa[s->a2] - s->lo2) * s->inv_cell - (double)c2;
                left |= f1 < near;
                right |= f1 > far;
                up |= f2 > far;
            }
            if (!right && !up)
                continue;
            for (int k = 0; k < 4; k++) {
                if (!on[k] || (fd2[k] > 0 && !up) || (fd1[k] > 0 && !right) ||
                    (fd1[k] < 0 && !left))
                    continue;
                uint32_t l = lo[k], h = hi[k];
                while (l < end[k] && (uint64_t)s->q[l] + reach < qmin)
                    l++;
                if (h < l)
                    h = l;
                while (h < end[k] && (uint64_t)s->q[h] <= qmax + reach)
                    h++;
                lo[k] = l;
                hi[k] = h;
                if (!group_range(s, &G, l, h, valid, false, buf))
                    return false;
            }
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

/* Points per work item of the search (whole rows): long enough runs for
 * the cursors, short enough to balance uneven rows. */
#define BLOCK_POINTS 4096

/* Most slices of the offsets' prefix sum. */
#define MAX_SLICES 256

/* Row cells are this many radii wide: a point is then near (within eps
 * of) a neighbouring row on one axis for about 2 in 3 of the points, and
 * a row holds enough points that its set-up cost is spread thin. */
#define ROW_CELLS 3

/* Sub-cells per cell along the sweep axis (as a power of two): the window
 * is then at most eps + 2/2^s cells wide on each side. */
#define SWEEP_SUB_BITS 5

/*
 * Sort the points for the sweep. The sweep axis is the longest side of the
 * bounding box (on a surface, rows along it are long); rows are cells of
 * edge ROW_CELLS * eps in the other two axes, so two points within eps
 * are in rows at most one apart on each, and only a point within eps of
 * its row's side can have a neighbour across that side. The sweep
 * coordinate is quantised to cell / 2^s, so two points within eps are at
 * most `reach` quanta apart. Coordinates are scaled by reciprocals (no
 * division per point); the margins on `near` and `reach` cover their
 * rounding.
 */
static mr_status sweep_build(sweep *s, const float *pos, size_t n, double eps, int strict,
                             const double box[6], int threads, size_t *peak, mr_error *err)
{
    memset(s, 0, sizeof *s);
    s->n = n;
    const double *lo = box, *hi = box + 3;
    mr_grid grid;
    mr_grid_init(&grid, lo, hi, ROW_CELLS * eps * (1.0 + 1e-8));
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
    s->a1 = a1;
    s->a2 = a2;
    s->lo1 = lo[a1];
    s->lo2 = lo[a2];
    s->inv_cell = inv_cell;
    /* cell coordinates are below 2^21, so their rounding is far below the
     * absolute margin */
    s->near = eps * inv_cell * (1 + 1e-6) + 1e-7;

    /* keys of at most 32 bits (the usual case) sort a third faster */
    const unsigned shift2 = qbits + grid.bits[a1];
    const unsigned key_bits = shift2 + grid.bits[a2];
    const bool narrow = key_bits <= 32;
    uint64_t *keys64 = narrow ? NULL : mr_alloc_array(n, sizeof *keys64);
    uint32_t *keys32 = narrow ? mr_alloc_array(n, sizeof *keys32) : NULL;
    s->ids = mr_alloc_array(n, sizeof *s->ids);
    s->px = mr_alloc_array(n + PAD, 3 * sizeof *s->px);
    s->q = mr_alloc_array(n, sizeof *s->q);
    size_t *chunk_rows = mr_calloc_array((size_t)threads + 1, sizeof *chunk_rows);
    if ((!keys64 && !keys32) || !s->ids || !s->px || !s->q || !chunk_rows) {
        free(keys64);
        free(keys32);
        free(chunk_rows);
        return mr_fail_nomem(err, NULL, n * 28);
    }
    s->py = s->px + n + PAD;
    s->pz = s->py + n + PAD;
    for (size_t i = n; i < n + PAD; i++)
        s->px[i] = s->py[i] = s->pz[i] = 0;
    /* The float distance of a pair is within a few ulps of its exact
     * value; the bound is 10 ppm above eps^2 and never below the underflow
     * of tiny differences. */
    s->eps2f = (float)(eps * eps * (1 + 1e-5));
    if (!(s->eps2f >= 4 * FLT_MIN))
        s->eps2f = 4 * FLT_MIN;
    /* A float distance 10 ppm below eps^2 is within it however it rounded
     * (a few ulps: under 1 ppm); tiny radii, where underflow could weigh
     * more than that, and radii whose square is near a float's range
     * (an overflowed distance would pass) leave every candidate to the
     * exact test. */
    s->eps2_in = eps * eps > 1e-30 && eps * eps < 1e37 ? (float)(eps * eps * (1 - 1e-5)) : -1.0f;
    /* ids, positions, sweep coordinates, keys and the radix scratch */
    *peak = n * (20 + (narrow ? 12 : 20));
    const double l0 = lo[ax], l1 = lo[a1], l2 = lo[a2];
    const uint64_t d0 = qdims, d1 = grid.dims[a1], d2 = grid.dims[a2];
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
        const uint64_t key = (c2 << shift2) | (c1 << qbits) | q;
        if (narrow)
            keys32[i] = (uint32_t)key;
        else
            keys64[i] = key;
        s->ids[i] = (uint32_t)i;
    }
    mr_status st = narrow ? mr_radix_sort_u32(keys32, s->ids, n, key_bits, threads, err)
                          : mr_radix_sort_u64(keys64, s->ids, n, key_bits, threads, err);
    if (st != MR_OK) {
        free(keys64);
        free(keys32);
        free(chunk_rows);
        return st;
    }

    /* Rows, sweep coordinates and positions in sorted order, in one pass:
     * each thread counts the rows starting in its slice, then fills them. */
    const uint64_t qmask = (UINT64_C(1) << qbits) - 1;
#define KEY_AT(i) (narrow ? (uint64_t)keys32[i] : keys64[i])
    _Atomic int failed;
    atomic_init(&failed, 0);
#pragma omp parallel num_threads(threads) if (n > PARALLEL_MIN)
    {
        const size_t nt = (size_t)omp_get_num_threads(), me = (size_t)omp_get_thread_num();
        const size_t i0 = n * me / nt, i1 = n * (me + 1) / nt;
        size_t count = 0;
        for (size_t i = i0; i < i1; i++)
            count += i == 0 || (KEY_AT(i) >> qbits) != (KEY_AT(i - 1) >> qbits);
        chunk_rows[me + 1] = count;
#pragma omp barrier
#pragma omp single
        {
            for (size_t t = 0; t < nt; t++)
                chunk_rows[t + 1] += chunk_rows[t];
            s->rows = chunk_rows[nt];
            s->keys = mr_alloc_array(s->rows, sizeof *s->keys);
            s->first = mr_alloc_array(s->rows + 1, sizeof *s->first);
            if (!s->keys || !s->first)
                atomic_store(&failed, 1);
            else
                s->first[s->rows] = (uint32_t)n;
        }
        if (!atomic_load(&failed))
            for (size_t i = i0, r = chunk_rows[me]; i < i1; i++) {
                const uint64_t key = KEY_AT(i);
                if (i == 0 || (key >> qbits) != (KEY_AT(i - 1) >> qbits)) {
                    s->keys[r] = key >> qbits;
                    s->first[r++] = (uint32_t)i;
                }
                s->q[i] = (uint32_t)(key & qmask);
                const float *p = pos + 3 * (size_t)s->ids[i];
                s->px[i] = p[0];
                s->py[i] = p[1];
                s->pz[i] = p[2];
            }
    }
#undef KEY_AT
    free(keys64);
    free(keys32);
    free(chunk_rows);
    if (atomic_load(&failed))
        return mr_fail_nomem(err, NULL, s->rows * 12);
    return MR_OK;
}

mr_status mr_radius_graph_build(mr_radius_graph *g, const float *pos, size_t n, double eps,
                                int strict, const double box[6], int threads, mr_error *err)
{
    memset(g, 0, sizeof *g);
    g->n = n;
    if (n > UINT32_MAX - 1)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu points: more than 32-bit indices can address", n);
    if (threads < 1)
        threads = 1;
    /* Strictly closer than 0 is never true: the graph has no edge. */
    const bool empty = n == 0 || (strict && eps == 0);
    sweep s;
    memset(&s, 0, sizeof s);
    edge_buf *bufs = NULL;
    size_t *blk_first = NULL;
    uint32_t *cnt = NULL;
    _Atomic int32_t *dep = NULL;
    size_t sort_bytes = 0, transient = 0;
    mr_status st = empty ? MR_OK
                         : sweep_build(&s, pos, n, eps, strict, box, threads, &sort_bytes, err);
    if (st != MR_OK) {
        sweep_free(&s);
        return st;
    }
    g->offsets = mr_alloc_array(n + 1, sizeof *g->offsets);
    g->depend = mr_alloc_array(n, sizeof *g->depend);
    if (!g->offsets || !g->depend) {
        st = mr_fail_nomem(err, NULL, n * 12);
        goto done;
    }
    g->offsets[0] = 0;
    g->bytes = (n + 1) * sizeof *g->offsets + n * sizeof *g->depend;
    g->peak_bytes = sort_bytes > g->bytes ? sort_bytes : g->bytes;
    if (empty) {
        for (size_t i = 0; i < n; i++) {
            g->offsets[i + 1] = 0;
            atomic_init(&g->depend[i], 0);
        }
        g->adj = mr_alloc_array(0, sizeof *g->adj);
        if (!g->adj)
            st = mr_fail_nomem(err, NULL, 1);
        goto done;
    }
    const size_t sweep_bytes = n * (sizeof *s.ids + 3 * sizeof *s.px + sizeof *s.q) + s.rows * 12;
    transient = sweep_bytes;

    /* work items: runs of whole rows of about BLOCK_POINTS points */
    size_t blocks = 0;
    blk_first = mr_alloc_array(n / BLOCK_POINTS + 2, sizeof *blk_first);
    bufs = mr_calloc_array((size_t)threads, sizeof *bufs);
    cnt = mr_alloc_array(n, sizeof *cnt);
    dep = g->depend;
    if (!blk_first || !bufs || !cnt) {
        st = mr_fail_nomem(err, NULL, n * 4);
        goto done;
    }
    transient += n * sizeof *cnt;
    for (size_t r = 0; r < s.rows; r++)
        if (blocks == 0 || s.first[r] - s.first[blk_first[blocks - 1]] >= BLOCK_POINTS)
            blk_first[blocks++] = r;
    blk_first[blocks] = s.rows;

    /* One search: each thread appends the pairs of the blocks it takes to
     * its own buffer; then every pair is counted at both ends. (The team
     * may be smaller than asked: every thread walks all the buffers.) */
    _Atomic int failed;
    atomic_init(&failed, 0);
#pragma omp parallel num_threads(threads) if (n > PARALLEL_MIN)
    {
#pragma omp for schedule(static)
        for (size_t i = 0; i < n; i++) {
            cnt[i] = 0;
            atomic_init(&dep[i], 0);
        }
        /* the thread's buffer is filled through a copy of its own: the
         * buffers' headers share cache lines */
        edge_buf mine = {NULL, 0, 0};
#pragma omp for schedule(dynamic, 1) nowait
        for (size_t blk = 0; blk < blocks; blk++)
            if (!atomic_load_explicit(&failed, memory_order_relaxed) &&
                !search_rows(&s, blk_first[blk], blk_first[blk + 1], &mine))
                atomic_store_explicit(&failed, 1, memory_order_relaxed);
        bufs[omp_get_thread_num()] = mine;
#pragma omp barrier
        /* Counting: each thread owns a slice of the ids and walks every
         * buffer, counting the ends that fall in its slice: plain stores
         * into entries no other thread touches. (A select into a sink
         * entry instead of the branches was twice as slow: the sink's
         * increments form one long dependency chain.) */
        const uint32_t nt = (uint32_t)omp_get_num_threads(), me = (uint32_t)omp_get_thread_num();
        const uint32_t lo = own_lo(n, me, nt), span = own_lo(n, me + 1, nt) - lo;
        for (int t = 0; t < threads; t++) {
            const uint32_t *d = bufs[t].data;
            for (size_t e = 0; e < bufs[t].len; e += 2) {
                const uint32_t u = d[e], v = d[e + 1];
                if (u - lo < span)
                    cnt[u]++;
                if (v - lo < span)
                    atomic_store_explicit(&dep[v],
                                          atomic_load_explicit(&dep[v], memory_order_relaxed) + 1,
                                          memory_order_relaxed);
            }
        }
    }
    size_t buffered = 0;
    for (int t = 0; t < threads; t++)
        buffered += bufs[t].cap * sizeof *bufs[t].data;
    transient += buffered;
    if (atomic_load(&failed)) {
        st = mr_fail_nomem(err, NULL, buffered);
        goto done;
    }
    if (g->bytes + transient > g->peak_bytes)
        g->peak_bytes = g->bytes + transient;
    sweep_free(&s);
    memset(&s, 0, sizeof s);
    transient -= sweep_bytes;

    /* offsets: a prefix sum over the counts, in slices (the slice sums
     * first, then each slice from its start); the counts become the
     * placement cursors */
    size_t *off = g->offsets;
    size_t slice_sum[MAX_SLICES + 1];
    const size_t slices = threads < MAX_SLICES ? (size_t)threads : MAX_SLICES;
    slice_sum[0] = 0;
#pragma omp parallel for schedule(static, 1) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t t = 0; t < slices; t++) {
        size_t sum = 0;
        for (size_t i = n * t / slices; i < n * (t + 1) / slices; i++)
            sum += cnt[i];
        slice_sum[t + 1] = sum;
    }
    for (size_t t = 0; t < slices; t++)
        slice_sum[t + 1] += slice_sum[t];
#pragma omp parallel for schedule(static, 1) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t t = 0; t < slices; t++) {
        size_t at = slice_sum[t];
        for (size_t i = n * t / slices; i < n * (t + 1) / slices; i++) {
            off[i] = at;
            at += cnt[i];
            cnt[i] = 0;
        }
    }
    off[n] = slice_sum[slices];
    g->edge_count = off[n];
    g->adj = mr_alloc_array(g->edge_count, sizeof *g->adj);
    if (!g->adj) {
        st = mr_fail_nomem(err, NULL, g->edge_count * sizeof *g->adj);
        goto done;
    }
    g->bytes += g->edge_count * sizeof *g->adj;

    /* Place every pair under its smaller end, then sort each list, so that
     * every consumer walks the members of a cluster in index order. */
#pragma omp parallel num_threads(threads) if (n > PARALLEL_MIN)
    {
        /* each thread places the pairs whose smaller end it owns */
        const uint32_t nt = (uint32_t)omp_get_num_threads(), me = (uint32_t)omp_get_thread_num();
        const uint32_t lo = own_lo(n, me, nt), span = own_lo(n, me + 1, nt) - lo;
        for (int t = 0; t < threads; t++) {
            const uint32_t *d = bufs[t].data;
            for (size_t e = 0; e < bufs[t].len; e += 2) {
                const uint32_t u = d[e];
                if (u - lo < span)
                    g->adj[off[u] + cnt[u]++] = d[e + 1];
            }
        }
#pragma omp barrier
#pragma omp for schedule(dynamic, 16384)
        for (size_t i = 0; i < n; i++)
            if (off[i + 1] - off[i] > 1)
                sort_list(g->adj + off[i], off[i + 1] - off[i]);
    }

done:
    if (transient + g->bytes > g->peak_bytes)
        g->peak_bytes = transient + g->bytes;
    if (bufs)
        for (int t = 0; t < threads; t++)
            free(bufs[t].data);
    free(bufs);
    free(blk_first);
    free(cnt);
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
