/*
 * The sequential simplifier's state and phases, shared by mr_simplify and
 * mr_mesh_simplify (attributes). Internal.
 */
#ifndef MR_SIMPLIFY_INTERNAL_H
#define MR_SIMPLIFY_INTERNAL_H

#include "../mesh/adjacency.h"
#include "collapse.h"
#include "heap.h"
#include "quadric.h"

typedef struct mr_simplifier mr_simplifier;

/* batched.c: an edge (a, b) of a pass and the bits of its (float) cost. */
typedef struct mr_candidate {
    uint32_t key, a, b;
} mr_candidate;

struct mr_simplifier {
    mr_collapse_mesh m;
    mr_quadricf *q;          /* per vertex, relative to its position */
    uint32_t *best;          /* per vertex: other end of its queued collapse */
    uint8_t *stale;          /* per vertex: key is only a lower bound */
    mr_heap heap;
    mr_collapse_limits limits;
    int half;
    int batched;             /* MR_STRATEGY_BATCHED: see batched.c */
    struct mr_candidate *cand; /* batched: a pass's edges */
    size_t cand_cap;
    uint8_t *mark;           /* batched: per vertex, changed in this pass */
    uint32_t *hist;          /* batched: histogram */
    uint64_t *best64;        /* batched: per vertex, its cheapest candidate */
    double centre[3], scale, diagonal;
    double error_base;       /* bounding-box diagonal of all the input's
                                vertices: relative errors are relative to it */
    float lo[3], hi[3];      /* bounding box of the referenced input vertices */
    double box[3];           /* its half extents, normalised: targets stay
                                inside (|target[k]| <= box[k]) */
    size_t input_vertices;
    size_t blocked_vertices; /* non-manifold or inconsistently wound: locked */
    mr_simplify_stop stop;   /* why mr_simplifier_run stopped */
    size_t pruned;           /* parts dropped by options.prune */
    /* Attribute hooks (mr_mesh_simplify): extra validity, and an action
     * before a collapse r -> k to target is applied. */
    bool (*attr_valid)(mr_simplifier *s, uint32_t r, uint32_t k);
    void (*attr_apply)(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3]);
    void *attr;
};

/* What the run aims at, from the options. */
typedef struct mr_simplify_goal {
    size_t vertices, triangles; /* stop at or below (0 = unused) */
    double limit;               /* largest cost allowed (squared, normalised) */
    size_t planned;             /* collapses the targets need, for progress */
} mr_simplify_goal;

/* Are the targets met? */
static inline bool mr_simplifier_reached(const mr_simplifier *s, const mr_simplify_goal *g)
{
    return s->m.live_vertices <= g->vertices ||
           (g->triangles && s->m.live_triangles <= g->triangles);
}

/* Output position of vertex v: its normalised position scaled back, kept
 * inside the input's bounding box (the rounding of a target at its face
 * must not leave it, nor the float range). */
static inline void mr_simplifier_position(const mr_simplifier *s, uint32_t v, float p[3])
{
    for (int k = 0; k < 3; k++) {
        const float f = (float)((double)s->m.pos[3 * (size_t)v + k] * s->diagonal + s->centre[k]);
        p[k] = f < s->lo[k] ? s->lo[k] : f > s->hi[k] ? s->hi[k] : f;
    }
}

/* A normalised distance e as the error the options speak in. */
static inline double mr_simplifier_error(const mr_simplifier *s, const mr_simplify_options *o,
                                         double e)
{
    return o->error_absolute ? e * s->diagonal : e * s->diagonal / s->error_base;
}

/* The inverse: an error in the options' terms as a normalised distance
 * (normalised by the referenced vertices' diagonal; relative errors are
 * relative to the whole input's). */
static inline double mr_simplifier_normalised(const mr_simplifier *s,
                                              const mr_simplify_options *o, double e)
{
    return (o->error_absolute ? e : e * s->error_base) / s->diagonal;
}

mr_status mr_simplify_check_options(const mr_simplify_options *o, size_t input_vertices,
                                    size_t input_triangles, mr_error *err);
mr_status mr_simplifier_init(mr_simplifier *s, const float *positions, size_t stride,
                             size_t vertex_count, const uint32_t *indices,
                             size_t triangle_count, const mr_simplify_options *o,
                             const uint8_t *extra_flags, mr_error *err);
mr_status mr_simplifier_fill_queue(mr_simplifier *s, mr_error *err);
size_t mr_simplifier_run(mr_simplifier *s, const mr_simplify_options *o, double *max_error);
void mr_simplifier_targets(const mr_simplifier *s, const mr_simplify_options *o,
                           mr_simplify_goal *g);
/* The collapse of edge (a, b) this simplifier makes -- full: to the
 * optimum, a pinned end stays, else the larger id goes; half: the cheaper
 * direction -- as r removed, k kept, target; returns its cost (INFINITY
 * when it may not happen). Symmetric in a and b. */
double mr_simplifier_plan_edge(const mr_simplifier *s, uint32_t a, uint32_t b, uint32_t *r,
                               uint32_t *k, double target[3]);
/* mr_simplifier_plan_edge for n edges (a[i], b[i]) at once, the same
 * bits (free edges in a vector loop): cost[i], and when r is not NULL
 * r[i], k[i] and target[3i..3i+2]. */
void mr_simplifier_plan_edges(const mr_simplifier *s, size_t n, const uint32_t *a,
                              const uint32_t *b, double *cost, uint32_t *r, uint32_t *k,
                              double *target);
/* Apply a valid planned collapse: attribute hook, quadrics, mesh. */
void mr_simplifier_collapse(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3]);
mr_status mr_simplifier_batched_init(mr_simplifier *s, mr_error *err);
size_t mr_simplifier_run_batched(mr_simplifier *s, const mr_simplify_options *o,
                                 double *max_error);
bool mr_simplifier_valid(mr_simplifier *s, uint32_t u, uint32_t w, double *cost);
mr_status mr_simplifier_output(const mr_simplifier *s, const float *positions, size_t stride,
                               mr_simplified *out, mr_error *err);
void mr_simplifier_free(mr_simplifier *s);

#endif
