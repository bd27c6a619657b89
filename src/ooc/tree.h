/*
 * The chunk tree of the out-of-core simplification (tree.c): a k-d tree
 * over the triangles' centroids whose leaves -- the chunks -- hold at most
 * `capacity` triangles each. It is built from counts, not from the
 * triangles: a pass over the faces counts every centroid in a grid of
 * bins over the bounding box; each node over capacity is split at the
 * bin boundary nearest its triangles' median along the longest side of
 * its box, and so on down; a node whose triangles all fall in one bin
 * gets a finer grid over that bin, counted in the next pass. A triangle's
 * chunk is found by the same bins (ooc_tree_locate), so the counts are
 * the chunks' sizes exactly. Leaves are numbered in depth-first order:
 * every node covers a run of them. Everything depends on the centroids
 * and the capacity only. Internal.
 */
#ifndef MR_OOC_TREE_H
#define MR_OOC_TREE_H

#include "../core/internal.h"

typedef struct ooc_grid {
    double lo[3], scale[3]; /* bin along k: floor((x - lo[k]) * scale[k]), clamped */
    uint32_t n;             /* bins a side */
    uint32_t *count;        /* n^3 counts while the grid is counted, else NULL */
} ooc_grid;

typedef struct ooc_node {
    int32_t child[2];       /* -1: a leaf */
    int32_t parent;         /* -1: the root */
    uint32_t grid;          /* its split's grid (an open node: the one to count) */
    uint32_t split;         /* a centroid's bin below it: child 0 */
    uint32_t box[3][2];     /* its bins in its grid, [lo, hi) */
    uint64_t triangles;
    uint32_t first_leaf, last_leaf; /* the leaves under it (ooc_tree_number) */
    uint32_t leaf;          /* a leaf's number */
    int height;             /* a leaf 0, else 1 + its children's most */
    uint8_t axis;
    uint8_t open;           /* waits for its grid's counts */
} ooc_node;

typedef struct ooc_tree {
    ooc_grid *grids;
    size_t ngrids;
    ooc_node *nodes;
    size_t nnodes;
    uint64_t capacity;
    size_t leaves;
    uint32_t *leaf_node;    /* leaf number -> node */
    size_t oversized;       /* leaves over capacity: all their centroids
                               at one point (or the refinements ran out) */
    int height;             /* the root's */
} ooc_tree;

static inline double ooc_centroid(const float *a, const float *b, const float *c, int k)
{
    return ((double)a[k] + (double)b[k] + (double)c[k]) / 3.0;
}

/* A tree of one open node over [lo, hi] with a grid of n^3 bins. */
mr_status ooc_tree_init(ooc_tree *t, const double lo[3], const double hi[3], uint32_t n,
                        uint64_t capacity, mr_error *err);
void ooc_tree_free(ooc_tree *t);
/* The node the centroid c falls in: a leaf, or an open node. */
uint32_t ooc_tree_locate(const ooc_tree *t, const double c[3]);
/* Count c in its open node's grid (a node that is not open: nothing). */
void ooc_tree_count(ooc_tree *t, const double c[3]);
/* Are nodes waiting for counts? */
bool ooc_tree_open(const ooc_tree *t);
/* Split the open nodes by their counts; those that need a finer grid get
 * one (open again, for the next pass) unless last_round, when they stay
 * leaves over capacity. */
mr_status ooc_tree_split(ooc_tree *t, bool last_round, mr_error *err);
/* Number the leaves depth first, the nodes' leaf runs and heights. */
mr_status ooc_tree_number(ooc_tree *t, mr_error *err);

#endif
