/* The chunk tree (tree.h). */
#include "tree.h"

#include <math.h>

/* Bins a side of a finer grid over one bin of a coarser one. */
enum { REFINE_BINS = 16 };

static inline uint32_t grid_bin(const ooc_grid *g, int k, double x)
{
    const double b = (x - g->lo[k]) * g->scale[k];
    if (!(b > 0))
        return 0; /* below, or NaN */
    return b >= (double)g->n ? g->n - 1 : (uint32_t)b;
}

static mr_status grid_add(ooc_tree *t, const double lo[3], const double hi[3], uint32_t n,
                          mr_error *err)
{
    ooc_grid *g = mr_realloc_array(t->grids, t->ngrids + 1, sizeof *g);
    if (!g)
        return mr_fail_nomem(err, NULL, (t->ngrids + 1) * sizeof *g);
    t->grids = g;
    ooc_grid *ng = &g[t->ngrids];
    memset(ng, 0, sizeof *ng);
    ng->n = n;
    for (int k = 0; k < 3; k++) {
        ng->lo[k] = lo[k];
        const double ext = hi[k] - lo[k];
        ng->scale[k] = ext > 0 ? (double)n / ext : 0;
    }
    ng->count = mr_calloc_array((size_t)n * n * n, sizeof *ng->count);
    if (!ng->count)
        return mr_fail_nomem(err, NULL, (size_t)n * n * n * sizeof *ng->count);
    t->ngrids++;
    return MR_OK;
}

static int32_t node_add(ooc_tree *t, int32_t parent, mr_error *err)
{
    ooc_node *nn = mr_realloc_array(t->nodes, t->nnodes + 1, sizeof *nn);
    if (!nn) {
        mr_fail_nomem(err, NULL, (t->nnodes + 1) * sizeof *nn);
        return -1;
    }
    t->nodes = nn;
    ooc_node *n = &nn[t->nnodes];
    memset(n, 0, sizeof *n);
    n->child[0] = n->child[1] = -1;
    n->parent = parent;
    return (int32_t)t->nnodes++;
}

mr_status ooc_tree_init(ooc_tree *t, const double lo[3], const double hi[3], uint32_t n,
                        uint64_t capacity, mr_error *err)
{
    memset(t, 0, sizeof *t);
    t->capacity = capacity;
    mr_status st = grid_add(t, lo, hi, n, err);
    if (st != MR_OK)
        return st;
    if (node_add(t, -1, err) < 0)
        return MR_ERR_NO_MEMORY;
    ooc_node *root = &t->nodes[0];
    root->open = 1;
    root->grid = 0;
    for (int k = 0; k < 3; k++) {
        root->box[k][0] = 0;
        root->box[k][1] = n;
    }
    return MR_OK;
}

void ooc_tree_free(ooc_tree *t)
{
    for (size_t i = 0; i < t->ngrids; i++)
        free(t->grids[i].count);
    free(t->grids);
    free(t->nodes);
    free(t->leaf_node);
    memset(t, 0, sizeof *t);
}

uint32_t ooc_tree_locate(const ooc_tree *t, const double c[3])
{
    uint32_t i = 0;
    for (;;) {
        const ooc_node *n = &t->nodes[i];
        if (n->child[0] < 0)
            return i;
        const uint32_t b = grid_bin(&t->grids[n->grid], n->axis, c[n->axis]);
        i = (uint32_t)n->child[b < n->split ? 0 : 1];
    }
}

void ooc_tree_count(ooc_tree *t, const double c[3])
{
    const ooc_node *n = &t->nodes[ooc_tree_locate(t, c)];
    if (!n->open)
        return;
    ooc_grid *g = &t->grids[n->grid];
    const size_t x = grid_bin(g, 0, c[0]), y = grid_bin(g, 1, c[1]), z = grid_bin(g, 2, c[2]);
    g->count[(z * g->n + y) * g->n + x]++;
}

bool ooc_tree_open(const ooc_tree *t)
{
    for (size_t i = 0; i < t->nnodes; i++)
        if (t->nodes[i].open)
            return true;
    return false;
}

/* The counts of grid g in box b along axis k, into m (one per bin of the
 * box's side); returns their sum. */
