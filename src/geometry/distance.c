/*
 * Point-to-triangle distance and the bounding-volume hierarchies of
 * distance.h.
 *
 * Build: top-down over an array of primitive records. Each node computes
 * the box of its primitives (their centroid bounds come from the parent's
 * partition pass), then picks the
 * cheapest of the split planes between BINS bins along the axis of the
 * largest centroid extent by the surface-area heuristic, and partitions
 * the primitive records in place. While building, a subtree over k
 * primitives owns 2k - 1 node slots (enough for any binary tree with k
 * leaves): the root takes the first, the left subtree the next 2 kl - 1,
 * the right one the rest. So every node's slot follows from the primitive
 * ranges alone, subtrees can be built as independent OpenMP tasks without
 * any shared counter, and the result is the same for every thread count.
 * A final pass lays the used slots out in a compact array, the two
 * children of a node side by side in one cache line.
 *
 * Slivers: an axis-aligned box bounds a long thin triangle badly unless it
 * lies along an axis, and a fan of N slivers around one vertex (a polygon
 * face of N corners, fan-triangulated) puts a point of the surface inside
 * a fixed share of all N boxes, so every query tested O(N) triangles and
 * mr_compare took O(N^2). Such triangles go to a second tree whose nodes
 * are boxes oriented along their own triangles (see "the tree of oriented
 * boxes" below); queries search both trees. A mesh without many slivers
 * builds the box tree alone, exactly as before.
 */
#include "distance.h"

#include <float.h>
#include <math.h>

#include "../core/omp_compat.h"

#define BINS 16
#define MAX_LEAF 4           /* primitives per leaf at most */
#define MIN_LEAF 2           /* ranges this small always become leaves */
#define TRAVERSAL_COST 1.0   /* of a node visit, relative to one primitive test */
#define TASK_MIN 8192        /* subtrees smaller than this are built in one task */
#define SAH_MAX_DEPTH 64     /* below this depth, median splits keep the depth bounded */
#define STACK_SIZE 128       /* > SAH_MAX_DEPTH + 32 median levels + slack */
#define DEGENERATE_SIN2 1e-20 /* sin^2 of the angle at a below which a triangle is a sliver */
#define NEEDLE_SIN2 1e-6      /* ... below which the face region projects onto the plane */

/* The search loop is shared by the triangle and point queries; inlined,
 * the primitive test is a direct call the compiler can inline too. */
#if defined(__GNUC__)
#define MR_ALWAYS_INLINE __attribute__((always_inline))
#else
#define MR_ALWAYS_INLINE
#endif

/* ---- small vector helpers --------------------------------------------------- */

static inline double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void sub3(double r[3], const double a[3], const double b[3])
{
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

/* r = a + s * u */
static inline void axpy3(double r[3], const double a[3], double s, const double u[3])
{
    r[0] = a[0] + s * u[0];
    r[1] = a[1] + s * u[1];
    r[2] = a[2] + s * u[2];
}

static inline double dist2(const double a[3], const double b[3])
{
    double d[3];
    sub3(d, a, b);
    return dot3(d, d);
}

/* num / den clamped to [0, 1]; 0 when den is not positive. The region tests
 * guarantee a positive denominator in exact arithmetic; this keeps rounding
 * from ever producing NaN or a point off the edge. */
static inline double ratio(double num, double den)
{
    if (!(den > 0))
        return 0;
    double r = num / den;
    return r < 0 ? 0 : r > 1 ? 1 : r;
}

/* ---- point to segment and triangle ----------------------------------------- */

double mr_point_segment_dist2(const double p[3], const double a[3], const double b[3],
                              double closest[3])
{
    double ab[3], ap[3], q[3];
    sub3(ab, b, a);
    sub3(ap, p, a);
    axpy3(q, a, ratio(dot3(ap, ab), dot3(ab, ab)), ab);
    if (closest)
        memcpy(closest, q, sizeof q);
    return dist2(p, q);
}

/* A sliver: the nearest point of its three edges. */
static double degenerate_dist2(const double p[3], const double a[3], const double b[3],
                               const double c[3], double closest[3])
{
    double q[3], qb[3];
    double best = mr_point_segment_dist2(p, a, b, q);
    double d = mr_point_segment_dist2(p, b, c, qb);
    if (d < best) {
        best = d;
        memcpy(q, qb, sizeof q);
    }
    d = mr_point_segment_dist2(p, c, a, qb);
    if (d < best) {
        best = d;
        memcpy(q, qb, sizeof q);
    }
    if (closest)
        memcpy(closest, q, sizeof q);
    return best;
}

static inline double finish(const double p[3], const double q[3], double closest[3])
{
    if (closest)
        memcpy(closest, q, 3 * sizeof *q);
    return dist2(p, q);
}

/* The face region of a triangle with a small angle at a: the projection
 * of p onto the plane (see mr_point_triangle_dist2). Out of line: the
 * common path keeps its registers. */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static double needle_dist2(const double p[3], const double a[3], const double ab[3],
                           const double ac[3], double closest[3])
{
    const double n[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                         ab[0] * ac[1] - ab[1] * ac[0]};
    double ap[3], q[3];
    sub3(ap, p, a);
    axpy3(q, p, -(dot3(ap, n) / dot3(n, n)), n);
    return finish(p, q, closest);
}

double mr_point_triangle_dist2(const double p[3], const double a[3], const double b[3],
                               const double c[3], double closest[3])
{
    double ab[3], ac[3], ap[3], bp[3], cp[3], q[3];
    sub3(ab, b, a);
    sub3(ac, c, a);
    /* |ab x ac|^2 = |ab|^2 |ac|^2 sin^2: tiny means the face region below
     * would divide by (almost) zero. */
    double n[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                   ab[0] * ac[1] - ab[1] * ac[0]};
    if (dot3(n, n) <= DEGENERATE_SIN2 * dot3(ab, ab) * dot3(ac, ac))
        return degenerate_dist2(p, a, b, c, closest);

    sub3(ap, p, a);
    double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
    if (d1 <= 0 && d2 <= 0) /* vertex region a */
        return finish(p, a, closest);

    sub3(bp, p, b);
    double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    if (d3 >= 0 && d4 <= d3) /* vertex region b */
        return finish(p, b, closest);

    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) { /* edge region ab */
        axpy3(q, a, ratio(d1, d1 - d3), ab);
        return finish(p, q, closest);
    }

    sub3(cp, p, c);
    double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    if (d6 >= 0 && d5 <= d6) /* vertex region c */
        return finish(p, c, closest);

    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) { /* edge region ac */
        axpy3(q, a, ratio(d2, d2 - d6), ac);
        return finish(p, q, closest);
    }

    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) { /* edge region bc */
        double bc[3];
        sub3(bc, c, b);
        axpy3(q, b, ratio(d4 - d3, (d4 - d3) + (d5 - d6)), bc);
        return finish(p, q, closest);
    }

    double denom = va + vb + vc; /* = |ab x ac|^2 in exact arithmetic */
    if (!(denom > 0))
        return degenerate_dist2(p, a, b, c, closest);
    /* A small angle at a (a needle there, or a cap): va, vb, vc are then
     * differences of products 1 / sin^2 times their own size, so the
     * barycentric point below would be off by up to 1e-16 / sin^2 of the
     * triangle's size (2e-7 away from a point on a needle at sin 3e-5); the
     * projection onto the plane is off by rounding only. (A needle at b or
     * c costs the formula below only 1e-16 / sin.) The test reads |ab|^2
     * = d1 - d3 and |ac|^2 = d2 - d6 off the dot products above. */
    if (denom < NEEDLE_SIN2 * (d1 - d3) * (d2 - d6))
        return needle_dist2(p, a, ab, ac, closest);
    double v = vb / denom, w = vc / denom;
    q[0] = a[0] + ab[0] * v + ac[0] * w;
    q[1] = a[1] + ab[1] * v + ac[1] * w;
    q[2] = a[2] + ab[2] * v + ac[2] * w;
    return finish(p, q, closest);
}

