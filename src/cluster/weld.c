/*
 * Epsilon welding: S-Weld, P-Weld and P-Weld-Async (Fathollahi and Chester,
 * "Lock-free Vertex Clustering for Multicore Mesh Reduction", SIGGRAPH Asia
 * 2023), and the epsilon finder.
 *
 * Everything works in "rank space": rank r is the r-th vertex in visiting
 * order (the vertex itself in index order; perm[r] in grade order), so
 * every algorithm below is written for index order and the grade order is
 * a permutation applied once at the start (positions) and once at the end
 * (the remap).
 *
 * Why the three algorithms agree bit for bit. The neighbour graph keeps,
 * for each rank, its larger neighbours sorted ascending. A cluster's
 * centroid is its smallest member and every other member is a larger
 * neighbour of it, so "the centroid, then its adjacency list filtered to
 * the cluster's members" lists the members in increasing rank, whichever
 * algorithm found them. The representative is that list's sum in double
 * divided by the count, rounded once to float: the same operations in the
 * same order everywhere. Cluster ids follow the centroids' ranks, which is
 * the order S-Weld creates them in.
 *
 * Why half the graph is enough for S-Weld. When S-Weld reaches an
 * unclustered vertex u, every smaller neighbour w of u is already
 * clustered: w was visited before u, and had w been unclustered then, it
 * would have started a cluster and taken u with it. So u's still
 * unclustered neighbours are all larger than u: the lists the graph keeps.
 */
#include "grid.h"

#include "../mesh/adjacency.h"

#include "../core/omp_compat.h"

#define NONE UINT32_MAX
#define TRI_CHUNK 16384u  /* triangles per retriangulation work item */
#define REP_CHUNK 8192u   /* ranks per repositioning work item */
#define PARALLEL_MIN 16384

void mr_weld_options_default(mr_weld_options *options)
{
    memset(options, 0, sizeof *options);
    options->algorithm = MR_WELD_AUTO;
    options->order = MR_WELD_ORDER_INDEX;
}

void mr_welded_free(mr_welded *result)
{
    if (!result)
        return;
    free(result->positions);
    free(result->indices);
    free(result->remap);
    memset(result, 0, sizeof *result);
}

/* ---- representatives --------------------------------------------------- */

/* One per-vertex float array that is averaged over each cluster: the
 * positions (indexed by rank) and the attributes (indexed by vertex). */
typedef struct channel {
    const float *data;
    unsigned width;
    int by_rank;
    float *out;
} channel;

typedef struct weld_job {
    size_t n;
    const float *pos;      /* packed, in rank order */
    const uint32_t *perm;  /* rank -> vertex, NULL for index order */
    channel ch[4];
    unsigned nch;
    unsigned total_width;
    const uint32_t *indices;
    size_t tc;
    int drop;
    int threads;
} weld_job;

static inline void accumulate(const weld_job *j, uint32_t r, double *acc)
{
    const uint32_t v = j->perm ? j->perm[r] : r;
    for (unsigned c = 0, o = 0; c < j->nch; o += j->ch[c].width, c++) {
        const float *p = j->ch[c].data + (size_t)(j->ch[c].by_rank ? r : v) * j->ch[c].width;
        for (unsigned k = 0; k < j->ch[c].width; k++)
            acc[o + k] += (double)p[k];
    }
}

/* Representative k of the cluster whose centroid is rank c; its members
 * are c and the ranks m of c's list with label[m] == k. */
static void represent(const weld_job *j, const mr_radius_graph *g, uint32_t c,
                      const uint32_t *label, uint32_t k)
{
    if (g->offsets[c] == g->offsets[(size_t)c + 1]) {
        /* No larger neighbour: c is alone (most vertices at welding
         * radii). The mean of one value, as the sum below computes it
         * from +0: the value, with -0 turned into +0. */
        const uint32_t v = j->perm ? j->perm[c] : c;
        for (unsigned ci = 0; ci < j->nch; ci++) {
            const unsigned w = j->ch[ci].width;
            const float *p = j->ch[ci].data + (size_t)(j->ch[ci].by_rank ? c : v) * w;
            float *out = j->ch[ci].out + (size_t)k * w;
            for (unsigned q = 0; q < w; q++)
                out[q] = p[q] + 0.0f;
        }
        return;
    }
    double acc[12] = {0};
    accumulate(j, c, acc);
    size_t count = 1;
    for (size_t e = g->offsets[c]; e < g->offsets[(size_t)c + 1]; e++) {
        uint32_t m = g->adj[e];
        if (label[m] == k) {
            accumulate(j, m, acc);
            count++;
        }
    }
    const double d = (double)count;
    for (unsigned ci = 0, o = 0; ci < j->nch; o += j->ch[ci].width, ci++) {
        float *out = j->ch[ci].out + (size_t)k * j->ch[ci].width;
        for (unsigned q = 0; q < j->ch[ci].width; q++)
            out[q] = (float)(acc[o + q] / d);
    }
}

