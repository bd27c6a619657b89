/*
 * meshreduce — reduce triangle meshes and point clouds, fast, on every core.
 *
 * This is the only header a user includes. Conventions:
 *   - every name is prefixed mr_ (types, functions) or MR_ (macros, enum values);
 *   - the algorithms take flat arrays (float positions with a byte stride,
 *     uint32_t triangle indices), so callers need not adopt a mesh type;
 *     mr_mesh is an owning container for file I/O and the command-line tool;
 *   - every fallible call returns an mr_status and, when given a non-NULL
 *     mr_error, fills it with a message naming the file, the line or byte
 *     offset, and what is wrong. The library never prints, exits or aborts on
 *     bad input;
 *   - options structs are initialised by mr_*_options_default() so that
 *     fields can be added without breaking callers;
 *   - calls run on OpenMP teams of the `threads` they are given. Any call
 *     may run at the same time as others on the caller's threads, also from
 *     inside the caller's own OpenMP parallel region: with nesting off
 *     (OpenMP's default) its teams then have one thread each, with the same
 *     result. The simplifier turns OMP_DYNAMIC's adjustment off for the
 *     length of a call and restores the caller's setting.
 */
#ifndef MESHREDUCE_H
#define MESHREDUCE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MR_VERSION_MAJOR 0
#define MR_VERSION_MINOR 3
#define MR_VERSION_PATCH 0
#define MR_VERSION_STRING "0.3.0"

/* ------------------------------------------------------------------------ */
/* Status and errors                                                        */
/* ------------------------------------------------------------------------ */

typedef enum mr_status {
    MR_OK = 0,
    MR_ERR_INVALID_ARGUMENT, /* a bad option or argument from the caller */
    MR_ERR_IO,               /* a file could not be opened, read or written */
    MR_ERR_PARSE,            /* a file's content is malformed */
    MR_ERR_UNSUPPORTED,      /* well-formed but not supported (format, type) */
    MR_ERR_EMPTY,            /* the input holds nothing to work on */
    MR_ERR_TOO_LARGE,        /* counts beyond what 32-bit indices can address */
    MR_ERR_NO_MEMORY,        /* an allocation failed */
    MR_ERR_CANCELLED         /* the progress callback asked to stop */
} mr_status;

/* Sentinel for mr_error.line and mr_error.offset when they do not apply. */
#define MR_NO_POSITION UINT64_MAX

typedef struct mr_error {
    mr_status status;
    uint64_t line;      /* 1-based line in a text file, or MR_NO_POSITION */
    uint64_t offset;    /* byte offset in the file, or MR_NO_POSITION */
    char message[512];  /* full text, e.g. "bunny.obj:12: face index 0 ..." */
} mr_error;

/* A short constant name for a status ("parse error", ...). */
const char *mr_status_string(mr_status status);

/* Version string of the library that is linked in. */
const char *mr_version(void);

/* ------------------------------------------------------------------------ */
/* The owning mesh                                                          */
/* ------------------------------------------------------------------------ */

/*
 * Vertices are stored as tightly packed arrays; attribute arrays are NULL
 * when absent. A mesh with triangle_count == 0 is a point cloud.
 * Attributes are per vertex: a file whose corners use different texture
 * coordinates or normals for one position (UV seams, hard edges) is read as
 * several vertices at the same position.
 */
/* Texture coordinate sets besides the first (mr_mesh.more_texcoords). */
#define MR_MORE_TEXCOORDS 3

typedef struct mr_mesh {
    size_t vertex_count;
    size_t triangle_count;
    float *positions;   /* 3 * vertex_count: x y z */
    float *normals;     /* 3 * vertex_count, or NULL */
    float *texcoords;   /* 2 * vertex_count: u v, or NULL; v = 0 is the
                           image's bottom row (OBJ's and PLY's way: glTF's
                           v, which points down, is flipped on reading and
                           writing) */
    float *colors;      /* 4 * vertex_count: r g b a in [0, 1], or NULL */
    uint32_t *indices;  /* 3 * triangle_count, counter-clockwise */
    /* Since 0.3.0: what game and web assets carry besides (glTF's other
     * attributes, an OBJ's usemtl groups). Simplification carries them as
     * its surviving vertices had them (texture sets 1-3, joints and
     * weights: no blend is made), keeps each triangle's material (a
     * vertex two materials share is a seam), and leaves tangents out:
     * they follow the normals and texture coordinates it moves
     * (MikkTSpace tangents are the client's to make). */
    float *more_texcoords[MR_MORE_TEXCOORDS]; /* sets 1, 2, 3 (glTF
                           TEXCOORD_1..3): 2 * vertex_count each, v up as
                           texcoords', or NULL */
    float *tangents;    /* 4 * vertex_count: x y z, and w = +-1 the
                           bitangent's sign (bitangent = w * normal x
                           tangent), or NULL */
    uint16_t *joints;   /* 4 * vertex_count: skin joints (glTF JOINTS_0:
                           indices into the skin's joints), or NULL */
    float *weights;     /* 4 * vertex_count: their weights (WEIGHTS_0);
                           joints and weights are both set or both NULL */
    uint32_t *materials; /* triangle_count: each triangle's material, an
                           index into the file's (glTF's materials[], an
                           OBJ's usemtl names in order of first use), or
                           UINT32_MAX for none; or NULL */
} mr_mesh;

/* Flags for mr_mesh_alloc: which attribute arrays to allocate. */
enum {
    MR_ATTR_NORMALS = 1u << 0,
    MR_ATTR_TEXCOORDS = 1u << 1,
    MR_ATTR_COLORS = 1u << 2,
    MR_ATTR_TEXCOORDS1 = 1u << 3, /* more_texcoords[0]; [1] and [2] are */
    MR_ATTR_TEXCOORDS2 = 1u << 4, /* the next two flags */
    MR_ATTR_TEXCOORDS3 = 1u << 5,
    MR_ATTR_TANGENTS = 1u << 6,
    MR_ATTR_SKIN = 1u << 7,       /* joints and weights */
    MR_ATTR_MATERIALS = 1u << 8,  /* per triangle */
    /* the attributes simplification interpolates and weighs */
    MR_ATTR_BASIC = MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_COLORS
};

/* An empty mesh (all counts zero, all pointers NULL). */
void mr_mesh_init(mr_mesh *mesh);

/* Free every array of the mesh and reset it to empty. NULL is allowed. */
void mr_mesh_free(mr_mesh *mesh);

/* Allocate arrays for vertex_count vertices, triangle_count triangles and
 * the attributes in attr_flags (MR_ATTR_*). The contents are uninitialised.
 * The mesh must be empty (mr_mesh_init). On failure the mesh stays empty. */
mr_status mr_mesh_alloc(mr_mesh *mesh, size_t vertex_count, size_t triangle_count,
                        unsigned attr_flags, mr_error *err);

/* Deep copy. dst must be empty. */
mr_status mr_mesh_copy(mr_mesh *dst, const mr_mesh *src, mr_error *err);

/* The MR_ATTR_* flags of the attribute arrays present in the mesh. */
unsigned mr_mesh_attributes(const mr_mesh *mesh);

/* How many distinct materials the triangles have (none not counted; 0
 * without materials, or where the count's memory is not there). */
size_t mr_mesh_material_count(const mr_mesh *mesh);

/* ------------------------------------------------------------------------ */
/* File input and output                                                    */
/* ------------------------------------------------------------------------ */

typedef enum mr_format {
    MR_FORMAT_AUTO = 0, /* by extension, with content sniffing for PLY/STL */
    MR_FORMAT_OBJ,
    MR_FORMAT_PLY,
    MR_FORMAT_STL,
    MR_FORMAT_XYZ,      /* plain text point cloud: "x y z [nx ny nz]" lines */
    MR_FORMAT_GLTF      /* glTF 2.0 (.gltf with its buffers, or .glb): read as
                           its scene's triangles in world space; written as
                           one mesh (simplify keeps a glTF input's document:
                           mr_simplify_gltf) */
} mr_format;

typedef enum mr_encoding {
    MR_ENCODING_DEFAULT = 0, /* binary little endian for PLY/STL */
    MR_ENCODING_ASCII,
    MR_ENCODING_BINARY_LE,
    MR_ENCODING_BINARY_BE    /* PLY only */
} mr_encoding;

typedef struct mr_read_options {
    mr_format format;   /* MR_FORMAT_AUTO: from the extension and content */
    int threads;        /* 0 = all cores */
} mr_read_options;

