/*
 * The working mesh of the edge-collapse simplifiers, on flat arrays, and the
 * two operations every simplifier (sequential, or parallel on a locked
 * neighbourhood) is built from: is a collapse valid, and apply it.
 * Internal, not part of the API.
 *
 * Storage, all flat and allocated once:
 *   - pos: float positions in normalised coordinates (see simplify.c);
 *   - tris: 3 vertex ids per triangle; a deleted triangle has
 *     tris[3t] == MR_COLLAPSE_NONE (degenerate input triangles start so);
 *   - per vertex the list of its live triangles, as corner ids 3t + j
 *     with tris[3t + j] == v (so v's corner is never searched for):
 *     refs[start[v] .. start[v] + count[v]). A collapse u -> v writes v's merged list at the
 *     end of refs (the old lists of u and v become garbage) and removes the
 *     deleted triangles from the lists of their third vertices in place. When
 *     refs is full, mr_collapse_reserve compacts it in place (no extra
 *     memory): the array is sized at 1 + 1/4 times the initial lists (3
 *     bytes a triangle), so that happens about once per 90,000 collapses on
 *     a 1M-triangle mesh;
 *   - per vertex flags (MR_VF_*).
 *
 * Topology classification (mr_collapse_mesh_init): a vertex whose edges all
 * have one or two consistently oriented triangles and whose triangles form
 * one fan is manifold (interior, or boundary when the fan is open); any
 * other referenced vertex -- on an edge of three or more triangles, on an
 * edge whose two triangles disagree in orientation, or with several fans
 * (bowtie) -- is flagged NONMANIFOLD and LOCKED and never collapses.
 * Unreferenced vertices are flagged REMOVED from the start.
 */
#ifndef MR_COLLAPSE_H
#define MR_COLLAPSE_H

#include "../../core/internal.h"
#include "../../mesh/adjacency.h"
#include "kernels.h"

#define MR_COLLAPSE_NONE UINT32_MAX

/* The validity test works on stack arrays for vertices of up to this many
 * triangles, and on heap arrays (sorting instead of comparing every pair)
 * beyond: a vertex of any valence may collapse. */
#define MR_COLLAPSE_MAX_DEGREE 128

enum {
    MR_VF_BOUNDARY = 1u << 0,    /* on an open boundary */
    MR_VF_LOCKED = 1u << 1,      /* never moves (lock_border, vertex_lock,
                                    non-manifold) */
    MR_VF_SEAM = 1u << 2,        /* on an attribute seam (mr_mesh_simplify) */
    MR_VF_REMOVED = 1u << 3,     /* collapsed away, or never referenced */
    MR_VF_MOVED = 1u << 4,       /* position differs from the input's */
    MR_VF_NONMANIFOLD = 1u << 5,
    MR_VF_BLOCKED = 1u << 6,     /* simplifier's bookkeeping: an edge at
                                    this vertex was found invalid and left
                                    the queue until the ring changes */
    MR_VF_CORNER = 1u << 7       /* where an open boundary or a seam turns
                                    (mr_simplifier_mark_corners): stays in
                                    place while the run can do without
                                    moving it */
};

typedef struct mr_collapse_mesh {
    size_t vertex_count, triangle_count;
    float *pos;          /* 3 * vertex_count, normalised coordinates */
    uint32_t *tris;      /* 3 * triangle_count */
    uint32_t *start;     /* vertex_count */
    uint32_t *count;     /* vertex_count */
    uint32_t *refs;      /* refs_capacity */
    size_t refs_size, refs_capacity;
    uint8_t *flags;      /* vertex_count, MR_VF_* */
    uint32_t *dead;      /* vertex_count, or NULL (lazy meshes only): the
                            deleted triangles v's list still holds (a
                            "dirty" list when nonzero; kept apart from the
                            flags, which other collapses read meanwhile) */
    bool lazy;           /* long lists keep deleted triangles until cleaned */
    size_t live_vertices;  /* referenced, not removed */
    size_t live_triangles;
    int threads;         /* compaction's team (mr_collapse_compact) */
    int level;           /* omp_get_level() where the mesh was made: deeper,
                            compaction runs on the calling team */
    size_t *seg;         /* 3 * (threads + 1): compaction's segments */
    uint64_t *alive;     /* a bit per triangle, set when live: compaction's
                            (valid only during one) */
} mr_collapse_mesh;

