/*
 * Surface distances between two meshes (mr_compare) and the vertex
 * similarity of two reductions (mr_vertex_similarity).
 *
 * mr_compare, Metro-style. The points of a surface are its referenced
 * vertices (in index order) followed by `samples` area-uniform samples.
 * Sampling is stratified along the cumulative area: sample j takes the
 * area position (j + u) / samples * total_area with u uniform in [0, 1),
 * finds its triangle by binary search in the prefix sums of the triangle
 * areas, and a uniform point in that triangle (the square-root trick).
 * Each sample is still uniformly distributed over its stratum, so the set
 * is area-uniform, with less clumping than independent draws, and --
 * which matters for speed -- consecutive samples lie on the same or
 * neighbouring triangles, so the nearest triangle found for one is a tight
 * starting bound (the hint) for the next.
 *
 * The random numbers are a hash of (seed, sample index), not a sequential
 * generator, and the points are processed in fixed blocks of BLOCK
 * queries whose partial results (max, sum of squares, sum) are combined
 * in block order. Hints only carry within a block. So every figure is
 * bitwise the same for every thread count and schedule.
 *
 * Conventions: a mesh whose triangles all have zero area gets no samples
 * (only its vertices); the reference bounding box covers its referenced
 * vertices (those on the surface); a *_rel value is 0 when the diagonal
 * is 0. Referenced vertices must have finite coordinates.
 */
#include "reference.h"
#include "../mesh/adjacency.h"

#include <math.h>

#include "../core/omp_compat.h"

#define BLOCK 4096              /* queries per unit of work */
#define AREA_BLOCK 8192         /* triangles per block of the prefix sums */
#define DEFAULT_SAMPLES 1000000
#define DEFAULT_SEED 1

void mr_compare_options_default(mr_compare_options *options)
{
    if (!options)
        return;
    memset(options, 0, sizeof *options);
    options->samples = DEFAULT_SAMPLES;
    options->seed = DEFAULT_SEED;
    options->threads = 0;
}

/* ---- counter-based random numbers ------------------------------------------- */


/* The k-th uniform number in [0, 1) of item i in the stream `seed`. */
static inline double unit_random(uint64_t seed, uint64_t i, unsigned k)
{
    uint64_t h = mr_mix64(seed + 0x9e3779b97f4a7c15ull * (4 * i + k + 1));
    return (double)(h >> 11) * 0x1p-53;
}

/* ---- one surface ------------------------------------------------------------ */

typedef struct surface {
    const char *name; /* "reference mesh", "test mesh": for messages */
    const float *pos;
    size_t vertex_count;
    const uint32_t *idx;
    size_t triangle_count;
    uint32_t *verts;  /* referenced vertex ids, increasing */
    size_t vert_count;
    double *prefix;   /* triangle_count + 1 cumulative areas */
    double area;
    uint32_t last_positive; /* last triangle with a positive area */
    size_t samples;   /* 0 when the area is 0 */
    uint64_t seed;
    double diagonal;  /* of the referenced vertices' box */
} surface;

static void surface_free(surface *s)
{
    free(s->verts);
    free(s->prefix);
    s->verts = NULL;
    s->prefix = NULL;
}

static inline void load(const float *pos, uint32_t v, double p[3])
{
    p[0] = pos[3 * (size_t)v];
    p[1] = pos[3 * (size_t)v + 1];
    p[2] = pos[3 * (size_t)v + 2];
}

static mr_status check_surface(const surface *s, mr_error *err)
{
    if (s->vertex_count > 0 && !s->pos)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, s->name,
                             "positions are NULL for %zu vertices", s->vertex_count);
    if (s->triangle_count > 0 && !s->idx)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, s->name,
                             "indices are NULL for %zu triangles", s->triangle_count);
    if (s->triangle_count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, NULL,
                             "%s has no triangles: distances need a surface", s->name);
    mr_error e;
    mr_status st = mr_check_indices(s->idx, s->triangle_count, s->vertex_count, &e);
    if (st != MR_OK)
        return mr_fail_plain(err, st, s->name, "%s", e.message);
    return MR_OK;
}

/* The referenced vertices in increasing order; checks that they are
 * finite and measures their box. */
static mr_status collect_vertices(surface *s, mr_error *err)
{
    uint8_t *used = mr_calloc_array(s->vertex_count, 1);
    if (!used)
        return mr_fail_nomem(err, s->name, s->vertex_count);
    for (size_t c = 0; c < 3 * s->triangle_count; c++)
        used[s->idx[c]] = 1;
    size_t n = 0;
    for (size_t v = 0; v < s->vertex_count; v++)
        n += used[v];
    s->verts = mr_alloc_array(n, sizeof *s->verts);
    if (!s->verts) {
        free(used);
        return mr_fail_nomem(err, s->name, n * sizeof *s->verts);
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t k = 0;
    for (size_t v = 0; v < s->vertex_count; v++) {
        if (!used[v])
            continue;
        double p[3];
        load(s->pos, (uint32_t)v, p);
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
            free(used);
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, s->name,
                                 "vertex %zu has a non-finite coordinate", v);
        }
        for (int a = 0; a < 3; a++) {
            lo[a] = p[a] < lo[a] ? p[a] : lo[a];
            hi[a] = p[a] > hi[a] ? p[a] : hi[a];
        }
        s->verts[k++] = (uint32_t)v;
    }
    free(used);
    s->vert_count = n;
    double d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    s->diagonal = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    return MR_OK;
}