/* ---- building --------------------------------------------------------------- */

/* A primitive while building: its box, the box centre (the point that is
 * binned) and its id. The records themselves are partitioned, so every
 * pass over a node's range reads memory in order. */
typedef struct prim {
    float lo[3], hi[3], c[3];
    uint32_t id;
} prim;

typedef struct build_ctx {
    prim *prims;
    mr_bvh_node *slots; /* 2 * count - 1, sparse */
} build_ctx;

typedef struct bin {
    float lo[3], hi[3];
    uint32_t count;
} bin;

static inline void box_empty(float lo[3], float hi[3])
{
    for (int k = 0; k < 3; k++) {
        lo[k] = FLT_MAX;
        hi[k] = -FLT_MAX;
    }
}

static inline void box_grow(float lo[3], float hi[3], const float *plo, const float *phi)
{
    for (int k = 0; k < 3; k++) {
        lo[k] = plo[k] < lo[k] ? plo[k] : lo[k];
        hi[k] = phi[k] > hi[k] ? phi[k] : hi[k];
    }
}

/* Half the surface area: the SAH's relative hit probability. */
static inline double half_area(const float lo[3], const float hi[3])
{
    double dx = (double)hi[0] - lo[0], dy = (double)hi[1] - lo[1], dz = (double)hi[2] - lo[2];
    if (!(dx >= 0 && dy >= 0 && dz >= 0))
        return 0; /* empty box */
    return dx * dy + dy * dz + dz * dx;
}

/* Centroid bounds and the binning transform of a node. */
typedef struct frame {
    float cmin[3], cmax[3];
    float scale[3]; /* bins per unit; 0 on an axis without extent */
    int bins;       /* fewer for small nodes, whose cost is in the sweeps */
} frame;

static void frame_init(frame *f)
{
    box_empty(f->cmin, f->cmax);
}

static void frame_finish(frame *f, size_t count)
{
    f->bins = count >= 4 * BINS ? BINS : count >= BINS ? BINS / 2 : BINS / 4;
    for (int k = 0; k < 3; k++) {
        float extent = f->cmax[k] - f->cmin[k];
        /* Slightly under bins / extent so that the largest centroid lands in
         * the last bin, not one past it; 0 when the axis cannot be split. */
        float scale = extent > 0 ? (float)f->bins * 0.999999f / extent : 0;
        f->scale[k] = isfinite(scale) ? scale : 0;
    }
}

static inline int bin_of(const frame *f, const prim *p, int axis)
{
    int b = (int)((p->c[axis] - f->cmin[axis]) * f->scale[axis]);
    return b < 0 ? 0 : b >= f->bins ? f->bins - 1 : b;
}

typedef struct split {
    int axis, bin; /* left: bins < bin; axis -1: none found */
    double cost;
} split;

/* One pass: the node's box and the bins along `axis`. */
static void fill_bins(const build_ctx *bc, size_t first, size_t count, const frame *f,
                      int axis, bin bins[BINS], mr_bvh_node *node)
{
    for (int b = 0; b < f->bins; b++) {
        box_empty(bins[b].lo, bins[b].hi);
        bins[b].count = 0;
    }
    box_empty(node->lo, node->hi);
    for (size_t i = first; i < first + count; i++) {
        const prim *p = &bc->prims[i];
        box_grow(node->lo, node->hi, p->lo, p->hi);
        bin *b = &bins[bin_of(f, p, axis)];
        box_grow(b->lo, b->hi, p->lo, p->hi);
        b->count++;
    }
}

/* The axis of the largest centroid extent (binning only that one costs a
 * third of binning all three, for trees nearly as good), -1 if none. */
static int split_axis(const frame *f)
{
    int axis = -1;
    float best = 0;
    for (int k = 0; k < 3; k++)
        if (f->scale[k] > 0 && f->cmax[k] - f->cmin[k] > best) {
            best = f->cmax[k] - f->cmin[k];
            axis = k;
        }
    return axis;
}

/* The cheapest of the nb - 1 planes of one axis. */
static void sweep_axis(const bin *bins, int nb, int axis, double parent_area, split *best)
{
    double right_area[BINS];
    uint32_t right_count[BINS];
    float lo[3], hi[3];
    box_empty(lo, hi);
    uint32_t n = 0;
    for (int b = nb - 1; b > 0; b--) {
        box_grow(lo, hi, bins[b].lo, bins[b].hi);
        n += bins[b].count;
        right_area[b] = half_area(lo, hi);
        right_count[b] = n;
    }
    box_empty(lo, hi);
    n = 0;
    for (int b = 1; b < nb; b++) {
        box_grow(lo, hi, bins[b - 1].lo, bins[b - 1].hi);
        n += bins[b - 1].count;
        if (n == 0 || right_count[b] == 0)
            continue;
        double cost = TRAVERSAL_COST +
                      (half_area(lo, hi) * n + right_area[b] * right_count[b]) / parent_area;
        if (cost < best->cost) {
            best->axis = axis;
            best->bin = b;
            best->cost = cost;
        }
    }
}

/* Move the primitives left of the split to the front, and measure the
 * centroid bounds of both sides on the way. Returns the left count. */
static size_t partition_range(build_ctx *bc, size_t first, size_t count, const frame *f, split s,
                        frame *left, frame *right)
{
    prim *p = bc->prims;
    size_t i = first, j = first + count;
    frame_init(left);
    frame_init(right);
    while (i < j) {
        if (bin_of(f, &p[i], s.axis) < s.bin) {
            box_grow(left->cmin, left->cmax, p[i].c, p[i].c);
            i++;
        } else {
            j--;
            box_grow(right->cmin, right->cmax, p[i].c, p[i].c);
            prim t = p[i];
            p[i] = p[j];
            p[j] = t;
        }
    }
    frame_finish(left, i - first);
    frame_finish(right, first + count - i);
    return i - first;
}

static void range_frame(const build_ctx *bc, size_t first, size_t count, frame *f)
{
    frame_init(f);
    for (size_t i = first; i < first + count; i++)
        box_grow(f->cmin, f->cmax, bc->prims[i].c, bc->prims[i].c);
    frame_finish(f, count);
}