static uint64_t marginal(const ooc_grid *g, const uint32_t b[3][2], int k, uint64_t *m)
{
    const uint32_t n = g->n;
    for (uint32_t i = b[k][0]; i < b[k][1]; i++)
        m[i - b[k][0]] = 0;
    uint64_t sum = 0;
    for (uint32_t z = b[2][0]; z < b[2][1]; z++)
        for (uint32_t y = b[1][0]; y < b[1][1]; y++) {
            const uint32_t *row = g->count + ((size_t)z * n + y) * n;
            for (uint32_t x = b[0][0]; x < b[0][1]; x++) {
                const uint32_t c = row[x];
                if (!c)
                    continue;
                const uint32_t at = k == 0 ? x : k == 1 ? y : z;
                m[at - b[k][0]] += c;
                sum += c;
            }
        }
    return sum;
}

/* Split node i in its (counted) grid, down to leaves within capacity; a
 * node whose triangles share one bin gets a finer grid over it (open)
 * unless last_round. */
static mr_status split_node(ooc_tree *t, uint32_t i, bool last_round, uint64_t *m,
                            mr_error *err)
{
    ooc_node *n = &t->nodes[i];
    n->open = 0;
    if (n->triangles <= t->capacity)
        return MR_OK;
    const ooc_grid *g = &t->grids[n->grid];
    /* the axes by the box's length, longest first (ties: x, y, z) */
    int order[3] = {0, 1, 2};
    double len[3];
    for (int k = 0; k < 3; k++)
        len[k] = g->scale[k] > 0 ? (double)(n->box[k][1] - n->box[k][0]) / g->scale[k] : 0;
    for (int a = 0; a < 2; a++)
        for (int b = a + 1; b < 3; b++)
            if (len[order[b]] > len[order[a]]) {
                const int x = order[a];
                order[a] = order[b];
                order[b] = x;
            }
    for (int oi = 0; oi < 3; oi++) {
        const int k = order[oi];
        const uint32_t b0 = n->box[k][0], b1 = n->box[k][1];
        if (b1 - b0 < 2 || g->scale[k] == 0)
            continue;
        const uint64_t total = marginal(g, n->box, k, m);
        /* the boundary whose left side is nearest half, both sides non-empty */
        uint64_t left = 0, best_left = 0;
        uint32_t best = 0;
        double best_gap = INFINITY;
        for (uint32_t s = b0 + 1; s < b1; s++) {
            left += m[s - 1 - b0];
            if (left == 0 || left == total)
                continue;
            const double gap = fabs((double)left - 0.5 * (double)total);
            if (gap < best_gap) {
                best_gap = gap;
                best = s;
                best_left = left;
            }
        }
        if (best == 0)
            continue;
        const int32_t c0 = node_add(t, (int32_t)i, err);
        const int32_t c1 = c0 < 0 ? -1 : node_add(t, (int32_t)i, err);
        if (c1 < 0)
            return MR_ERR_NO_MEMORY;
        n = &t->nodes[i]; /* the array moved */
        n->axis = (uint8_t)k;
        n->split = best;
        n->child[0] = c0;
        n->child[1] = c1;
        for (int side = 0; side < 2; side++) {
            ooc_node *c = &t->nodes[n->child[side]];
            c->grid = n->grid;
            memcpy(c->box, n->box, sizeof c->box);
            c->triangles = side == 0 ? best_left : total - best_left;
        }
        /* child 0: [b0, best) along k; child 1: [best, b1) */
        t->nodes[c0].box[k][0] = b0;
        t->nodes[c0].box[k][1] = best;
        t->nodes[c1].box[k][0] = best;
        t->nodes[c1].box[k][1] = b1;
        mr_status st = split_node(t, (uint32_t)c0, last_round, m, err);
        if (st == MR_OK)
            st = split_node(t, (uint32_t)c1, last_round, m, err);
        return st;
    }
    /* every triangle in one bin: a finer grid over it, counted next */
    if (last_round) {
        t->oversized++;
        return MR_OK;
    }
    uint32_t at[3];
    for (int k = 0; k < 3; k++) {
        marginal(g, n->box, k, m);
        at[k] = n->box[k][0];
        for (uint32_t b = n->box[k][0]; b < n->box[k][1]; b++)
            if (m[b - n->box[k][0]]) {
                at[k] = b;
                break;
            }
    }
    double lo[3], hi[3];
    bool extent = false;
    for (int k = 0; k < 3; k++) {
        if (g->scale[k] > 0) {
            lo[k] = g->lo[k] + (double)at[k] / g->scale[k];
            hi[k] = g->lo[k] + (double)(at[k] + 1) / g->scale[k];
        } else {
            lo[k] = hi[k] = g->lo[k];
        }
        extent |= hi[k] > lo[k];
    }
    if (!extent) {
        t->oversized++; /* all at one point */
        return MR_OK;
    }
    mr_status st = grid_add(t, lo, hi, REFINE_BINS, err);
    if (st != MR_OK)
        return st;
    n = &t->nodes[i];
    n->grid = (uint32_t)(t->ngrids - 1);
    n->open = 1;
    for (int k = 0; k < 3; k++) {
        n->box[k][0] = 0;
        n->box[k][1] = REFINE_BINS;
    }
    return MR_OK;
}