static mr_status alloc_outputs(weld_job *j, size_t clusters, mr_error *err)
{
    for (unsigned c = 0; c < j->nch; c++) {
        j->ch[c].out = mr_alloc_array(clusters, j->ch[c].width * sizeof(float));
        if (!j->ch[c].out)
            return mr_fail_nomem(err, NULL, clusters * j->ch[c].width * sizeof(float));
    }
    return MR_OK;
}

static void shrink_outputs(weld_job *j, size_t clusters)
{
    for (unsigned c = 0; c < j->nch; c++) {
        float *p = mr_realloc_array(j->ch[c].out, clusters, j->ch[c].width * sizeof(float));
        if (p)
            j->ch[c].out = p;
    }
}

/* ---- retriangulation --------------------------------------------------- */

static size_t tri_survivors(const uint32_t *in, size_t t0, size_t t1, const uint32_t *remap)
{
    size_t n = 0;
    for (size_t t = t0; t < t1; t++) {
        uint32_t a = remap[in[3 * t]], b = remap[in[3 * t + 1]], c = remap[in[3 * t + 2]];
        n += a != b && b != c && a != c;
    }
    return n;
}

static void tri_write(const uint32_t *in, size_t t0, size_t t1, const uint32_t *remap, int drop,
                      uint32_t *out)
{
    for (size_t t = t0; t < t1; t++) {
        uint32_t a = remap[in[3 * t]], b = remap[in[3 * t + 1]], c = remap[in[3 * t + 2]];
        if (drop && (a == b || b == c || a == c))
            continue;
        out[0] = a, out[1] = b, out[2] = c;
        out += 3;
    }
}

/* Remap every triangle (dropping collapsed ones when asked) with
 * `threads` threads; chunk offsets come from a prefix sum over per-chunk
 * survivor counts, so the output order is the input order. */
static mr_status retriangulate(const weld_job *j, const uint32_t *remap, uint32_t *out,
                               size_t *out_tc, int threads, mr_error *err)
{
    const size_t tc = j->tc;
    if (!j->drop) {
#pragma omp parallel for schedule(static) num_threads(threads) if (tc > PARALLEL_MIN)
        for (size_t t = 0; t < tc; t++)
            tri_write(j->indices, t, t + 1, remap, 0, out + 3 * t);
        *out_tc = tc;
        return MR_OK;
    }
    const size_t chunks = (tc + TRI_CHUNK - 1) / TRI_CHUNK;
    size_t *base = mr_alloc_array(chunks + 1, sizeof *base);
    if (!base)
        return mr_fail_nomem(err, NULL, (chunks + 1) * sizeof *base);
#pragma omp parallel for schedule(static) num_threads(threads) if (chunks > 1)
    for (size_t c = 0; c < chunks; c++) {
        size_t t1 = (c + 1) * TRI_CHUNK < tc ? (c + 1) * TRI_CHUNK : tc;
        base[c + 1] = tri_survivors(j->indices, c * TRI_CHUNK, t1, remap);
    }
    base[0] = 0;
    for (size_t c = 0; c < chunks; c++)
        base[c + 1] += base[c];
#pragma omp parallel for schedule(static) num_threads(threads) if (chunks > 1)
    for (size_t c = 0; c < chunks; c++) {
        size_t t1 = (c + 1) * TRI_CHUNK < tc ? (c + 1) * TRI_CHUNK : tc;
        tri_write(j->indices, c * TRI_CHUNK, t1, remap, 1, out + 3 * base[c]);
    }
    *out_tc = base[chunks];
    free(base);
    return MR_OK;
}

/* ---- the algorithms ----------------------------------------------------- */

typedef struct weld_result {
    uint32_t *remap;   /* by input vertex */
    uint32_t *indices; /* 3 * tc capacity */
    size_t clusters;
    size_t tc;
} weld_result;

/* S-Weld (Algorithm 1): one serial pass that creates each cluster and its
 * representative as it meets the centroid, then a serial retriangulation. */
static mr_status sweld(weld_job *j, const mr_radius_graph *g, uint32_t *label,
                       weld_result *res, mr_weld_stats *st, mr_error *err)
{
    const size_t n = j->n;
    double t0 = mr_now_seconds();
    mr_status s = alloc_outputs(j, n, err);
    if (s != MR_OK)
        return s;
    for (size_t r = 0; r < n; r++)
        label[r] = NONE;
    uint32_t k = 0;
    for (uint32_t r = 0; r < n; r++) {
        if (label[r] != NONE)
            continue;
        label[r] = k;
        for (size_t e = g->offsets[r]; e < g->offsets[(size_t)r + 1]; e++)
            if (label[g->adj[e]] == NONE)
                label[g->adj[e]] = k;
        represent(j, g, r, label, k);
        k++;
    }
    if (j->perm)
        for (size_t r = 0; r < n; r++)
            res->remap[j->perm[r]] = label[r];
    shrink_outputs(j, k);
    res->clusters = k;
    double t1 = mr_now_seconds();
    s = retriangulate(j, res->remap, res->indices, &res->tc, 1, err);
    st->seconds_mapping = t1 - t0;
    st->seconds_retriangulation = mr_now_seconds() - t1;
    return s;
}