static double triangle_area(const float *pos, const uint32_t *tri)
{
    double a[3], b[3], c[3];
    load(pos, tri[0], a);
    load(pos, tri[1], b);
    load(pos, tri[2], c);
    return mr_triangle_area(a, b, c);
}

/* prefix[t] = area of the triangles before t. Each fixed block of
 * triangles gets a local running sum, the block totals are added in order
 * into offsets, and each prefix is offset + local sum. The last prefix of a
 * block is then exactly the next block's offset, so the array is
 * non-decreasing, and it has the same bits for every thread count. */
static mr_status area_prefix(surface *s, int nt, mr_error *err)
{
    const size_t tc = s->triangle_count, nb = (tc + AREA_BLOCK - 1) / AREA_BLOCK;
    s->prefix = mr_alloc_array(tc + 1, sizeof *s->prefix);
    double *offset = mr_alloc_array(nb + 1, sizeof *offset);
    if (!s->prefix || !offset) {
        free(offset);
        return mr_fail_nomem(err, s->name, (tc + nb + 2) * sizeof *offset);
    }
    double *prefix = s->prefix;
#pragma omp parallel for schedule(static) num_threads(nt) if (tc > 65536)
    for (size_t b = 0; b < nb; b++) {
        const size_t end = (b + 1) * AREA_BLOCK < tc ? (b + 1) * AREA_BLOCK : tc;
        double sum = 0;
        for (size_t t = b * AREA_BLOCK; t < end; t++) {
            sum += triangle_area(s->pos, s->idx + 3 * t);
            prefix[t + 1] = sum;
        }
        offset[b + 1] = sum;
    }
    offset[0] = 0;
    for (size_t b = 0; b < nb; b++)
        offset[b + 1] += offset[b];
#pragma omp parallel for schedule(static) num_threads(nt) if (tc > 65536)
    for (size_t b = 0; b < nb; b++) {
        const size_t end = (b + 1) * AREA_BLOCK < tc ? (b + 1) * AREA_BLOCK : tc;
        for (size_t t = b * AREA_BLOCK; t < end; t++)
            prefix[t + 1] = offset[b] + prefix[t + 1];
    }
    prefix[0] = 0;
    s->area = prefix[tc];
    free(offset);
    s->last_positive = 0;
    for (size_t t = tc; t-- > 0;)
        if (prefix[t + 1] > prefix[t]) {
            s->last_positive = (uint32_t)t;
            break;
        }
    return MR_OK;
}

/* The triangle holding area position `a`: prefix[t] <= a < prefix[t + 1]
 * (so never a zero-area triangle). */
static uint32_t find_triangle(const surface *s, double a)
{
    size_t lo = 0, hi = s->triangle_count + 1; /* first prefix > a lies in [lo, hi) */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (s->prefix[mid] > a)
            hi = mid;
        else
            lo = mid + 1;
    }
    if (lo == 0 || lo > s->triangle_count) /* rounding at the very ends */
        return lo == 0 ? 0 : s->last_positive;
    return (uint32_t)(lo - 1);
}

/* Point q of the surface: a vertex for q < vert_count, else a sample
 * (its triangle returned, its barycentric weights in w, which may be
 * NULL). */
static inline uint32_t surface_point_w(const surface *s, size_t q, double p[3], double w[3])
{
    if (q < s->vert_count) {
        load(s->pos, s->verts[q], p);
        return MR_NO_HINT;
    }
    const uint64_t j = q - s->vert_count;
    const double a = ((double)j + unit_random(s->seed, j, 0)) * (s->area / (double)s->samples);
    const uint32_t t = find_triangle(s, a);
    const uint32_t *tri = s->idx + 3 * (size_t)t;
    double va[3], vb[3], vc[3];
    load(s->pos, tri[0], va);
    load(s->pos, tri[1], vb);
    load(s->pos, tri[2], vc);
    const double r1 = sqrt(unit_random(s->seed, j, 1)), r2 = unit_random(s->seed, j, 2);
    const double wa = 1 - r1, wb = r1 * (1 - r2), wc = r1 * r2;
    for (int k = 0; k < 3; k++)
        p[k] = wa * va[k] + wb * vb[k] + wc * vc[k];
    if (w)
        w[0] = wa, w[1] = wb, w[2] = wc;
    return t;
}

static inline uint32_t surface_point(const surface *s, size_t q, double p[3])
{
    return surface_point_w(s, q, p, NULL);
}

/* ---- blocks of queries ------------------------------------------------------- */

typedef struct partial {
    double max, sum2, sum;
} partial;

