/*
 * Procedural meshes: the project's embedded default input.
 *
 *   sphere  geodesic sphere: an icosahedron whose faces are subdivided with
 *           frequency f (class I), 20 f^2 triangles and 10 f^2 + 2
 *           vertices on the unit sphere. The seed is not used.
 *   torus   major radius 1, minor radius 0.35, a periodic nu x nv quad grid
 *           split into triangles, with 3 to 6 round holes (chosen from the
 *           seed) cut out; vertices no triangle uses are left out. Each
 *           hole is a disk, so V - E + F = -(number of holes). Grids too
 *           coarse to keep the holes apart (below about 400 triangles) get
 *           no holes: a closed torus.
 *   scan    the geodesic sphere with every vertex moved along its ray by
 *           a few smooth lobes plus fractal gradient noise whose finest
 *           octave is about two edge lengths wide, plus a tiny radial
 *           "scanner noise" per vertex. The radius stays strictly inside
 *           (SCAN_RMIN, SCAN_RMAX) * SCAN_SCALE = (30, 70) units around the
 *           origin. Because each vertex only moves along its own ray and
 *           stays at a positive radius, every triangle stays inside the
 *           cone over its sphere triangle: the surface is star-shaped,
 *           closed, genus 0 and never intersects itself.
 *
 * Everything is computed from integer hashing and per-element formulas
 * (vertex positions and triangle indices are written by independent loop
 * iterations), so the output is bitwise identical for every OpenMP thread
 * count. Only sqrt, floor and exp (scan) and sin, cos (torus) come from the
 * math library.
 */
#include "generate.h"

#include <math.h>

#define GEN_PI 3.14159265358979323846

/* Counts beyond this are refused: triangle and vertex indices must fit in
 * 32 bits (mr_mesh_alloc allows at most UINT32_MAX - 1 vertices). */
#define GEN_MAX_TRIANGLES ((uint64_t)UINT32_MAX)
/* Requests above this are refused before any arithmetic could overflow. */
#define GEN_MAX_REQUEST ((uint64_t)1 << 40)

/* ------------------------------------------------------------------------ */
/* Names                                                                    */
/* ------------------------------------------------------------------------ */

static const char *const generator_names[] = {"sphere", "torus", "scan"};

int mr_generator_from_name(const char *name, mr_generator *kind)
{
    if (!name)
        return -1;
    for (int k = 0; k < 3; k++) {
        if (strcmp(name, generator_names[k]) == 0) {
            if (kind)
                *kind = (mr_generator)k;
            return 0;
        }
    }
    return -1;
}

const char *mr_generator_name(mr_generator kind)
{
    if ((int)kind < 0 || (int)kind >= 3)
        return "unknown";
    return generator_names[kind];
}

/* ------------------------------------------------------------------------ */
/* Hashing: every random choice is a pure function of (seed, position)     */
/* ------------------------------------------------------------------------ */


/* The i-th value of an independent stream named by `tag` for `seed`. */
static inline uint64_t stream(uint64_t seed, uint64_t tag, uint64_t i)
{
    return mr_mix64(mr_mix64(seed ^ mr_mix64(tag)) + i * 0x9e3779b97f4a7c15ull);
}

/* Uniform in [0, 1) from the top 53 bits. */
static inline double unit01(uint64_t h) { return (double)(h >> 11) * 0x1.0p-53; }

/* Uniform in [-1, 1). */
static inline double unit11(uint64_t h) { return 2.0 * unit01(h) - 1.0; }

/* ------------------------------------------------------------------------ */
/* Icosahedron and its class-I subdivision                                  */
/* ------------------------------------------------------------------------ */

/*
 * Vertex numbering of a geodesic sphere of frequency f:
 *   [0, 12)                       the icosahedron's corners;
 *   12 + e (f-1) + (k-1)          edge e's k-th inner point (k = 1..f-1),
 *                                 counted from its lower-numbered corner;
 *   12 + 30 (f-1) + t I + local   face t's inner points, I = (f-1)(f-2)/2.
 * A point of face t = (A, B, C) is named by (i, j), i, j >= 0, i + j <= f,
 * at barycentric weights (f-i-j, i, j). Points on the face's border map to
 * the corner or edge numbering, which is how neighbouring faces share them
 * exactly.
 */
typedef struct geodesic {
    double corner[12][3]; /* unnormalised; all of the same length */
    int face[20][3];      /* counter-clockwise seen from outside */
    int edge[30][2];      /* lower corner first */
    int edge_of[12][12];  /* edge index of a corner pair, -1 if none */
    uint32_t f;
    uint32_t edge_base;   /* first edge vertex: 12 */
    uint32_t face_base;   /* first face-interior vertex */
    uint32_t face_inner;  /* interior vertices per face */
    uint32_t vertex_count;
} geodesic;