/* Lock-free minimum: centroid estimates only ever decrease, so there is no
 * ABA, and the loop retries only when another centroid lowered the value
 * between the load and the exchange. */
static inline void cas_min(_Atomic uint32_t *a, uint32_t v)
{
    uint32_t cur = atomic_load_explicit(a, memory_order_relaxed);
    while (v < cur &&
           !atomic_compare_exchange_weak_explicit(a, &cur, v, memory_order_relaxed,
                                                  memory_order_relaxed))
        ;
}

/*
 * P-Weld's mapping (Algorithm 2, lines 5-15): rounds over all ranks with a
 * static schedule; a rank whose dependency count has reached 0 is
 * resolved: its centroid estimate is final. It marks itself done (-1),
 * offers itself as centroid to its larger neighbours if it is one, and
 * releases them. The decrement is a release and the test an acquire, so a
 * rank that sees 0 also sees every centroid offer made before the
 * decrements that brought it there. Ranks released earlier in the same
 * round by the same thread are resolved in that round, so one thread
 * needs a single productive round. Returns the number of rounds.
 */
static unsigned pweld_map(const mr_radius_graph *g, _Atomic uint32_t *centroid, int threads)
{
    const size_t n = g->n;
    _Atomic int32_t *depend = g->depend;
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t r = 0; r < n; r++)
        atomic_init(&centroid[r], (uint32_t)r);
    size_t done = 0;
    unsigned rounds = 0;
    while (done < n) {
        size_t finished = 0;
#pragma omp parallel for schedule(static) num_threads(threads) reduction(+ : finished) \
    if (n > PARALLEL_MIN)
        for (size_t r = 0; r < n; r++) {
            if (atomic_load_explicit(&depend[r], memory_order_acquire) != 0)
                continue;
            atomic_store_explicit(&depend[r], -1, memory_order_relaxed);
            const bool is_centroid =
                atomic_load_explicit(&centroid[r], memory_order_relaxed) == (uint32_t)r;
            for (size_t e = g->offsets[r]; e < g->offsets[r + 1]; e++) {
                uint32_t m = g->adj[e];
                if (is_centroid)
                    cas_min(&centroid[m], (uint32_t)r);
                atomic_fetch_sub_explicit(&depend[m], 1, memory_order_release);
            }
            finished++;
        }
        done += finished;
        rounds++;
    }
    return rounds;
}

static inline bool is_centroid(const _Atomic uint32_t *centroid, size_t r)
{
    return atomic_load_explicit(&centroid[r], memory_order_relaxed) == (uint32_t)r;
}

/* P-Weld's reduction (lines 16-21) and retriangulation (22-23): a serial
 * numbering pass, then parallel labelling, repositioning and
 * retriangulation. */
static mr_status pweld_finish(weld_job *j, const mr_radius_graph *g,
                              const _Atomic uint32_t *centroid, uint32_t *label,
                              weld_result *res, mr_weld_stats *st, mr_error *err)
{
    const size_t n = j->n;
    const int T = j->threads;
    double t0 = mr_now_seconds();
    uint32_t k = 0;
    for (size_t r = 0; r < n; r++)
        if (is_centroid(centroid, r))
            label[r] = k++;
    res->clusters = k;
    mr_status s = alloc_outputs(j, k, err);
    if (s != MR_OK)
        return s;
#pragma omp parallel num_threads(T) if (n > PARALLEL_MIN)
    {
#pragma omp for schedule(static)
        for (size_t r = 0; r < n; r++) {
            uint32_t c = atomic_load_explicit(&centroid[r], memory_order_relaxed);
            if (c != r)
                label[r] = label[c];
        }
#pragma omp for schedule(static) nowait
        for (size_t r = 0; r < n; r++)
            if (j->perm)
                res->remap[j->perm[r]] = label[r];
#pragma omp for schedule(static)
        for (size_t r = 0; r < n; r++)
            if (is_centroid(centroid, r))
                represent(j, g, (uint32_t)r, label, label[r]);
    }
    double t1 = mr_now_seconds();
    s = retriangulate(j, res->remap, res->indices, &res->tc, T, err);
    st->seconds_reduction = t1 - t0;
    st->seconds_retriangulation = mr_now_seconds() - t1;
    return s;
}