/* Distances from points [begin, end) of `src` to the surface in `dst`. */
static partial surface_block(const surface *src, const mr_tri_bvh *dst, size_t begin,
                             size_t end)
{
    partial r = {0, 0, 0};
    uint32_t hint = MR_NO_HINT;
    for (size_t q = begin; q < end; q++) {
        double p[3];
        surface_point(src, q, p);
        const double d = sqrt(mr_tri_bvh_nearest(dst, p, hint, &hint, NULL));
        r.max = d > r.max ? d : r.max;
        r.sum2 += d * d;
        r.sum += d;
    }
    return r;
}

/* Distances from the reference's vertices [begin, end) to the nearest test
 * vertex (the modified Hausdorff distance). */
static partial vertex_block(const surface *src, const mr_point_bvh *dst, size_t begin,
                            size_t end)
{
    partial r = {0, 0, 0};
    uint32_t hint = MR_NO_HINT;
    for (size_t q = begin; q < end; q++) {
        double p[3];
        load(src->pos, src->verts[q], p);
        const double d2 = mr_point_bvh_nearest(dst, p, hint, &hint);
        const double d = sqrt(d2);
        r.max = d > r.max ? d : r.max;
        r.sum2 += d2;
        r.sum += d;
    }
    return r;
}

/* The three kinds of work, as one list of blocks so that the threads stay
 * busy to the end. */
enum { REF_TO_TEST, TEST_TO_REF, REF_VERTICES, KINDS };

typedef struct job {
    const surface *surf[2];
    const mr_tri_bvh *tree[2];
    const mr_point_bvh *points; /* over the test's referenced vertices */
    size_t count[KINDS];        /* queries of each kind */
    size_t blocks[KINDS + 1];   /* first block of each kind, then the total */
} job;

static partial run_block(const job *jb, size_t b)
{
    int kind = 0;
    while (b >= jb->blocks[kind + 1])
        kind++;
    const size_t begin = (b - jb->blocks[kind]) * BLOCK;
    const size_t end = begin + BLOCK < jb->count[kind] ? begin + BLOCK : jb->count[kind];
    if (kind == REF_VERTICES)
        return vertex_block(jb->surf[0], jb->points, begin, end);
    return surface_block(jb->surf[kind], jb->tree[1 - kind], begin, end);
}

/* Combine the block results of each kind in block order. */
static void combine(const job *jb, const partial *part, partial total[KINDS])
{
    for (int k = 0; k < KINDS; k++) {
        partial t = {0, 0, 0};
        for (size_t b = jb->blocks[k]; b < jb->blocks[k + 1]; b++) {
            t.max = part[b].max > t.max ? part[b].max : t.max;
            t.sum2 += part[b].sum2;
            t.sum += part[b].sum;
        }
        total[k] = t;
    }
}

static mr_status run_queries(job *jb, int nt, partial total[KINDS], mr_error *err)
{
    jb->count[REF_TO_TEST] = jb->surf[0]->vert_count + jb->surf[0]->samples;
    jb->count[TEST_TO_REF] = jb->surf[1]->vert_count + jb->surf[1]->samples;
    jb->count[REF_VERTICES] = jb->surf[0]->vert_count;
    jb->blocks[0] = 0;
    for (int k = 0; k < KINDS; k++)
        jb->blocks[k + 1] = jb->blocks[k] + (jb->count[k] + BLOCK - 1) / BLOCK;
    const size_t nb = jb->blocks[KINDS];
    partial *part = mr_alloc_array(nb, sizeof *part);
    if (!part)
        return mr_fail_nomem(err, NULL, nb * sizeof *part);
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
    for (size_t b = 0; b < nb; b++)
        part[b] = run_block(jb, b);
    combine(jb, part, total);
    free(part);
    return MR_OK;
}

/* ---- mr_compare -------------------------------------------------------------- */

static mr_status prepare(surface *s, int nt, mr_error *err)
{
    mr_status st = check_surface(s, err);
    if (st == MR_OK)
        st = collect_vertices(s, err);
    if (st == MR_OK)
        st = area_prefix(s, nt, err);
    if (st == MR_OK && s->area <= 0)
        s->samples = 0; /* nothing to sample: vertices only */
    return st;
}

static inline double relative(double v, double diagonal)
{
    return diagonal > 0 ? v / diagonal : 0;
}

static void fill_result(const surface *ref, const surface *test, const partial t[KINDS],
                        mr_compare_result *r)
{
    memset(r, 0, sizeof *r);
    const size_t n0 = ref->vert_count + ref->samples, n1 = test->vert_count + test->samples;
    r->ref_points = n0;
    r->test_points = n1;
    r->ref_to_test_max = t[REF_TO_TEST].max;
    r->test_to_ref_max = t[TEST_TO_REF].max;
    r->ref_to_test_rms = sqrt(t[REF_TO_TEST].sum2 / (double)n0);
    r->test_to_ref_rms = sqrt(t[TEST_TO_REF].sum2 / (double)n1);
    r->hausdorff = r->ref_to_test_max > r->test_to_ref_max ? r->ref_to_test_max
                                                           : r->test_to_ref_max;
    r->rms = sqrt((t[REF_TO_TEST].sum2 + t[TEST_TO_REF].sum2) / (double)(n0 + n1));
    r->mean = (t[REF_TO_TEST].sum + t[TEST_TO_REF].sum) / (double)(n0 + n1);
    r->modified_hausdorff = sqrt(t[REF_VERTICES].sum2 / (double)ref->vert_count);
    r->diagonal = ref->diagonal;
    r->hausdorff_rel = relative(r->hausdorff, r->diagonal);
    r->rms_rel = relative(r->rms, r->diagonal);
    r->mean_rel = relative(r->mean, r->diagonal);
    r->modified_hausdorff_rel = relative(r->modified_hausdorff, r->diagonal);
}