static void make_leaf(const build_ctx *bc, mr_bvh_node *node, size_t first, size_t count)
{
    box_empty(node->lo, node->hi);
    for (size_t i = first; i < first + count; i++)
        box_grow(node->lo, node->hi, bc->prims[i].lo, bc->prims[i].hi);
    node->a = (uint32_t)first;
    node->b = (uint32_t)count | MR_BVH_LEAF;
}

/* Split [first, first + count) for the node at `slot` (whose box it sets);
 * returns the left count, 0 for a leaf. */
static size_t split_node(build_ctx *bc, mr_bvh_node *node, size_t first, size_t count,
                         int depth, const frame *f, frame *left, frame *right)
{
    if (count <= MIN_LEAF) {
        make_leaf(bc, node, first, count);
        return 0;
    }
    const int axis = split_axis(f);
    if (depth < SAH_MAX_DEPTH && axis >= 0) {
        bin bins[BINS];
        fill_bins(bc, first, count, f, axis, bins, node);
        const double area = half_area(node->lo, node->hi);
        split s = {-1, 0, INFINITY};
        sweep_axis(bins, f->bins, axis, area > 0 ? area : 1, &s);
        if (count > MAX_LEAF || s.cost < (double)count)
            return partition_range(bc, first, count, f, s, left, right);
    }
    if (count <= MAX_LEAF) {
        make_leaf(bc, node, first, count);
        return 0;
    }
    /* Too deep or all centres equal: halve by position, which bounds the
     * depth whatever the geometry. */
    make_leaf(bc, node, first, count); /* for the box */
    const size_t nl = count / 2;
    range_frame(bc, first, nl, left);
    range_frame(bc, first + nl, count - nl, right);
    return nl;
}

static void build_node(build_ctx *bc, size_t slot, size_t first, size_t count, int depth,
                       const frame *f)
{
    mr_bvh_node *node = &bc->slots[slot];
    frame left, right;
    const size_t nl = split_node(bc, node, first, count, depth, f, &left, &right);
    if (nl == 0)
        return;
    const size_t lslot = slot + 1, rslot = slot + 2 * nl;
    node->a = (uint32_t)lslot;
    node->b = (uint32_t)rslot;
    if (count >= TASK_MIN) {
#pragma omp task default(shared) firstprivate(bc, lslot, first, nl, depth, left)
        build_node(bc, lslot, first, nl, depth + 1, &left);
    } else {
        build_node(bc, lslot, first, nl, depth + 1, &left);
    }
    build_node(bc, rslot, first + nl, count - nl, depth + 1, &right);
}

/* Renumbering of the used slots: map[slot] = new index. The two children
 * of a node get consecutive indices 2k, 2k + 1, so with 32-byte nodes in a
 * 64-byte aligned array a query reads both children's boxes from one cache
 * line; pairs are handed out depth-first, so a subtree stays together.
 * Index 1 is padding. Returns the node count. The stack holds at most one
 * pending right child per level. */
static size_t number_nodes(const mr_bvh_node *slots, uint32_t *map)
{
    uint32_t stack[STACK_SIZE];
    size_t top = 0, next = 2;
    map[0] = 0;
    stack[top++] = 0;
    while (top > 0) {
        uint32_t s = stack[--top];
        if (slots[s].b & MR_BVH_LEAF)
            continue;
        map[slots[s].a] = (uint32_t)next;
        map[slots[s].b] = (uint32_t)next + 1;
        next += 2;
        stack[top++] = slots[s].b;
        stack[top++] = slots[s].a;
    }
    return next;
}

/* Lays the used slots out compactly (see number_nodes). `slot_axes`, when
 * not NULL, holds 9 doubles per slot (the thin tree's node frames), which
 * move with their nodes into *axes. */
static mr_status compact(mr_bvh *bvh, const mr_bvh_node *slots, size_t nslots,
                         const double *slot_axes, double **axes, mr_error *err)
{
    uint32_t *map = mr_alloc_array(nslots, sizeof *map);
    if (!map)
        return mr_fail_nomem(err, NULL, nslots * sizeof *map);
    const size_t n = number_nodes(slots, map);
    /* n < 2^32 nodes of 32 bytes: no overflow; a multiple of 64 bytes as
     * aligned_alloc wants. */
    const size_t bytes = (n * sizeof *bvh->nodes + 63) / 64 * 64;
    bvh->nodes = aligned_alloc(64, bytes);
    if (slot_axes)
        *axes = mr_calloc_array(9 * n, sizeof **axes);
    if (!bvh->nodes || (slot_axes && !*axes)) {
        free(map);
        return mr_fail_nomem(err, NULL, bytes + (slot_axes ? 72 * n : 0));
    }
    memset(&bvh->nodes[1], 0, sizeof *bvh->nodes);
    bvh->node_count = n;
    uint32_t stack[STACK_SIZE];
    size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
        uint32_t s = stack[--top];
        mr_bvh_node node = slots[s];
        if (!(node.b & MR_BVH_LEAF)) {
            stack[top++] = node.b;
            stack[top++] = node.a;
            node.a = map[node.a];
            node.b = map[node.b];
        }
        bvh->nodes[map[s]] = node;
        if (slot_axes)
            memcpy(*axes + 9 * (size_t)map[s], slot_axes + 9 * (size_t)s, 9 * sizeof **axes);
    }
    free(map);
    return MR_OK;
}

void mr_bvh_free(mr_bvh *bvh)
{
    if (!bvh)
        return;
    free(bvh->nodes);
    free(bvh->order);
    memset(bvh, 0, sizeof *bvh);
}

mr_status mr_bvh_build(mr_bvh *bvh, const float *lo, const float *hi, size_t count,
                       int threads, mr_error *err)
{
    memset(bvh, 0, sizeof *bvh);
    if (count == 0 || count >= MR_BVH_LEAF)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "cannot build a hierarchy over %zu primitives", count);
    const size_t nslots = 2 * count - 1;
    build_ctx bc;
    bc.prims = mr_alloc_array(count, sizeof *bc.prims);
    bc.slots = mr_alloc_array(nslots, sizeof *bc.slots);
    bvh->order = mr_alloc_array(count, sizeof *bvh->order);
    mr_status st = MR_OK;
    if (!bc.prims || !bc.slots || !bvh->order) {
        st = mr_fail_nomem(err, NULL, count * sizeof *bc.prims + nslots * sizeof *bc.slots);
        goto done;
    }
    const int nt = mr_thread_count(threads);
#pragma omp parallel for schedule(static) num_threads(nt) if (count > TASK_MIN)
    for (size_t i = 0; i < count; i++) {
        prim *p = &bc.prims[i];
        for (int k = 0; k < 3; k++) {
            p->lo[k] = lo[3 * i + k];
            p->hi[k] = hi[3 * i + k];
            p->c[k] = 0.5f * p->lo[k] + 0.5f * p->hi[k];
        }
        p->id = (uint32_t)i;
    }
    frame root;
    range_frame(&bc, 0, count, &root);
#pragma omp parallel num_threads(nt) if (count >= TASK_MIN && nt > 1)
#pragma omp single
    build_node(&bc, 0, 0, count, 0, &root);

    if ((st = compact(bvh, bc.slots, nslots, NULL, NULL, err)) != MR_OK)
        goto done;
    for (size_t i = 0; i < count; i++)
        bvh->order[i] = bc.prims[i].id;
    bvh->prim_count = count;