/*
 * P-Weld-Async (section 3.2): cluster ids from a parallel prefix sum over
 * the centroids each thread finds in its static block; then repositioning
 * and retriangulation run in one region with no barrier between them,
 * threads taking work items (blocks of ranks to reposition, then blocks of
 * triangles) from a shared counter, so the memory-bound repositioning is
 * hidden behind the retriangulation. Every item writes its own part of
 * the output, so the result does not depend on who takes which item.
 * When collapsed triangles are dropped the overlapped part counts the
 * survivors per block and a last parallel pass writes them compacted.
 */
static mr_status pweld_async_finish(weld_job *j, const mr_radius_graph *g,
                                    const _Atomic uint32_t *centroid, uint32_t *label,
                                    weld_result *res, mr_weld_stats *st, mr_error *err)
{
    const size_t n = j->n, tc = j->tc;
    const int T = j->threads;
    size_t *counts = mr_calloc_array((size_t)T + 1, sizeof *counts);
    const size_t tchunks = (tc + TRI_CHUNK - 1) / TRI_CHUNK;
    size_t *tbase = mr_calloc_array(tchunks + 1, sizeof *tbase);
    if (!counts || !tbase) {
        free(counts);
        free(tbase);
        return mr_fail_nomem(err, NULL, ((size_t)T + tchunks) * sizeof(size_t));
    }
    const size_t vchunks = (n + REP_CHUNK - 1) / REP_CHUNK;
    const size_t items = vchunks + tchunks;
    _Atomic size_t next;
    atomic_init(&next, 0);
    mr_status s = MR_OK;
    double t0 = mr_now_seconds(), t1 = t0;
#pragma omp parallel num_threads(T)
    {
        const int t = omp_get_thread_num(), nt = omp_get_num_threads();
        const size_t lo = n * (size_t)t / (size_t)nt, hi = n * ((size_t)t + 1) / (size_t)nt;
        size_t mine = 0;
        for (size_t r = lo; r < hi; r++)
            mine += is_centroid(centroid, r);
        counts[t + 1] = mine;
#pragma omp barrier
#pragma omp single
        {
            for (int q = 0; q < nt; q++)
                counts[q + 1] += counts[q];
            res->clusters = counts[nt];
            s = alloc_outputs(j, res->clusters, err);
        }
        if (s == MR_OK) {
            uint32_t k = (uint32_t)counts[t];
            for (size_t r = lo; r < hi; r++)
                if (is_centroid(centroid, r))
                    label[r] = k++;
#pragma omp barrier
            for (size_t r = lo; r < hi; r++) {
                uint32_t c = atomic_load_explicit(&centroid[r], memory_order_relaxed);
                if (c != r)
                    label[r] = label[c];
                if (j->perm)
                    res->remap[j->perm[r]] = label[r];
            }
#pragma omp barrier
#pragma omp master
            t1 = mr_now_seconds();
            for (;;) {
                size_t item = atomic_fetch_add_explicit(&next, 1, memory_order_relaxed);
                if (item >= items)
                    break;
                if (item < vchunks) {
                    size_t r1 = (item + 1) * REP_CHUNK < n ? (item + 1) * REP_CHUNK : n;
                    for (size_t r = item * REP_CHUNK; r < r1; r++)
                        if (is_centroid(centroid, r))
                            represent(j, g, (uint32_t)r, label, label[r]);
                } else {
                    size_t c = item - vchunks;
                    size_t a = c * TRI_CHUNK, b = a + TRI_CHUNK < tc ? a + TRI_CHUNK : tc;
                    if (j->drop)
                        tbase[c + 1] = tri_survivors(j->indices, a, b, res->remap);
                    else
                        tri_write(j->indices, a, b, res->remap, 0, res->indices + 3 * a);
                }
            }
        }
    }
    if (s == MR_OK && j->drop) {
        for (size_t c = 0; c < tchunks; c++)
            tbase[c + 1] += tbase[c];
#pragma omp parallel for schedule(static) num_threads(T) if (tchunks > 1)
        for (size_t c = 0; c < tchunks; c++) {
            size_t a = c * TRI_CHUNK, b = a + TRI_CHUNK < tc ? a + TRI_CHUNK : tc;
            tri_write(j->indices, a, b, res->remap, 1, res->indices + 3 * tbase[c]);
        }
        res->tc = tbase[tchunks];
    } else {
        res->tc = tc;
    }
    st->seconds_reduction = t1 - t0;
    st->seconds_retriangulation = mr_now_seconds() - t1;
    free(counts);
    free(tbase);
    return s;
}

/* ---- visiting order ----------------------------------------------------- */

/* Float bits of a value >= 0 order like the values. */
static inline uint32_t float_bits(float f)
{
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    return b;
}

