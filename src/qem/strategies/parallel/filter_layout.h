/*
 * The slot layout of a heap with filter levels: Table 1 of the
 * filter-level priority queue paper (FPPQ, section 3.2). Internal.
 *
 * Slots are numbered row by row, left to right, the root 0. With l_f
 * filter levels the heap is:
 *   - l_t = l_f + 1 top levels: a binary tree of n_t = 2^l_t - 1 nodes, its
 *     last row w = 2^l_f = (n_t + 1) / 2 wide;
 *   - l_f filter rows of w nodes each, n_f = l_f * w nodes in all. A filter
 *     node has two parents in the row above: the first directly above (same
 *     column), the second that many columns to the left, wrapping round,
 *     where the offset is 1 in the bottom filter row and doubles at each row
 *     going up (2^(l_f - 1) in the top filter row). So every bottom filter
 *     node is below all w nodes of the last top row (a butterfly);
 *   - below the filter, a binary tree again, as if the bottom filter row
 *     were the last top row (slot i there is slot i - n_f of a plain heap).
 * With l_f = 0 there is no filter: n_t = 1, w = 1, n_f = 0, and every
 * formula below is the binary heap's (children 2i+1, 2i+2, parent (i-1)/2).
 *
 * The paper's table, its superscripts restored (checked against Fig. 1 and
 * its text -- node 7 of Fig. 1c has parents 3 and 5, node 10 has 6 and 4,
 * node 11 has 7 and 10 -- and by brute force in tests/test_fppq.c):
 *   column   i_c = (i - n_t + w) % w            (nodes from row l_t - 1 on)
 *   row      i_r = floor((n_t + n_f - i - 1) / w)  (bottom filter row 0,
 *                                                   last top row l_f)
 *   1st child:  2i + 1                  if i < n_t - w
 *               i + w                   if n_t - w <= i < n_t + n_f - w
 *               2i + 1 - n_f            otherwise
 *   2nd child:  2i + 2                  if i < n_t - w
 *               i + w - i_c + (i_c + 2^(i_r - 1)) % w
 *                                       if n_t - w <= i < n_t + n_f - w
 *               2i + 2 - n_f            otherwise
 *   1st parent: floor((i - 1) / 2)      if i < n_t
 *               i - w                   if n_t <= i < n_t + n_f
 *               floor((i - 1 + n_f) / 2) otherwise
 *   2nd parent: i - w - i_c + (w + i_c - 2^i_r) % w
 *                                       if n_t <= i < n_t + n_f (else none)
 * Parents always have smaller slot numbers than their children: locking in
 * increasing slot order is locking top-down.
 */
#ifndef MR_FILTER_LAYOUT_H
#define MR_FILTER_LAYOUT_H

#include <stdint.h>

/* Most filter levels a queue may have (n_t = 8191, n_f = 49152). */
#define MR_FILTER_MAX_LEVELS 12

typedef struct mr_filter_layout {
    uint32_t levels; /* l_f */
    uint32_t top;    /* n_t = 2^(l_f + 1) - 1 */
    uint32_t width;  /* w = 2^l_f */
    uint32_t filter; /* n_f = l_f * w */
} mr_filter_layout;

static inline mr_filter_layout mr_filter_layout_make(unsigned levels)
{
    mr_filter_layout l;
    l.levels = levels;
    l.width = 1u << levels;
    l.top = 2 * l.width - 1;
    l.filter = levels * l.width;
    return l;
}

/* i_c and i_r, for slots of the last top row and the filter rows. */
static inline uint32_t mr_filter_column(const mr_filter_layout *l, uint32_t i)
{
    return (i - l->top + l->width) & (l->width - 1);
}

static inline uint32_t mr_filter_row(const mr_filter_layout *l, uint32_t i)
{
    return (l->top + l->filter - i - 1) / l->width;
}

/* Children as 64-bit numbers: past the last 32-bit slot they are only
 * compared with the heap's size. */
static inline uint64_t mr_filter_child1(const mr_filter_layout *l, uint32_t i)
{
    if (i < l->top - l->width)
        return 2 * (uint64_t)i + 1;
    if (i < l->top + l->filter - l->width)
        return (uint64_t)i + l->width;
    return 2 * (uint64_t)i + 1 - l->filter;
}

static inline uint64_t mr_filter_child2(const mr_filter_layout *l, uint32_t i)
{
    if (i < l->top - l->width)
        return 2 * (uint64_t)i + 2;
    if (i < l->top + l->filter - l->width) {
        const uint32_t c = mr_filter_column(l, i), r = mr_filter_row(l, i);
        return (uint64_t)i + l->width - c + ((c + (1u << (r - 1))) & (l->width - 1));
    }
    return 2 * (uint64_t)i + 2 - l->filter;
}

/* The parents of slot i > 0 into p; returns how many (1 or 2). */
static inline unsigned mr_filter_parents(const mr_filter_layout *l, uint32_t i, uint32_t p[2])
{
    if (i < l->top) {
        p[0] = (i - 1) / 2;
        return 1;
    }
    if (i < l->top + l->filter) {
        const uint32_t c = mr_filter_column(l, i), r = mr_filter_row(l, i);
        p[0] = i - l->width;
        p[1] = i - l->width - c + ((l->width + c - (1u << r)) & (l->width - 1));
        return 2;
    }
    p[0] = (uint32_t)(((uint64_t)i - 1 + l->filter) / 2);
    return 1;
}

#endif /* MR_FILTER_LAYOUT_H */
