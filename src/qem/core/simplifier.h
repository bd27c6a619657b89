/*
 * The simplifier core: the state of a run and the verbs every strategy
 * shares -- set-up (setup.c), costs, plans, the tests and the collapse
 * (cost.c on collapse.c's mesh), the end of a run and the output
 * (output.c), the surface fit (refine.c). Internal. It knows no strategy:
 * the strategies (qem/strategies/) stand on it, and the entry points
 * (qem/simplify.c, qem/mesh_simplify.c) choose one and own its state.
 *
 * A call: the entry checks the options and fills a plan's strategy part,
 * mr_simplifier_init resolves the rest of the options into the plan
 * (targets, error bound, threads, kernels, progress) and builds the
 * working mesh and its quadrics; the strategy runs on s->plan alone (it
 * never sees the options); mr_simplifier_finish says why the run stopped
 * and prunes; then the output and mr_simplifier_free.
 */
#ifndef MR_QEM_SIMPLIFIER_H
#define MR_QEM_SIMPLIFIER_H

#include "../../mesh/adjacency.h"
#include "collapse.h"
#include "kernels.h"
#include "quadric.h"

typedef struct mr_simplifier mr_simplifier;

/*
 * What a caller adds to a run's vertices, each array one entry per input
 * vertex (all optional). Besides flags, the marks of a chunk of a larger
 * mesh (the out-of-core path, qem/chunk.c), whose cut vertices -- those
 * that triangles of other chunks use too -- the caller locks (flags):
 *   - an edge of one triangle between two cut vertices may have its other
 *     triangles elsewhere: it is no open boundary (no constraint planes,
 *     no corner's polyline);
 *   - a collapse r -> k into a cut vertex is refused when r has a cut
 *     neighbour other than k and the edge's opposite vertices: k's edges
 *     in other chunks are not seen, and the collapse could join k to that
 *     neighbour twice (mr_simplifier_allowed);
 *   - quadrics: each vertex's quadric from the runs before (a chunk made
 *     of simplified chunks), relative to its position, lengths in units
 *     of `unit` (a quadric's area terms scale by unit^2, and so on), in
 *     place of its triangles' planes; the open edges those runs could not
 *     tell from a cut (both ends were cut there: was_cut) get their
 *     constraint planes now, when one end is no longer cut.
 */
typedef struct mr_vertex_marks {
    const uint8_t *flags;          /* or'ed into the vertices' flags (MR_VF_*) */
    const uint8_t *cut;            /* nonzero: on the chunk's cut */
    const mr_quadricf *quadrics;   /* or NULL */
    const uint8_t *was_cut;        /* with quadrics */
    double unit;                   /* with quadrics: their length unit */
} mr_vertex_marks;

/* What the run aims at. */
typedef struct mr_simplify_goal {
    size_t vertices, triangles; /* stop at or below (0 = unused) */
    double limit;               /* largest cost allowed (squared, normalised) */
    size_t planned;             /* collapses the targets need, for progress */
} mr_simplify_goal;

/*
 * A run's plan: the options resolved once, for the core and the strategy
 * to read. The entry fills the strategy's part (strategy .. partitions);
 * mr_simplifier_init the rest.
 */
typedef struct mr_simplify_plan {
    int strategy;            /* mr_strategy */
    bool spatial_order;      /* work the triangles in a spatial order when
                                the input's is not coherent (setup.c) */
    bool edge_plans;         /* the strategy plans edges (plan_edge), so the
                                best quality may use memoryless plans */
    unsigned filter_levels, multiqueue_factor, partitions; /* its settings */
    mr_simplify_goal goal;   /* targets and the error bound, normalised */
    double error_bound;      /* options.max_error, normalised (0: none) */
    bool error_absolute;     /* errors in model units, else relative */
    bool until_error;
    bool prune;
    int threads;             /* the threads the run may use */
    const mr_kernels *kernels;
    mr_progress_fn progress; /* options.progress, or NULL */
    void *progress_user;
} mr_simplify_plan;

