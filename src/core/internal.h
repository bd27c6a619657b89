/*
 * Internal helpers shared by every part of the library: error reporting,
 * checked allocation, byte order. Not part of the public API.
 */
#ifndef MR_INTERNAL_H
#define MR_INTERNAL_H

#include "meshreduce.h"

#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(__GNUC__)
#define MR_PRINTF(f, a) __attribute__((format(printf, f, a)))
#define MR_LIKELY(x) __builtin_expect(!!(x), 1)
#define MR_UNLIKELY(x) __builtin_expect(!!(x), 0)
#else
#define MR_PRINTF(f, a)
#define MR_LIKELY(x) (x)
#define MR_UNLIKELY(x) (x)
#endif

/*
 * Fill `err` (when non-NULL) and return `status`. The message is composed as
 *   "<name>:<line>: <text>"            when line != MR_NO_POSITION
 *   "<name>: byte <offset>: <text>"    when only offset is given
 *   "<name>: <text>"                   otherwise
 * and name may be NULL, in which case the "<name>" prefix is left out
 * ("line 12: ...", "byte 40: ...").
 */
mr_status mr_fail(mr_error *err, mr_status status, const char *name, uint64_t line,
                  uint64_t offset, const char *fmt, ...) MR_PRINTF(6, 7);

/* mr_fail without a position. */
#define mr_fail_plain(err, status, name, ...) \
    mr_fail((err), (status), (name), MR_NO_POSITION, MR_NO_POSITION, __VA_ARGS__)

/* Report an allocation failure of `bytes` bytes. */
mr_status mr_fail_nomem(mr_error *err, const char *name, size_t bytes);

/* Clear an error record to MR_OK with an empty message. */
void mr_error_clear(mr_error *err);

/* malloc/calloc/realloc with overflow-checked element counts. They return
 * NULL on overflow or failure; count 0 returns a valid non-NULL pointer. */
void *mr_alloc_array(size_t count, size_t size);
void *mr_calloc_array(size_t count, size_t size);
void *mr_realloc_array(void *p, size_t count, size_t size);

/* Compact the vertex arrays of `mesh` given old -> new indices (new index
 * < old index or equal, UINT32_MAX = dropped) and the new vertex count.
 * Attribute arrays move with the positions. Triangle indices are not
 * touched. */
void mr_mesh_compact_vertices(mr_mesh *mesh, const uint32_t *remap, size_t new_count);
/* n vertices' texture sets 1-3, tangents, joints and weights from src's
 * vertex `from` on to dst's vertex `at` on (each array both have; may
 * overlap). */
void mr_mesh_copy_more(mr_mesh *dst, size_t at, const mr_mesh *src, size_t from, size_t n);
/* n triangles in material order (mesh.c): *order the triangles, none
 * first, then by material, each run in its input order (a stable sort);
 * *key[i] order[i]'s material + 1 (0: none). Both malloc'd. */
mr_status mr_material_order(const uint32_t *materials, size_t n, uint32_t **key,
                            uint32_t **order, mr_error *err);

/* Monotonic wall clock in seconds (phase timings). */
double mr_now_seconds(void);

/* sRGB display values (0..1, clamped; NaN stays NaN) to linear light and
 * back (IEC 61966-2-1): glTF's colour factors and COLOR_0 are linear, the
 * renderer's textures and output display values. */
static inline float mr_srgb_to_linear(float v)
{
    v = v < 0 ? 0 : v > 1 ? 1 : v;
    return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
}

static inline float mr_linear_to_srgb(float v)
{
    v = v < 0 ? 0 : v > 1 ? 1 : v;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

/* Byte order helpers for binary formats (the host may be of either order). */
static inline bool mr_host_is_little_endian(void)
{
    const uint16_t one = 1;
    uint8_t b;
    memcpy(&b, &one, 1);
    return b == 1;
}

static inline uint16_t mr_bswap16(uint16_t v) { return (uint16_t)((v >> 8) | (v << 8)); }
static inline uint32_t mr_bswap32(uint32_t v)
{
    return ((v & 0xffu) << 24) | ((v & 0xff00u) << 8) | ((v >> 8) & 0xff00u) | (v >> 24);
}
static inline uint64_t mr_bswap64(uint64_t v)
{
    return ((uint64_t)mr_bswap32((uint32_t)v) << 32) | mr_bswap32((uint32_t)(v >> 32));
}

/* splitmix64's finaliser: a bijective 64-bit mix with full avalanche; the
 * library's one hash for seeds, counter-based random streams and keys. */
static inline uint64_t mr_mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= UINT64_C(0xbf58476d1ce4e5b9);
    x ^= x >> 27;
    x *= UINT64_C(0x94d049bb133111eb);
    x ^= x >> 31;
    return x;
}

/* Area of the triangle (a, b, c), half the length of the cross product. */
static inline double mr_triangle_area(const double a[3], const double b[3], const double c[3])
{
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double x = u[1] * v[2] - u[2] * v[1];
    double y = u[2] * v[0] - u[0] * v[2];
    double z = u[0] * v[1] - u[1] * v[0];
    return 0.5 * sqrt(x * x + y * y + z * z);
}

/* Number of threads to use for a requested count (0 = all cores): at most
 * the team a parallel region opened here can have (one inside the caller's
 * parallel region when nesting is off, and in the serial build; at most
 * OMP_THREAD_LIMIT). */
int mr_thread_count(int requested);

#endif /* MR_INTERNAL_H */