/*
 * The grade of Low and Tan (1997): a vertex matters more the longer its
 * longest incident edge (it stands for more surface) and the sharper it is,
 * measured by cos(theta / 2) for the widest angle theta between two of its
 * incident edges (0 on a flat fan, 1 at a needle tip). Both terms are
 * scaled to [0, 1] and weighted equally. perm[r] = the r-th vertex by
 * decreasing grade, ties in index order (a stable sort).
 */
#define GRADE_MAX_EDGES 32

static mr_status grade_order(const float *pos, size_t n, const uint32_t *indices, size_t tc,
                             int threads, uint32_t *perm, mr_error *err)
{
    mr_vertex_triangles vt;
    mr_status s = mr_vertex_triangles_build(&vt, indices, tc, n, err);
    if (s != MR_OK)
        return s;
    float *len = mr_alloc_array(n, sizeof *len);
    float *sharp = mr_alloc_array(n, sizeof *sharp);
    uint32_t *keys = mr_alloc_array(n, sizeof *keys);
    if (!len || !sharp || !keys) {
        s = mr_fail_nomem(err, NULL, n * 16);
        goto done;
    }
    double longest = 0;
#pragma omp parallel for schedule(dynamic, 1024) num_threads(threads) reduction(max : longest)
    for (size_t v = 0; v < n; v++) {
        double e[GRADE_MAX_EDGES][3];
        int k = 0;
        double lmax = 0;
        for (uint32_t i = vt.offsets[v]; i < vt.offsets[v + 1] && k < GRADE_MAX_EDGES; i++) {
            const uint32_t *tri = indices + 3 * (size_t)vt.triangles[i];
            for (int c = 0; c < 3 && k < GRADE_MAX_EDGES; c++) {
                if (tri[c] == v)
                    continue;
                const float *p = pos + 3 * (size_t)tri[c], *q = pos + 3 * v;
                double d[3] = {(double)p[0] - q[0], (double)p[1] - q[1], (double)p[2] - q[2]};
                double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                if (!(l > 0))
                    continue;
                lmax = fmax(lmax, l);
                for (int a = 0; a < 3; a++)
                    e[k][a] = d[a] / l;
                k++;
            }
        }
        double mincos = 1;
        for (int a = 0; a < k; a++)
            for (int b = a + 1; b < k; b++)
                mincos = fmin(mincos, e[a][0] * e[b][0] + e[a][1] * e[b][1] + e[a][2] * e[b][2]);
        len[v] = (float)lmax;
        sharp[v] = k >= 2 ? (float)sqrt(fmax(0.0, 0.5 * (1 + mincos))) : 0.0f;
        longest = fmax(longest, lmax);
    }
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t v = 0; v < n; v++) {
        double grade = 0.5 * sharp[v] + (longest > 0 ? 0.5 * len[v] / longest : 0.0);
        keys[v] = UINT32_MAX - float_bits((float)grade);
        perm[v] = (uint32_t)v;
    }
    s = mr_radix_sort_u32(keys, perm, n, 32, threads, err);
done:
    free(len);
    free(sharp);
    free(keys);
    mr_vertex_triangles_free(&vt);
    return s;
}

/* ---- driver ------------------------------------------------------------- */

typedef struct weld_in {
    const float *positions;
    size_t stride;
    size_t n;
    const float *normals, *texcoords, *colors;
    const uint32_t *indices;
    size_t tc;
} weld_in;

static mr_status check_eps(double eps, mr_error *err)
{
    if (!(eps >= 0) || isinf(eps))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "weld radius eps must be a finite number >= 0, got %g", eps);
    return MR_OK;
}

static mr_status check_input(const weld_in *in, mr_error *err)
{
    if (in->n == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL, "no vertices to weld");
    if (!in->positions)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "positions is NULL");
    if (in->stride != 0 && in->stride < 3 * sizeof(float))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "position stride %zu is less than 12 bytes", in->stride);
    if (in->n >= UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu vertices: more than 32-bit indices can address", in->n);
    if (in->tc > 0 && !in->indices)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "%zu triangles but no indices", in->tc);
    return mr_check_indices(in->indices, in->tc, in->n, err);
}

/* Packed positions in rank order: the input itself when it is packed and
 * in index order, else a copy (*owned). Fails on a non-finite coordinate. */
static mr_status packed_positions(const weld_in *in, const uint32_t *perm, int threads,
                                  const float **pos, float **owned, double box[6],
                                  mr_error *err)
{
    const size_t n = in->n, stride = in->stride ? in->stride : 3 * sizeof(float);
    *owned = NULL;
    if (stride == 3 * sizeof(float) && !perm) {
        *pos = in->positions;
    } else {
        float *p = mr_alloc_array(n, 3 * sizeof(float));
        if (!p)
            return mr_fail_nomem(err, NULL, n * 12);
        const unsigned char *base = (const unsigned char *)in->positions;
#pragma omp parallel for schedule(static) num_threads(threads) if (n > PARALLEL_MIN)
        for (size_t r = 0; r < n; r++)
            memcpy(p + 3 * r, base + (size_t)(perm ? perm[r] : r) * stride, 3 * sizeof(float));
        *pos = *owned = p;
    }
    size_t bad;
    if (!mr_points_bounds(*pos, n, threads, box, box + 3, &bad)) {
        free(*owned);
        *owned = NULL;
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "vertex %zu has a non-finite coordinate",
                             (size_t)(perm ? perm[bad] : bad));
    }
    return MR_OK;
}

