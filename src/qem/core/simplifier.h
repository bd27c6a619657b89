/*
 * The simplifier core's state and phases, shared by the strategies
 * (greedy.c, batched.c), the dispatcher that picks one (simplify.c:
 * mr_simplify) and mr_mesh_simplify (attributes). Internal.
 *
 * A run: mr_simplifier_init (setup.c; mr_mesh_simplify then adds its seams
 * and hooks), mr_simplifier_fill_queue (the strategy's queue or candidate
 * arrays), mr_simplifier_run (the strategy, then why it stopped and the
 * pruning: output.c), the output, mr_simplifier_free.
 */
#ifndef MR_SIMPLIFY_INTERNAL_H
#define MR_SIMPLIFY_INTERNAL_H

#include "../../mesh/adjacency.h"
#include "collapse.h"
#include "quadric.h"

typedef struct mr_simplifier mr_simplifier;
/* greedy.c's state (its heap), from mr_simplifier_greedy_init to the end
 * of mr_simplifier_run_greedy. */
typedef struct mr_greedy mr_greedy;

/* batched.c's state (its own file), from mr_simplifier_batched_init to
 * mr_simplifier_free. */
typedef struct mr_batched mr_batched;

/* parallel/queued.c's state (the concurrent-queue strategies), from
 * mr_simplifier_queued_init to the end of mr_simplifier_run_queued. */
typedef struct mr_queued mr_queued;

/* partitioned.c's state, from mr_simplifier_partitioned_init to
 * mr_simplifier_free. */
typedef struct mr_partitioned mr_partitioned;

/* Is strategy x one of the concurrent-queue ones (parallel/queued.c)? */
static inline bool mr_strategy_queued(int x)
{
    return x >= MR_STRATEGY_PPQ && x <= MR_STRATEGY_MULTIQUEUE;
}

/* What the partitioned strategy counts (mr_simplify_stats' fields). */
typedef struct mr_partition_profile {
    size_t passes, interior, boundary, boundary_seq, tail, rebalances;
    size_t deferred;     /* the boundary-aware variant's claim conflicts */
    size_t trigger[4];   /* its rebalances by trigger (MR_TRIGGER_*) */
} mr_partition_profile;

/* The boundary-aware variant's rebalance triggers, as counted. */
enum { MR_TRIGGER_COUNT, MR_TRIGGER_IMBALANCE, MR_TRIGGER_BOUNDARY, MR_TRIGGER_ACCEPTANCE };

/* What the concurrent-queue strategies count, summed over the threads
 * (mr_simplify_stats' profile fields). */
typedef struct mr_queued_profile {
    size_t pops, locks, lock_failures, checks, updates, compactions;
} mr_queued_profile;