struct mr_reference {
    surface s;
    mr_tri_bvh tree;
    mr_compare_options options;
    int threads;
};

const mr_tri_bvh *mr_reference_hierarchy(const mr_reference *ref) { return &ref->tree; }

int mr_reference_threads(const mr_reference *ref) { return ref->threads; }

static void reference_surface(surface *s, const float *positions, size_t vertex_count,
                              const uint32_t *indices, size_t triangle_count,
                              const mr_compare_options *opt)
{
    *s = (surface){.name = "reference mesh", .pos = positions, .vertex_count = vertex_count,
                   .idx = indices, .triangle_count = triangle_count, .samples = opt->samples,
                   .seed = mr_mix64(opt->seed ^ 0x7265666572656e63ull)};
}

mr_status mr_reference_build(const float *positions, size_t vertex_count,
                             const uint32_t *indices, size_t triangle_count,
                             const mr_compare_options *options, mr_reference **out,
                             mr_error *err)
{
    if (!out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no output for the reference");
    *out = NULL;
    mr_reference *r = mr_calloc_array(1, sizeof *r);
    if (!r)
        return mr_fail_nomem(err, NULL, sizeof *r);
    mr_compare_options_default(&r->options);
    if (options)
        r->options = *options;
    r->threads = mr_thread_count(r->options.threads);
    reference_surface(&r->s, positions, vertex_count, indices, triangle_count, &r->options);
    mr_status st = prepare(&r->s, r->threads, err);
    if (st == MR_OK)
        st = mr_tri_bvh_build(&r->tree, r->s.pos, r->s.idx, r->s.triangle_count, r->threads,
                              err);
    if (st != MR_OK) {
        mr_reference_free(r);
        return st;
    }
    *out = r;
    return MR_OK;
}

void mr_reference_free(mr_reference *r)
{
    if (!r)
        return;
    mr_tri_bvh_free(&r->tree);
    surface_free(&r->s);
    free(r);
}

mr_status mr_compare_with(const mr_reference *ref, const float *test_positions,
                          size_t test_vertex_count, const uint32_t *test_indices,
                          size_t test_triangle_count, mr_compare_result *result, mr_error *err)
{
    if (!result || !ref)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "reference or result is NULL");
    memset(result, 0, sizeof *result);
    const int nt = ref->threads;
    surface test = {.name = "test mesh", .pos = test_positions,
                    .vertex_count = test_vertex_count, .idx = test_indices,
                    .triangle_count = test_triangle_count, .samples = ref->options.samples,
                    .seed = mr_mix64(ref->options.seed ^ 0x746573746d657368ull)};
    mr_tri_bvh tree;
    mr_point_bvh points;
    memset(&tree, 0, sizeof tree);
    memset(&points, 0, sizeof points);
    mr_status st = prepare(&test, nt, err);
    if (st == MR_OK)
        st = mr_tri_bvh_build(&tree, test.pos, test.idx, test.triangle_count, nt, err);
    if (st == MR_OK)
        st = mr_point_bvh_build(&points, test.pos, test.verts, test.vert_count, nt, err);
    partial total[KINDS];
    if (st == MR_OK) {
        job jb = {{&ref->s, &test}, {&ref->tree, &tree}, &points, {0}, {0}};
        st = run_queries(&jb, nt, total, err);
    }
    if (st == MR_OK)
        fill_result(&ref->s, &test, total, result);
    mr_point_bvh_free(&points);
    mr_tri_bvh_free(&tree);
    surface_free(&test);
    return st;
}

mr_status mr_compare(const float *ref_positions, size_t ref_vertex_count,
                     const uint32_t *ref_indices, size_t ref_triangle_count,
                     const float *test_positions, size_t test_vertex_count,
                     const uint32_t *test_indices, size_t test_triangle_count,
                     const mr_compare_options *options, mr_compare_result *result,
                     mr_error *err)
{
    if (!result)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "result is NULL");
    memset(result, 0, sizeof *result);
    mr_reference *ref;
    mr_status st = mr_reference_build(ref_positions, ref_vertex_count, ref_indices,
                                      ref_triangle_count, options, &ref, err);
    if (st != MR_OK)
        return st;
    st = mr_compare_with(ref, test_positions, test_vertex_count, test_indices,
                         test_triangle_count, result, err);
    mr_reference_free(ref);
    return st;
}