typedef struct weld_out {
    float *positions, *normals, *texcoords, *colors;
    uint32_t *indices, *remap;
    size_t vertex_count, triangle_count;
} weld_out;

static mr_status weld_run(const weld_in *in, const mr_weld_options *options, weld_out *out,
                          mr_weld_stats *st, mr_error *err)
{
    mr_weld_options defaults;
    if (!options) {
        mr_weld_options_default(&defaults);
        options = &defaults;
    }
    memset(out, 0, sizeof *out);
    memset(st, 0, sizeof *st);
    mr_status s = check_eps(options->eps, err);
    if (s != MR_OK || (s = check_input(in, err)) != MR_OK)
        return s;
    if (options->algorithm < MR_WELD_AUTO || options->algorithm > MR_WELD_PWELD_ASYNC)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "unknown weld algorithm %d",
                             (int)options->algorithm);
    const size_t n = in->n;
    const double t_start = mr_now_seconds();
    weld_job j;
    memset(&j, 0, sizeof j);
    j.n = n;
    j.threads = mr_thread_count(options->threads);
    j.indices = in->indices;
    j.tc = in->tc;
    j.drop = options->drop_degenerate != 0;
    st->input_vertices = n;
    st->input_triangles = in->tc;
    st->eps = options->eps;
    st->threads = j.threads;
    st->algorithm = options->algorithm == MR_WELD_AUTO ? MR_WELD_PWELD_ASYNC : options->algorithm;

    uint32_t *perm = NULL, *label_own = NULL;
    double box[6];
    float *pos_own = NULL;
    _Atomic uint32_t *centroid = NULL;
    mr_radius_graph g;
    memset(&g, 0, sizeof g);
    size_t base_bytes = 0;

    /* visiting order */
    if (options->order == MR_WELD_ORDER_GRADE && in->tc > 0) {
        const float *packed;
        float *tmp;
        if ((s = packed_positions(in, NULL, j.threads, &packed, &tmp, box, err)) != MR_OK)
            goto fail;
        perm = mr_alloc_array(n, sizeof *perm);
        if (!perm) {
            free(tmp);
            s = mr_fail_nomem(err, NULL, n * 4);
            goto fail;
        }
        s = grade_order(packed, n, in->indices, in->tc, j.threads, perm, err);
        free(tmp);
        if (s != MR_OK)
            goto fail;
        base_bytes += n * sizeof *perm;
    }
    j.perm = perm;
    if ((s = packed_positions(in, perm, j.threads, &j.pos, &pos_own, box, err)) != MR_OK)
        goto fail;
    if (pos_own)
        base_bytes += n * 12;
    st->seconds_order = mr_now_seconds() - t_start;

    /* channels: positions first, then the attributes present */
    j.ch[j.nch++] = (channel){j.pos, 3, 1, NULL};
    if (in->normals)
        j.ch[j.nch++] = (channel){in->normals, 3, 0, NULL};
    if (in->texcoords)
        j.ch[j.nch++] = (channel){in->texcoords, 2, 0, NULL};
    if (in->colors)
        j.ch[j.nch++] = (channel){in->colors, 4, 0, NULL};

    double t = mr_now_seconds();
    if ((s = mr_radius_graph_build(&g, j.pos, n, options->eps, options->strict != 0, box, j.threads,
                                   err)) != MR_OK)
        goto fail;
    st->seconds_graph = mr_now_seconds() - t;
    st->graph_edges = g.edge_count;

    weld_result res = {NULL, NULL, 0, 0};
    res.remap = mr_alloc_array(n, sizeof *res.remap);
    res.indices = mr_alloc_array(in->tc, 3 * sizeof *res.indices);
    /* in index order the rank labels are the remap itself */
    uint32_t *label = res.remap;
    if (perm)
        label = label_own = mr_alloc_array(n, sizeof *label_own);
    if (!res.remap || !res.indices || !label) {
        free(res.remap);
        free(res.indices);
        s = mr_fail_nomem(err, NULL, n * 8 + in->tc * 12);
        goto fail;
    }
    size_t work = base_bytes + g.bytes + (label_own ? n * 4 : 0);
    if (st->algorithm == MR_WELD_SERIAL) {
        s = sweld(&j, &g, label, &res, st, err);
    } else {
        centroid = mr_alloc_array(n, sizeof *centroid);
        if (!centroid) {
            s = mr_fail_nomem(err, NULL, n * 4);
        } else {
            work += n * sizeof *centroid;
            t = mr_now_seconds();
            st->rounds = pweld_map(&g, centroid, j.threads);
            st->seconds_mapping = mr_now_seconds() - t;
            if (st->algorithm == MR_WELD_PWELD)
                s = pweld_finish(&j, &g, centroid, label, &res, st, err);
            else
                s = pweld_async_finish(&j, &g, centroid, label, &res, st, err);
        }
    }
    if (s != MR_OK) {
        free(res.remap);
        free(res.indices);
        for (unsigned c = 0; c < j.nch; c++)
            free(j.ch[c].out);
        goto fail;
    }
    st->peak_bytes = base_bytes + g.peak_bytes > work ? base_bytes + g.peak_bytes : work;

    if (res.tc < in->tc) {
        uint32_t *p = mr_realloc_array(res.indices, res.tc, 3 * sizeof *p);
        if (p)
            res.indices = p;
    }
    out->remap = res.remap;
    out->indices = res.indices;
    out->vertex_count = res.clusters;
    out->triangle_count = res.tc;
    unsigned c = 0;
    out->positions = j.ch[c++].out;
    if (in->normals)
        out->normals = j.ch[c++].out;
    if (in->texcoords)
        out->texcoords = j.ch[c++].out;
    if (in->colors)
        out->colors = j.ch[c++].out;
    st->output_vertices = res.clusters;
    st->output_triangles = res.tc;