done:
    free(bc.prims);
    free(bc.slots);
    if (st != MR_OK)
        mr_bvh_free(bvh);
    return st;
}

/* ---- the tree of oriented boxes over thin triangles ------------------------ */

/*
 * Built like the box tree above (the same slot scheme, tasks, depth rule
 * and compaction), but every node first fits its own frame to its
 * triangles: the principal axes of their corners (the eigenvectors of the
 * corners' covariance, by Jacobi rotations). Its bounds are the slabs of
 * its corners' projections on those axes, and the split is the binned
 * surface-area heuristic over the triangles' boxes in that frame, along
 * all three axes. A bundle of slivers gets a frame along them and a box as
 * thin as the bundle, whatever its direction.
 */

typedef struct thin_prim {
    float v[9];  /* corners */
    uint32_t id;
} thin_prim;

/* A triangle in its node's frame: box and centre along the three axes. */
typedef struct thin_proj {
    float lo[3], hi[3], c[3];
} thin_proj;

typedef struct thin_ctx {
    thin_prim *prims;
    thin_proj *proj;      /* scratch, one per primitive, for the node owning it */
    mr_bvh_node *slots;   /* 2 * count - 1, sparse */
    double *axes;         /* 9 per slot */
} thin_ctx;

/* Eigenvectors of the symmetric 3 x 3 matrix a (destroyed) as the rows of
 * u, by decreasing eigenvalue: cyclic Jacobi rotations, orthonormal to
 * rounding whatever the input (a zero matrix gives the identity). */
static void eigen_frame(double a[3][3], double u[3][3])
{
    double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int sweep = 0; sweep < 50; sweep++) {
        const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if (!(off > 1e-30 * diag))
            break;
        for (int pq = 0; pq < 3; pq++) {
            const int p = pq == 2 ? 1 : 0, q = pq == 0 ? 1 : 2;
            if (a[p][q] == 0)
                continue;
            const double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
            double t = 1 / (fabs(theta) + sqrt(theta * theta + 1));
            if (fabs(theta) > 1e150)
                t = 0.5 / fabs(theta);
            if (theta < 0)
                t = -t;
            const double c = 1 / sqrt(t * t + 1), s = t * c;
            const double apq = a[p][q];
            a[p][p] -= t * apq;
            a[q][q] += t * apq;
            a[p][q] = a[q][p] = 0;
            for (int r = 0; r < 3; r++) {
                if (r == p || r == q)
                    continue;
                const double arp = a[r][p], arq = a[r][q];
                a[r][p] = a[p][r] = c * arp - s * arq;
                a[r][q] = a[q][r] = s * arp + c * arq;
            }
            for (int k = 0; k < 3; k++) {
                const double vp = v[k][p], vq = v[k][q];
                v[k][p] = c * vp - s * vq;
                v[k][q] = s * vp + c * vq;
            }
        }
    }
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 2; i++)
        for (int j = i + 1; j < 3; j++)
            if (a[order[j]][order[j]] > a[order[i]][order[i]]) {
                int t = order[i];
                order[i] = order[j];
                order[j] = t;
            }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            u[i][k] = v[k][order[i]];
    /* Orthonormal to a few rounding errors, however many rotations ran:
     * Gram-Schmidt on the first two, their cross product for the third. */
    double l = sqrt(u[0][0] * u[0][0] + u[0][1] * u[0][1] + u[0][2] * u[0][2]);
    for (int k = 0; k < 3; k++)
        u[0][k] /= l;
    const double d = u[1][0] * u[0][0] + u[1][1] * u[0][1] + u[1][2] * u[0][2];
    for (int k = 0; k < 3; k++)
        u[1][k] -= d * u[0][k];
    l = sqrt(u[1][0] * u[1][0] + u[1][1] * u[1][1] + u[1][2] * u[1][2]);
    for (int k = 0; k < 3; k++)
        u[1][k] /= l;
    u[2][0] = u[0][1] * u[1][2] - u[0][2] * u[1][1];
    u[2][1] = u[0][2] * u[1][0] - u[0][0] * u[1][2];
    u[2][2] = u[0][0] * u[1][1] - u[0][1] * u[1][0];
}

/* The node's frame (three unit axes, row by row) from its triangles'
 * corners: all of them, or FRAME_SAMPLE evenly spaced triangles of a large
 * node (any frame gives true bounds; this one only needs to be good). */
#define FRAME_SAMPLE 256

static void thin_frame(const thin_prim *p, size_t count, double axes[9])
{
    const size_t step = count > FRAME_SAMPLE ? count / FRAME_SAMPLE : 1;
    const size_t used = (count + step - 1) / step;
    double mx = 0, my = 0, mz = 0;
    for (size_t i = 0; i < count; i += step)
        for (int c = 0; c < 3; c++) {
            mx += p[i].v[3 * c];
            my += p[i].v[3 * c + 1];
            mz += p[i].v[3 * c + 2];
        }
    const double inv = 1.0 / (3.0 * (double)used);
    mx *= inv, my *= inv, mz *= inv;
    double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
    for (size_t i = 0; i < count; i += step)
        for (int c = 0; c < 3; c++) {
            const double dx = p[i].v[3 * c] - mx, dy = p[i].v[3 * c + 1] - my,
                         dz = p[i].v[3 * c + 2] - mz;
            xx += dx * dx, xy += dx * dy, xz += dx * dz;
            yy += dy * dy, yz += dy * dz, zz += dz * dz;
        }
    double a[3][3] = {{xx, xy, xz}, {xy, yy, yz}, {xz, yz, zz}};
    double u[3][3];
    eigen_frame(a, u);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            axes[3 * i + k] = u[i][k];
}

static inline double dot_axis(const double *axis, const float *v)
{
    return axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
}