/* ---- vertex similarity ------------------------------------------------------- */

/*
 * b's vertices sorted by origin ((origin << 32) | index keys), then one
 * binary search per vertex of a. Conventions: an empty `a` is 1 when `b`
 * is empty too and 0 otherwise; NULL arrays with a non-zero count, and a
 * failed allocation, give NaN (the signature has no error channel).
 */
double mr_vertex_similarity(const float *a_positions, const uint32_t *a_origin,
                            size_t a_vertex_count, const float *b_positions,
                            const uint32_t *b_origin, size_t b_vertex_count)
{
    if ((a_vertex_count && (!a_positions || !a_origin)) ||
        (b_vertex_count && (!b_positions || !b_origin)) || b_vertex_count > UINT32_MAX)
        return NAN;
    if (a_vertex_count == 0)
        return b_vertex_count == 0 ? 1.0 : 0.0;
    uint64_t *keys = mr_alloc_array(b_vertex_count, sizeof *keys);
    if (!keys)
        return NAN;
    for (size_t i = 0; i < b_vertex_count; i++)
        keys[i] = ((uint64_t)b_origin[i] << 32) | i;
    if (mr_radix_sort_u64(keys, NULL, b_vertex_count, 64, 0, NULL) != MR_OK) {
        free(keys);
        return NAN;
    }
    size_t same = 0;
    const size_t nb = b_vertex_count;
#pragma omp parallel for schedule(static) reduction(+ : same) if (a_vertex_count > 65536)
    for (size_t i = 0; i < a_vertex_count; i++) {
        const uint64_t origin = a_origin[i];
        size_t lo = 0, hi = nb; /* first key with origin >= a's */
        while (lo < hi) {
            size_t mid = lo + (hi - lo) / 2;
            if (keys[mid] >> 32 < origin)
                lo = mid + 1;
            else
                hi = mid;
        }
        for (size_t k = lo; k < nb && keys[k] >> 32 == origin; k++) {
            const size_t j = (uint32_t)keys[k];
            if (memcmp(a_positions + 3 * i, b_positions + 3 * j, 3 * sizeof(float)) == 0) {
                same++;
                break;
            }
        }
    }
    free(keys);
    return (double)same / (double)a_vertex_count;
}

/* ---- attribute deviation ------------------------------------------------------ */

typedef struct attr_partial {
    double sum2[4], max[4]; /* normal, UV, colour; the texture deviation */
    size_t texture_points;
} attr_partial;

/*
 * A mesh's texture map as a grid over its UV box (about one cell a
 * triangle): each cell lists the triangles whose UV box meets it; a
 * triangle over more than UV_WIDE cells (a degenerate or wrapping map) is
 * listed once, in `wide`, and tried for every point.
 */
#define UV_WIDE 1024

typedef struct uv_grid {
    double lo[2], cell[2];
    size_t nx, ny;
    size_t *start;   /* nx * ny + 1 */
    uint32_t *tri;
    uint32_t *wide;
    size_t nwide;
} uv_grid;

static void uv_grid_free(uv_grid *g)
{
    free(g->start);
    free(g->tri);
    free(g->wide);
    memset(g, 0, sizeof *g);
}

/* The cells [c0, c1] in x and y of triangle t's UV box. */
static void uv_cells(const uv_grid *g, const mr_mesh *m, size_t t, size_t c[4])
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 2; k++) {
            const double u = m->texcoords[2 * (size_t)m->indices[3 * t + (size_t)j] + (size_t)k];
            lo[k] = u < lo[k] ? u : lo[k];
            hi[k] = u > hi[k] ? u : hi[k];
        }
    const size_t n[2] = {g->nx, g->ny};
    for (int k = 0; k < 2; k++) {
        double a = floor((lo[k] - g->lo[k]) / g->cell[k]), b = floor((hi[k] - g->lo[k]) / g->cell[k]);
        a = !(a >= 0) ? 0 : a > (double)(n[k] - 1) ? (double)(n[k] - 1) : a; /* NaN: 0 */
        b = !(b >= 0) ? 0 : b > (double)(n[k] - 1) ? (double)(n[k] - 1) : b;
        c[2 * k] = (size_t)a;
        c[2 * k + 1] = (size_t)b;
    }
}