static double det3(const double a[3], const double b[3], const double c[3])
{
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/* Corners (0, +-1, +-phi) and their cyclic permutations; edges join the
 * corners at distance 2, faces are the 20 triangles of mutually adjacent
 * corners, oriented by the sign of their determinant. Derived rather than
 * tabulated so that orientation and adjacency cannot disagree. */
static void geodesic_init(geodesic *g, uint32_t f)
{
    const double phi = (1.0 + sqrt(5.0)) / 2.0;
    int n = 0;
    for (int axis = 0; axis < 3; axis++)
        for (int s1 = -1; s1 <= 1; s1 += 2)
            for (int s2 = -1; s2 <= 1; s2 += 2) {
                double v[3] = {0, 0, 0};
                v[(axis + 1) % 3] = s1;
                v[(axis + 2) % 3] = s2 * phi;
                memcpy(g->corner[n++], v, sizeof v);
            }

    int adjacent[12][12];
    for (int a = 0; a < 12; a++)
        for (int b = 0; b < 12; b++) {
            double d2 = 0;
            for (int k = 0; k < 3; k++) {
                double d = g->corner[a][k] - g->corner[b][k];
                d2 += d * d;
            }
            adjacent[a][b] = a != b && fabs(d2 - 4.0) < 1e-6;
            g->edge_of[a][b] = -1;
        }

    int ne = 0, nf = 0;
    for (int a = 0; a < 12; a++)
        for (int b = a + 1; b < 12; b++) {
            if (!adjacent[a][b])
                continue;
            g->edge[ne][0] = a;
            g->edge[ne][1] = b;
            g->edge_of[a][b] = g->edge_of[b][a] = ne++;
            for (int c = b + 1; c < 12; c++) {
                if (!adjacent[a][c] || !adjacent[b][c])
                    continue;
                int *t = g->face[nf++];
                bool ccw = det3(g->corner[a], g->corner[b], g->corner[c]) > 0;
                t[0] = a;
                t[1] = ccw ? b : c;
                t[2] = ccw ? c : b;
            }
        }

    g->f = f;
    g->edge_base = 12;
    g->face_base = 12 + 30 * (f - 1);
    g->face_inner = (f - 1) * (f - 2) / 2; /* f = 1 gives 0 */
    g->vertex_count = 10 * f * f + 2;
}

/* Index of an inner point (i, j) of a face within that face's block. Row j
 * (1..f-2) holds i = 1..f-1-j; rows before j hold (j-1)(f-1) - (j-1)j/2. */
static inline uint32_t face_local(uint32_t f, uint32_t i, uint32_t j)
{
    return (j - 1) * (f - 1) - (j - 1) * j / 2 + (i - 1);
}

/* Vertex on edge (a, b), k steps of f from a. */
static inline uint32_t edge_vertex(const geodesic *g, int a, int b, uint32_t k)
{
    if (k == 0)
        return (uint32_t)a;
    if (k == g->f)
        return (uint32_t)b;
    uint32_t e = (uint32_t)g->edge_of[a][b];
    uint32_t from_low = a < b ? k : g->f - k;
    return g->edge_base + e * (g->f - 1) + (from_low - 1);
}

/* Vertex index of point (i, j) of face t. */
static inline uint32_t geodesic_vertex(const geodesic *g, int t, uint32_t i, uint32_t j)
{
    const int *c = g->face[t];
    uint32_t f = g->f;
    if (j == 0)
        return edge_vertex(g, c[0], c[1], i);
    if (i == 0)
        return edge_vertex(g, c[0], c[2], j);
    if (i + j == f)
        return edge_vertex(g, c[1], c[2], j);
    return g->face_base + (uint32_t)t * g->face_inner + face_local(f, i, j);
}

/* The smallest frequency whose 20 f^2 triangles are nearest to `n`. */
static uint32_t geodesic_frequency(uint64_t n)
{
    uint64_t f = (uint64_t)floor(sqrt((double)n / 20.0));
    if (f < 1)
        f = 1;
    /* sqrt may be off by one near squares; settle it in integers. */
    while (f > 1 && 20 * f * f > n)
        f--;
    while (20 * (f + 1) * (f + 1) <= n)
        f++;
    uint64_t lo = 20 * f * f, hi = 20 * (f + 1) * (f + 1);
    if (n > lo && hi - n < n - lo)
        f++;
    return (uint32_t)f;
}

/* ------------------------------------------------------------------------ */
/* Scan displacement                                                        */
/* ------------------------------------------------------------------------ */

#define SCAN_SCALE 50.0     /* unit radius -> scanner units (a ~100 box) */
#define SCAN_RMIN 0.6       /* radius bounds on the unit sphere ...      */
#define SCAN_RMAX 1.4       /* ... kept by a smooth saturation           */
#define SCAN_BASE_FREQ 1.0  /* lattice cells per unit at octave 0        */
#define SCAN_AMP0 0.14      /* octave 0 amplitude; halves per octave     */
#define SCAN_MAX_OCTAVES 16
#define SCAN_MAX_LOBES 6
#define SCAN_JITTER 0.05    /* scanner noise, in mean edge lengths       */

typedef struct scan_params {
    int octaves;
    uint64_t octave_seed[SCAN_MAX_OCTAVES];
    double octave_offset[SCAN_MAX_OCTAVES][3];
    int lobes;
    double lobe_dir[SCAN_MAX_LOBES][3];
    double lobe_amp[SCAN_MAX_LOBES];
    double lobe_sharp[SCAN_MAX_LOBES];
    uint64_t jitter_seed;
    double jitter;          /* amplitude on the unit sphere */
} scan_params;

/* A rotation with rational entries (from the quaternion (3, 1, 2, 4)),
 * applied between octaves so that their lattices never line up: exact to
 * the last bit on every platform, unlike one built with sin and cos. */
static const double octave_rotation[3][3] = {
    {-10.0 / 30, -20.0 / 30, 20.0 / 30},
    {28.0 / 30, -4.0 / 30, 10.0 / 30},
    {-4.0 / 30, 22.0 / 30, 20.0 / 30},
};

static void scan_params_init(scan_params *p, uint64_t seed, uint32_t f)
{
    /* Finest lattice cell about two mean edges wide (edge ~ 1.2 / f on the
     * unit sphere), so a mesh has real detail down to its resolution. */
    double finest = (double)f / 2.4 / SCAN_BASE_FREQ;
    int octaves = 1; /* 1 + round(log2(finest)), with exact halvings */
    while (finest > 1.4142135623730951 && octaves < SCAN_MAX_OCTAVES) {
        finest /= 2;
        octaves++;
    }
    p->octaves = octaves;
    for (int k = 0; k < p->octaves; k++) {
        p->octave_seed[k] = stream(seed, 0x6f63746176ull, (uint64_t)k);
        for (int a = 0; a < 3; a++)
            p->octave_offset[k][a] =
                64.0 * unit01(stream(seed, 0x6f6666736574ull, (uint64_t)(3 * k + a)));
    }

    /* Lobes: broad bulges and dents so the shape is not a ball. */
    p->lobes = 4 + (int)(stream(seed, 0x6c6f6265ull, 0) % 3);
    for (int i = 0; i < p->lobes; i++) {
        uint64_t s = 16 * (uint64_t)i;
        double d[3], n2 = 0;
        do { /* a direction, rejecting the corners of the cube for isotropy */
            n2 = 0;
            for (int a = 0; a < 3; a++) {
                d[a] = unit11(stream(seed, 0x6c646972ull, s++));
                n2 += d[a] * d[a];
            }
        } while (n2 > 1.0 || n2 < 1e-4);
        double n = sqrt(n2);
        for (int a = 0; a < 3; a++)
            p->lobe_dir[i][a] = d[a] / n;
        double u = unit01(stream(seed, 0x6c616d70ull, (uint64_t)i));
        double amp = 0.08 + 0.12 * u;
        p->lobe_amp[i] = i % 3 == 2 ? -0.6 * amp : amp; /* every third a dent */
        p->lobe_sharp[i] = 1.0 + 3.0 * unit01(stream(seed, 0x6c736870ull, (uint64_t)i));
    }

    p->jitter_seed = stream(seed, 0x6a6974ull, 0);
    p->jitter = SCAN_JITTER * 1.2 / (double)f;
}

/* The 12 cube-edge directions of classic gradient noise. A table lookup
 * rather than a switch: the choice is random, so branches would mispredict
 * on nearly every lattice corner. */
static const double gradients[12][3] = {
    {1, 1, 0}, {-1, 1, 0}, {1, -1, 0}, {-1, -1, 0}, {1, 0, 1}, {-1, 0, 1},
    {1, 0, -1}, {-1, 0, -1}, {0, 1, 1}, {0, -1, 1}, {0, 1, -1}, {0, -1, -1},
};

/* Weight of an octave lattice corner: its gradient, picked by the hash's
 * top 32 bits scaled to 0..11, dotted with the offset from that corner. */
static inline double corner_dot(uint64_t h, double x, double y, double z)
{
    const double *g = gradients[((h >> 32) * 12) >> 32];
    return g[0] * x + g[1] * y + g[2] * z;
}

static inline double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
static inline double lerp(double a, double b, double t) { return a + t * (b - a); }

/* 3D gradient noise, roughly in [-1, 1], zero on lattice points. A lattice
 * point's hash is the mix of the seed plus its coordinates times large odd
 * constants: one mix per corner, and the eight corners of a cell share the
 * three products. */
static double gradient_noise(uint64_t seed, double x, double y, double z)
{
    double fx = floor(x), fy = floor(y), fz = floor(z);
    double ux = x - fx, uy = y - fy, uz = z - fz;
    uint64_t hx = (uint64_t)(int64_t)fx * 0x8cb92ba72f3d8dd7ull;
    uint64_t hy = (uint64_t)(int64_t)fy * 0xd6e8feb86659fd93ull;
    uint64_t hz = (uint64_t)(int64_t)fz * 0xa0761d6478bd642full;
    const uint64_t sx = 0x8cb92ba72f3d8dd7ull, sy = 0xd6e8feb86659fd93ull,
                   sz = 0xa0761d6478bd642full;
    double v[8];
    for (int c = 0; c < 8; c++) {
        int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
        uint64_t h = mr_mix64(seed + hx + (dx ? sx : 0) + hy + (dy ? sy : 0) + hz +
                           (dz ? sz : 0));
        v[c] = corner_dot(h, ux - dx, uy - dy, uz - dz);
    }
    double wx = fade(ux), wy = fade(uy), wz = fade(uz);
    double x00 = lerp(v[0], v[1], wx), x10 = lerp(v[2], v[3], wx);
    double x01 = lerp(v[4], v[5], wx), x11 = lerp(v[6], v[7], wx);
    return lerp(lerp(x00, x10, wy), lerp(x01, x11, wy), wz);
}

/* Fractal sum: each octave doubles the frequency and halves the amplitude,
 * so each contributes the same slope: rough at every scale. */
static double scan_fbm(const scan_params *p, const double dir[3])
{
    double q[3] = {dir[0], dir[1], dir[2]};
    double freq = SCAN_BASE_FREQ, amp = SCAN_AMP0, sum = 0;
    for (int k = 0; k < p->octaves; k++) {
        const double *o = p->octave_offset[k];
        sum += amp * gradient_noise(p->octave_seed[k], q[0] * freq + o[0],
                                    q[1] * freq + o[1], q[2] * freq + o[2]);
        double r[3];
        for (int a = 0; a < 3; a++)
            r[a] = octave_rotation[a][0] * q[0] + octave_rotation[a][1] * q[1] +
                   octave_rotation[a][2] * q[2];
        memcpy(q, r, sizeof r);
        freq *= 2;
        amp *= 0.5;
    }
    return sum;
}

/* Radius (on the unit sphere) of the scan along unit direction dir for
 * vertex v. The raw displacement is not strictly bounded; the saturation
 * q -> q / (1 + q^4)^(1/4) is smooth, close to the identity for |q| < 0.6
 * (so typical detail is not flattened) and keeps the radius strictly
 * inside (SCAN_RMIN, SCAN_RMAX). */
static double scan_radius(const scan_params *p, const double dir[3], uint32_t v)
{
    double d = scan_fbm(p, dir);
    for (int i = 0; i < p->lobes; i++) {
        const double *l = p->lobe_dir[i];
        double c = dir[0] * l[0] + dir[1] * l[1] + dir[2] * l[2];
        d += p->lobe_amp[i] * exp(p->lobe_sharp[i] * (c - 1.0));
    }
    d += p->jitter * unit11(stream(p->jitter_seed, 0, v));
    const double half = (SCAN_RMAX - SCAN_RMIN) / 2, mid = (SCAN_RMAX + SCAN_RMIN) / 2;
    double q = (d + 1.0 - mid) / half, q2 = q * q;
    return mid + half * q / sqrt(sqrt(1.0 + q2 * q2));
}

/* ------------------------------------------------------------------------ */
/* Geodesic sphere and scan                                                 */
/* ------------------------------------------------------------------------ */

/* Write vertex v from an unnormalised direction: on the unit sphere, or
 * displaced as the scan when scan is non-NULL. */
/* Vertex v's position into o[0..2]. */
static void place_vertex(float *o, uint32_t v, const double w[3], const scan_params *scan)
{
    double n = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double dir[3] = {w[0] / n, w[1] / n, w[2] / n};
    double r = scan ? scan_radius(scan, dir, v) * SCAN_SCALE : 1.0;
    o[0] = (float)(dir[0] * r);
    o[1] = (float)(dir[1] * r);
    o[2] = (float)(dir[2] * r);
}

/* Weighted sum of corners a, b, c (the weights are barycentric times f). */
static void corner_mix(const geodesic *g, int a, double wa, int b, double wb, int c,
                       double wc, double out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = wa * g->corner[a][k] + wb * g->corner[b][k] + wc * g->corner[c][k];
}

static void geodesic_positions(const geodesic *g, const scan_params *scan, float *pos)
{
    const long f = (long)g->f;
    for (int c = 0; c < 12; c++)
        place_vertex(pos + 3 * (size_t)c, (uint32_t)c, g->corner[c], scan);

    /* Each edge point is computed once, from its edge's lower corner, so
     * both faces beside it see the same vertex. */
    const long edge_points = 30 * (f - 1);
#pragma omp parallel for schedule(dynamic, 256)
    for (long q = 0; q < edge_points; q++) {
        long e = q / (f - 1), k = q % (f - 1) + 1;
        double w[3];
        corner_mix(g, g->edge[e][0], (double)(f - k), g->edge[e][1], (double)k, 0, 0.0, w);
        const uint32_t v = g->edge_base + (uint32_t)q;
        place_vertex(pos + 3 * (size_t)v, v, w, scan);
    }

    /* Face interiors, one task per row of a face. */
    const long rows = f > 2 ? 20 * (f - 2) : 0;
#pragma omp parallel for schedule(dynamic, 4)
    for (long r = 0; r < rows; r++) {
        int t = (int)(r / (f - 2));
        uint32_t j = (uint32_t)(r % (f - 2)) + 1;
        const int *c = g->face[t];
        for (uint32_t i = 1; i + j < (uint32_t)f; i++) {
            double w[3];
            corner_mix(g, c[0], (double)((uint32_t)f - i - j), c[1], (double)i, c[2],
                       (double)j, w);
            uint32_t v = g->face_base + (uint32_t)t * g->face_inner + face_local(g->f, i, j);
            place_vertex(pos + 3 * (size_t)v, v, w, scan);
        }
    }
}

/* The first triangle of face t's row j: after t f^2 triangles of earlier
 * faces and j (2f - j) of earlier rows. */
static inline uint64_t row_start(uint64_t f, uint64_t t, uint64_t j)
{
    return t * f * f + j * (2 * f - j);
}

/* Triangles of face t, row j, into o: (f - j) upward ones interleaved with
 * (f - j - 1) downward ones. */
static void geodesic_row_triangles(const geodesic *g, int t, uint32_t j, uint32_t *o)
{
    const uint32_t f = g->f;
    for (uint32_t i = 0; i + j < f; i++) {
        uint32_t a = geodesic_vertex(g, t, i, j), b = geodesic_vertex(g, t, i + 1, j),
                 c = geodesic_vertex(g, t, i, j + 1);
        o[0] = a, o[1] = b, o[2] = c;
        o += 3;
        if (i + j + 1 < f) {
            o[0] = b;
            o[1] = geodesic_vertex(g, t, i + 1, j + 1);
            o[2] = c;
            o += 3;
        }
    }
}

static mr_status generate_geodesic(size_t triangles, const uint64_t *seed, mr_mesh *mesh,
                                   mr_error *err)
{
    uint32_t f = geodesic_frequency(triangles);
    uint64_t tri = 20 * (uint64_t)f * f;
    if (tri > GEN_MAX_TRIANGLES)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu triangles exceed the 32-bit index limit", triangles);

    geodesic g;
    geodesic_init(&g, f);
    scan_params scan;
    if (seed)
        scan_params_init(&scan, *seed, f);

    mr_mesh m;
    mr_mesh_init(&m);
    mr_status st = mr_mesh_alloc(&m, g.vertex_count, (size_t)tri, 0, err);
    if (st != MR_OK)
        return st;
    geodesic_positions(&g, seed ? &scan : NULL, m.positions);

    const long rows = 20 * (long)f;
#pragma omp parallel for schedule(dynamic, 16)
    for (long r = 0; r < rows; r++)
        geodesic_row_triangles(&g, (int)(r / f), (uint32_t)(r % f),
                               m.indices + 3 * row_start(f, (uint64_t)(r / f), (uint64_t)(r % f)));
    *mesh = m;
    return MR_OK;
}

/* ---- the geodesic mesh in pieces (mr_gen_stream) ------------------------- */

struct mr_gen_stream {
    geodesic g;
    scan_params scan;
    bool has_scan;
    uint64_t triangles;
};

/* The corner weights of vertex v: the point of generate_geodesic's
 * numbering (corners, edge points, face interiors row by row). */
static void vertex_weights(const geodesic *g, uint32_t v, double w[3])
{
    const uint32_t f = g->f;
    if (v < 12) {
        memcpy(w, g->corner[v], 3 * sizeof *w);
        return;
    }
    if (v < g->face_base) {
        const uint32_t q = v - g->edge_base, e = q / (f - 1), k = q % (f - 1) + 1;
        corner_mix(g, g->edge[e][0], (double)(f - k), g->edge[e][1], (double)k, 0, 0.0, w);
        return;
    }
    const uint32_t r = v - g->face_base, t = r / g->face_inner, local = r % g->face_inner;
    /* the row j whose block holds local: face_local(f, 1, j) <= local */
    uint32_t j = 1;
    {
        const double a = (double)f - 0.5; /* face_local(f, 1, j) = (j-1)(f-1) - (j-1)j/2 */
        double jj = a - sqrt(a * a - 2.0 * (double)local); /* (j-1) estimated */
        j = (uint32_t)(jj > 0 ? jj : 0) + 1;
        while (j > 1 && face_local(f, 1, j) > local)
            j--;
        while (j + 1 <= f - 2 && face_local(f, 1, j + 1) <= local)
            j++;
    }
    const uint32_t i = local - face_local(f, 1, j) + 1;
    const int *c = g->face[t];
    corner_mix(g, c[0], (double)(f - i - j), c[1], (double)i, c[2], (double)j, w);
}

mr_status mr_gen_stream_open(mr_generator kind, size_t triangles, uint64_t seed,
                             mr_gen_stream **out, mr_error *err)
{
    *out = NULL;
    if (kind != MR_GEN_SPHERE && kind != MR_GEN_SCAN)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, NULL,
                             "only the sphere and the scan are generated in pieces");
    if (triangles == 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "triangle count must be positive");
    if ((uint64_t)triangles > GEN_MAX_REQUEST)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu triangles exceed the 32-bit index limit", triangles);
    const uint32_t f = geodesic_frequency(triangles);
    const uint64_t tri = 20 * (uint64_t)f * f;
    if (tri > GEN_MAX_TRIANGLES)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu triangles exceed the 32-bit index limit", triangles);
    mr_gen_stream *gs = mr_calloc_array(1, sizeof *gs);
    if (!gs)
        return mr_fail_nomem(err, NULL, sizeof *gs);
    geodesic_init(&gs->g, f);
    gs->has_scan = kind == MR_GEN_SCAN;
    if (gs->has_scan)
        scan_params_init(&gs->scan, seed, f);
    gs->triangles = tri;
    *out = gs;
    return MR_OK;
}