struct mr_simplifier {
    mr_simplify_plan plan;
    mr_collapse_mesh m;
    mr_quadricf *q;          /* per vertex, relative to its position */
    mr_collapse_limits limits;
    int half;
    int keep_volume;         /* MR_QUALITY_BEST: volume-preserving targets
                                (mr_simplifier_place) */
    int memoryless;          /* MR_QUALITY_BEST with an edge strategy:
                                Lindstrom-Turk's placement and cost
                                (cost.c, mr_simplifier_plan_edge) */
    double memoryless_scale; /* its costs' unit: 1 / (2 mean triangle area)^2 */
    double memoryless_limit; /* the error bound (normalised, squared) its
                                plans test themselves, or INFINITY */
    void *state;             /* the strategy's, owned by the entry through
                                the strategy's verbs */
    mr_simplify_stats profile; /* the strategy's counts (its profile fields) */
    bool cancelled;          /* the progress callback asked to stop */
    double reported;         /* the last fraction reported */
    double fit_share;        /* of the progress, the surface fit's part
                                (MR_QUALITY_BEST); the collapses report
                                the rest */
    double centre[3], scale, diagonal;
    double error_base;       /* bounding-box diagonal of all the input's
                                vertices: relative errors are relative to it */
    float lo[3], hi[3];      /* bounding box of the referenced input vertices */
    double box[3];           /* its half extents, normalised: targets stay
                                inside (|target[k]| <= box[k]) */
    uint32_t *order;         /* or NULL: working triangle t is input triangle
                                order[t] (plan.spatial_order: setup.c's
                                spatial_order); from mr_simplifier_init until
                                the caller frees it (mr_mesh_simplify reorders
                                its corners by it) */
    size_t input_vertices;
    size_t corners;          /* flagged MR_VF_CORNER, until released */
    size_t blocked_vertices; /* non-manifold or inconsistently wound: locked */
    mr_simplify_stop stop;   /* why the run stopped (mr_simplifier_finish) */
    size_t pruned;           /* parts dropped by options.prune */
    /* Attribute hooks (mr_mesh_simplify): extra validity, and an action
     * before a collapse r -> k to target is applied. */
    bool (*attr_valid)(const mr_simplifier *s, uint32_t r, uint32_t k);
    void (*attr_apply)(const mr_simplifier *s, uint32_t r, uint32_t k, const double target[3]);
    /* The attributes' part of a collapse of edge (u, w), as a quadric in
     * the position alone (their values at each position at their best):
     * added to q, relative to w's position, with no weight. Reads what
     * attr_valid reads, and u's and w's wedges. */
    void (*attr_cost)(const mr_simplifier *s, uint32_t u, uint32_t w, mr_quadric *q);
    /* A hint that attr_cost of edge (u, w) comes soon (or NULL). */
    void (*attr_prefetch)(const mr_simplifier *s, uint32_t u, uint32_t w);
    /* When the run ends short of its targets: loosen the attribute rules
     * for one more stage (mr_simplify_run); whether anything changed. */
    bool (*attr_release)(mr_simplifier *s);
    void *attr;              /* the hooks' own state: they write only through it */
    const uint8_t *cut;      /* the marks' cut vertices (a chunk's), or NULL */
};

/* Blocks of triangles of the working order, and the blocks in a group of
 * its first level: the batched strategy works in them, and setup.c decides
 * by them whether to reorder the triangles (plan.spatial_order). */
#define MR_BATCH_BLOCK_TRIANGLES 4096
#define MR_BATCH_FIRST_SHIFT 2