typedef struct mr_write_options {
    mr_format format;      /* MR_FORMAT_AUTO: from the path's extension */
    mr_encoding encoding;
    int write_normals;     /* write the normals when the mesh has them (1) */
    int write_texcoords;   /* likewise for texture coordinates (1) */
    int write_colors;      /* likewise for colors (1) */
    /* OBJ only: its materials (all NULL/0 by default: none written). An
     * `mtllib` line with `mtllib` (the library file names, as the input's
     * mtllib lines gave them), and a `usemtl NAME` line before each run
     * of faces of one material: face_material[t] indexes
     * material_names (UINT32_MAX: no material; such faces go first, as
     * OBJ cannot switch back to none). */
    const char *mtllib;
    const char *const *material_names;
    size_t material_count;
    const uint32_t *face_material;  /* NULL: the mesh's own materials */
    /* The file the mesh's material ids come from (since 0.3.0), or NULL.
     * Into glTF, the materials become one primitive each and a glTF
     * material named by material_names; where materials_from is the OBJ
     * whose mtllib files define them (`mtllib` and material_names, or
     * else its own mtllib and usemtl lines), its Kd becomes the base
     * colour, d its alpha, and its map_Kd the base colour texture, held
     * in the file's buffer (a library or texture that cannot be read, or
     * a texture neither PNG nor JPEG, leaves the colour). Into OBJ from a
     * glTF (materials_from a .gltf
     * or .glb, material_names NULL): OUT's name with .mtl is written
     * beside it with a newmtl per glTF material (its name; Kd and d from
     * baseColorFactor; map_Kd its base colour texture, written beside as
     * OUT_K.png or .jpg), and the OBJ's mtllib and usemtl lines name
     * them; all the files or none. Joints and weights are not written
     * into a plain mesh's glTF (they need its skin: a glTF document keeps
     * it). */
    const char *materials_from;
} mr_write_options;

/* An OBJ file's materials: its mtllib lines' file names and each
 * triangle's usemtl (a face line of n corners is n - 2 triangles, in file
 * order, as mr_mesh_read reads them). */
typedef struct mr_obj_materials {
    char *mtllib;             /* the mtllib lines' file names, blank-separated,
                                 or NULL */
    char **names;             /* the usemtl names, in order of first use */
    size_t count;
    uint32_t *face_material;  /* triangle_count: an index into names, or
                                 UINT32_MAX before any usemtl */
    size_t triangle_count;
} mr_obj_materials;

/* Read an OBJ file's materials (a pass over its lines; no mesh). An OBJ
 * without usemtl lines gives count 0 and a NULL face_material. */
mr_status mr_obj_materials_read(const char *path, mr_obj_materials *materials, mr_error *err);
void mr_obj_materials_free(mr_obj_materials *materials);

void mr_read_options_default(mr_read_options *options);
void mr_write_options_default(mr_write_options *options);

/* Format named by a path's extension (case-insensitive: .obj .ply .stl
 * .xyz .gltf .glb), or MR_FORMAT_AUTO when it names none. */
mr_format mr_format_from_path(const char *path);

/* Format of a file's content: MR_FORMAT_PLY ("ply\n" magic),
 * MR_FORMAT_STL (ascii "solid ... facet" or a binary body whose size
 * matches its triangle count), else MR_FORMAT_AUTO. */
mr_format mr_format_sniff(const void *data, size_t size);

/* Read a mesh or point cloud. `mesh` must be empty; it stays empty on
 * failure. `options` may be NULL for the defaults. Large files are
 * memory-mapped. */
mr_status mr_mesh_read(const char *path, const mr_read_options *options,
                       mr_mesh *mesh, mr_error *err);

/* The vertex and triangle counts of a binary PLY file (polygons count as
 * their fans' triangles), from its header and its faces' vertex counts,
 * checked as mr_mesh_read checks them, without decoding the rest. Other
 * files: MR_ERR_UNSUPPORTED. */
mr_status mr_file_counts(const char *path, size_t *vertex_count, size_t *triangle_count,
                         mr_error *err);

/* Parse from memory. `name` is used in error messages (may be NULL). */
mr_status mr_mesh_read_memory(const void *data, size_t size, const char *name,
                              const mr_read_options *options, mr_mesh *mesh,
                              mr_error *err);

/* Write a mesh. A regular file appears complete or not at all: it is
 * written to a temporary file beside it and renamed into place, keeping an
 * existing file's permission bits. A symbolic link is followed (its target
 * is replaced); a dangling link is an error. Devices, FIFOs and /dev/stdout
 * are written in place. NaN or infinite values in what the format stores
 * are refused before any file is created. `options` may be NULL for the
 * defaults. */
mr_status mr_mesh_write(const char *path, const mr_mesh *mesh,
                        const mr_write_options *options, mr_error *err);

/* Remove the temporary files of the writes in progress, in every thread
 * (those of mr_mesh_write and mr_png_write), which a process killed in the
 * middle of a write would leave beside their destinations as hidden
 * ".meshreduce-PID-XXXXXX" files. Async-signal-safe: it calls only
 * unlink(), gettid() and clock_nanosleep(), with atomics, no lock and no
 * allocation; it covers a file being created at that moment on any
 * thread, the calling one included (it waits for another thread's open()
 * to return), and a removal another thread's call is making. Meant for
 * the handler of a signal that ends the process (SIGINT, SIGTERM, SIGHUP),
 * which the host program installs: the library installs no signal
 * handler. Keep the handler installed until the call returns (no
 * SA_RESETHAND: a second signal would end the process under it). Writes
 * still in progress then fail (their rename finds no file); writes that
 * start during the call wait for its end; a destination is never
 * touched. */
void mr_remove_pending_files(void);

/* ------------------------------------------------------------------------ */
/* Cleanup                                                                  */
/* ------------------------------------------------------------------------ */

/* Each returns MR_OK and the number of removed elements in *removed (may be
 * NULL). They keep the relative order of what stays. */

/* Remove vertices that no triangle references. Point clouds (no triangles)
 * are left unchanged. */
mr_status mr_mesh_remove_unreferenced(mr_mesh *mesh, size_t *removed, mr_error *err);

/* Merge vertices whose positions are bitwise equal (-0 and +0 count as
 * equal; and, when require_same_attributes is set, whose attributes are
 * equal too) into the first of them: triangles are remapped and the later
 * copies removed from the vertex arrays (in a point cloud too). Triangles
 * that become degenerate stay; mr_mesh_remove_degenerate removes them. */
mr_status mr_mesh_weld_exact(mr_mesh *mesh, int require_same_attributes,
                             size_t *removed, mr_error *err);

/* Remove triangles that use a vertex twice, and (when remove_duplicates)
 * every triangle after the first over the same three vertices, in either
 * orientation. */
mr_status mr_mesh_remove_degenerate(mr_mesh *mesh, int remove_duplicates,
                                    size_t *removed, mr_error *err);

/* Make the winding of the triangles consistent: across every edge shared
 * by exactly two triangles, one runs it one way and the other the other
 * way (edges of one triangle or of three or more do not link triangles).
 * A closed connected part is wound to face outwards (positive enclosed
 * volume); an open one keeps the winding of most of its triangles (ties:
 * of its first triangle). Triangles are flipped by swapping their second
 * and third corners. A part that cannot be oriented (a Moebius strip) is
 * left as it is and counted in *nonorientable (may be NULL); *flipped
 * (may be NULL) gets the number of triangles flipped. Deterministic. */
mr_status mr_mesh_orient(mr_mesh *mesh, size_t *flipped, size_t *nonorientable,
                         mr_error *err);

/*
 * Which vertices are one point of the surface. Files split a vertex where
 * its attributes differ across the surface (a UV seam, a hard edge: several
 * vertices at one position), and they keep apart parts that only touch
 * (two shells sharing a point, a double-sided sheet). Vertices at
 * bitwise-equal positions (-0 equals +0) are one surface point where
 * triangles join them across the split -- a geometric edge (its ends taken
 * by position) of exactly two triangles, wound against each other, that
 * use different vertices for it, and do not lie folded onto each other
 * (normals opposite within a degree: two coincident sheets, as a
 * double-sided one glued at its border) -- and the vertices so joined form one
 * manifold fan (a disk, or a half-disk on an open boundary); otherwise
 * they stay apart. point[v] (vertex_count entries) receives the lowest
 * index of the vertices of v's surface point (v itself for most);
 * *split_vertices (may be NULL) the number of vertices with point[v] != v.
 * Positions are packed floats. Deterministic. The simplifier, the
 * statistics and mr_mesh_weld_seams all use this one rule.
 */
mr_status mr_surface_points(const float *positions, size_t vertex_count,
                            const uint32_t *indices, size_t triangle_count, uint32_t *point,
                            size_t *split_vertices, mr_error *err);

/* Merge the vertices of each surface point (mr_surface_points) whose
 * attributes (the arrays the mesh has) are bitwise equal into the first
 * of them, as mr_mesh_weld_exact does: after an attribute array is
 * dropped, the splits that only it caused go. Parts that only touch stay
 * apart. *removed (may be NULL) gets the number of vertices merged. */
mr_status mr_mesh_weld_seams(mr_mesh *mesh, size_t *removed, mr_error *err);

/* ------------------------------------------------------------------------ */
/* Statistics                                                               */
/* ------------------------------------------------------------------------ */