size_t mr_gen_stream_vertex_count(const mr_gen_stream *gs) { return gs->g.vertex_count; }

size_t mr_gen_stream_triangle_count(const mr_gen_stream *gs) { return (size_t)gs->triangles; }

void mr_gen_stream_positions(const mr_gen_stream *gs, size_t first, size_t count, float *pos)
{
    const ptrdiff_t n = (ptrdiff_t)count;
#pragma omp parallel for schedule(dynamic, 1024) if (n > 4096)
    for (ptrdiff_t i = 0; i < n; i++) {
        const uint32_t v = (uint32_t)(first + (size_t)i);
        double w[3];
        vertex_weights(&gs->g, v, w);
        place_vertex(pos + 3 * i, v, w, gs->has_scan ? &gs->scan : NULL);
    }
}

mr_status mr_gen_stream_triangles(const mr_gen_stream *gs, size_t first, size_t count,
                                  uint32_t *idx, mr_error *err)
{
    const geodesic *g = &gs->g;
    const uint64_t f = g->f, end = first + count;
    if (count == 0)
        return MR_OK;
    /* the rows (t, j) that meet [first, end); a row whole inside is made in
     * place, the one or two cut by the ends in a buffer */
    const uint64_t t0 = first / (f * f), t1 = (end - 1) / (f * f);
    const long rows = (long)((t1 - t0 + 1) * f);
    uint32_t *row = mr_alloc_array(3 * 2 * (size_t)f, sizeof *row);
    if (!row)
        return mr_fail_nomem(err, NULL, 24 * (size_t)f);
#pragma omp parallel for schedule(dynamic, 16) if (count > 65536)
    for (long r = 0; r < rows; r++) {
        const uint64_t t = t0 + (uint64_t)r / f, j = (uint64_t)r % f;
        const uint64_t r0 = row_start(f, t, j), rn = 2 * (f - j) - 1;
        if (r0 >= first && r0 + rn <= end)
            geodesic_row_triangles(g, (int)t, (uint32_t)j, idx + 3 * (r0 - first));
    }
    for (long r = 0; r < rows; r++) {
        const uint64_t t = t0 + (uint64_t)r / f, j = (uint64_t)r % f;
        const uint64_t r0 = row_start(f, t, j), rn = 2 * (f - j) - 1;
        if (r0 + rn <= first || r0 >= end || (r0 >= first && r0 + rn <= end))
            continue;
        geodesic_row_triangles(g, (int)t, (uint32_t)j, row);
        const uint64_t a = r0 > first ? r0 : first, b = r0 + rn < end ? r0 + rn : end;
        memcpy(idx + 3 * (a - first), row + 3 * (a - r0), 3 * sizeof *idx * (b - a));
    }
    free(row);
    return MR_OK;
}