mr_status ooc_tree_split(ooc_tree *t, bool last_round, mr_error *err)
{
    uint32_t most = REFINE_BINS;
    for (size_t i = 0; i < t->ngrids; i++)
        most = t->grids[i].n > most ? t->grids[i].n : most;
    uint64_t *m = mr_alloc_array(most, sizeof *m);
    if (!m)
        return mr_fail_nomem(err, NULL, most * sizeof *m);
    const size_t grids_before = t->ngrids, nodes_before = t->nnodes;
    /* the open nodes' totals from their grids */
    for (size_t i = 0; i < nodes_before; i++) {
        ooc_node *n = &t->nodes[i];
        if (!n->open)
            continue;
        const ooc_grid *g = &t->grids[n->grid];
        uint64_t sum = 0;
        const size_t cells = (size_t)g->n * g->n * g->n;
        for (size_t c = 0; c < cells; c++)
            sum += g->count[c];
        n->triangles = sum;
    }
    mr_status st = MR_OK;
    for (size_t i = 0; i < nodes_before && st == MR_OK; i++)
        if (t->nodes[i].open)
            st = split_node(t, (uint32_t)i, last_round, m, err);
    free(m);
    /* the counted grids are done with: their bins still place centroids */
    for (size_t i = 0; i < grids_before; i++) {
        free(t->grids[i].count);
        t->grids[i].count = NULL;
    }
    return st;
}

mr_status ooc_tree_number(ooc_tree *t, mr_error *err)
{
    /* depth first, child 0 first, without recursion: a stack of nodes
     * with how far each is */
    int32_t *stack = mr_alloc_array(2 * t->nnodes + 2, sizeof *stack);
    size_t leaves = 0;
    for (size_t i = 0; i < t->nnodes; i++)
        leaves += t->nodes[i].child[0] < 0;
    t->leaf_node = mr_alloc_array(leaves ? leaves : 1, sizeof *t->leaf_node);
    if (!stack || !t->leaf_node) {
        free(stack);
        return mr_fail_nomem(err, NULL, t->nnodes * 8 + leaves * 4);
    }
    size_t sp = 0, next = 0;
    stack[sp++] = 0;
    stack[sp++] = 0; /* (node, state): 0 on the way down, 1 on the way up */
    while (sp) {
        const int32_t state = stack[--sp], i = stack[--sp];
        ooc_node *n = &t->nodes[i];
        if (n->child[0] < 0) {
            n->leaf = n->first_leaf = n->last_leaf = (uint32_t)next;
            n->height = 0;
            t->leaf_node[next++] = (uint32_t)i;
            continue;
        }
        if (state == 0) {
            stack[sp++] = i;
            stack[sp++] = 1;
            stack[sp++] = n->child[1];
            stack[sp++] = 0;
            stack[sp++] = n->child[0];
            stack[sp++] = 0;
            continue;
        }
        const ooc_node *a = &t->nodes[n->child[0]], *b = &t->nodes[n->child[1]];
        n->first_leaf = a->first_leaf;
        n->last_leaf = b->last_leaf;
        n->height = 1 + (a->height > b->height ? a->height : b->height);
    }
    free(stack);
    t->leaves = next;
    t->height = t->nodes[0].height;
    return MR_OK;
}