/* Limits of mr_collapse_valid. */
typedef struct mr_collapse_limits {
    double min_cos_turn; /* a triangle's normal may turn by an angle whose
                            cosine is at least this (>= 0: flips are
                            always refused) */
    int half_edge;       /* half-edge collapse: u may not leave the
                            boundary (or a seam) for an inner vertex */
    const mr_kernels *kernels; /* the vector kernels (fan_ok) */
} mr_collapse_limits;

/* Build the working mesh: positions are normalised as (p - centre) *
 * scale and stored as float; triangle t is input triangle order[t]
 * (order NULL: t). Indices must be in range. Positions and
 * classification run on up to `threads` threads (same result on any
 * number). On failure the mesh is left empty (safe to free). */
mr_status mr_collapse_mesh_init(mr_collapse_mesh *m, const float *positions, size_t stride,
                                size_t vertex_count, const uint32_t *indices,
                                size_t triangle_count, const uint32_t *order,
                                const double centre[3], double scale, int threads,
                                mr_error *err);
void mr_collapse_mesh_free(mr_collapse_mesh *m);

/* v's list: corner ids 3t + j, tris[3t + j] == v. */
static inline const uint32_t *mr_collapse_vertex_tris(const mr_collapse_mesh *m, uint32_t v)
{
    return m->refs + m->start[v];
}

/* The head of half-edge h = 3t + j: the corner after j in triangle t. */
static inline uint32_t mr_collapse_he_dst(const mr_collapse_mesh *m, uint32_t h)
{
    const uint32_t j = h % 3;
    return m->tris[h - j + mr_local_next(j)];
}

static inline void mr_collapse_load(const mr_collapse_mesh *m, uint32_t v, double p[3])
{
    p[0] = m->pos[3 * v];
    p[1] = m->pos[3 * v + 1];
    p[2] = m->pos[3 * v + 2];
}

/*
 * Prefetch hints for a collapse at vertex v that comes soon, in stages
 * (each reads only what the one before brought in): 0, v's list head; 1,
 * the list; 2, its triangles. A caller with a batch of collapses runs
 * stage s for the collapse a few turns ahead, later stages nearer, so
 * that a validity test does not wait for memory one load at a time.
 */
static inline void mr_collapse_prefetch(const mr_collapse_mesh *m, uint32_t v, int stage)
{
    if (stage == 0) {
        __builtin_prefetch(m->start + v);
        __builtin_prefetch(m->count + v);
        return;
    }
    const uint32_t *list = m->refs + m->start[v];
    const uint32_t n = m->count[v] < 16 ? m->count[v] : 16;
    if (stage == 1) {
        __builtin_prefetch(list);
        __builtin_prefetch(list + n);
        return;
    }
    for (uint32_t i = 0; i < n; i++)
        __builtin_prefetch(m->tris + list[i]);
}

/* Number of live triangles with both vertices v and w (from v's list). */
uint32_t mr_collapse_edge_triangles(const mr_collapse_mesh *m, uint32_t v, uint32_t w);

/*
 * May edge (u, v) collapse, u removed and v kept at `target` (normalised
 * coordinates)? True only when the mesh stays a valid 2-manifold of the
 * same topology: (1) the link condition (the common neighbours of u and v
 * are exactly the opposite vertices of the one or two triangles on the
 * edge); (2) no other triangle around u (or around v when v moves) flips,
 * turns by more than the limit, or degenerates; (3) no duplicate
 * triangle arises; (4) two boundary vertices only collapse along a
 * boundary edge, and the last triangles of a component never vanish;
 * (5) a LOCKED or CORNER vertex never moves. Reads only the triangles of u and v and
 * the flags and positions of their vertices.
 */
bool mr_collapse_valid(const mr_collapse_mesh *m, uint32_t u, uint32_t v,
                       const double target[3], const mr_collapse_limits *limits);

/* Room for one more collapse of u and v in refs: compacts refs when
 * needed. Needs exclusive access to the whole mesh. refs keeps room for
 * one list per live triangle beyond all live lists, the most a merged
 * list can hold. */