typedef struct mr_stats {
    size_t vertex_count;            /* all vertices */
    size_t referenced_vertices;     /* vertices used by a triangle */
    size_t unreferenced_vertices;
    size_t surface_vertices;        /* points of the surface among them
                                       (mr_surface_points): the vertices of
                                       every topology figure below */
    size_t split_vertices;          /* referenced vertices that repeat a
                                       surface point for other attributes
                                       (UV seams, hard edges):
                                       referenced - surface_vertices */
    size_t triangle_count;
    size_t degenerate_triangles;    /* a vertex repeated */
    size_t duplicate_triangles;     /* same vertex set as an earlier triangle */
    size_t edge_count;              /* distinct undirected edges (degenerate
                                       triangles contribute none) */
    size_t boundary_edges;          /* edges with one incident triangle */
    size_t nonmanifold_edges;       /* edges with three or more */
    size_t misoriented_edges;       /* edges of two triangles that run them
                                       the same way (inconsistent winding:
                                       the simplifier locks their vertices) */
    size_t nonmanifold_vertices;    /* referenced vertices whose triangles form
                                       more than one fan, or touch a
                                       non-manifold edge */
    size_t boundary_loops;          /* closed chains of boundary edges */
    size_t components;              /* triangle components connected through
                                       shared vertices (isolated vertices
                                       not counted) */
    long long euler_characteristic; /* V - E + F, V = surface_vertices */
    int closed;                     /* no boundary edge, no non-manifold edge
                                       (and at least one edge) */
    int manifold;                   /* no non-manifold edge or vertex (and at
                                       least one edge) */
    int oriented;                   /* manifold and no misoriented edge */
    double bbox_min[3], bbox_max[3];/* over all vertices */
    double bbox_diagonal;
    double surface_area;
} mr_stats;

/* Statistics of a mesh given as flat arrays. stride is the byte distance
 * between consecutive positions (0 = 3 * sizeof(float)). The topology
 * (edges, boundaries, manifoldness, components, Euler characteristic) is
 * that of the surface: vertices split only by their attributes count as
 * one point (mr_surface_points). */
mr_status mr_stats_compute(const float *positions, size_t stride, size_t vertex_count,
                           const uint32_t *indices, size_t triangle_count,
                           mr_stats *stats, mr_error *err);

/* ------------------------------------------------------------------------ */
/* Procedural meshes: the embedded default input                            */
/* ------------------------------------------------------------------------ */

typedef enum mr_generator {
    MR_GEN_SPHERE = 0, /* unit geodesic sphere, closed, genus 0: 20 f^2
                          triangles for the frequency f nearest the request;
                          the seed is not used */
    MR_GEN_TORUS,      /* torus (radii 1 and 0.35) with 3-6 round holes
                          placed from the seed: open, Euler characteristic
                          -holes (below ~400 triangles: no holes) */
    MR_GEN_SCAN        /* closed, genus-0 noisy scan-like surface with
                          detail down to the edge length, radius 30-70
                          units around the origin; the default input */
} mr_generator;

/* Generator kind from its name ("sphere", "torus", "scan"); returns 0 and
 * sets *kind, or -1 for an unknown name. */
int mr_generator_from_name(const char *name, mr_generator *kind);
const char *mr_generator_name(mr_generator kind);

/* Generate a mesh with about `triangles` triangles (the nearest count the
 * kind's tessellation allows). Deterministic for a given kind, triangle
 * count and seed, on every platform and thread count. `mesh` must be
 * empty. */
mr_status mr_generate(mr_generator kind, size_t triangles, uint64_t seed,
                      mr_mesh *mesh, mr_error *err);

/* Generate straight into a file: mr_generate's mesh written as by
 * mr_mesh_write (the same bytes). A sphere or a scan written as PLY is
 * streamed, never held in memory whole (blocks of a million vertices or
 * triangles: about 30 MB at any size, up to the 32-bit indices' 4.29
 * billion triangles); the torus and the other formats are made in memory
 * first. vertices_out and triangles_out (may be NULL) receive the counts. */
mr_status mr_generate_file(mr_generator kind, size_t triangles, uint64_t seed, const char *path,
                           const mr_write_options *options, size_t *vertices_out,
                           size_t *triangles_out, mr_error *err);

/* ------------------------------------------------------------------------ */
/* Simplification: greedy quadric-error edge collapse                       */
/* ------------------------------------------------------------------------ */

typedef enum mr_collapse_kind {
    MR_COLLAPSE_FULL = 0, /* both ends move to the quadric-optimal position
                             (the quality default) */
    MR_COLLAPSE_HALF      /* one end moves onto the other's position; a
                             vertex's priority is its best outgoing collapse */
} mr_collapse_kind;

/* How the next collapses are chosen. */
typedef enum mr_strategy {
    MR_STRATEGY_GREEDY = 0, /* always the cheapest valid collapse, from an
                               indexed heap with mutable priorities: the
                               sequential reference */
    MR_STRATEGY_BATCHED,    /* passes: every edge's cost, then the cheapest
                               ones in order, at most one collapse per
                               vertex per pass (much faster, nearly the
                               same result) */
    /* The vertex queue of the greedy half-edge strategy on a concurrent
     * priority queue, threads collapsing at once under per-vertex locks
     * (the filter-priority-queue paper's kernel). Half-edge collapse only
     * (MR_COLLAPSE_HALF; MR_COLLAPSE_FULL is refused). Relaxed: on more
     * than one thread the output may vary with the thread count and the
     * timing. Every other option applies as for MR_STRATEGY_GREEDY: the
     * targets (a vertex target is hit exactly at any thread count),
     * max_error, until_error, lock_border, vertex_lock, boundary_weight,
     * max_normal_turn, prune, attribute seams (mr_mesh_simplify); progress
     * is called from the calling thread only. */
    MR_STRATEGY_PPQ,        /* strict pops of the root: on one thread the
                               same output as MR_STRATEGY_GREEDY (half) */
    MR_STRATEGY_RPPQ,       /* pops any unlocked one of the top n_t nodes
                               of the same heap (n_t = 2^(l+1) - 1 for
                               l = filter_levels): no rank bound */
    MR_STRATEGY_FPPQ,       /* the heap with filter_levels l filter levels:
                               every pop among the best l * 2^l + 1 */
    MR_STRATEGY_MULTIQUEUE, /* multiqueue_factor * threads locked heaps:
                               pops usually near the top, no bound */
    /* Partitioned batches: vertices in `partitions` slabs along the
     * longest axis (balanced by vertex counts, rebalanced as the mesh
     * shrinks); each pass, every slab applies its interior collapses
     * (whose two closed 1-rings lie in the slab) in cost order on its own
     * thread; the edges across slabs follow, by slabs shifted half a slab
     * where their 1-rings fit in one, else in one global cost order on
     * the calling thread. Full or half collapse. For a fixed `partitions`
     * the output is byte-identical at every thread count. */
    MR_STRATEGY_PARTITIONED,
    /* Its boundary-aware variant: each slab's collapses are chosen first,
     * as a batch under claims (a collapse joins only when neither end lies
     * in the closed 1-ring of an end already in it, and no end of one in
     * its own), then applied together on every thread; the edges across
     * slabs follow in one global claim walk, in cost order, and are applied
     * together the same way. The slabs are rebalanced when one of four
     * counts says they are stale: collapses since the last balance, load
     * imbalance, the fraction of candidates across slabs, the slabs'
     * acceptance rate (mr_simplify_stats). Byte-identical output at every
     * thread count for a fixed `partitions`, as above. */
    MR_STRATEGY_PARTITIONED_BOUNDARY
} mr_strategy;

/* Progress of a simplification: the fraction done in [0, 1], from the
 * calling thread, never decreasing. Return 0 to go on; anything else
 * cancels: the work stops at the next report (within about 1 % of the
 * collapses) and the call fails with MR_ERR_CANCELLED, its output left
 * empty. With MR_QUALITY_BEST the collapses report up to 0.5 and the
 * surface fit after it the rest, after the input's search hierarchy and
 * after each of its sweeps (about a seventh of the fit each). */
typedef int (*mr_progress_fn)(double fraction_done, void *user);

/* How hard the simplifier works for closeness to the input's surface. */
typedef enum mr_simplify_quality {
    MR_QUALITY_DEFAULT = 0, /* each survivor at its quadric's optimum */
    MR_QUALITY_BEST         /* full collapse only: Lindstrom and Turk's
                               memoryless collapses with the batched, greedy
                               and partitioned strategies (each survivor where
                               the triangles around it sweep the least volume,
                               the enclosed volume kept, the collapses ranked
                               by that volume; the queued strategies keep
                               their quadric collapses),
                               and at the end the output's vertices fitted to
                               the input's surface (least squares, no triangle
                               flips, and no two triangles that the collapses
                               left apart brought to cross: such moves are put
                               back); lower RMS and Hausdorff distance, 5-15x
                               the time. max_error still bounds the quadric
                               error. */
} mr_simplify_quality;