fail:
    mr_radius_graph_free(&g);
    free((void *)centroid);
    free(label_own);
    free(pos_own);
    free(perm);
    st->seconds_total = mr_now_seconds() - t_start;
    return s;
}

mr_status mr_weld(const float *positions, size_t stride, size_t vertex_count,
                  const uint32_t *indices, size_t triangle_count,
                  const mr_weld_options *options, mr_welded *out, mr_error *err)
{
    if (!out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "output is NULL");
    memset(out, 0, sizeof *out);
    weld_in in = {positions, stride, vertex_count, NULL, NULL, NULL, indices, triangle_count};
    weld_out o;
    mr_status s = weld_run(&in, options, &o, &out->stats, err);
    if (s != MR_OK)
        return s;
    out->vertex_count = o.vertex_count;
    out->triangle_count = o.triangle_count;
    out->positions = o.positions;
    out->indices = o.indices;
    out->remap = o.remap;
    return MR_OK;
}

mr_status mr_mesh_weld(const mr_mesh *in, const mr_weld_options *options, mr_mesh *out,
                       uint32_t **remap, mr_weld_stats *stats, mr_error *err)
{
    if (remap)
        *remap = NULL;
    if (!in || !out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "mesh is NULL");
    mr_mesh_init(out);
    weld_in w = {in->positions, 0, in->vertex_count, in->normals, in->texcoords, in->colors,
                 in->indices, in->triangle_count};
    weld_out o;
    mr_weld_stats st;
    mr_status s = weld_run(&w, options, &o, &st, err);
    if (stats)
        *stats = st;
    if (s != MR_OK)
        return s;
    out->vertex_count = o.vertex_count;
    out->triangle_count = o.triangle_count;
    out->positions = o.positions;
    out->normals = o.normals;
    out->texcoords = o.texcoords;
    out->colors = o.colors;
    out->indices = o.indices;
    if (remap)
        *remap = o.remap;
    else
        free(o.remap);
    o.remap = NULL;
    return MR_OK;
}

/* ---- the epsilon finder -------------------------------------------------- */

/*
 * The finder's evaluations. Every radius it tries after the bracket is
 * below the bracket's top b, so the graph at b, with the squared distance
 * of every edge (computed as the graph builder computes it), holds the
 * graph of each of them: the edges whose distance passes the test at that
 * radius. A bisection step is then S-Weld's marking pass over that graph,
 * filtered, instead of a new neighbour search.
 */
typedef struct finder_graph {
    mr_radius_graph g;
    double *d2; /* per edge of g */
} finder_graph;

static void finder_graph_free(finder_graph *f)
{
    mr_radius_graph_free(&f->g);
    free(f->d2);
    f->d2 = NULL;
}