void mr_gen_stream_close(mr_gen_stream *gs) { free(gs); }

/* ------------------------------------------------------------------------ */
/* Torus with holes                                                         */
/* ------------------------------------------------------------------------ */

#define TORUS_R 1.0
#define TORUS_r 0.35
#define TORUS_MAX_HOLES 6
/* Holes are round in arc length (s = R theta, t = r phi). Any two are at
 * least HOLE_GAP apart, and holes are cut only when a grid cell's diagonal
 * is shorter than that: then no two holes' cells share a vertex. */
#define HOLE_GAP 0.4
#define HOLE_RMIN 0.2
#define HOLE_RMAX 0.35

typedef struct torus_holes {
    int count;
    double cs[TORUS_MAX_HOLES], ct[TORUS_MAX_HOLES], radius[TORUS_MAX_HOLES];
} torus_holes;

typedef struct torus_grid {
    uint32_t nu, nv;       /* cells around the major and the minor circle */
    double ds, dt;         /* cell size in arc length */
    const torus_holes *holes; /* NULL when the grid is too coarse for them */
} torus_grid;

static const double period_s = 2 * GEN_PI * TORUS_R, period_t = 2 * GEN_PI * TORUS_r;

/* Signed difference a - b wrapped into [-period/2, period/2]. */
static double wrap_diff(double a, double b, double period)
{
    double d = a - b;
    return d - period * floor(d / period + 0.5);
}

