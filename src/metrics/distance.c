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
 */
#include "distance.h"

#include <float.h>
#include <math.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#define BINS 16
#define MAX_LEAF 4           /* primitives per leaf at most */
#define MIN_LEAF 2           /* ranges this small always become leaves */
#define TRAVERSAL_COST 1.0   /* of a node visit, relative to one primitive test */
#define TASK_MIN 8192        /* subtrees smaller than this are built in one task */
#define SAH_MAX_DEPTH 64     /* below this depth, median splits keep the depth bounded */
#define STACK_SIZE 128       /* > SAH_MAX_DEPTH + 32 median levels + slack */
#define DEGENERATE_SIN2 1e-20 /* sin^2 of the angle at a below which a triangle is a sliver */

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
#pragma omp task default(shared) firstprivate(lslot, first, nl, depth, left)
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

static mr_status compact(mr_bvh *bvh, const mr_bvh_node *slots, size_t nslots, mr_error *err)
{
    uint32_t *map = mr_alloc_array(nslots, sizeof *map);
    if (!map)
        return mr_fail_nomem(err, NULL, nslots * sizeof *map);
    const size_t n = number_nodes(slots, map);
    /* n < 2^32 nodes of 32 bytes: no overflow; a multiple of 64 bytes as
     * aligned_alloc wants. */
    const size_t bytes = (n * sizeof *bvh->nodes + 63) / 64 * 64;
    bvh->nodes = aligned_alloc(64, bytes);
    if (!bvh->nodes) {
        free(map);
        return mr_fail_nomem(err, NULL, bytes);
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

    if ((st = compact(bvh, bc.slots, nslots, err)) != MR_OK)
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

typedef struct stack_entry {
    uint32_t node;
    double d2;
} stack_entry;

/* The primitive test of a query: the squared distance, or any value >=
 * best when the primitive cannot be nearer than best. */
typedef double (*prim_dist_fn)(const void *data, uint32_t slot, const double p[3],
                               double best);

/*
 * Nearest-first depth-first search: at an interior node both children's
 * box distances are computed, the nearer is visited next and the farther
 * pushed with its distance, which is checked again when popped (the bound
 * may have shrunk meanwhile). `best` and `best_slot` come in as the bound
 * from the hint (INFINITY / UINT32_MAX without one).
 */
MR_ALWAYS_INLINE static inline double bvh_search(const mr_bvh *bvh, const void *data,
                                                 prim_dist_fn test_prim, const double p[3],
                                                 double best, uint32_t *best_slot)
{
    stack_entry stack[STACK_SIZE];
    int top = 0;
    const mr_bvh_node *nodes = bvh->nodes;
    uint32_t cur = 0;
    if (box_dist2(&nodes[0], p) >= best)
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
            /* Nearer child first; selects rather than branches, as the
             * order is unpredictable. */
            const double d0 = box_dist2(&nodes[n->a], p), d1 = box_dist2(&nodes[n->b], p);
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
    free(t->tri);
    free(t->slot);
    memset(t, 0, sizeof *t);
}

/* Per-triangle float boxes for the builder. */
static void triangle_boxes(const float *positions, const uint32_t *indices, size_t n,
                           float *lo, float *hi)
{
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t t = 0; t < n; t++) {
        const float *v[3];
        for (int k = 0; k < 3; k++)
            v[k] = positions + 3 * (size_t)indices[3 * t + k];
        for (int k = 0; k < 3; k++) {
            float a = v[0][k], b = v[1][k], c = v[2][k];
            lo[3 * t + k] = fminf(a, fminf(b, c));
            hi[3 * t + k] = fmaxf(a, fmaxf(b, c));
        }
    }
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

mr_status mr_tri_bvh_build(mr_tri_bvh *t, const float *positions, const uint32_t *indices,
                           size_t triangle_count, int threads, mr_error *err)
{
    memset(t, 0, sizeof *t);
    const size_t n = triangle_count;
    float *lo = mr_alloc_array(3 * n, sizeof *lo), *hi = mr_alloc_array(3 * n, sizeof *hi);
    mr_status st = MR_OK;
    if (!lo || !hi) {
        st = mr_fail_nomem(err, NULL, 6 * n * sizeof *lo);
        goto done;
    }
    const int nt = mr_thread_count(threads);
    triangle_boxes(positions, indices, n, lo, hi);
    if ((st = mr_bvh_build(&t->bvh, lo, hi, n, threads, err)) != MR_OK)
        goto done;
    t->tri = mr_alloc_array(n, sizeof *t->tri);
    t->slot = mr_alloc_array(n, sizeof *t->slot);
    if (!t->tri || !t->slot) {
        st = mr_fail_nomem(err, NULL, n * (sizeof *t->tri + sizeof *t->slot));
        goto done;
    }
    const uint32_t *order = t->bvh.order;
#pragma omp parallel for schedule(static) num_threads(nt) if (n > 65536)
    for (size_t s = 0; s < n; s++) {
        const uint32_t id = order[s];
        fill_record(&t->tri[s], positions, indices + 3 * (size_t)id, id);
        t->slot[id] = (uint32_t)s;
    }
    t->triangle_count = n;
done:
    free(lo);
    free(hi);
    if (st != MR_OK)
        mr_tri_bvh_free(t);
    return st;
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
    best = bvh_search(&t->bvh, t->tri, tri_prim, p, best, &best_slot);
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
    best = bvh_search(&t->bvh, t->pts, pt_prim, p, best, &best_slot);
    if (best_slot == UINT32_MAX)
        best_slot = 0;
    if (point)
        *point = t->bvh.order[best_slot];
    return best;
}