/*
 * What the seams of an attribute mesh (mr_mesh_simplify) may do. Held, a
 * seam vertex slides only along its seam, and where islands meet or a seam
 * meets an open boundary it stays. Freed, a seam vertex off the open
 * boundaries may leave its seam wherever the attribute quadrics price it
 * lowest (meshoptimizer's permissive mode); it needs weighted attributes,
 * which price it (without them the seams hold).
 *   MR_SEAMS_AUTO (default): held, and freed in a last stage when the run
 *     ends short of its target with them; freed from the start where the
 *     vertices they lock are a tenth of the surface points or more (an
 *     atlas of many small islands: the Khronos DamagedHelmet, 13 %), where
 *     holding them would crowd the collapses into the few free regions.
 *   MR_SEAMS_FREE: freed from the start.
 *   MR_SEAMS_KEEP: held, even when the target is missed for them.
 */
typedef enum mr_seam_mode {
    MR_SEAMS_AUTO = 0,
    MR_SEAMS_FREE,
    MR_SEAMS_KEEP
} mr_seam_mode;

typedef struct mr_simplify_options {
    /* Targets: simplification stops at the first one reached. 0 = unused.
     * At least one target (or max_error) must be set. Vertex counts and
     * ratios count referenced vertices only, as surface points (copies of
     * a vertex split by attributes at one position count once). */
    double target_ratio;        /* fraction of vertices to keep, (0, 1] */
    size_t target_vertices;
    size_t target_triangles;
    double max_error;           /* stop before a collapse whose error (a
                                   distance) exceeds this; 0 = no limit */
    int until_error;            /* no count target: collapse as far as
                                   max_error (or, without it, the rules)
                                   allow; the CLI's --triangles 0 */
    int error_absolute;         /* max_error is absolute (1) or relative to
                                   the bounding-box diagonal of all the
                                   input's vertices (0, default) */

    mr_collapse_kind collapse;  /* MR_COLLAPSE_FULL by default */
    mr_strategy strategy;       /* MR_STRATEGY_BATCHED by default */
    double boundary_weight;     /* weight of the perpendicular-plane quadrics
                                   that hold open boundaries and attribute
                                   seams in place (default 1; 0 = none) */
    double max_normal_turn;     /* radians: refuse collapses that turn a
                                   triangle's normal by more than this
                                   (default 60 degrees); flips are always
                                   refused */
    int lock_border;            /* never move boundary vertices */
    int prune;                  /* after the collapses, drop the connected
                                   parts whose bounding-box diagonal is at
                                   most the error bound (max_error, or else
                                   the largest collapse error made), never
                                   the largest part (by that diagonal; ties
                                   by triangles, then by place: the same
                                   part whatever the vertex order) */
    const uint8_t *vertex_lock; /* optional, one byte per input vertex:
                                   nonzero = this vertex never moves */
    int threads;                /* 0 = all cores (parallel algorithms) */
    mr_progress_fn progress;    /* optional, called from the calling thread */
    void *progress_user;
    unsigned filter_levels;     /* MR_STRATEGY_FPPQ and _RPPQ: filter levels
                                   l (1 .. 5; 0 = from the thread count,
                                   mr_fppq_default_levels) */
    unsigned multiqueue_factor; /* MR_STRATEGY_MULTIQUEUE: heaps per thread
                                   (0 = 2) */
    unsigned partitions;        /* MR_STRATEGY_PARTITIONED(_BOUNDARY): slabs, 1 ..
                                   MR_PARTITIONS_MAX (0 = MR_PARTITIONS_DEFAULT,
                                   a constant: never from the thread count,
                                   so the output does not depend on it) */
    mr_simplify_quality quality; /* MR_QUALITY_DEFAULT by default */
    /* The attributes' part in a collapse's cost (mr_mesh_simplify; the
     * position-only entry points have no attributes): each weighted
     * attribute's deviation over the merged triangles enters the quadric
     * (Hoppe's memory-efficient attribute quadrics) with its weight
     * squared, beside the squared distance, so that a deviation of 1
     * counts as a distance of `weight` times a scale of the mesh: a
     * normal's (per unit-vector component) and a colour's (per unit of a
     * channel, 0 .. 1) the input's mean edge length; texture coordinates
     * per the distance a deviation moves the texture on the surface
     * (sqrt(area / UV area)). A weighted attribute takes, at each collapse,
     * the value its quadric puts at the survivor (normals renormalised,
     * colours clamped to [0, 1]); a weight of 0 leaves it out of the cost
     * (it is interpolated along the edge, as with all weights 0 before
     * 0.2). With attributes in the cost, the errors the run reports and
     * bounds (max_error) include them. Defaults: MR_NORMAL_WEIGHT,
     * MR_UV_WEIGHT, MR_COLOR_WEIGHT. */
    double normal_weight, uv_weight, color_weight;
    /* Attribute seams (mr_mesh_simplify): MR_SEAMS_AUTO by default. */
    mr_seam_mode seams;
} mr_simplify_options;

#define MR_NORMAL_WEIGHT 0.5
#define MR_UV_WEIGHT 0.25
#define MR_COLOR_WEIGHT 1.0

#define MR_PARTITIONS_DEFAULT 16
#define MR_PARTITIONS_MAX 4096

void mr_simplify_options_default(mr_simplify_options *options);

/* Why a simplification stopped. A missed target is a result, not an
 * error: the output is as far as the rules allow. */
typedef enum mr_simplify_stop {
    MR_STOP_TARGET = 0, /* a vertex, ratio or triangle target was reached */
    MR_STOP_MAX_ERROR,  /* every further collapse would exceed max_error */
    MR_STOP_LOCKED,     /* missed: no remaining edge may move (locked ends:
                           non-manifold or misoriented fans, lock_border,
                           vertex_lock; or two pinned seam ends) */
    MR_STOP_REFUSED     /* missed: every remaining collapse is refused by
                           the validity tests (link condition, a part's last
                           triangles, flips, max_normal_turn, seams) */
} mr_simplify_stop;

/* A sentence saying why (for messages). */
const char *mr_simplify_stop_string(mr_simplify_stop stop);

/* What a simplification produced and how long each phase took. */
typedef struct mr_simplify_stats {
    size_t input_vertices;      /* referenced input vertices, counted as
                                   surface points (mr_surface_points: the
                                   copies of a vertex split by attributes
                                   count once), as the targets count them */
    size_t locked_vertices;     /* input vertices that could not move: their
                                   triangles are not one consistently wound
                                   fan (non-manifold, or misoriented edges:
                                   mr_mesh_orient fixes the latter) */
    size_t input_triangles;
    size_t output_vertices;     /* vertices of the output arrays */
    size_t output_points;       /* surface points of the output, counted as
                                   input_vertices (mr_mesh_simplify keeps
                                   attribute splits: output_vertices may be
                                   more) */
    size_t output_triangles;
    size_t collapses;
    size_t pruned_parts;        /* parts dropped by options.prune */
    int target_reached;         /* stop is MR_STOP_TARGET or _MAX_ERROR,
                                   or any with until_error */
    mr_simplify_stop stop;
    double max_error;           /* largest collapse error, as a distance */
    double seconds_setup;       /* adjacency, quadrics, queue */
    double seconds_collapse;
    double seconds_output;      /* compaction */
    /* The concurrent-queue strategies' profile (MR_STRATEGY_PPQ .. _MULTIQUEUE;
     * 0 for the others), summed over the threads: */
    size_t queue_pops;          /* vertices taken from the queue */
    size_t lock_acquisitions;   /* vertex locks taken */
    size_t lock_failures;       /* neighbourhoods not locked: released, the
                                   vertex put back, another top tried */
    size_t topology_checks;     /* validity tests of a collapse */
    size_t priority_updates;    /* queue keys set (re-keys, inserts, removals) */
    size_t compactions;         /* all threads stopped to compact the lists */
    /* MR_STRATEGY_PARTITIONED's profile (0 for the others): */
    size_t partition_passes;    /* passes (gather, interior, boundary) */
    size_t interior_collapses;  /* made by the slabs concurrently */
    size_t boundary_collapses;  /* edges across slabs, after the slabs'
                                   step of each pass: concurrently by the
                                   shifted slabs (planes halfway between),
                                   the rest in one global order */
    size_t boundary_sequential; /* of those, made on the calling thread */
    size_t tail_collapses;      /* the last ones to the target: every
                                   candidate in one global order */
    size_t rebalances;          /* slabs recomputed as the mesh shrank */
    /* MR_STRATEGY_PARTITIONED_BOUNDARY's too (0 for the others): */
    size_t claim_conflicts;     /* candidates deferred to a later pass:
                                   their neighbourhood met a claimed one */
    size_t rebalance_count;     /* rebalances by trigger: the live vertices
                                   halved since the last balance; */
    size_t rebalance_imbalance; /* one slab's interior candidates 1.5x the
                                   mean; */
    size_t rebalance_boundary;  /* the candidates across slabs 1.5x their
                                   share just after the last balance; */
    size_t rebalance_acceptance; /* the slabs' acceptance rate half of its
                                   rate just after the last balance */
} mr_simplify_stats;