struct mr_simplifier {
    mr_collapse_mesh m;
    mr_quadricf *q;          /* per vertex, relative to its position */
    mr_collapse_limits limits;
    int half;
    int keep_volume;         /* MR_QUALITY_BEST: volume-preserving targets
                                (mr_simplifier_keep_volume) */
    int memoryless;          /* MR_QUALITY_BEST with an edge strategy:
                                Lindstrom-Turk's placement and cost
                                (cost.c, mr_simplifier_plan_edge) */
    double memoryless_scale; /* its costs' unit: 1 / (2 mean triangle area)^2 */
    double memoryless_limit; /* the error bound (normalised, squared) its
                                plans test themselves, or INFINITY */
    int batched;             /* MR_STRATEGY_BATCHED: see batched.c */
    mr_greedy *greedy;       /* else greedy.c's, while it runs */
    mr_batched *bt;          /* else batched.c's */
    int queued;              /* the strategy when MR_STRATEGY_PPQ ..
                                _MULTIQUEUE (queued.c), else 0 */
    unsigned filter_levels, multiqueue_factor; /* its options */
    mr_queued *qd;           /* its state, while it runs */
    mr_queued_profile profile; /* its counts, after the run */
    int partitioned;         /* MR_STRATEGY_PARTITIONED(_BOUNDARY): partitioned.c */
    int boundary_aware;      /* MR_STRATEGY_PARTITIONED_BOUNDARY:
                                partitioned_boundary.c's run */
    unsigned partitions;     /* its slabs (options.partitions, or the default) */
    mr_partitioned *pt;      /* its state */
    mr_partition_profile pprofile; /* its counts, after the run */
    int threads;             /* threads the run may use (options.threads) */
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
                                order[t] (batched: setup.c's spatial_order);
                                from mr_simplifier_init until the caller
                                frees it (mr_mesh_simplify reorders its
                                corners by it) */
    size_t input_vertices;
    size_t corners;          /* flagged MR_VF_CORNER, until released */
    size_t blocked_vertices; /* non-manifold or inconsistently wound: locked */
    mr_simplify_stop stop;   /* why mr_simplifier_run stopped */
    size_t pruned;           /* parts dropped by options.prune */
    /* Attribute hooks (mr_mesh_simplify): extra validity, and an action
     * before a collapse r -> k to target is applied. */
    bool (*attr_valid)(const mr_simplifier *s, uint32_t r, uint32_t k);
    void (*attr_apply)(const mr_simplifier *s, uint32_t r, uint32_t k, const double target[3]);
    void *attr;              /* the hooks' own state: they write only through it */
};

/* batched.c's blocks of triangles and the blocks in a group at its first
 * level (setup.c decides by them whether to reorder the triangles). */
#define MR_BATCH_BLOCK_TRIANGLES 4096
#define MR_BATCH_FIRST_SHIFT 2

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

/* ---- the vertex queues' candidates (greedy.c, parallel/queued.c) */
/*
 * Calls visit(w) for every neighbour w of u: the vertex after u in each of
 * its triangles, which covers every inner edge once; plus the vertex before
 * u when both ends are on a boundary (a boundary edge is seen from one
 * side only). Some edges may be visited twice, which is harmless.
 */
#define MR_FOR_EACH_NEIGHBOUR(s, u, w, ...)                                           \
    do {                                                                              \
        const mr_collapse_mesh *m_ = &(s)->m;                                         \
        const uint32_t *list_ = mr_collapse_vertex_tris(m_, (u));                     \
        const uint32_t n_ = m_->count[(u)];                                           \
        const bool ub_ = (m_->flags[(u)] & (MR_VF_BOUNDARY | MR_VF_SEAM)) != 0;       \
        for (uint32_t i_ = 0; i_ < n_; i_++) {                                        \
            const uint32_t k_ = list_[i_] % 3;                                        \
            const uint32_t *t_ = m_->tris + (list_[i_] - k_);                         \
            {                                                                         \
                const uint32_t w = t_[k_ == 2 ? 0 : k_ + 1];                          \
                __VA_ARGS__                                                           \
            }                                                                         \
            if (ub_) {                                                                \
                const uint32_t w = t_[k_ == 0 ? 2 : k_ - 1];                          \
                if (m_->flags[w] & (MR_VF_BOUNDARY | MR_VF_SEAM)) {                   \
                    __VA_ARGS__                                                       \
                }                                                                     \
            }                                                                         \
        }                                                                             \
    } while (0)

/* ---- setup.c: the set-up, the targets, the release */
mr_status mr_simplify_check_options(const mr_simplify_options *o, size_t input_vertices,
                                    size_t input_triangles, mr_error *err);
mr_status mr_simplifier_init(mr_simplifier *s, const float *positions, size_t stride,
                             size_t vertex_count, const uint32_t *indices,
                             size_t triangle_count, const mr_simplify_options *o,
                             const uint8_t *extra_flags, mr_error *err);
void mr_simplifier_targets(const mr_simplifier *s, const mr_simplify_options *o,
                           mr_simplify_goal *g);
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
/* May the planned collapse r -> k (to target, at cost) happen now: its
 * cost finite and within limit, the mesh's tests (mr_collapse_valid) and
 * the attribute hook's? The one test every strategy makes. */
/* Move a planned full collapse's target to keep the enclosed volume
 * (MR_QUALITY_BEST; cost.c), its cost to that point's. Nothing to do in
 * the memoryless mode, whose plans keep the volume already. */
void mr_simplifier_keep_volume(const mr_simplifier *s, uint32_t r, uint32_t k, double target[3],
                               double *cost);
/* The memoryless mode's cost of a collapse past the error bound: finite, so
 * that the stop reason says "error bound", and above the goal's limit
 * (mr_simplifier_targets) in that mode. */
#define MR_MEMORYLESS_OVER 1e300
/* The largest error the collapses left (normalised distance): in the
 * memoryless mode the strategies' costs are no distances, so the run
 * reports the vertices' quadric errors instead (cost.c). */
double mr_simplifier_vertex_error(const mr_simplifier *s);

/* Release what only the run needed -- the quadrics and the strategy's
 * state -- keeping the mesh (before the surface fit, whose arrays would
 * otherwise come on top of them). */
void mr_simplifier_release_run(mr_simplifier *s);
/* Fit the output's vertices to the input's surface (MR_QUALITY_BEST's last
 * step, after the strategy; refine.c): the input as mr_simplifier_init got
 * it. */
mr_status mr_simplifier_refine(mr_simplifier *s, const mr_simplify_options *o,
                               const float *positions, size_t stride, const uint32_t *indices,
                               size_t triangle_count, mr_error *err);
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
bool mr_simplifier_allowed(const mr_simplifier *s, uint32_t r, uint32_t k, const double target[3],
                           double cost, double limit);
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
/* After the strategy: why it stopped (s->stop) and options.prune
 * (s->pruned); max_error is the run's. */
void mr_simplifier_finish(mr_simplifier *s, const mr_simplify_options *o, double max_error);
mr_status mr_simplifier_output(const mr_simplifier *s, const float *positions, size_t stride,
                               mr_simplified *out, mr_error *err);

/* ---- simplify.c: the dispatcher, which alone picks the strategy */
mr_status mr_simplifier_fill_queue(mr_simplifier *s, mr_error *err);
size_t mr_simplifier_run(mr_simplifier *s, const mr_simplify_options *o, double *max_error);

/* Report `fraction` of the whole call done (options.progress, when set)
 * from the calling thread; true when the callback asked to stop
 * (s->cancelled is then set): the strategy ends its run as at a reached
 * target, the surface fit after its sweep, and the caller fails with
 * MR_ERR_CANCELLED (mr_simplifier_cancelled). */
static inline bool mr_simplifier_report(mr_simplifier *s, const mr_simplify_options *o,
                                        double fraction)
{
    /* never backwards: a second stage of the run (mr_simplifier_run)
     * counts from its own start */
    fraction = fraction > s->reported ? fraction : s->reported;
    s->reported = fraction;
    if (o->progress && !s->cancelled && o->progress(fraction, o->progress_user) != 0)
        s->cancelled = true;
    return s->cancelled;
}

/* The strategies' report: `fraction` of the collapses done. */
static inline bool mr_simplifier_progress(mr_simplifier *s, const mr_simplify_options *o,
                                          double fraction)
{
    return mr_simplifier_report(s, o, (1 - s->fit_share) * fraction);
}

/* The error of a cancelled run. */
mr_status mr_simplifier_cancelled(mr_error *err);

/* ---- the strategies: start (fill the queue), run */
mr_status mr_simplifier_greedy_init(mr_simplifier *s, mr_error *err);
size_t mr_simplifier_run_greedy(mr_simplifier *s, const mr_simplify_options *o,
                                double *max_error);
mr_status mr_simplifier_batched_init(mr_simplifier *s, mr_error *err);
void mr_simplifier_batched_free(mr_simplifier *s);
size_t mr_simplifier_run_batched(mr_simplifier *s, const mr_simplify_options *o,
                                 double *max_error);
mr_status mr_simplifier_queued_init(mr_simplifier *s, mr_error *err);
void mr_simplifier_queued_free(mr_simplifier *s);
size_t mr_simplifier_run_queued(mr_simplifier *s, const mr_simplify_options *o,
                                double *max_error);
mr_status mr_simplifier_partitioned_init(mr_simplifier *s, mr_error *err);
void mr_simplifier_partitioned_free(mr_simplifier *s);
size_t mr_simplifier_run_partitioned(mr_simplifier *s, const mr_simplify_options *o,
                                     double *max_error);
size_t mr_simplifier_run_partitioned_boundary(mr_simplifier *s, const mr_simplify_options *o,
                                              double *max_error);
/* A run's profile as mr_simplify_stats' fields. */
void mr_queued_profile_stats(const mr_queued_profile *p, mr_simplify_stats *stats);
void mr_partition_profile_stats(const mr_partition_profile *p, mr_simplify_stats *stats);
/* For the tests: vertex v's slab (or shifted slab), whether edge (a, b)
 * is interior to a shifted slab (the boundary step's test), and the
 * candidates a pass of the partitioned strategy would gather now (no cost
 * limit), each with whether it is interior; returns their number (at most
 * cap are stored). */
unsigned mr_partitioned_slab(const mr_simplifier *s, uint32_t v, bool shifted_slabs);
bool mr_partitioned_shifted_interior(const mr_simplifier *s, uint32_t a, uint32_t b);
size_t mr_partitioned_edges(mr_simplifier *s, uint32_t *a, uint32_t *b, uint8_t *interior,
                            size_t cap);

#endif