/* 3 to 6 holes placed from the seed by rejection sampling, independent of
 * the resolution so every size of one seed has the same holes. */
static void torus_holes_init(torus_holes *h, uint64_t seed)
{
    int wanted = 3 + (int)(stream(seed, 0x686f6c6573ull, 0) % 4);
    h->count = 0;
    uint64_t draw = 0;
    for (int tries = 0; tries < 2000 && h->count < wanted; tries++) {
        double cs = period_s * unit01(stream(seed, 0x686f6c65ull, draw++));
        double ct = period_t * unit01(stream(seed, 0x686f6c65ull, draw++));
        double rad = HOLE_RMIN + (HOLE_RMAX - HOLE_RMIN) * unit01(stream(seed, 0x686f6c65ull, draw++));
        bool ok = true;
        for (int i = 0; i < h->count && ok; i++) {
            double ds = wrap_diff(cs, h->cs[i], period_s);
            double dt = wrap_diff(ct, h->ct[i], period_t);
            ok = sqrt(ds * ds + dt * dt) >= rad + h->radius[i] + HOLE_GAP;
        }
        if (ok) {
            h->cs[h->count] = cs;
            h->ct[h->count] = ct;
            h->radius[h->count] = rad;
            h->count++;
        }
    }
}

static torus_grid torus_grid_make(uint32_t nu, uint32_t nv, const torus_holes *holes)
{
    torus_grid g = {nu, nv, period_s / nu, period_t / nv, NULL};
    if (sqrt(g.ds * g.ds + g.dt * g.dt) < HOLE_GAP)
        g.holes = holes;
    return g;
}