/* The result of a simplification on flat arrays: malloc'd arrays that
 * mr_simplified_free releases. origin[i] is the input vertex that output
 * vertex i descends from (the vertex it kept: for a collapse of u into v,
 * v's origin). */
typedef struct mr_simplified {
    size_t vertex_count;
    size_t triangle_count;
    float *positions;           /* 3 * vertex_count */
    uint32_t *indices;          /* 3 * triangle_count */
    uint32_t *origin;           /* vertex_count input vertex ids */
    mr_simplify_stats stats;
} mr_simplified;

void mr_simplified_free(mr_simplified *result);

/* Simplify a triangle mesh given as flat arrays (stride: bytes between
 * positions, 0 = packed). Deterministic. Unreferenced input vertices do
 * not appear in the output. `out` is filled on success; on failure it is
 * left empty. */
mr_status mr_simplify(const float *positions, size_t stride, size_t vertex_count,
                      const uint32_t *indices, size_t triangle_count,
                      const mr_simplify_options *options, mr_simplified *out,
                      mr_error *err);

/* Simplify an owning mesh, carrying normals, texture coordinates and
 * colors through (attribute seams -- vertices split at one position -- are
 * kept). `out` must be empty; `origin` (optional) receives a malloc'd array
 * of out->vertex_count input vertex ids; `stats` (optional) the figures. */
mr_status mr_mesh_simplify(const mr_mesh *in, const mr_simplify_options *options,
                           mr_mesh *out, uint32_t **origin, mr_simplify_stats *stats,
                           mr_error *err);

/*
 * A chain of levels of detail: level k is mr_mesh_simplify of level k - 1
 * (of the input for the first) to fractions[k] of the input's triangles,
 * each with the options (their targets are set per level: target_ratio,
 * target_vertices and target_triangles must be 0; max_error, when set,
 * still bounds each level's collapses). fractions: count values in (0, 1),
 * strictly decreasing. Each level is measured against the input
 * (mr_compare with `samples` area samples a mesh, 0 = the default's), and
 * its error is the largest Hausdorff distance of it and every level
 * before: never smaller than the one before. origin[v] of a level is its
 * vertex v's input vertex (composed through the levels). levels[] gets
 * count entries; free them with mr_lod_levels_free (also after a failure,
 * where the levels not built are empty).
 */
typedef struct mr_lod_level {
    mr_mesh mesh;
    uint32_t *origin;            /* mesh.vertex_count input vertex ids */
    mr_simplify_stats stats;     /* its simplification from the level before */
    size_t target_triangles;     /* fraction * the input's triangles */
    double hausdorff_rel, rms_rel; /* measured against the input, relative to
                                    its bounding-box diagonal */
    double error_rel;            /* the largest hausdorff_rel up to this level */
} mr_lod_level;

mr_status mr_mesh_lods(const mr_mesh *in, const double *fractions, size_t count,
                       const mr_simplify_options *options, size_t samples,
                       mr_lod_level *levels, mr_error *err);
void mr_lod_levels_free(mr_lod_level *levels, size_t count);

/* ------------------------------------------------------------------------ */
/* Out-of-core simplification                                               */
/* ------------------------------------------------------------------------ */

/*
 * Simplification of a mesh file of any size in bounded memory: a binary
 * PLY input is read in passes (its bounding box; its triangles' centroids
 * counted into a k-d tree of chunks that fit the budget; its triangles
 * spilled chunk by chunk to temporary files), each chunk is simplified in
 * memory with the vertices it shares with other chunks locked, then
 * neighbouring chunks are merged up the tree, their shared cut unlocked
 * and reduced with each vertex's quadric carried from below, up to the
 * root, which meets the targets. The chunks and the tree depend on the
 * input and the options only (the memory budget among them), never on
 * the machine or the thread count: the same options give the same bytes.
 * An input whose in-memory simplification fits the budget (about 160
 * bytes a triangle) is simplified in memory as mr_mesh_simplify does,
 * with its bytes. On the out-of-core path the normals, texture
 * coordinates and colors of a binary PLY or OBJ input travel through the
 * chunks (surface points, seams kept, also across the cuts and into an
 * output larger than a chunk, written as PLY); a PLY's
 * vertices split by attributes that the write options drop are joined
 * as in memory, and so are the vertices of a PLY or OBJ without
 * attributes that repeat a position (an unwelded export: found by a
 * sort of the positions). Indices stay 32-bit: at most 4,294,967,295
 * vertices and triangles.
 */
#define MR_MEMORY_DEFAULT ((uint64_t)4 << 30) /* 4 GiB */

typedef struct mr_out_of_core_options {
    uint64_t memory;      /* bytes (0 = MR_MEMORY_DEFAULT) */
    const char *temp_dir; /* NULL: $TMPDIR, else the output's directory, else
                             /tmp. Temporary files there have no name (they
                             go with the process, however it ends) */
    uint64_t temp_budget; /* temporary bytes at most (0 = no limit): past
                             it the call fails */
} mr_out_of_core_options;

void mr_out_of_core_options_default(mr_out_of_core_options *options);

#define MR_LEVELS_MAX 48
#define MR_SPLITS_MAX 63

typedef struct mr_simplify_file_stats {
    mr_simplify_stats simplify;  /* the whole job's: counts, stop, largest
                                    error; collapses and times summed over
                                    the chunks (the root's stop) */
    int out_of_core;             /* 0: simplified in memory */
    size_t chunks;               /* the tree's leaves */
    size_t chunk_capacity;       /* triangles a chunk may hold */
    size_t oversized_chunks;     /* leaves over it (centroids at one point) */
    unsigned levels;             /* the tree's height + 1 */
    size_t level_chunks[MR_LEVELS_MAX];    /* chunks simplified at each
                                              level (0: the leaves) */
    double level_seconds[MR_LEVELS_MAX];   /* their time */
    size_t level_triangles[MR_LEVELS_MAX]; /* their input triangles */
    unsigned passes;             /* passes over the input's faces */
    unsigned splits;             /* the tree's first inner nodes, breadth
                                    first (at most MR_SPLITS_MAX): where they
                                    cut, for measuring near the cuts */
    int split_axis[MR_SPLITS_MAX];   /* 0 x, 1 y, 2 z */
    double split_at[MR_SPLITS_MAX];  /* the plane's coordinate */
    uint64_t memory;             /* the budget */
    uint64_t temp_bytes_peak;    /* temporary disk at most */
    double seconds_read;         /* the passes over the input */
    double seconds_simplify;     /* the chunks */
    double seconds_write;
    double seconds_total;
    size_t top_chunks;           /* 0; or, when the output does not fit one
                                    chunk: the pieces the tree ends at, each
                                    simplified to its share, their cuts
                                    then reduced in bands, the output
                                    written as one PLY stream */
} mr_simplify_file_stats;

/* Simplify the file in_path into out_path (written whole or not at all,
 * as mr_mesh_write writes) by the options (their targets count the whole
 * input; options->vertex_lock, when set, has one byte per input vertex),
 * in ooc's memory (NULL: defaults). stats (optional) get the figures. */
mr_status mr_simplify_file(const char *in_path, const char *out_path,
                           const mr_simplify_options *options,
                           const mr_out_of_core_options *ooc, const mr_write_options *write,
                           mr_simplify_file_stats *stats, mr_error *err);

/* ------------------------------------------------------------------------ */
/* glTF documents                                                           */
/* ------------------------------------------------------------------------ */

/*
 * Simplify a glTF 2.0 file (.gltf with its buffers, or .glb) into another
 * (.gltf or .glb by out_path's extension), keeping the document: each
 * mesh's triangle primitives are simplified on their own, in the mesh's
 * space (a mesh that several nodes instance once), with their materials;
 * points and lines, the scene, nodes, materials, images, samplers, skins,
 * animations, extras and extensions are written back as they were. The
 * targets: target_ratio applies to each primitive; target_triangles and
 * target_vertices are split over the primitives in proportion to their
 * triangles;
 * a relative max_error is relative to the diagonal of all the primitives'
 * positions. Attributes besides NORMAL, TEXCOORD_0 and COLOR_0 (more UV
 * sets and colors, JOINTS_n and WEIGHTS_n, morph targets) are the
 * surviving input vertex's; TANGENT is dropped (clients compute MikkTSpace
 * tangents where a material needs them) and counted. Accessors and
 * buffer views nothing uses any more are dropped, the buffers joined into
 * one (a .gltf's beside it as OUT.bin; its external images copied beside
 * it when it goes to another folder; a .glb takes them in). Compressed
 * geometry (KHR_draco_mesh_compression, EXT_meshopt_compression) is
 * refused. options->vertex_lock is not supported here.
 */
typedef struct mr_gltf_simplify_stats {
    mr_simplify_stats simplify; /* summed over the primitives (their largest
                                   error; target_reached: all of them) */
    size_t primitives;          /* triangle primitives simplified */
    size_t dropped_tangents;    /* primitives whose TANGENT was dropped */
} mr_gltf_simplify_stats;