/* Float below / above a double: the slab bounds round outwards. */
static inline float float_down(double x)
{
    float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static inline float float_up(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

/* The node's frame and slab bounds, and every triangle's box in it. */
static void thin_fit(thin_ctx *tc, mr_bvh_node *node, double *axes, size_t first, size_t count)
{
    thin_frame(tc->prims + first, count, axes);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = first; i < first + count; i++) {
        const thin_prim *p = &tc->prims[i];
        thin_proj *q = &tc->proj[i];
        for (int k = 0; k < 3; k++) {
            double pl = INFINITY, ph = -INFINITY, sum = 0;
            for (int c = 0; c < 3; c++) {
                const double s = dot_axis(axes + 3 * k, p->v + 3 * c);
                pl = s < pl ? s : pl;
                ph = s > ph ? s : ph;
                sum += s;
            }
            q->lo[k] = (float)pl;
            q->hi[k] = (float)ph;
            q->c[k] = (float)(sum / 3);
            lo[k] = pl < lo[k] ? pl : lo[k];
            hi[k] = ph > hi[k] ? ph : hi[k];
        }
    }
    for (int k = 0; k < 3; k++) {
        node->lo[k] = float_down(lo[k]);
        node->hi[k] = float_up(hi[k]);
    }
}

/* Binned SAH over the three axes of the node's frame; returns the left
 * count, 0 for a leaf. */
static size_t thin_split(thin_ctx *tc, mr_bvh_node *node, size_t first, size_t count,
                         int depth)
{
    node->a = (uint32_t)first;
    node->b = (uint32_t)count | MR_BVH_LEAF;
    if (count <= MIN_LEAF)
        return 0;
    const thin_proj *q = tc->proj + first;
    float cmin[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, cmax[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (size_t i = 0; i < count; i++)
        for (int k = 0; k < 3; k++) {
            cmin[k] = q[i].c[k] < cmin[k] ? q[i].c[k] : cmin[k];
            cmax[k] = q[i].c[k] > cmax[k] ? q[i].c[k] : cmax[k];
        }
    const int nb = count >= 4 * BINS ? BINS : count >= BINS ? BINS / 2 : BINS / 4;
    split best = {-1, 0, INFINITY};
    float scale[3] = {0, 0, 0};
    if (depth < SAH_MAX_DEPTH) {
        const double area = half_area(node->lo, node->hi);
        for (int axis = 0; axis < 3; axis++) {
            const float extent = cmax[axis] - cmin[axis];
            const float sc = extent > 0 ? (float)nb * 0.999999f / extent : 0;
            if (!(sc > 0) || !isfinite(sc))
                continue;
            scale[axis] = sc;
            bin bins[BINS];
            for (int b = 0; b < nb; b++) {
                box_empty(bins[b].lo, bins[b].hi);
                bins[b].count = 0;
            }
            for (size_t i = 0; i < count; i++) {
                int b = (int)((q[i].c[axis] - cmin[axis]) * sc);
                b = b < 0 ? 0 : b >= nb ? nb - 1 : b;
                box_grow(bins[b].lo, bins[b].hi, q[i].lo, q[i].hi);
                bins[b].count++;
            }
            sweep_axis(bins, nb, axis, area > 0 ? area : 1, &best);
        }
    }
    if (best.axis < 0 || (count <= MAX_LEAF && !(best.cost < (double)count))) {
        if (count <= MAX_LEAF)
            return 0;
        return count / 2; /* too deep or all centres equal: halve by position */
    }
    /* Partition the primitives (and their projections) by the chosen plane. */
    thin_prim *p = tc->prims;
    thin_proj *pr = tc->proj;
    size_t i = first, j = first + count;
    const int axis = best.axis;
    while (i < j) {
        int b = (int)((pr[i].c[axis] - cmin[axis]) * scale[axis]);
        b = b < 0 ? 0 : b >= nb ? nb - 1 : b;
        if (b < best.bin) {
            i++;
        } else {
            j--;
            thin_prim t = p[i];
            p[i] = p[j];
            p[j] = t;
            thin_proj u = pr[i];
            pr[i] = pr[j];
            pr[j] = u;
        }
    }
    return i - first;
}

static void thin_node(thin_ctx *tc, size_t slot, size_t first, size_t count, int depth)
{
    mr_bvh_node *node = &tc->slots[slot];
    thin_fit(tc, node, tc->axes + 9 * slot, first, count);
    const size_t nl = thin_split(tc, node, first, count, depth);
    if (nl == 0)
        return;
    const size_t lslot = slot + 1, rslot = slot + 2 * nl;
    node->a = (uint32_t)lslot;
    node->b = (uint32_t)rslot;
    if (count >= TASK_MIN) {
#pragma omp task default(shared) firstprivate(tc, lslot, first, nl, depth)
        thin_node(tc, lslot, first, nl, depth + 1);
    } else {
        thin_node(tc, lslot, first, nl, depth + 1);
    }
    thin_node(tc, rslot, first + nl, count - nl, depth + 1);
}

/* The thin tree over triangles ids[0 .. count) (1 <= count < 2^31):
 * bvh->order holds positions in `ids`. */
static mr_status thin_build(mr_bvh *bvh, double **axes, double *reach, const float *positions,
                            const uint32_t *indices, const uint32_t *ids, size_t count,
                            int threads, mr_error *err)
{
    memset(bvh, 0, sizeof *bvh);
    *axes = NULL;
    const size_t nslots = 2 * count - 1;
    thin_ctx tc;
    tc.prims = mr_alloc_array(count, sizeof *tc.prims);
    tc.proj = mr_alloc_array(count, sizeof *tc.proj);
    tc.slots = mr_alloc_array(nslots, sizeof *tc.slots);
    tc.axes = mr_alloc_array(9 * nslots, sizeof *tc.axes);
    bvh->order = mr_alloc_array(count, sizeof *bvh->order);
    mr_status st = MR_OK;
    if (!tc.prims || !tc.proj || !tc.slots || !tc.axes || !bvh->order) {
        st = mr_fail_nomem(err, NULL, count * (sizeof *tc.prims + sizeof *tc.proj) +
                                          nslots * (sizeof *tc.slots + 9 * sizeof *tc.axes));
        goto done;
    }
    double r = 0;
    for (size_t i = 0; i < count; i++) {
        thin_prim *p = &tc.prims[i];
        for (int c = 0; c < 3; c++) {
            const float *v = positions + 3 * (size_t)indices[3 * (size_t)ids[i] + c];
            memcpy(p->v + 3 * c, v, 3 * sizeof *v);
            const double l1 = fabs((double)v[0]) + fabs((double)v[1]) + fabs((double)v[2]);
            r = l1 > r ? l1 : r;
        }
        p->id = (uint32_t)i;
    }
    *reach = r;
    const int nt = mr_thread_count(threads);
#pragma omp parallel num_threads(nt) if (count >= TASK_MIN && nt > 1)
#pragma omp single
    thin_node(&tc, 0, 0, count, 0);

    if ((st = compact(bvh, tc.slots, nslots, tc.axes, axes, err)) != MR_OK)
        goto done;
    for (size_t i = 0; i < count; i++)
        bvh->order[i] = tc.prims[i].id;
    bvh->prim_count = count;
done:
    free(tc.prims);
    free(tc.proj);
    free(tc.slots);
    free(tc.axes);
    if (st != MR_OK) {
        mr_bvh_free(bvh);
        free(*axes);
        *axes = NULL;
    }
    return st;
}

/* ---- queries ---------------------------------------------------------------- */

/* Squared distance from p to a node's box (0 inside). Floats read as
 * doubles: an exact lower bound up to one rounding per operation. */
static inline double box_dist2(const mr_bvh_node *n, const double p[3])
{
    double d = 0;
    for (int k = 0; k < 3; k++) {
        const double below = n->lo[k] - p[k], above = p[k] - n->hi[k];
        const double e = below > above ? below : above;
        const double c = e > 0 ? e : 0;
        d += c * c;
    }
    return d;
}

#if defined(__SSE2__)
#include <emmintrin.h>
/* box_dist2 of nodes x and y at once, one in each lane: the same
 * operations in the same order, so the same bits. */
static inline void box_dist2_pair(const mr_bvh_node *x, const mr_bvh_node *y, const double p[3],
                                  double *dx, double *dy)
{
    __m128d d = _mm_setzero_pd();
    const __m128d zero = _mm_setzero_pd();
    for (int k = 0; k < 3; k++) {
        const __m128d pk = _mm_set1_pd(p[k]);
        const __m128d lo = _mm_set_pd((double)y->lo[k], (double)x->lo[k]);
        const __m128d hi = _mm_set_pd((double)y->hi[k], (double)x->hi[k]);
        const __m128d below = _mm_sub_pd(lo, pk), above = _mm_sub_pd(pk, hi);
        /* below > above ? below : above */
        const __m128d gt = _mm_cmpgt_pd(below, above);
        const __m128d e = _mm_or_pd(_mm_and_pd(gt, below), _mm_andnot_pd(gt, above));
        const __m128d pos = _mm_cmpgt_pd(e, zero);
        const __m128d c = _mm_and_pd(pos, e);
        d = _mm_add_pd(d, _mm_mul_pd(c, c));
    }
    _mm_storel_pd(dx, d);
    _mm_storeh_pd(dy, d);
}
#endif

/* Fetch what a search reads after node c: its children, or for a leaf
 * its first primitive (records of prim_size bytes at data). */
static inline void prefetch_below(const mr_bvh_node *nodes, const mr_bvh_node *c,
                                  const void *data, size_t prim_size)
{
    if (c->b & MR_BVH_LEAF) {
        __builtin_prefetch((const char *)data + prim_size * c->a);
    } else {
        __builtin_prefetch(&nodes[c->a]);
        __builtin_prefetch(&nodes[c->b]);
    }
}

typedef struct stack_entry {
    uint32_t node;
    double d2;
} stack_entry;

/* The primitive test of a query: the squared distance, or any value >=
 * best when the primitive cannot be nearer than best. */
typedef double (*prim_dist_fn)(const void *data, uint32_t slot, const double p[3],
                               double best);

/* The bound of a query: a lower bound of the squared distance from p to
 * anything in node i. */
typedef double (*node_dist_fn)(const void *bound, const mr_bvh_node *nodes, uint32_t i,
                               const double p[3], double best);

static inline double aabb_node_dist2(const void *bound, const mr_bvh_node *nodes, uint32_t i,
                                     const double p[3], double best)
{
    (void)bound;
    (void)best;
    return box_dist2(&nodes[i], p);
}

/*
 * An oriented node: slab k is lo_k <= u_k . x <= hi_k. The axes are unit
 * and orthogonal to within a few 1e-16, so |U d|^2 <= (1 + 1e-15) |d|^2
 * (Gershgorin) and the sum of the squared slab distances, shrunk by
 * THIN_SHRINK, bounds |p - x|^2 from below for every x in the node. The
 * projections u . p (here) and u . corner (at build) are each off by at
 * most 3.4e-16 |.|_1; `slack` (per query: THIN_SLACK (|p|_1 + the largest
 * corner |.|_1)) covers both, so the bound never exceeds the distance.
 */
#define THIN_SHRINK (1 - 1e-12)
#define THIN_SLACK 1e-15

typedef struct thin_bound {
    const double *axes; /* 9 per node */
    double slack;
} thin_bound;

static inline double thin_node_dist2(const void *bound, const mr_bvh_node *nodes, uint32_t i,
                                     const double p[3], double best)
{
    const thin_bound *tb = bound;
    const double *u = tb->axes + 9 * (size_t)i;
    const mr_bvh_node *n = &nodes[i];
    double d = 0;
    /* The second axis first: across a bundle of slivers, the one that
     * most often rules a node out; a partial sum is a bound too. */
    static const int order[3] = {1, 0, 2};
    for (int j = 0; j < 3; j++) {
        const int k = order[j];
        const double s = u[3 * k] * p[0] + u[3 * k + 1] * p[1] + u[3 * k + 2] * p[2];
        const double below = n->lo[k] - s, above = s - n->hi[k];
        const double e = (below > above ? below : above) - tb->slack;
        const double c = e > 0 ? e : 0;
        d += c * c;
        if (d * THIN_SHRINK >= best)
            break;
    }
    return d * THIN_SHRINK;
}

/*
 * Nearest-first depth-first search: at an interior node both children's
 * box distances are computed, the nearer is visited next and the farther
 * pushed with its distance, which is checked again when popped (the bound
 * may have shrunk meanwhile). `best` and `best_slot` come in as the bound
 * from the hint (INFINITY / UINT32_MAX without one).
 */
MR_ALWAYS_INLINE static inline double bvh_search(const mr_bvh *bvh, node_dist_fn node_dist,
                                                 const void *bound, const void *data,
                                                 size_t prim_size, prim_dist_fn test_prim,
                                                 const double p[3], double best,
                                                 uint32_t *best_slot)
{
    stack_entry stack[STACK_SIZE];
    int top = 0;
    const mr_bvh_node *nodes = bvh->nodes;
    uint32_t cur = 0;
    if (node_dist(bound, nodes, 0, p, best) >= best)
        return best;
    for (;;) {
        const mr_bvh_node *n = &nodes[cur];
        if (n->b & MR_BVH_LEAF) {
            const uint32_t end = n->a + (n->b & ~MR_BVH_LEAF);
            for (uint32_t s = n->a; s < end; s++) {
                double d = test_prim(data, s, p, best);
                if (d < best) {
                    best = d;
                    *best_slot = s;
                }
            }
        } else {
            /* The next level's nodes, or a leaf's first primitive, are
             * fetched while these two boxes are measured: a search is
             * a chain of dependent loads (the nodes of a 100k-triangle
             * mesh's tree and its records are megabytes). */
            const mr_bvh_node *ca = &nodes[n->a], *cb = &nodes[n->b];
            prefetch_below(nodes, ca, data, prim_size);
            prefetch_below(nodes, cb, data, prim_size);
            /* Nearer child first; selects rather than branches, as the
             * order is unpredictable. */
            double d0, d1;
#if defined(__SSE2__)
            if (node_dist == aabb_node_dist2) {
                box_dist2_pair(ca, cb, p, &d0, &d1);
            } else
#endif
            {
                d0 = node_dist(bound, nodes, n->a, p, best);
                d1 = node_dist(bound, nodes, n->b, p, best);
            }
            const bool swap = d1 < d0;
            const uint32_t near = swap ? n->b : n->a, far = swap ? n->a : n->b;
            const double dn = swap ? d1 : d0, df = swap ? d0 : d1;
            /* The depth is bounded (SAH_MAX_DEPTH + 32 median levels), so
             * the stack cannot fill; the test only guards memory. */
            if (df < best && top < STACK_SIZE) {
                stack[top].node = far;
                stack[top].d2 = df;
                top++;
            }
            if (dn < best) {
                cur = near;
                continue;
            }
        }
        /* pop the next subtree that can still hold something nearer */
        for (;;) {
            if (top == 0)
                return best;
            top--;
            if (stack[top].d2 < best)
                break;
        }
        cur = stack[top].node;
    }
}

/* ---- nearest triangle ------------------------------------------------------- */

static inline double tri_exact_dist2(const mr_tri_rec *r, const double p[3],
                                     double closest[3])
{
    const float *f = r->v;
    double a[3] = {f[0], f[1], f[2]}, b[3] = {f[3], f[4], f[5]}, c[3] = {f[6], f[7], f[8]};
    return mr_point_triangle_dist2(p, a, b, c, closest);
}

/*
 * The plane test first: |n . (p - a)| is the distance to the triangle's
 * plane, a lower bound of the distance to the triangle. n is a float
 * rounding of the unit normal, off by at most about 2e-7 in length and
 * direction, so the bound is lowered by 4e-7 |p - a|_1 (>= that error)
 * to stay a true lower bound.
 */
static inline double tri_prim(const void *data, uint32_t slot, const double p[3], double best)
{
    const mr_tri_rec *r = (const mr_tri_rec *)data + slot;
    const double dx = p[0] - r->v[0], dy = p[1] - r->v[1], dz = p[2] - r->v[2];
    const double pd = fabs(dx * r->n[0] + dy * r->n[1] + dz * r->n[2]);
    const double lb = pd - 4e-7 * (fabs(dx) + fabs(dy) + fabs(dz));
    if (lb > 0 && lb * lb >= best)
        return best;
    return tri_exact_dist2(r, p, NULL);
}

void mr_tri_bvh_free(mr_tri_bvh *t)
{
    if (!t)
        return;
    mr_bvh_free(&t->bvh);
    mr_bvh_free(&t->thin);
    free(t->thin_axes);
    free(t->tri);
    free(t->slot);
    memset(t, 0, sizeof *t);
}

static void fill_record(mr_tri_rec *r, const float *positions, const uint32_t *tri,
                        uint32_t id)
{
    for (int k = 0; k < 3; k++)
        memcpy(r->v + 3 * k, positions + 3 * (size_t)tri[k], 3 * sizeof(float));
    double ab[3], ac[3];
    for (int k = 0; k < 3; k++) {
        ab[k] = (double)r->v[3 + k] - r->v[k];
        ac[k] = (double)r->v[6 + k] - r->v[k];
    }
    double n[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                   ab[0] * ac[1] - ab[1] * ac[0]};
    const double n2 = dot3(n, n);
    /* Slivers (as in mr_point_triangle_dist2) get no plane: no pruning. */
    const bool flat = n2 > DEGENERATE_SIN2 * dot3(ab, ab) * dot3(ac, ac);
    const double inv = flat ? 1 / sqrt(n2) : 0;
    for (int k = 0; k < 3; k++)
        r->n[k] = (float)(n[k] * inv);
    r->id = id;
}

/*
 * Per-triangle float boxes for the builders, and which triangles go to the
 * thin tree. A triangle is thin when its box's half-area h exceeds
 * THIN_RATIO times its area (a compact triangle's is 2 to 6 times, in any
 * orientation). Near the surface a query meets about (sum of the boxes'
 * half-areas) / (surface area) boxes; thin triangles get their own tree
 * only when their half-areas add up to more than THIN_SHARE times the
 * others', so a mesh with a few scattered slivers keeps one box tree, as
 * before. The sums are taken in fixed blocks, combined in order: the
 * choice is the same for every thread count. *thin_count is 0 for one tree
 * (thin[] then means nothing).
 */
#define THIN_RATIO 16.0
#define THIN_SHARE 0.5
#define THIN_BLOCK 65536

static mr_status triangle_boxes(const float *positions, const uint32_t *indices, size_t n,
                                int nt, float *lo, float *hi, uint8_t *thin,
                                size_t *thin_count, mr_error *err)
{
    const size_t nb = (n + THIN_BLOCK - 1) / THIN_BLOCK;
    double *sums = mr_calloc_array(2 * nb, sizeof *sums);
    if (!sums)
        return mr_fail_nomem(err, NULL, 2 * nb * sizeof *sums);
    /* h > THIN_RATIO |n| / 2, squared (n = ab x ac, |n| = twice the area) */
    const double k2 = 0.25 * THIN_RATIO * THIN_RATIO;
#pragma omp parallel for schedule(static) num_threads(nt) if (n > THIN_BLOCK)
    for (size_t b = 0; b < nb; b++) {
        const size_t end = (b + 1) * THIN_BLOCK < n ? (b + 1) * THIN_BLOCK : n;
        double thin_sum = 0, other_sum = 0;
        for (size_t t = b * THIN_BLOCK; t < end; t++) {
            const float *v[3];
            for (int k = 0; k < 3; k++)
                v[k] = positions + 3 * (size_t)indices[3 * t + k];
            /* min / max by comparison (the corners are finite): what the
             * SSE minss / maxss in libm's fminf / fmaxf return, without a call. */
            for (int k = 0; k < 3; k++) {
                const float x = v[0][k], y = v[1][k], z = v[2][k];
                const float yz_lo = y < z ? y : z, yz_hi = y > z ? y : z;
                lo[3 * t + k] = x < yz_lo ? x : yz_lo;
                hi[3 * t + k] = x > yz_hi ? x : yz_hi;
            }
            double ab[3], ac[3];
            for (int k = 0; k < 3; k++) {
                ab[k] = (double)v[1][k] - v[0][k];
                ac[k] = (double)v[2][k] - v[0][k];
            }
            const double nx = ab[1] * ac[2] - ab[2] * ac[1], ny = ab[2] * ac[0] - ab[0] * ac[2],
                         nz = ab[0] * ac[1] - ab[1] * ac[0];
            const double h = half_area(lo + 3 * t, hi + 3 * t);
            thin[t] = h * h > k2 * (nx * nx + ny * ny + nz * nz);
            thin_sum += thin[t] ? h : 0;
            other_sum += thin[t] ? 0 : h;
        }
        sums[2 * b] = thin_sum;
        sums[2 * b + 1] = other_sum;
    }
    double thin_sum = 0, other_sum = 0;
    for (size_t b = 0; b < nb; b++) {
        thin_sum += sums[2 * b];
        other_sum += sums[2 * b + 1];
    }
    free(sums);
    size_t count = 0;
    if (thin_sum > THIN_SHARE * other_sum)
        for (size_t t = 0; t < n; t++)
            count += thin[t];
    *thin_count = count;
    return MR_OK;
}

mr_status mr_tri_bvh_build(mr_tri_bvh *t, const float *positions, const uint32_t *indices,
                           size_t triangle_count, int threads, mr_error *err)
{
    memset(t, 0, sizeof *t);
    const size_t n = triangle_count;
    float *lo = mr_alloc_array(3 * n, sizeof *lo), *hi = mr_alloc_array(3 * n, sizeof *hi);
    uint8_t *thin = mr_alloc_array(n, 1);
    uint32_t *ids = NULL; /* the box tree's triangles, then the thin tree's */
    mr_status st = MR_OK;
    if (!lo || !hi || !thin) {
        st = mr_fail_nomem(err, NULL, 6 * n * sizeof *lo + n);
        goto done;
    }
    const int nt = mr_thread_count(threads);
    size_t nthin = 0;
    if ((st = triangle_boxes(positions, indices, n, nt, lo, hi, thin, &nthin, err)) != MR_OK)
        goto done;
    const size_t nbox = n - nthin;
    if (nthin > 0) {
        /* Split the ids, each part in increasing order, and pack the box
         * tree's boxes in place (a triangle's packed index never exceeds
         * its own). */
        if (!(ids = mr_alloc_array(n, sizeof *ids))) {
            st = mr_fail_nomem(err, NULL, n * sizeof *ids);
            goto done;
        }
        size_t kb = 0, kt = nbox;
        for (size_t i = 0; i < n; i++) {
            if (thin[i]) {
                ids[kt++] = (uint32_t)i;
                continue;
            }
            memmove(lo + 3 * kb, lo + 3 * i, 3 * sizeof *lo);
            memmove(hi + 3 * kb, hi + 3 * i, 3 * sizeof *hi);
            ids[kb++] = (uint32_t)i;
        }
    }
    if (nbox > 0 && (st = mr_bvh_build(&t->bvh, lo, hi, nbox, threads, err)) != MR_OK)
        goto done;
    if (nthin > 0 &&
        (st = thin_build(&t->thin, &t->thin_axes, &t->thin_reach, positions, indices,
                         ids + nbox, nthin, threads, err)) != MR_OK)
        goto done;
    t->tri = mr_alloc_array(n, sizeof *t->tri);
    t->slot = mr_alloc_array(n, sizeof *t->slot);
    if (!t->tri || !t->slot) {
        st = mr_fail_nomem(err, NULL, n * (sizeof *t->tri + sizeof *t->slot));
        goto done;
    }
    const uint32_t *order = t->bvh.order, *thin_order = t->thin.order;
#pragma omp parallel for schedule(static) num_threads(nt) if (n > 65536)
    for (size_t s = 0; s < n; s++) {
        uint32_t id;
        if (s < nbox)
            id = ids ? ids[order[s]] : order[s];
        else
            id = ids[nbox + thin_order[s - nbox]];
        fill_record(&t->tri[s], positions, indices + 3 * (size_t)id, id);
        t->slot[id] = (uint32_t)s;
    }
    t->triangle_count = n;
done:
    free(lo);
    free(hi);
    free(thin);
    free(ids);
    if (st != MR_OK)
        mr_tri_bvh_free(t);
    return st;
}

/* The thin tree's part of a query (out of line: most meshes have none, and
 * the box tree's search stays as compact as without it). */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static double thin_search(const mr_tri_bvh *t, const double p[3], double best,
                          uint32_t *best_slot)
{
    const size_t off = t->bvh.prim_count;
    const thin_bound tb = {
        t->thin_axes, THIN_SLACK * (fabs(p[0]) + fabs(p[1]) + fabs(p[2]) + t->thin_reach)};
    uint32_t s = UINT32_MAX;
    const double d =
        bvh_search(&t->thin, thin_node_dist2, &tb, t->tri + off, sizeof *t->tri, tri_prim, p, best,
                   &s);
    if (s == UINT32_MAX)
        return best;
    *best_slot = (uint32_t)(off + s);
    return d;
}

double mr_tri_bvh_nearest(const mr_tri_bvh *t, const double p[3], uint32_t hint,
                          uint32_t *triangle, double closest[3])
{
    double best = INFINITY;
    uint32_t best_slot = UINT32_MAX;
    if (hint < t->triangle_count) {
        best_slot = t->slot[hint];
        best = tri_exact_dist2(&t->tri[best_slot], p, NULL);
    }
    if (t->bvh.prim_count)
        best = bvh_search(&t->bvh, aabb_node_dist2, NULL, t->tri, sizeof *t->tri, tri_prim, p, best,
                          &best_slot);
    if (t->thin.prim_count)
        best = thin_search(t, p, best, &best_slot);
    if (best_slot == UINT32_MAX) /* only for NaN input: nothing compared below inf */
        best_slot = 0;
    if (triangle)
        *triangle = t->tri[best_slot].id;
    if (closest)
        tri_exact_dist2(&t->tri[best_slot], p, closest);
    return best;
}

/* ---- nearest point ---------------------------------------------------------- */

static inline double pt_slot_dist2(const float *pts, uint32_t slot, const double p[3])
{
    const float *f = pts + 3 * (size_t)slot;
    double dx = p[0] - f[0], dy = p[1] - f[1], dz = p[2] - f[2];
    return dx * dx + dy * dy + dz * dz;
}

static inline double pt_prim(const void *data, uint32_t slot, const double p[3], double best)
{
    (void)best;
    return pt_slot_dist2(data, slot, p);
}

void mr_point_bvh_free(mr_point_bvh *t)
{
    if (!t)
        return;
    mr_bvh_free(&t->bvh);
    free(t->pts);
    free(t->slot);
    memset(t, 0, sizeof *t);
}

mr_status mr_point_bvh_build(mr_point_bvh *t, const float *positions, const uint32_t *ids,
                             size_t count, int threads, mr_error *err)
{
    memset(t, 0, sizeof *t);
    const size_t n = count;
    /* A point is its own box: the float copy serves as both lo and hi. */
    float *box = mr_alloc_array(3 * n, sizeof *box);
    mr_status st = MR_OK;
    if (!box) {
        st = mr_fail_nomem(err, NULL, 3 * n * sizeof *box);
        goto done;
    }
    const int nt = mr_thread_count(threads);
#pragma omp parallel for schedule(static) num_threads(nt) if (n > 65536)
    for (size_t i = 0; i < n; i++) {
        const float *f = positions + 3 * (size_t)(ids ? ids[i] : i);
        memcpy(box + 3 * i, f, 3 * sizeof *f);
    }
    if ((st = mr_bvh_build(&t->bvh, box, box, n, threads, err)) != MR_OK)
        goto done;
    t->pts = mr_alloc_array(3 * n, sizeof *t->pts);
    t->slot = mr_alloc_array(n, sizeof *t->slot);
    if (!t->pts || !t->slot) {
        st = mr_fail_nomem(err, NULL, n * (3 * sizeof *t->pts + sizeof *t->slot));
        goto done;
    }
    const uint32_t *order = t->bvh.order;
#pragma omp parallel for schedule(static) num_threads(nt) if (n > 65536)
    for (size_t s = 0; s < n; s++) {
        memcpy(t->pts + 3 * s, box + 3 * (size_t)order[s], 3 * sizeof(float));
        t->slot[order[s]] = (uint32_t)s;
    }
    t->point_count = n;
done:
    free(box);
    if (st != MR_OK)
        mr_point_bvh_free(t);
    return st;
}

double mr_point_bvh_nearest(const mr_point_bvh *t, const double p[3], uint32_t hint,
                            uint32_t *point)
{
    double best = INFINITY;
    uint32_t best_slot = UINT32_MAX;
    if (hint < t->point_count) {
        best_slot = t->slot[hint];
        best = pt_slot_dist2(t->pts, best_slot, p);
    }
    best = bvh_search(&t->bvh, aabb_node_dist2, NULL, t->pts, 3 * sizeof *t->pts, pt_prim, p, best,
                      &best_slot);
    if (best_slot == UINT32_MAX)
        best_slot = 0;
    if (point)
        *point = t->bvh.order[best_slot];
    return best;
}