/* The cells hole k removes from cell row j: those whose centre is within
 * the hole's radius, a cyclic run [start, start + len) of columns. The same
 * run is computed for counting and for emission, so both always agree; the
 * runs shrink monotonically away from the hole's centre row, which makes
 * every hole a simply connected patch without pinched corners. */
static int torus_row_runs(const torus_grid *g, uint32_t j, uint32_t start[], uint32_t len[])
{
    int n = 0;
    if (!g->holes)
        return 0;
    double t = (j + 0.5) * g->dt;
    for (int k = 0; k < g->holes->count; k++) {
        double d = wrap_diff(t, g->holes->ct[k], period_t);
        double r = g->holes->radius[k];
        if (d * d >= r * r)
            continue;
        double w = sqrt(r * r - d * d), c = g->holes->cs[k];
        int64_t lo = (int64_t)ceil((c - w) / g->ds - 0.5);
        int64_t hi = (int64_t)floor((c + w) / g->ds - 0.5);
        if (hi < lo)
            continue;
        int64_t nu = g->nu;
        start[n] = (uint32_t)(((lo % nu) + nu) % nu);
        len[n] = (uint32_t)(hi - lo + 1);
        n++;
    }
    return n;
}

static inline bool in_runs(uint32_t i, uint32_t nu, int n, const uint32_t start[],
                           const uint32_t len[])
{
    for (int k = 0; k < n; k++)
        if ((i + nu - start[k]) % nu < len[k])
            return true;
    return false;
}