void mr_collapse_reserve(mr_collapse_mesh *m, uint32_t u, uint32_t v);

/*
 * Lists of a lazy mesh (m->lazy): taking a deleted triangle out of a list
 * of more than 64 entries would cost the list's length at every deletion
 * -- quadratic around a vertex of huge valence (the centre of a fanned
 * polygon loses a triangle with every collapse on its rim). Such a list
 * keeps the entry and counts it in dead[] (the list is then dirty);
 * it is cleaned once half of it is dead, at compaction, and by this call,
 * which every reader of a dirty list makes first: the collapse's
 * two ends before mr_collapse_valid and mr_collapse_apply (they assert
 * it). A deleted triangle's entries never match a vertex
 * (mr_collapse_edge_triangles counts right on a dirty list). Writes only
 * v's list, count and dead[v].
 */
void mr_collapse_clean(mr_collapse_mesh *m, uint32_t v);

/* Does v's list still hold deleted triangles? */
static inline bool mr_collapse_dirty(const mr_collapse_mesh *m, uint32_t v)
{
    return m->dead && m->dead[v];
}

/*
 * Collapse u into v, v moving to `target`: the triangles on the edge are
 * deleted, u's other triangles now use v, v's list becomes the merged one,
 * u is flagged REMOVED and v inherits u's BOUNDARY and SEAM flags. The
 * collapse must be valid and mr_collapse_reserve called before. Writes
 * only u, v, their triangles, the lists of the opposite vertices, and the
 * end of refs. Returns the number of deleted triangles (1 or 2).
 */
unsigned mr_collapse_apply(mr_collapse_mesh *m, uint32_t u, uint32_t v,
                           const double target[3]);

/*
 * What one collapse u -> v touches, so that several can run at once (the
 * batched strategy's rounds):
 *   reads   the lists of u and v, their triangles, the flags and positions
 *           of every vertex of those triangles (the closed 1-rings of u and
 *           v: mr_collapse_valid), and the counts of the opposite vertices
 *           (the third vertices of the edge's triangles);
 *   writes  u and v (position, flags, start, count), their triangles
 *           (relabelled or deleted), the merged list's slots, and of each
 *           opposite vertex dead[] (atomically when `shared`: its list is
 *           then left as it is, the entry only counted dead, so that two
 *           collapses may share an opposite vertex; else its list and
 *           count too) and, for an ear's tip (whose only triangle is on the
 *           edge), the REMOVED flag.
 * It changes no other vertex's position, flags or list. So two shared
 * collapses A and B commute, and may run at the same time, when no end of
 * A shares a triangle with an end of B (a symmetric relation); each one's
 * validity then still holds after the other. Global state -- refs_size,
 * live_vertices, live_triangles, allocating dead[] -- is left to the
 * caller: this form writes v's merged list at `out` (room for count[u] +
 * count[v] - 1 entries inside refs, handed out by the caller: the
 * collapse deletes at least one triangle, which is in both lists, and the
 * merge writes at most one entry past its end), stores the vertices it removes (u, and
 * an ear's tip) in *removed, and returns the triangles it deletes. The
 * caller zeroes the slots the list leaves unused (no compaction tag may
 * stay behind) and sets refs_size past them. `shared` needs a lazy mesh
 * with dead[] allocated (mr_collapse_prepare).
 */
unsigned mr_collapse_apply_at(mr_collapse_mesh *m, uint32_t u, uint32_t v,
                              const double target[3], uint32_t *out, size_t *removed,
                              bool shared);

/* Allocate dead[] for a lazy mesh (before collapses run concurrently; a
 * mesh without it removes entries eagerly, which is slower, not wrong). */
void mr_collapse_prepare(mr_collapse_mesh *m);

/* Compact refs now (exclusive access): afterwards the free room is at
 * least one entry per live triangle. Runs on up to m->threads threads;
 * inside a parallel region opened since the mesh was made (m->level),
 * every thread of that team must call it (it shares the work out and
 * meets the others at barriers). The layout it
 * leaves -- every live list in the order the lists lay in refs, from 0 --
 * is the same on any number of threads. */
void mr_collapse_compact(mr_collapse_mesh *m);

#endif /* MR_COLLAPSE_H */