static mr_status uv_grid_build(uv_grid *g, const mr_mesh *m, mr_error *err)
{
    memset(g, 0, sizeof *g);
    const size_t nt = m->triangle_count;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (size_t i = 0; i < 3 * nt; i++)
        for (int k = 0; k < 2; k++) {
            const double u = m->texcoords[2 * (size_t)m->indices[i] + (size_t)k];
            if (isfinite(u)) {
                lo[k] = u < lo[k] ? u : lo[k];
                hi[k] = u > hi[k] ? u : hi[k];
            }
        }
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1]))
        return MR_OK; /* no finite UV: no cell, nothing found */
    const double side = ceil(sqrt((double)nt));
    g->nx = g->ny = side < 1 ? 1 : side > 4096 ? 4096 : (size_t)side;
    for (int k = 0; k < 2; k++) {
        g->lo[k] = lo[k];
        const double ext = hi[k] - lo[k];
        g->cell[k] = (ext > 0 ? ext : 1) / (double)(k ? g->ny : g->nx) * (1 + 1e-9);
    }
    const size_t cells = g->nx * g->ny;
    g->start = mr_calloc_array(cells + 1, sizeof *g->start);
    if (!g->start)
        return mr_fail_nomem(err, NULL, cells * sizeof *g->start);
    size_t wide = 0;
    for (size_t t = 0; t < nt; t++) { /* count */
        size_t c[4];
        uv_cells(g, m, t, c);
        const size_t area = (c[1] - c[0] + 1) * (c[3] - c[2] + 1);
        if (area > UV_WIDE) {
            wide++;
            continue;
        }
        for (size_t y = c[2]; y <= c[3]; y++)
            for (size_t x = c[0]; x <= c[1]; x++)
                g->start[y * g->nx + x + 1]++;
    }
    for (size_t i = 0; i < cells; i++)
        g->start[i + 1] += g->start[i];
    g->tri = mr_alloc_array(g->start[cells] + 1, sizeof *g->tri);
    g->wide = mr_alloc_array(wide + 1, sizeof *g->wide);
    size_t *fill = mr_alloc_array(cells + 1, sizeof *fill);
    if (!g->tri || !g->wide || !fill) {
        free(fill);
        uv_grid_free(g);
        return mr_fail_nomem(err, NULL, g->start ? g->start[cells] * 4 : 0);
    }
    memcpy(fill, g->start, cells * sizeof *fill);
    for (size_t t = 0; t < nt; t++) { /* fill, in triangle order */
        size_t c[4];
        uv_cells(g, m, t, c);
        if ((c[1] - c[0] + 1) * (c[3] - c[2] + 1) > UV_WIDE) {
            g->wide[g->nwide++] = (uint32_t)t;
            continue;
        }
        for (size_t y = c[2]; y <= c[3]; y++)
            for (size_t x = c[0]; x <= c[1]; x++)
                g->tri[fill[y * g->nx + x]++] = (uint32_t)t;
    }
    free(fill);
    return MR_OK;
}

/* The position of m's triangle t at UV u, when u is inside t's UV
 * triangle (a small tolerance at its edges): true and the point in p. */
static bool uv_point(const mr_mesh *m, uint32_t t, const double u[2], double p[3])
{
    const uint32_t *tri = m->indices + 3 * (size_t)t;
    const float *a = m->texcoords + 2 * (size_t)tri[0], *b = m->texcoords + 2 * (size_t)tri[1],
                *c = m->texcoords + 2 * (size_t)tri[2];
    const double e1[2] = {(double)b[0] - a[0], (double)b[1] - a[1]},
                 e2[2] = {(double)c[0] - a[0], (double)c[1] - a[1]},
                 d[2] = {u[0] - a[0], u[1] - a[1]};
    const double det = e1[0] * e2[1] - e1[1] * e2[0];
    if (!(fabs(det) > 0))
        return false;
    const double wb = (d[0] * e2[1] - d[1] * e2[0]) / det, wc = (e1[0] * d[1] - e1[1] * d[0]) / det;
    const double tol = 1e-7;
    if (!(wb >= -tol && wc >= -tol && wb + wc <= 1 + tol))
        return false;
    double pa[3], pb[3], pc[3];
    load(m->positions, tri[0], pa);
    load(m->positions, tri[1], pb);
    load(m->positions, tri[2], pc);
    for (int k = 0; k < 3; k++)
        p[k] = (1 - wb - wc) * pa[k] + wb * pb[k] + wc * pc[k];
    return true;
}

/* The farthest an equal-UV point counts, in reference diagonals: beyond,
 * it is taken for another chart's (UVs that overlap: mirrored halves, the
 * two sides of a planar projection) and the point is not counted. */
#define TEXTURE_REACH 0.05

/* The texture deviation at a point x of one mesh whose UV is u: the
 * distance from x to the nearest point of the other mesh m (grid g) with
 * the same UV (several where charts overlap in UV) within `reach`; false
 * where none. */
static bool texture_deviation(const uv_grid *g, const mr_mesh *m, const double u[2],
                              const double x[3], double reach, double *dist)
{
    if (!g->start)
        return false;
    double best = reach * reach;
    const double fx = floor((u[0] - g->lo[0]) / g->cell[0]),
                 fy = floor((u[1] - g->lo[1]) / g->cell[1]);
    if (fx >= 0 && fy >= 0 && fx < (double)g->nx && fy < (double)g->ny) {
        const size_t cell = (size_t)fy * g->nx + (size_t)fx;
        for (size_t i = g->start[cell]; i < g->start[cell + 1]; i++) {
            double p[3];
            if (uv_point(m, g->tri[i], u, p)) {
                const double d2 = (p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) +
                                  (p[2] - x[2]) * (p[2] - x[2]);
                best = d2 < best ? d2 : best;
            }
        }
    }
    for (size_t i = 0; i < g->nwide; i++) {
        double p[3];
        if (uv_point(m, g->wide[i], u, p)) {
            const double d2 = (p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) +
                              (p[2] - x[2]) * (p[2] - x[2]);
            best = d2 < best ? d2 : best;
        }
    }
    if (!(best < reach * reach))
        return false;
    *dist = sqrt(best);
    return true;
}