static uint64_t torus_kept_cells(const torus_grid *g)
{
    uint64_t kept = 0;
    for (uint32_t j = 0; j < g->nv; j++) {
        uint32_t start[TORUS_MAX_HOLES], len[TORUS_MAX_HOLES];
        int n = torus_row_runs(g, j, start, len);
        kept += g->nu;
        for (int k = 0; k < n; k++)
            kept -= len[k];
    }
    return kept;
}

/* Grid whose triangle count is nearest to n: cells about square in arc
 * length (nu / nv ~ R / r), the expected loss to the holes compensated,
 * then nu and nv tried around that estimate with exact counts. */
static torus_grid torus_choose_grid(uint64_t n, const torus_holes *holes)
{
    double hole_area = 0;
    for (int k = 0; k < holes->count; k++)
        hole_area += GEN_PI * holes->radius[k] * holes->radius[k];
    double keep = 1.0 - hole_area / (period_s * period_t);
    double cells = (double)n / 2.0 / keep;
    double nv0 = floor(sqrt(cells * period_t / period_s) + 0.5);
    if (nv0 < 3)
        nv0 = 3;
    double nu0 = floor(cells / nv0 + 0.5);
    if (nu0 < 3)
        nu0 = 3;

    torus_grid best = torus_grid_make(3, 3, holes);
    uint64_t best_diff = UINT64_MAX;
    for (int dv = -1; dv <= 1; dv++)
        for (int du = -3; du <= 3; du++) {
            double nu = nu0 + du, nv = nv0 + dv;
            if (nu < 3 || nv < 3)
                continue;
            torus_grid g = torus_grid_make((uint32_t)nu, (uint32_t)nv, holes);
            uint64_t tri = 2 * torus_kept_cells(&g);
            uint64_t diff = tri > n ? tri - n : n - tri;
            if (diff < best_diff) {
                best_diff = diff;
                best = g;
            }
        }
    return best;
}

/* Scratch for the torus: per-row prefix sums and the old -> new vertex
 * numbering of the full grid. */
typedef struct torus_work {
    size_t *tri_start;  /* nv + 1 */
    size_t *vert_start; /* nv + 1 */
    uint32_t *remap;    /* nu * nv */
} torus_work;

/* Count the triangles of cell row j and the used vertices of vertex row j
 * (a vertex is used when any of its four cells is kept). */
static void torus_count_row(const torus_grid *g, uint32_t j, size_t *tris, size_t *verts)
{
    uint32_t s0[TORUS_MAX_HOLES], l0[TORUS_MAX_HOLES], s1[TORUS_MAX_HOLES], l1[TORUS_MAX_HOLES];
    int below = torus_row_runs(g, (j + g->nv - 1) % g->nv, s0, l0);
    int here = torus_row_runs(g, j, s1, l1);
    size_t t = 0, v = 0;
    const uint32_t nu = g->nu;
    for (uint32_t i = 0; i < nu; i++) {
        uint32_t left = (i + nu - 1) % nu;
        bool keep_here = !in_runs(i, nu, here, s1, l1);
        t += keep_here;
        v += keep_here || !in_runs(left, nu, here, s1, l1) || !in_runs(i, nu, below, s0, l0) ||
             !in_runs(left, nu, below, s0, l0);
    }
    *tris = 2 * t;
    *verts = v;
}