mr_status mr_simplify_gltf(const char *in_path, const char *out_path,
                           const mr_simplify_options *options, mr_gltf_simplify_stats *stats,
                           mr_error *err);

/* Levels of detail of a glTF document in one document (MSFT_lod): each
 * triangle primitive's chain as mr_mesh_lods builds it (fractions of its
 * triangles, in its mesh's space), level k's meshes added as copies of
 * the document's (named NAME_lodK, their other attributes and morph
 * targets carried as mr_simplify_gltf carries them), and every node with
 * a mesh given an LOD node per level (its transform, skin and morph
 * weights, the copy's mesh, extras "lod" and "lod_error"; no children)
 * listed in its MSFT_lod "ids"; the rest of the document as
 * mr_simplify_gltf writes it. levels[k] gets level k's figures (its mesh
 * stays empty): the statistics summed over the primitives, the largest
 * Hausdorff and RMS distance over them relative to the diagonal of all
 * the primitives' positions, and the error (the largest Hausdorff so far).
 * A relative options->max_error is relative to that diagonal. */
mr_status mr_simplify_gltf_lods(const char *in_path, const char *out_path,
                                const double *fractions, size_t count,
                                const mr_simplify_options *options, size_t samples,
                                mr_lod_level *levels, mr_error *err);

/* Copy a glTF document into another (.gltf or .glb by out_path), as
 * mr_simplify_gltf writes it: the same document, its buffers joined into
 * one and what nothing uses dropped; *primitives (optional) gets its
 * triangle primitives' count. */
mr_status mr_convert_gltf(const char *in_path, const char *out_path, size_t *primitives,
                          mr_error *err);

/* ------------------------------------------------------------------------ */
/* Error metrics                                                            */
/* ------------------------------------------------------------------------ */

typedef struct mr_compare_options {
    size_t samples;      /* area-uniform surface samples per mesh, besides
                            its vertices (default 1,000,000; 0 = vertices
                            only) */
    uint64_t seed;       /* sampling seed (fixed default: same figures for
                            the same meshes) */
    int threads;         /* 0 = all cores */
} mr_compare_options;

void mr_compare_options_default(mr_compare_options *options);

/* Surface distances between a reference and a test mesh, Metro-style:
 * points on each surface (its vertices plus area-uniform samples), the
 * exact distance from each to the nearest point of the other surface.
 * Every distance is also given relative to the reference bounding-box
 * diagonal (the *_rel fields). */
typedef struct mr_compare_result {
    double hausdorff;          /* max of both one-sided maxima */
    double rms;                /* RMS over the points of both directions */
    double mean;               /* mean over the points of both directions */
    double ref_to_test_max, test_to_ref_max;
    double ref_to_test_rms, test_to_ref_rms;
    double hausdorff_rel, rms_rel, mean_rel;
    double modified_hausdorff; /* RMS over the reference's vertices of the
                                  distance to the nearest test vertex (the
                                  filter-queue paper's formula (3)) */
    double modified_hausdorff_rel;
    double diagonal;           /* reference bounding-box diagonal */
    size_t ref_points, test_points;
} mr_compare_result;

/* Compare two triangle meshes (flat arrays, packed positions). */
mr_status mr_compare(const float *ref_positions, size_t ref_vertex_count,
                     const uint32_t *ref_indices, size_t ref_triangle_count,
                     const float *test_positions, size_t test_vertex_count,
                     const uint32_t *test_indices, size_t test_triangle_count,
                     const mr_compare_options *options, mr_compare_result *result,
                     mr_error *err);

/* The deviation of the attributes that both meshes have, at matched
 * surface points: the samples mr_compare measures (each mesh's
 * area-uniform samples, by the same options and seed), each matched to
 * the nearest point of the other surface, both meshes' attributes
 * interpolated there (barycentric); the area samples only (a vertex on
 * a seam has both sides' values), or the vertices where options->samples
 * is 0. Normals: the angle in degrees between
 * the two (normalised); texture coordinates: the UV distance; colors: the
 * RGBA distance (channels in [0, 1]). RMS and largest over the points of
 * both directions. Near a seam the nearest point may fall on its other
 * side: the largest values there are the seam's jump. The same figures at
 * any thread count. */
typedef struct mr_attribute_error {
    unsigned attributes;          /* MR_ATTR_* both have: the figures measured */
    double normal_rms, normal_max;     /* degrees */
    double texcoord_rms, texcoord_max; /* UV units */
    double color_rms, color_max;       /* RGBA distance */
    size_t points;                /* matched points, both directions */
    /* The texture deviation (with texture coordinates): from each point,
     * the distance to the nearest point of the other surface that has its
     * UV (where charts overlap in UV, the nearest of them): how far the
     * texture moved on the surface, free of the seams' jumps. Model units,
     * and relative to the reference's bounding-box diagonal; over the
     * points whose UV the other map covers within 5 % of that diagonal
     * (texture_points of `points`: a chart's rim that the other mesh's
     * chart no longer reaches, whose equal-UV points are only another
     * chart's far away, is not counted). */
    double texture_rms, texture_max, texture_rms_rel, texture_max_rel;
    size_t texture_points;
} mr_attribute_error;

mr_status mr_compare_attributes(const mr_mesh *ref, const mr_mesh *test,
                                const mr_compare_options *options, mr_attribute_error *out,
                                mr_error *err);

/* A reference surface prepared once for several measurements against it
 * (a sheet of reductions, a sweep): its checks, its surface samples and its
 * nearest-triangle hierarchy, built by mr_reference_build with the
 * options' samples, seed and threads, which every measurement with it then
 * uses. The arrays must stay valid and unchanged until mr_reference_free.
 * mr_compare_with gives mr_compare's figures bit for bit. */
typedef struct mr_reference mr_reference;
mr_status mr_reference_build(const float *positions, size_t vertex_count,
                             const uint32_t *indices, size_t triangle_count,
                             const mr_compare_options *options, mr_reference **out,
                             mr_error *err);
void mr_reference_free(mr_reference *ref);
mr_status mr_compare_with(const mr_reference *ref, const float *test_positions,
                          size_t test_vertex_count, const uint32_t *test_indices,
                          size_t test_triangle_count, mr_compare_result *result, mr_error *err);

/* Vertex similarity of two reductions of the same mesh: the share of
 * output vertices of `a` for which `b` has an output vertex descending from
 * the same input vertex at the same position (bitwise). origin arrays as
 * produced by mr_simplify. Returns a fraction in [0, 1] of a's vertices. */
double mr_vertex_similarity(const float *a_positions, const uint32_t *a_origin,
                            size_t a_vertex_count, const float *b_positions,
                            const uint32_t *b_origin, size_t b_vertex_count);

/* ------------------------------------------------------------------------ */
/* Vertex clustering: exact epsilon welding and grid clustering             */
/* ------------------------------------------------------------------------ */

/*
 * Epsilon welding (vertex clustering in a fixed vertex order). Vertices are
 * visited in order (index order, or decreasing visual importance); an
 * unclustered vertex starts a new cluster with all its still-unclustered
 * neighbours within eps, and the cluster is represented by the mean of its
 * members (positions, and normals, texture coordinates and colors where
 * present), summed in double in member order. Triangles are remapped to the
 * representatives. This is Open3D's TriangleMesh::merge_close_vertices;
 * Open3D compares strictly (d < eps), which `strict` selects; the default
 * (d <= eps) also welds exact duplicates at eps = 0.
 *
 * The three algorithms give bitwise identical output at every thread count:
 * S-Weld, the serial reference (parallel neighbour graph, serial
 * clustering); P-Weld, the lock-free parallel mapping of Fathollahi and
 * Chester (SIGGRAPH Asia 2023, Algorithm 2); P-Weld-Async, which numbers
 * clusters by a parallel prefix sum and overlaps repositioning with
 * retriangulation.
 */
typedef enum mr_weld_algorithm {
    MR_WELD_AUTO = 0,    /* the fastest exact one (P-Weld-Async) */
    MR_WELD_SERIAL,      /* S-Weld */
    MR_WELD_PWELD,       /* P-Weld */
    MR_WELD_PWELD_ASYNC  /* P-Weld-Async */
} mr_weld_algorithm;

typedef enum mr_weld_order {
    MR_WELD_ORDER_INDEX = 0, /* vertex index order, as Open3D */
    MR_WELD_ORDER_GRADE      /* decreasing visual importance (Low and Tan
                                1997): longest incident edge and sharpness
                                (cosine of half the widest angle between
                                incident edges), ties by index */
} mr_weld_order;

typedef struct mr_weld_options {
    double eps;                  /* merge radius (absolute, >= 0) */
    int strict;                  /* 0: distance <= eps (default); 1: < eps */
    mr_weld_algorithm algorithm; /* MR_WELD_AUTO by default */
    mr_weld_order order;         /* MR_WELD_ORDER_INDEX by default */
    int drop_degenerate;         /* remove triangles that collapse (0) */
    int threads;                 /* 0 = all cores */
} mr_weld_options;