/* The attributes of mesh m at weights w of triangle t (a vertex: t is
 * MR_NO_HINT and v the vertex). */
static void attributes_at(const mr_mesh *m, uint32_t t, uint32_t v, const double w[3],
                          double n[3], double uv[2], double c[4])
{
    uint32_t id[3] = {v, v, v};
    double ww[3] = {1, 0, 0};
    if (t != MR_NO_HINT) {
        memcpy(id, m->indices + 3 * (size_t)t, sizeof id);
        memcpy(ww, w, sizeof ww);
    }
    for (int k = 0; k < 4; k++) {
        if (k < 3)
            n[k] = 0;
        if (k < 2)
            uv[k] = 0;
        c[k] = 0;
    }
    for (int j = 0; j < 3; j++) {
        const size_t x = id[j];
        for (int k = 0; m->normals && k < 3; k++)
            n[k] += ww[j] * m->normals[3 * x + (size_t)k];
        for (int k = 0; m->texcoords && k < 2; k++)
            uv[k] += ww[j] * m->texcoords[2 * x + (size_t)k];
        for (int k = 0; m->colors && k < 4; k++)
            c[k] += ww[j] * m->colors[4 * x + (size_t)k];
    }
}

/* Barycentric weights of point p (on triangle t of m, or nearly). */
static void weights_of(const mr_mesh *m, uint32_t t, const double p[3], double w[3])
{
    double a[3], b[3], c[3];
    load(m->positions, m->indices[3 * (size_t)t], a);
    load(m->positions, m->indices[3 * (size_t)t + 1], b);
    load(m->positions, m->indices[3 * (size_t)t + 2], c);
    double wb = 0, wc = 0;
    mr_edge_coords(a, b, c, p, 0, &wb, &wc);
    wb = wb < 0 ? 0 : wb > 1 ? 1 : wb;
    wc = wc < 0 ? 0 : wc > 1 - wb ? 1 - wb : wc;
    w[0] = 1 - wb - wc, w[1] = wb, w[2] = wc;
}

typedef struct attr_job {
    const surface *surf[2];
    const mr_mesh *mesh[2];
    const mr_tri_bvh *tree[2];
    const uv_grid *uv[2]; /* with texture coordinates */
    size_t count[2], blocks[3];
} attr_job;

static attr_partial attr_block(const attr_job *jb, size_t b)
{
    const int kind = b >= jb->blocks[1];
    const surface *src = jb->surf[kind];
    const mr_mesh *sm = jb->mesh[kind], *dm = jb->mesh[1 - kind];
    /* the area samples (a vertex on a seam has two sides' values; a
     * sample is inside a triangle), or the vertices where there are none */
    const size_t skip = src->samples ? src->vert_count : 0;
    const size_t begin = skip + (b - jb->blocks[kind]) * BLOCK;
    const size_t end =
        begin + BLOCK < skip + jb->count[kind] ? begin + BLOCK : skip + jb->count[kind];
    attr_partial r;
    memset(&r, 0, sizeof r);
    uint32_t hint = MR_NO_HINT;
    for (size_t q = begin; q < end; q++) {
        double p[3], w[3], closest[3], dw[3];
        const uint32_t t = surface_point_w(src, q, p, w);
        uint32_t near = MR_NO_HINT;
        mr_tri_bvh_nearest(jb->tree[1 - kind], p, hint, &near, closest);
        hint = near;
        weights_of(dm, near, closest, dw);
        double n0[3], u0[2], c0[4], n1[3], u1[2], c1[4];
        attributes_at(sm, t, q < src->vert_count ? src->verts[q] : 0, w, n0, u0, c0);
        attributes_at(dm, near, 0, dw, n1, u1, c1);
        double e[3] = {0, 0, 0};
        const double l0 = sqrt(n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]),
                     l1 = sqrt(n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]);
        if (l0 > 0 && l1 > 0) {
            double d = (n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2]) / (l0 * l1);
            d = d > 1 ? 1 : d < -1 ? -1 : d;
            e[0] = acos(d) * (180.0 / 3.14159265358979323846);
        }
        e[1] = sqrt((u0[0] - u1[0]) * (u0[0] - u1[0]) + (u0[1] - u1[1]) * (u0[1] - u1[1]));
        double c2 = 0;
        for (int k = 0; k < 4; k++)
            c2 += (c0[k] - c1[k]) * (c0[k] - c1[k]);
        e[2] = sqrt(c2);
        for (int k = 0; k < 3; k++) {
            r.sum2[k] += e[k] * e[k];
            r.max[k] = e[k] > r.max[k] ? e[k] : r.max[k];
        }
        double td;
        if (jb->uv[1 - kind] &&
            texture_deviation(jb->uv[1 - kind], dm, u0, p, TEXTURE_REACH * jb->surf[0]->diagonal,
                              &td)) {
            r.sum2[3] += td * td;
            r.max[3] = td > r.max[3] ? td : r.max[3];
            r.texture_points++;
        }
    }
    return r;
}