/* Are the plan's targets met? */
static inline bool mr_simplifier_reached(const mr_simplifier *s)
{
    const mr_simplify_goal *g = &s->plan.goal;
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
static inline double mr_simplifier_error(const mr_simplifier *s, double e)
{
    return s->plan.error_absolute ? e * s->diagonal : e * s->diagonal / s->error_base;
}

/* The inverse: an error in the options' terms as a normalised distance
 * (normalised by the referenced vertices' diagonal; relative errors are
 * relative to the whole input's). */
static inline double mr_simplifier_normalised(const mr_simplifier *s, double e)
{
    return (s->plan.error_absolute ? e : e * s->error_base) / s->diagonal;
}

/* ---- setup.c: the set-up, the release */
/* The options' checks that hold for every strategy (the entry checks the
 * strategy's own). */
mr_status mr_simplify_check_options(const mr_simplify_options *o, size_t input_triangles,
                                    mr_error *err);
/* The working mesh, its quadrics and corners, and the plan: *plan is the
 * strategy's part (the entry's), completed from o into s->plan; marks
 * (optional) as above, kept until mr_simplifier_free. o must have passed
 * mr_simplify_check_options. On failure s is left freed. */
mr_status mr_simplifier_init(mr_simplifier *s, const float *positions, size_t stride,
                             size_t vertex_count, const uint32_t *indices,
                             size_t triangle_count, const mr_simplify_options *o,
                             const mr_simplify_plan *plan, const mr_vertex_marks *marks,
                             mr_error *err);
/* Release the quadrics, keeping the mesh (before the surface fit, whose
 * arrays would otherwise come on top of them, and before the output). The
 * strategy's state is the entry's to release first. */
void mr_simplifier_release_quadrics(mr_simplifier *s);
/* Free the core's state (the strategy's must be gone: s->state NULL). */
void mr_simplifier_free(mr_simplifier *s);
/* Is (v, x) an edge of the polyline that mr_simplifier_mark_corners
 * looks at (an open boundary, a seam)? */
typedef bool (*mr_line_edge)(const mr_simplifier *s, uint32_t v, uint32_t x);
/* Flag MR_VF_CORNER the vertices flagged `line` (and not locked) where
 * their polyline, the edges on_line takes, turns sharply between two
 * straight runs (setup.c, is_corner); returns how many. mr_simplifier_init
 * marks the open boundaries' corners, mr_mesh_simplify its seams'. */
size_t mr_simplifier_mark_corners(mr_simplifier *s, uint8_t line, mr_line_edge on_line);
/* Clear every MR_VF_CORNER: the corners may move from now on. */
void mr_simplifier_release_corners(mr_simplifier *s);

/* ---- cost.c: costs, plans, validity, the collapse */
/* The full collapse of edge (u, w): the target relative to w's position
 * (x) and the cost, by the collapse rules (INFINITY when neither end may
 * go onto the other). */
double mr_simplifier_full_cost(const mr_simplifier *s, uint32_t u, uint32_t w, double x[3]);
/* The half-edge collapse u -> w (u moves onto w): its cost. */
double mr_simplifier_half_cost(const mr_simplifier *s, uint32_t u, uint32_t w);
/* The collapse behind u's queue entry (u, w) -- half: u goes onto w;
 * full: to the optimum, a pinned end stays, else u goes -- as r removed,
 * k kept, target; returns its cost. */
double mr_simplifier_plan(const mr_simplifier *s, uint32_t u, uint32_t w, uint32_t *r,
                          uint32_t *k, double target[3]);
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
/* The memoryless mode's cost of a collapse past the error bound: finite, so
 * that the stop reason says "error bound", and above the goal's limit
 * (setup.c) in that mode. */
#define MR_MEMORYLESS_OVER 1e300
/* The largest error the collapses left (normalised distance): in the
 * memoryless mode the strategies' costs are no distances, so the run
 * reports the vertices' quadric errors instead (cost.c). */
double mr_simplifier_vertex_error(const mr_simplifier *s);

/* Fit the output's vertices to the input's surface (MR_QUALITY_BEST's last
 * step, after the strategy; refine.c): the input as mr_simplifier_init got
 * it. */
mr_status mr_simplifier_refine(mr_simplifier *s, const float *positions, size_t stride,
                               const uint32_t *indices, size_t triangle_count, mr_error *err);
/* The fit's last step: every pair of the live triangles (nlive, vertex ids
 * below vc) that meets at pos gets its vertices put back to before -- their
 * positions before the fit -- unless one of them is a vertex of a triangle
 * that met another at before already (where the surface crossed itself,
 * the fit moves the crossing: that is no new one); so does every triangle
 * that this flips or turns further than min_cos from before, until none is
 * left (each round puts back a moved vertex: at worst all of them, the
 * collapses' surface). *put_back: the vertices put back. */
mr_status mr_fit_untangle(float *pos, const float *before, size_t vc, const uint32_t *live,
                          size_t nlive, double min_cos, int threads, size_t *put_back,
                          mr_error *err);
/* May the planned collapse r -> k (to target, at cost) happen now: its
 * cost finite and within limit, the mesh's tests (mr_collapse_valid) and
 * the attribute hook's? The one test every strategy makes: after
 * mr_simplifier_place, for a full collapse. */
bool mr_simplifier_allowed(const mr_simplifier *s, uint32_t r, uint32_t k, const double target[3],
                           double cost, double limit);
/* Where a planned collapse r -> k goes: the best quality's full collapses
 * move to the point that keeps the enclosed volume (Lindstrom-Turk's first
 * constraint; target and *cost are updated), every other collapse stays
 * as planned. Every strategy calls it between the plan and
 * mr_simplifier_allowed, on the ends' clean lists. */
void mr_simplifier_place(const mr_simplifier *s, uint32_t r, uint32_t k, double target[3],
                         double *cost);
/* Is u's queue entry (u, w) allowed (mr_simplifier_plan, then
 * mr_simplifier_allowed with no limit)? Its cost in *cost when not NULL. */
bool mr_simplifier_valid(const mr_simplifier *s, uint32_t u, uint32_t w, double *cost);
/* Apply a valid planned collapse: attribute hook, quadrics, mesh. */
void mr_simplifier_collapse(mr_simplifier *s, uint32_t r, uint32_t k, const double target[3]);
/* The same for one of several concurrent collapses (mr_collapse_apply_at
 * says which may run together): the merged list goes to out, the removed
 * vertices to *removed; returns the deleted triangles. Writes only what
 * the collapse owns (its ends, their triangles, k's quadric, and through
 * the attribute hook r's corners and k's wedges), and its opposite
 * vertices' dead[] counts, atomically (their lists stay as they are). */
unsigned mr_simplifier_collapse_at(mr_simplifier *s, uint32_t r, uint32_t k,
                                   const double target[3], uint32_t *out, size_t *removed);

/* ---- output.c: the end of a run */
/* After the strategy: why it stopped (s->stop) and the pruning
 * (s->pruned); max_error is the run's (in the options' units). */
void mr_simplifier_finish(mr_simplifier *s, double max_error);
mr_status mr_simplifier_output(const mr_simplifier *s, const float *positions, size_t stride,
                               mr_simplified *out, mr_error *err);
/* Vertex v's quadric for the next run of a chunked job (qem/chunk.h):
 * moved from where the run left v (run_pos: 3 * vertex_count normalised
 * positions) to out_pos (model units), in the job's length unit. */
void mr_simplifier_quadric_out(const mr_simplifier *s, uint32_t v, const float *run_pos,
                               const float out_pos[3], double unit, mr_quadricf *dst);

/* Report `fraction` of the whole call done (plan.progress, when set)
 * from the calling thread; true when the callback asked to stop
 * (s->cancelled is then set): the strategy ends its run as at a reached
 * target, the surface fit after its sweep, and the caller fails with
 * MR_ERR_CANCELLED (mr_simplifier_cancelled). */
static inline bool mr_simplifier_report(mr_simplifier *s, double fraction)
{
    /* never backwards: a second stage of the run (the entry's) counts
     * from its own start */
    fraction = fraction > s->reported ? fraction : s->reported;
    s->reported = fraction;
    if (s->plan.progress && !s->cancelled &&
        s->plan.progress(fraction, s->plan.progress_user) != 0)
        s->cancelled = true;
    return s->cancelled;
}

/* The strategies' report: `fraction` of the collapses done. */
static inline bool mr_simplifier_progress(mr_simplifier *s, double fraction)
{
    return mr_simplifier_report(s, (1 - s->fit_share) * fraction);
}

/* The error of a cancelled run. */
mr_status mr_simplifier_cancelled(mr_error *err);

#endif