void mr_weld_options_default(mr_weld_options *options);

typedef struct mr_weld_stats {
    size_t input_vertices;
    size_t input_triangles;
    size_t output_vertices;      /* clusters */
    size_t output_triangles;
    size_t graph_edges;          /* vertex pairs within eps */
    unsigned rounds;             /* P-Weld mapping rounds (0 for S-Weld) */
    int threads;
    mr_weld_algorithm algorithm; /* the one that ran */
    double eps;
    double seconds_order;        /* grade computation and sort */
    double seconds_graph;        /* neighbour graph */
    double seconds_mapping;      /* vertex -> cluster (S-Weld: its serial
                                    clustering with repositioning) */
    double seconds_reduction;    /* cluster numbering and repositioning
                                    (P-Weld-Async: numbering only) */
    double seconds_retriangulation; /* (P-Weld-Async: repositioning and
                                       retriangulation, overlapped) */
    double seconds_total;
    size_t peak_bytes;           /* most working memory held at once,
                                    besides the input and the output */
} mr_weld_stats;

/* The result of mr_weld: malloc'd arrays that mr_welded_free releases. */
typedef struct mr_welded {
    size_t vertex_count;
    size_t triangle_count;
    float *positions;  /* 3 * vertex_count: the cluster means */
    uint32_t *indices; /* 3 * triangle_count, in input triangle order */
    uint32_t *remap;   /* input vertex count entries: the output vertex
                          (cluster) of each input vertex */
    mr_weld_stats stats;
} mr_welded;

void mr_welded_free(mr_welded *result);

/* Weld a mesh or point cloud (triangle_count 0, indices may be NULL) given
 * as flat arrays; stride is the byte distance between positions (0 =
 * packed). Clusters are numbered in visiting order. A negative or NaN eps,
 * a non-finite position or a bad index is an error; `out` is left empty on
 * failure. */
mr_status mr_weld(const float *positions, size_t stride, size_t vertex_count,
                  const uint32_t *indices, size_t triangle_count,
                  const mr_weld_options *options, mr_welded *out, mr_error *err);

/* Weld an owning mesh, averaging normals, texture coordinates and colors
 * with the positions. `out` must be empty; `remap` (optional) receives the
 * malloc'd input-vertex -> output-vertex map; `stats` (optional). */
mr_status mr_mesh_weld(const mr_mesh *in, const mr_weld_options *options, mr_mesh *out,
                       uint32_t **remap, mr_weld_stats *stats, mr_error *err);

/* The epsilon finder: the smallest eps (to a relative 1e-6, by bisection
 * over whole mappings) whose weld removes at least `fraction` (in [0, 1))
 * of the vertices; *removed (optional) gets how many it removes. Uses
 * options->strict and threads, in index order; options->eps is ignored. */
mr_status mr_weld_find_eps(const float *positions, size_t stride, size_t vertex_count,
                           double fraction, const mr_weld_options *options, double *eps,
                           size_t *removed, mr_error *err);

/*
 * Grid clustering (Rossignac and Borrel 1993): every vertex falls into a
 * cubic cell of a uniform grid; each occupied cell becomes one vertex,
 * placed at the minimiser of the summed area-weighted plane quadrics of the
 * triangles that span three cells (Lindstrom 2000), kept inside its cell,
 * or at the mean of its points where they do not pin a point (point
 * clouds, flat or thin cells). Triangles that collapse, and duplicates,
 * are removed, and for meshes the vertices that no triangle uses. Order
 * free and deterministic at any thread count.
 */
typedef struct mr_cluster_options {
    double cell;            /* cell edge length (absolute), or 0 */
    size_t target_vertices; /* or: the cell size whose grid has about this
                               many occupied cells: within 2 %, else the
                               nearest count a few secant steps in log-log
                               scale meet (a sample's first, where the
                               cells are coarse) */
    int threads;            /* 0 = all cores */
    double cell_rel;        /* or (when > 0): the cell edge as this fraction
                               of the diagonal of the bounding box of all the
                               vertices */
} mr_cluster_options;

void mr_cluster_options_default(mr_cluster_options *options);

typedef struct mr_cluster_stats {
    size_t input_vertices, input_triangles;
    size_t cells;            /* occupied cells */
    size_t output_vertices, output_triangles;
    double cell;             /* the cell size used */
    double seconds_cells;    /* binning and sort (and the cell search) */
    double seconds_representatives;
    double seconds_triangles;
    double seconds_total;
    int streamed;             /* mr_cluster_file: 1 when the file was read in
                                 passes, 0 when read whole */
    uint64_t temp_bytes_peak; /* its temporary files at most (STL, OBJ) */
} mr_cluster_stats;

mr_status mr_mesh_cluster(const mr_mesh *in, const mr_cluster_options *options, mr_mesh *out,
                          mr_cluster_stats *stats, mr_error *err);

/* Cluster the mesh in the file in_path into out_path (written as by
 * mr_mesh_write with `write`, which may be NULL): the same bytes as
 * mr_mesh_read, mr_mesh_cluster and mr_mesh_write, in memory that grows
 * with the output, as in Lindstrom's out-of-core clustering: the input is
 * read in passes (its box, its vertices in blocks into their cells with a
 * provisional cell id a vertex, 4 bytes, its faces in batches), a binary
 * PLY file in place, a binary STL file welded and an OBJ file parsed into
 * temporary files (ooc's temp_dir and temp_budget) when its in-memory
 * clustering would not fit ooc's memory (NULL: defaults; about 64 bytes a
 * triangle; else it is read whole, as are ascii PLY and STL files). An
 * OBJ file streamed is clustered by its v lines, positions only: when its
 * vertices have normals, texture coordinates or colors that `write`
 * keeps, an error says so. A target count costs a few passes more over
 * the vertices (a sample's first). The input must be a regular file (it
 * is read more than once). */
mr_status mr_cluster_file(const char *in_path, const char *out_path,
                          const mr_cluster_options *options, const mr_out_of_core_options *ooc,
                          const mr_write_options *write,
                          mr_cluster_stats *stats, mr_error *err);

/* ------------------------------------------------------------------------ */
/* Rendering                                                                */
/* ------------------------------------------------------------------------ */

/*
 * A software rasterizer for looking at meshes: z-buffered, flat-shaded
 * triangles lit by a headlight (Lambert, two-sided), an optional wireframe
 * overlay, point clouds as shaded splats, supersampled anti-aliasing, an
 * orthographic camera framed from a bounding box. Output is an RGBA
 * buffer (one panel, possibly a sub-rectangle of a larger image), a
 * comparison sheet of several panels with captions and a colour bar, and
 * PNG files. Every image is byte-identical for the same input and options
 * at any thread count.
 */

typedef enum mr_view {
    MR_VIEW_ISO = 0, /* from the front-right, above: yaw 45, pitch 35.26 */
    MR_VIEW_FRONT,   /* looking along -z (yaw 0, pitch 0), +y up */
    MR_VIEW_SIDE,    /* looking along -x (yaw 90, pitch 0), +y up */
    MR_VIEW_TOP,     /* looking down along -y (pitch 90), -z up */
    MR_VIEW_CUSTOM   /* mr_render_options.yaw and .pitch */
} mr_view;

/* View from its name ("iso", "front", "side", "top"); returns 0 and sets
 * *view, or -1 for an unknown name. */
int mr_view_from_name(const char *name, mr_view *view);

/* How texture coordinates outside [0, 1] find a texel (glTF's sampler
 * wrap modes). */
typedef enum mr_wrap {
    MR_WRAP_REPEAT = 0,
    MR_WRAP_CLAMP,
    MR_WRAP_MIRROR
} mr_wrap;

/* A decoded image: height rows of width RGBA pixels (4 bytes each, rows
 * 4 * width bytes apart, the first row at the top). */
typedef struct mr_image {
    int width, height;
    uint8_t *rgba;
} mr_image;

/* A surface's look for the renderer: a base colour (sRGB display values,
 * each 0..1; glTF's linear baseColorFactor is converted when read) times
 * a texture sampled at the vertices' texture coordinates (bilinear, the
 * wrap modes), times the vertex colours where given. */
typedef struct mr_render_material {
    float color[4];
    const mr_image *texture;   /* or NULL: the colour alone */
    mr_wrap wrap_s, wrap_t;
    int v_up;                  /* texture coordinate v = 0 is the image's
                                  bottom row (OBJ), else its top (glTF) */
} mr_render_material;