static mr_status finder_graph_build(finder_graph *f, const float *pos, size_t n, double eps,
                                    int strict, const double *box, int threads, mr_error *err)
{
    f->d2 = NULL;
    mr_status s = mr_radius_graph_build(&f->g, pos, n, eps, strict, box, threads, err);
    if (s != MR_OK)
        return s;
    const mr_radius_graph *g = &f->g;
    f->d2 = mr_alloc_array(g->edge_count, sizeof *f->d2);
    if (!f->d2) {
        mr_radius_graph_free(&f->g);
        return mr_fail_nomem(err, NULL, g->edge_count * sizeof *f->d2);
    }
#pragma omp parallel for schedule(dynamic, 4096) num_threads(threads) if (n > PARALLEL_MIN)
    for (size_t r = 0; r < n; r++) {
        const float *a = pos + 3 * r;
        for (size_t e = g->offsets[r]; e < g->offsets[r + 1]; e++) {
            const float *b = pos + 3 * (size_t)g->adj[e];
            double dx = (double)a[0] - (double)b[0];
            double dy = (double)a[1] - (double)b[1];
            double dz = (double)a[2] - (double)b[2];
            f->d2[e] = dx * dx + dy * dy + dz * dz;
        }
    }
    return MR_OK;
}

/* Clusters of a weld at eps (eps no more than the radius f was built
 * for): S-Weld's marking pass over the edges within eps. */
static size_t count_clusters(const finder_graph *f, double eps, int strict, uint8_t *clustered)
{
    const mr_radius_graph *g = &f->g;
    const double eps2 = eps * eps;
    memset(clustered, 0, g->n);
    size_t k = 0;
    for (size_t r = 0; r < g->n; r++) {
        if (clustered[r])
            continue;
        k++;
        for (size_t e = g->offsets[r]; e < g->offsets[r + 1]; e++)
            if (strict ? f->d2[e] < eps2 : f->d2[e] <= eps2)
                clustered[g->adj[e]] = 1;
    }
    return k;
}

/* Build at eps and count there; f keeps the graph. */
static mr_status build_and_count(finder_graph *f, const float *pos, size_t n, double eps,
                                 int strict, const double *box, int threads,
                                 uint8_t *clustered, size_t *clusters, mr_error *err)
{
    finder_graph_free(f);
    mr_status s = finder_graph_build(f, pos, n, eps, strict, box, threads, err);
    if (s == MR_OK)
        *clusters = count_clusters(f, eps, strict, clustered);
    return s;
}

mr_status mr_weld_find_eps(const float *positions, size_t stride, size_t vertex_count,
                           double fraction, const mr_weld_options *options, double *eps,
                           size_t *removed, mr_error *err)
{
    mr_weld_options defaults;
    if (!options) {
        mr_weld_options_default(&defaults);
        options = &defaults;
    }
    if (!eps)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "eps is NULL");
    if (!(fraction >= 0 && fraction < 1))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "the share of vertices to remove must be in [0, 1), got %g",
                             fraction);
    weld_in in = {positions, stride, vertex_count, NULL, NULL, NULL, NULL, 0};
    mr_status s = check_input(&in, err);
    if (s != MR_OK)
        return s;
    const size_t n = vertex_count;
    const int threads = mr_thread_count(options->threads);
    const float *pos;
    float *owned;
    /* a flat-array call without triangles: the finder welds in index
     * order */
    double box[6];
    if ((s = packed_positions(&in, NULL, threads, &pos, &owned, box, err)) != MR_OK)
        return s;
    uint8_t *mark = mr_alloc_array(n, 1);
    if (!mark) {
        free(owned);
        return mr_fail_nomem(err, NULL, n);
    }
    const size_t target = (size_t)ceil(fraction * (double)n);
    const double *lo = box, *hi = box + 3;
    size_t k = 0, best_removed = 0;
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    double a = 0, b;
    finder_graph f;
    memset(&f, 0, sizeof f);
    /* eps = 0 already enough (duplicates, or nothing to remove)? */
    if ((s = build_and_count(&f, pos, n, 0, options->strict, box, threads, mark, &k, err)) != MR_OK)
        goto done;
    if (n - k >= target) {
        *eps = 0;
        best_removed = n - k;
        goto done;
    }
    /* bracket: grow b from a small share of the diagonal until enough goes
     * (a neighbour search per step, at radii that double: the last one
     * costs about as much as all before it) */
    b = diag > 0 ? diag * 1e-5 : 1;
    for (;;) {
        if ((s = build_and_count(&f, pos, n, b, options->strict, box, threads, mark, &k,
                                 err)) !=
            MR_OK)
            goto done;
        if (n - k >= target || b > 2 * diag)
            break;
        a = b;
        b *= 2;
    }
    best_removed = n - k;
    /* bisect: a removes too few, b enough; every step filters the graph
     * built at b */
    for (int it = 0; it < 60 && b - a > 1e-6 * b; it++) {
        double m = 0.5 * (a + b);
        k = count_clusters(&f, m, options->strict, mark);
        if (n - k >= target) {
            b = m;
            best_removed = n - k;
        } else {
            a = m;
        }
    }
    *eps = b;
done:
    if (s == MR_OK && removed)
        *removed = best_removed;
    finder_graph_free(&f);
    free(mark);
    free(owned);
    return s;
}