static void torus_place_row(const torus_grid *g, uint32_t j, const torus_work *w, float *pos)
{
    uint32_t s0[TORUS_MAX_HOLES], l0[TORUS_MAX_HOLES], s1[TORUS_MAX_HOLES], l1[TORUS_MAX_HOLES];
    int below = torus_row_runs(g, (j + g->nv - 1) % g->nv, s0, l0);
    int here = torus_row_runs(g, j, s1, l1);
    const uint32_t nu = g->nu;
    double phi = 2 * GEN_PI * j / g->nv;
    double ring = TORUS_R + TORUS_r * cos(phi), z = TORUS_r * sin(phi);
    size_t next = w->vert_start[j];
    for (uint32_t i = 0; i < nu; i++) {
        uint32_t left = (i + nu - 1) % nu;
        bool used = !in_runs(i, nu, here, s1, l1) || !in_runs(left, nu, here, s1, l1) ||
                    !in_runs(i, nu, below, s0, l0) || !in_runs(left, nu, below, s0, l0);
        size_t old = (size_t)j * nu + i;
        if (!used) {
            w->remap[old] = UINT32_MAX;
            continue;
        }
        double theta = 2 * GEN_PI * i / nu;
        float *o = pos + 3 * next;
        o[0] = (float)(ring * cos(theta));
        o[1] = (float)(ring * sin(theta));
        o[2] = (float)z;
        w->remap[old] = (uint32_t)next++;
    }
}

/* Cell (i, j) spans grid vertices i..i+1 around the major circle and
 * j..j+1 around the minor one; (d/dtheta) x (d/dphi) points outwards, so
 * this order is counter-clockwise seen from outside. */
static void torus_emit_row(const torus_grid *g, uint32_t j, const torus_work *w, uint32_t *idx)
{
    uint32_t start[TORUS_MAX_HOLES], len[TORUS_MAX_HOLES];
    int n = torus_row_runs(g, j, start, len);
    const uint32_t nu = g->nu;
    size_t row0 = (size_t)j * nu, row1 = (size_t)((j + 1) % g->nv) * nu;
    uint32_t *o = idx + 3 * w->tri_start[j];
    for (uint32_t i = 0; i < nu; i++) {
        if (in_runs(i, nu, n, start, len))
            continue;
        uint32_t i1 = (i + 1) % nu;
        uint32_t a = w->remap[row0 + i], b = w->remap[row0 + i1];
        uint32_t c = w->remap[row1 + i1], d = w->remap[row1 + i];
        o[0] = a, o[1] = b, o[2] = c;
        o[3] = a, o[4] = c, o[5] = d;
        o += 6;
    }
}

static mr_status generate_torus(size_t triangles, uint64_t seed, mr_mesh *mesh, mr_error *err)
{
    torus_holes holes;
    torus_holes_init(&holes, seed);
    torus_grid g = torus_choose_grid(triangles, &holes);
    uint64_t cells = (uint64_t)g.nu * g.nv;
    if (2 * cells > GEN_MAX_TRIANGLES)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu triangles exceed the 32-bit index limit", triangles);

    const long nv = (long)g.nv;
    torus_work w;
    w.tri_start = mr_alloc_array(2 * ((size_t)nv + 1), sizeof(size_t));
    w.remap = mr_alloc_array((size_t)cells, sizeof(uint32_t));
    if (!w.tri_start || !w.remap) {
        free(w.tri_start);
        free(w.remap);
        return mr_fail_nomem(err, NULL, (size_t)cells * sizeof(uint32_t));
    }
    w.vert_start = w.tri_start + nv + 1;

    /* Rows are counted in parallel, then numbered by a serial prefix sum:
     * the numbering does not depend on how rows were shared out. */
#pragma omp parallel for schedule(dynamic, 8)
    for (long j = 0; j < nv; j++)
        torus_count_row(&g, (uint32_t)j, &w.tri_start[j + 1], &w.vert_start[j + 1]);
    w.tri_start[0] = w.vert_start[0] = 0;
    for (long j = 0; j < nv; j++) {
        w.tri_start[j + 1] += w.tri_start[j];
        w.vert_start[j + 1] += w.vert_start[j];
    }

    mr_mesh m;
    mr_mesh_init(&m);
    mr_status st = mr_mesh_alloc(&m, w.vert_start[nv], w.tri_start[nv], 0, err);
    if (st == MR_OK) {
#pragma omp parallel for schedule(dynamic, 8)
        for (long j = 0; j < nv; j++)
            torus_place_row(&g, (uint32_t)j, &w, m.positions);
#pragma omp parallel for schedule(dynamic, 8)
        for (long j = 0; j < nv; j++)
            torus_emit_row(&g, (uint32_t)j, &w, m.indices);
        *mesh = m;
    }
    free(w.tri_start);
    free(w.remap);
    return st;
}

/* ------------------------------------------------------------------------ */
/* Entry point                                                              */
/* ------------------------------------------------------------------------ */

mr_status mr_generate(mr_generator kind, size_t triangles, uint64_t seed, mr_mesh *mesh,
                      mr_error *err)
{
    if (!mesh)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "mesh is NULL");
    if ((int)kind < 0 || (int)kind >= 3)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "unknown generator kind %d",
                             (int)kind);
    if (triangles == 0)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL,
                             "triangle count must be positive");
    if ((uint64_t)triangles > GEN_MAX_REQUEST)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu triangles exceed the 32-bit index limit", triangles);
    switch (kind) {
    case MR_GEN_SPHERE: return generate_geodesic(triangles, NULL, mesh, err);
    case MR_GEN_TORUS: return generate_torus(triangles, seed, mesh, err);
    case MR_GEN_SCAN: return generate_geodesic(triangles, &seed, mesh, err);
    }
    return MR_ERR_INVALID_ARGUMENT; /* not reached */
}