typedef struct mr_render_options {
    int width, height;          /* pixels (default 1024 x 768; 1 .. 16384) */
    mr_view view;               /* MR_VIEW_ISO by default */
    double yaw, pitch;          /* degrees, for MR_VIEW_CUSTOM: the camera
                                   turns yaw about +y from the front view,
                                   then looks down by pitch */
    int supersample;            /* k: k x k samples per pixel, box-filtered
                                   (default 3; 1 = no anti-aliasing; <= 8) */
    int wire;                   /* draw triangle edges over the surface */
    int threads;                /* 0 = all cores */
    uint32_t background;        /* 0xRRGGBB (default white) */
    uint32_t color;             /* surface colour 0xRRGGBB (default light
                                   grey-blue) */
    uint32_t wire_color;        /* 0xRRGGBB (default dark grey) */
    double point_radius;        /* splat radius in pixels for point clouds;
                                   0 = from the point density (default) */
    double margin;              /* empty border, a fraction of the smaller
                                   side (default 0.04) */
    int use_bounds;             /* frame the corners of this box instead of
                                   the drawn vertices (the default frames
                                   the vertices as seen from the view, the
                                   tightest fit) */
    float bounds_lo[3], bounds_hi[3];
    /* Heat colouring: a value per face (flat) or per vertex (interpolated);
     * at most one of them non-NULL. Values map linearly from
     * [scalar_min, scalar_max] onto mr_colormap, clamped. */
    const float *face_scalar;
    const float *vertex_scalar;
    double scalar_min, scalar_max;
    /* The surface's own look, drawn when no heat values are given (a
     * mesh, not a point cloud's splats, for textures): each face's
     * material (face_material[f] indexes materials; UINT32_MAX or a NULL
     * face_material with no materials: the plain `color`; NULL with
     * materials: material 0), the texture coordinates (2 floats a vertex)
     * its texture is sampled at, and vertex colours (4 floats a vertex,
     * rgba as display values 0..1) that multiply it. All NULL (the
     * default): every face in `color`, as before. */
    const float *texcoords;
    const float *vertex_colors;
    const uint32_t *face_material;
    const mr_render_material *materials;
    size_t material_count;
} mr_render_options;

void mr_render_options_default(mr_render_options *options);

/*
 * Render a triangle mesh (triangle_count > 0) or a point cloud
 * (triangle_count == 0: every vertex is a splat) into `rgba`: height rows
 * of width pixels, 4 bytes each, rows `row_bytes` apart (0 = 4 * width),
 * so a panel can be drawn into a sub-rectangle of a larger image. Positions
 * are packed floats; every vertex used must be finite. Vertices outside a
 * given bounds box are drawn where they fall (clipped to the image). The
 * whole rectangle is written, background included; alpha is 255.
 */
mr_status mr_render(const float *positions, size_t vertex_count, const uint32_t *indices,
                    size_t triangle_count, const mr_render_options *options, uint8_t *rgba,
                    size_t row_bytes, mr_error *err);

/* The heat-map colour of t in [0, 1] (clamped; NaN counts as 0): dark
 * blue through cyan, green and yellow to red, lightness rising then
 * falling so both ends stay distinct from white and black. */
void mr_colormap(double t, uint8_t rgb[3]);

/* ---- text: a built-in 5x7 bitmap font, ASCII 32..126 -------------------- */

/* Size in pixels of `text` drawn at integer `scale` (each glyph cell is 6
 * x 9 units: 5 x 7 glyph, spacing, line gap; '\n' starts a new line;
 * characters outside 32..126 draw as '?'). */
void mr_text_size(const char *text, int scale, int *width, int *height);

/* Draw text with its top-left corner at (x, y), clipped to the image. */
void mr_draw_text(uint8_t *rgba, int width, int height, size_t row_bytes, int x, int y,
                  const char *text, int scale, uint32_t color);

/* ---- heat maps: distance to a reference surface ------------------------ */

/*
 * Distance of a test mesh to a reference surface (triangle mesh), through
 * the library's nearest-triangle hierarchy. For a test mesh with triangles,
 * face_distance[f] (triangle_count floats) is the largest distance over the
 * face's three corners and four interior points (the centroid and the
 * points at barycentric (2/3, 1/6, 1/6) and its permutations), so a face
 * far from the surface shows even when its corners lie on it; for a point
 * cloud (test_triangle_count == 0) it is the distance of each point
 * (test_vertex_count floats). Deterministic at any thread count. *max_out
 * (may be NULL) receives the largest value.
 */
mr_status mr_surface_distances(const float *ref_positions, size_t ref_vertex_count,
                               const uint32_t *ref_indices, size_t ref_triangle_count,
                               const float *test_positions, size_t test_vertex_count,
                               const uint32_t *test_indices, size_t test_triangle_count,
                               int threads, float *face_distance, double *max_out,
                               mr_error *err);

/* The same against a prepared reference (mr_reference_build), on its
 * threads: the same values. */
mr_status mr_surface_distances_with(const mr_reference *ref, const float *test_positions,
                                    size_t test_vertex_count, const uint32_t *test_indices,
                                    size_t test_triangle_count, float *face_distance,
                                    double *max_out, mr_error *err);

/* ---- comparison sheets --------------------------------------------------- */

/* One panel: a mesh or point cloud, its caption ('\n' separates lines),
 * and optional heat values (as in mr_render_options). */
typedef struct mr_sheet_panel {
    const float *positions;
    size_t vertex_count;
    const uint32_t *indices;
    size_t triangle_count;
    const char *caption;
    const float *face_scalar;
    const float *vertex_scalar;
    /* the panel's look, as in mr_render_options (all NULL: plain) */
    const float *texcoords;
    const float *vertex_colors;
    const uint32_t *face_material;
    const mr_render_material *materials;
    size_t material_count;
} mr_sheet_panel;

typedef struct mr_sheet_options {
    mr_render_options render;   /* panel size, camera, shading; its bounds
                                   and scalars are set per sheet/panel */
    int columns;                /* panels per row (0 = all in one row) */
    int text_scale;             /* font scale of captions (0 = from the
                                   panel width) */
    double scalar_min, scalar_max; /* the heat range shared by all panels */
    const char *colorbar_label; /* caption of the colour bar */
    const char *colorbar_min_label, *colorbar_max_label; /* its end labels
                                   (NULL: the numbers scalar_min/max) */
    const char *title;          /* optional line above the panels */
} mr_sheet_options;

void mr_sheet_options_default(mr_sheet_options *options);

/*
 * Compose a sheet: the panels on a grid, all rendered from one camera
 * framed on all the panels' vertices together (or render.bounds when
 * use_bounds is set), each with its caption below, and a colour bar with
 * its scale under the grid when any panel has heat values. *rgba receives
 * a malloc'd image of *width x *height pixels (free() it).
 */
mr_status mr_render_sheet(const mr_sheet_panel *panels, size_t panel_count,
                          const mr_sheet_options *options, uint8_t **rgba, int *width,
                          int *height, mr_error *err);

/* ---- a mesh with its look ------------------------------------------------ */

/*
 * A mesh as mr_mesh_read gives it, with what the renderer needs to draw
 * it as its file shows it: for glTF, each triangle's material (its
 * primitive's baseColorFactor and baseColorTexture with the texture's
 * sampler; texture coordinates kept where any primitive has them, zero
 * elsewhere; COLOR_0 converted to display values; the materials in the
 * document's order); for OBJ, each face's `usemtl` material from the
 * `mtllib` files (Kd and map_Kd; the materials in the order of the
 * usemtl names, mr_obj_materials_read's, and a face whose name no
 * library defines is plain). Images
 * are PNG or JPEG, read relative to the file's folder (glTF: also
 * data: URIs and the .glb's buffer). Other formats (and an OBJ without
 * mtllib) have no materials: vertex colours only, where present.
 * A texture that cannot be read is an error naming the material and the
 * file; a texture set other than TEXCOORD_0, or an image format other
 * than PNG and JPEG, leaves that material untextured (its colour).
 */
typedef struct mr_look {
    mr_mesh mesh;
    uint32_t *face_material;          /* triangle_count, or NULL */
    mr_render_material *materials;    /* their textures point into images */
    size_t material_count;
    mr_image *images;
    size_t image_count;
} mr_look;

mr_status mr_look_read(const char *path, mr_look *look, mr_error *err);
void mr_look_free(mr_look *look);

/* ---- images: PNG and JPEG ------------------------------------------------ */

/* Decode a PNG (libpng) or JPEG (libjpeg-turbo) image from memory, told
 * apart by its first bytes, into 8-bit RGBA (grey, palette and 16-bit
 * PNGs converted; a JPEG's alpha is 255). `name` names it in messages.
 * Built without the library the format needs, MR_ERR_UNSUPPORTED says
 * which. */
mr_status mr_image_decode(const void *data, size_t size, const char *name, mr_image *image,
                          mr_error *err);
/* The same from a file. */
mr_status mr_image_read(const char *path, mr_image *image, mr_error *err);
void mr_image_free(mr_image *image);

/* ---- PNG ------------------------------------------------------------------ */

/* Write an RGBA image (rows 4 * width bytes apart) as an 8-bit RGB PNG
 * (alpha is dropped: images are opaque). The file appears complete or not
 * at all (temporary file beside it, then renamed). */
mr_status mr_png_write(const char *path, const uint8_t *rgba, int width, int height,
                       mr_error *err);

#ifdef __cplusplus
}
#endif

#endif /* MESHREDUCE_H */