mr_status mr_compare_attributes(const mr_mesh *ref, const mr_mesh *test,
                                const mr_compare_options *options, mr_attribute_error *out,
                                mr_error *err)
{
    if (!ref || !test || !out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "mesh or result is NULL");
    memset(out, 0, sizeof *out);
    mr_compare_options opt;
    mr_compare_options_default(&opt);
    if (options)
        opt = *options;
    const int nt = mr_thread_count(opt.threads);
    out->attributes = mr_mesh_attributes(ref) & mr_mesh_attributes(test) & MR_ATTR_BASIC;
    /* the same points as mr_compare's */
    surface s0, s1 = {.name = "test mesh", .pos = test->positions,
                      .vertex_count = test->vertex_count, .idx = test->indices,
                      .triangle_count = test->triangle_count, .samples = opt.samples,
                      .seed = mr_mix64(opt.seed ^ 0x746573746d657368ull)};
    reference_surface(&s0, ref->positions, ref->vertex_count, ref->indices, ref->triangle_count,
                      &opt);
    mr_tri_bvh t0, t1;
    memset(&t0, 0, sizeof t0);
    memset(&t1, 0, sizeof t1);
    mr_status st = prepare(&s0, nt, err);
    if (st == MR_OK)
        st = prepare(&s1, nt, err);
    if (st == MR_OK && out->attributes) {
        st = mr_tri_bvh_build(&t0, s0.pos, s0.idx, s0.triangle_count, nt, err);
        if (st == MR_OK)
            st = mr_tri_bvh_build(&t1, s1.pos, s1.idx, s1.triangle_count, nt, err);
    }
    uv_grid g0, g1;
    memset(&g0, 0, sizeof g0);
    memset(&g1, 0, sizeof g1);
    const bool uv = (out->attributes & MR_ATTR_TEXCOORDS) != 0;
    if (st == MR_OK && uv)
        st = uv_grid_build(&g0, ref, err);
    if (st == MR_OK && uv)
        st = uv_grid_build(&g1, test, err);
    if (st == MR_OK && out->attributes) {
        attr_job jb = {{&s0, &s1}, {ref, test}, {&t0, &t1}, {uv ? &g0 : NULL, uv ? &g1 : NULL},
                       {0, 0}, {0, 0, 0}};
        jb.count[0] = s0.samples ? s0.samples : s0.vert_count;
        jb.count[1] = s1.samples ? s1.samples : s1.vert_count;
        jb.blocks[1] = (jb.count[0] + BLOCK - 1) / BLOCK;
        jb.blocks[2] = jb.blocks[1] + (jb.count[1] + BLOCK - 1) / BLOCK;
        const size_t nb = jb.blocks[2];
        attr_partial *part = mr_alloc_array(nb + 1, sizeof *part);
        if (!part) {
            st = mr_fail_nomem(err, NULL, nb * sizeof *part);
        } else {
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
            for (size_t b = 0; b < nb; b++)
                part[b] = attr_block(&jb, b);
            attr_partial total;
            memset(&total, 0, sizeof total);
            for (size_t b = 0; b < nb; b++) { /* in block order: the same sums on any threads */
                for (int k = 0; k < 4; k++) {
                    total.sum2[k] += part[b].sum2[k];
                    total.max[k] = part[b].max[k] > total.max[k] ? part[b].max[k] : total.max[k];
                }
                total.texture_points += part[b].texture_points;
            }
            free(part);
            const double n = (double)(jb.count[0] + jb.count[1]);
            out->points = jb.count[0] + jb.count[1];
            if (out->attributes & MR_ATTR_NORMALS)
                out->normal_rms = sqrt(total.sum2[0] / n), out->normal_max = total.max[0];
            if (out->attributes & MR_ATTR_TEXCOORDS) {
                out->texcoord_rms = sqrt(total.sum2[1] / n), out->texcoord_max = total.max[1];
                out->texture_points = total.texture_points;
                if (total.texture_points) {
                    out->texture_rms = sqrt(total.sum2[3] / (double)total.texture_points);
                    out->texture_max = total.max[3];
                    const double d = s0.diagonal > 0 ? s0.diagonal : 1;
                    out->texture_rms_rel = out->texture_rms / d;
                    out->texture_max_rel = out->texture_max / d;
                }
            }
            if (out->attributes & MR_ATTR_COLORS)
                out->color_rms = sqrt(total.sum2[2] / n), out->color_max = total.max[2];
        }
    }
    uv_grid_free(&g0);
    uv_grid_free(&g1);
    mr_tri_bvh_free(&t0);
    mr_tri_bvh_free(&t1);
    surface_free(&s0);
    surface_free(&s1);
    return st;
}
