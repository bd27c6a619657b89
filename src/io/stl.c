/*
 * STL reader and writer, binary and ascii.
 *
 * STL stores every triangle's three corners by value, so the reader welds
 * corners whose positions are bitwise identical into one vertex (first
 * occurrence defines the vertex order) and returns an indexed mesh. Facet
 * normals are dropped: they are per triangle, not per vertex, and are
 * recomputed from the triangle when writing.
 *
 * Binary or ascii? A binary file's size is exactly 84 + 50 * count, so a
 * matching size means binary, even when its free-form 80-byte header starts
 * with "solid" (many exporters write that). Otherwise a file starting with
 * "solid" is ascii -- unless a NUL byte appears in its first 84 bytes: ascii
 * STL is text, while a binary header or triangle count almost always holds
 * a zero byte, so such a file is a damaged binary STL and gets the binary
 * size diagnosis rather than a confusing ascii syntax error. Anything else
 * is read as binary and fails with a size error.
 */
#include "io_internal.h"
#include "text.h"

#include <math.h>

enum {
    STL_HEADER_SIZE = 80,
    STL_BODY_OFFSET = 84,      /* header + uint32 triangle count */
    STL_TRIANGLE_SIZE = 50,    /* normal, 3 vertices (12 floats), uint16 */
    STL_VERTEX_OFFSET = 12     /* first vertex within a triangle record */
};

static uint32_t load_le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

static void store_le32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

/* ------------------------------------------------------------------------ */
/* Welding corners into vertices                                            */
/* ------------------------------------------------------------------------ */

/*
 * An open-addressing hash table (linear probing) over the 32-bit patterns
 * of the three coordinates. The key is stored in the slot so that a probe
 * touches one cache line and never the vertex array. The table starts
 * sized from the triangle count (a closed or open surface has about half as
 * many vertices as triangles) and doubles when more than half full, which
 * only happens for triangle soups; there is no per-vertex allocation. The
 * distinct positions live only in the table until the end, when they are
 * scattered into an exactly sized positions array.
 *
 * A large table is probed at random, one cache (and TLB) miss per corner.
 * Since the corners of a real STL file come with locality -- a vertex's
 * six or so triangles are usually written close together -- a small
 * direct-mapped cache of recently seen positions, which stays in the CPU's
 * cache, answers most lookups; the big table is probed mostly to insert.
 * The cache holds only (key, index) pairs already in the table, so the
 * result is the same with or without it.
 */
typedef struct weld_slot {
    uint32_t key[3];
    uint32_t index; /* WELD_EMPTY when the slot is free */
} weld_slot;

#define WELD_EMPTY UINT32_MAX
/* mr_mesh_alloc's limit: indices must stay below UINT32_MAX. */
#define WELD_MAX_VERTICES ((size_t)UINT32_MAX - 1)

/* At most 16 Ki entries, 256 KiB: fits L2. Small files get a smaller one,
 * so that reading them does not cost clearing the whole cache. */
enum { WELD_RECENT_MAX_BITS = 14 };

typedef struct weld_table {
    weld_slot *slots;
    size_t mask;        /* capacity - 1; the capacity is a power of two */
    size_t count;       /* distinct positions so far: the next vertex index */
    weld_slot *recent;  /* the small cache, indexed by the hash's top bits */
    int recent_shift;   /* 64 - log2(entries of the small cache) */
} weld_table;

/* Where the corners come from: `tri_stride` bytes per triangle, three
 * 12-byte corners back to back at `base`, stored little endian (binary
 * file) or in host order (the ascii reader's scratch array). */
typedef struct corner_source {
    const unsigned char *base;
    size_t tri_stride;
    bool swap; /* byte-swap each 32-bit word */
} corner_source;

static inline uint64_t weld_hash(const uint32_t k[3])
{
    /* Two multiplications and a final mix (the finaliser of splitmix64):
     * cheap, and coordinates that differ in low mantissa bits only still
     * spread over the whole table. */
    uint64_t h = ((uint64_t)k[0] << 32 | k[1]) * UINT64_C(0x9E3779B97F4A7C15);
    h ^= (uint64_t)k[2] * UINT64_C(0xC2B2AE3D27D4EB4F);
    h ^= h >> 31;
    h *= UINT64_C(0xBF58476D1CE4E5B9);
    h ^= h >> 29;
    return h;
}

static inline weld_slot *recent_slot(const weld_table *t, uint64_t h)
{
    return &t->recent[h >> t->recent_shift]; /* the bits the table uses last */
}

static inline bool key_equal(const uint32_t a[3], const uint32_t b[3])
{
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

/* An array of `count` free slots. (Huge pages were tried for the big
 * table: faster once the kernel has free huge pages, but its synchronous
 * compaction made a process's first read 1.5-2x slower, which is the read
 * a command-line tool does.) */
static weld_slot *alloc_slots(size_t count)
{
    weld_slot *p = mr_alloc_array(count, sizeof(weld_slot));
    if (p)
        memset(p, 0xff, count * sizeof(weld_slot)); /* every index WELD_EMPTY */
    return p;
}

static size_t next_pow2(size_t n)
{
    size_t c = 64;
    while (c < n && c <= SIZE_MAX / 2)
        c *= 2;
    return c;
}

static bool weld_table_init(weld_table *t, size_t capacity)
{
    t->slots = alloc_slots(capacity);
    int bits = 6; /* capacity is at least 64 */
    while (bits < WELD_RECENT_MAX_BITS && ((size_t)1 << bits) < capacity)
        bits++;
    t->recent = alloc_slots((size_t)1 << bits);
    t->recent_shift = 64 - bits;
    t->mask = capacity - 1;
    t->count = 0;
    return t->slots && t->recent;
}

static void weld_table_free(weld_table *t)
{
    free(t->slots);
    free(t->recent);
}

/* Double the table, re-inserting every key. Vertex indices do not change,
 * so the result does not depend on when this happens. */
static bool weld_table_grow(weld_table *t)
{
    size_t old_cap = t->mask + 1;
    if (old_cap > SIZE_MAX / 2)
        return false;
    weld_slot *bigger = alloc_slots(old_cap * 2);
    if (!bigger)
        return false;
    size_t mask = old_cap * 2 - 1;
    for (size_t i = 0; i < old_cap; i++) {
        const weld_slot *s = &t->slots[i];
        if (s->index == WELD_EMPTY)
            continue;
        size_t j = (size_t)weld_hash(s->key) & mask;
        while (bigger[j].index != WELD_EMPTY)
            j = (j + 1) & mask;
        bigger[j] = *s;
    }
    free(t->slots);
    t->slots = bigger;
    t->mask = mask;
    return true;
}

/* Index of the vertex at position `k`, adding it when new. Returns
 * WELD_EMPTY when the table cannot grow or the index limit is reached
 * (the caller tells the two apart by t->count). */
static inline uint32_t weld_insert(weld_table *t, const uint32_t k[3], uint64_t h)
{
    for (;;) {
        size_t i = (size_t)h & t->mask;
        for (;;) {
            weld_slot *s = &t->slots[i];
            if (s->index == WELD_EMPTY)
                break;
            if (key_equal(s->key, k))
                return s->index;
            i = (i + 1) & t->mask;
        }
        if (t->count < (t->mask + 1) / 2) { /* keep the load at most 1/2 */
            weld_slot *s = &t->slots[i];
            memcpy(s->key, k, sizeof s->key);
            s->index = (uint32_t)t->count;
            return (uint32_t)t->count++;
        }
        if (t->count >= WELD_MAX_VERTICES || !weld_table_grow(t))
            return WELD_EMPTY;
    }
}

/* 1 when a float's bit pattern is an infinity or a NaN (exponent all ones). */
static inline uint32_t bits_special(uint32_t bits)
{
    return (bits & 0x7f800000u) == 0x7f800000u;
}

/* Triangles handled per block: their corners are loaded, hashed and looked
 * up in the small cache, and the table slots of the misses prefetched,
 * before any is probed, so that the cache misses of one block overlap
 * instead of following one another. */
enum { WELD_BLOCK = 16 };

#if defined(__GNUC__)
#define WELD_PREFETCH(p) __builtin_prefetch(p)
#else
#define WELD_PREFETCH(p) ((void)(p))
#endif

typedef struct weld_block {
    uint32_t keys[3 * WELD_BLOCK][3];
    uint64_t hashes[3 * WELD_BLOCK];
    uint32_t found[3 * WELD_BLOCK]; /* index from the small cache, or WELD_EMPTY */
} weld_block;

/* Load, check and hash the corners of triangles [t0, t0 + n). Returns the
 * block-relative corner of the first non-finite coordinate, or -1. */
static int weld_load_block(const corner_source *src, const weld_table *t, size_t t0,
                           size_t n, weld_block *b)
{
    uint32_t special = 0; /* OR of "exponent all ones" tests */
    for (size_t j = 0; j < n; j++) {
        const unsigned char *tri = src->base + (t0 + j) * src->tri_stride;
        for (size_t c = 3 * j; c < 3 * j + 3; c++) {
            uint32_t *k = b->keys[c];
            memcpy(k, tri + 12 * (c - 3 * j), 12);
            if (src->swap) {
                k[0] = mr_bswap32(k[0]);
                k[1] = mr_bswap32(k[1]);
                k[2] = mr_bswap32(k[2]);
            }
            special |= bits_special(k[0]) | bits_special(k[1]) | bits_special(k[2]);
            uint64_t h = weld_hash(k);
            b->hashes[c] = h;
            /* A NaN key never matches: free cache entries hold all-ones
             * (NaN) keys, and blocks with a NaN are rejected below. */
            const weld_slot *r = recent_slot(t, h);
            b->found[c] = key_equal(r->key, k) ? r->index : WELD_EMPTY;
            if (b->found[c] == WELD_EMPTY)
                WELD_PREFETCH(&t->slots[(size_t)h & t->mask]);
        }
    }
    if (!special)
        return -1;
    for (size_t c = 0; c < 3 * n; c++)
        if (bits_special(b->keys[c][0]) || bits_special(b->keys[c][1]) ||
            bits_special(b->keys[c][2]))
            return (int)c;
    return -1;
}

/* Resolve the corners of a loaded block into `out`. */
static mr_status weld_resolve_block(weld_table *t, const weld_block *b, size_t corners,
                                    uint32_t *out, const char *name, mr_error *err)
{
    for (size_t c = 0; c < corners; c++) {
        uint32_t v = b->found[c];
        if (v == WELD_EMPTY) {
            v = weld_insert(t, b->keys[c], b->hashes[c]);
            if (MR_UNLIKELY(v == WELD_EMPTY))
                return t->count >= WELD_MAX_VERTICES
                           ? mr_fail_plain(err, MR_ERR_TOO_LARGE, name,
                                           "more than %zu distinct vertices exceed the "
                                           "32-bit index limit",
                                           WELD_MAX_VERTICES)
                           : mr_fail_nomem(err, name,
                                           (t->mask + 1) * 2 * sizeof(weld_slot));
            weld_slot *r = recent_slot(t, b->hashes[c]);
            memcpy(r->key, b->keys[c], sizeof r->key);
            r->index = v;
        }
        out[c] = v;
    }
    return MR_OK;
}

/* Scatter the table's keys into an exactly sized positions array. */
static mr_status weld_positions(const weld_table *t, mr_mesh *mesh, const char *name,
                                mr_error *err)
{
    mesh->positions = mr_alloc_array(t->count * 3, sizeof(float));
    if (!mesh->positions)
        return mr_fail_nomem(err, name, t->count * 3 * sizeof(float));
    for (size_t i = 0; i <= t->mask; i++)
        if (t->slots[i].index != WELD_EMPTY)
            memcpy(mesh->positions + 3 * (size_t)t->slots[i].index, t->slots[i].key,
                   3 * sizeof(float));
    mesh->vertex_count = t->count;
    return MR_OK;
}

/*
 * Weld the corners of `tri_count` triangles into `mesh` (positions, indices,
 * counts). On a non-finite coordinate returns MR_ERR_PARSE with *bad_corner
 * set and no message: the caller knows how to name the place.
 */
static mr_status weld_corners(const corner_source *src, size_t tri_count, mr_mesh *mesh,
                              size_t *bad_corner, const char *name, mr_error *err)
{
    if (tri_count > SIZE_MAX / 3 / sizeof(uint32_t))
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, name, "%zu triangles are too many",
                             tri_count);
    mesh->indices = mr_alloc_array(tri_count * 3, sizeof(uint32_t));
    if (!mesh->indices)
        return mr_fail_nomem(err, name, tri_count * 3 * sizeof(uint32_t));
    weld_table t;
    if (!weld_table_init(&t, next_pow2(tri_count))) {
        weld_table_free(&t);
        return mr_fail_nomem(err, name, next_pow2(tri_count) * sizeof(weld_slot));
    }
    weld_block b;
    mr_status st = MR_OK;
    for (size_t t0 = 0; t0 < tri_count && st == MR_OK; t0 += WELD_BLOCK) {
        size_t n = tri_count - t0 < WELD_BLOCK ? tri_count - t0 : WELD_BLOCK;
        int bad = weld_load_block(src, &t, t0, n, &b);
        if (bad >= 0) {
            *bad_corner = 3 * t0 + (size_t)bad;
            st = MR_ERR_PARSE;
            break;
        }
        st = weld_resolve_block(&t, &b, 3 * n, mesh->indices + 3 * t0, name, err);
    }
    if (st == MR_OK)
        st = weld_positions(&t, mesh, name, err);
    if (st == MR_OK)
        mesh->triangle_count = tri_count;
    weld_table_free(&t);
    return st;
}

/* ------------------------------------------------------------------------ */
/* Binary reader                                                            */
/* ------------------------------------------------------------------------ */

static mr_status read_binary(const char *data, size_t size, const char *name, mr_mesh *mesh,
                             mr_error *err)
{
    const unsigned char *d = (const unsigned char *)data;
    if (size < STL_BODY_OFFSET)
        return mr_fail_plain(err, MR_ERR_PARSE, name,
                             "file of %zu bytes is neither a binary STL (which needs an "
                             "84-byte header) nor an ascii STL (which starts with 'solid')",
                             size);
    uint32_t count = load_le32(d + STL_HEADER_SIZE);
    /* 64-bit arithmetic: 84 + 50 * count does not fit 32 bits. Checked
     * before anything is allocated, so that a huge count on a tiny file
     * fails at once. */
    uint64_t expected = STL_BODY_OFFSET + (uint64_t)STL_TRIANGLE_SIZE * count;
    if ((uint64_t)size < expected) {
        uint64_t held = (size - STL_BODY_OFFSET) / STL_TRIANGLE_SIZE;
        return mr_fail(err, MR_ERR_PARSE, name, MR_NO_POSITION,
                       STL_BODY_OFFSET + held * STL_TRIANGLE_SIZE,
                       "file holds %llu of the %lu triangles its header announces "
                       "(truncated binary STL: %zu bytes, %llu expected)",
                       (unsigned long long)held, (unsigned long)count, size,
                       (unsigned long long)expected);
    }
    if ((uint64_t)size > expected)
        return mr_fail(err, MR_ERR_PARSE, name, MR_NO_POSITION, expected,
                       "%llu bytes follow the %lu triangles the header announces "
                       "(file size %zu does not match a binary STL's %llu, and the file "
                       "is not ascii STL)",
                       (unsigned long long)((uint64_t)size - expected), (unsigned long)count,
                       size, (unsigned long long)expected);
    if (count == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, name, "binary STL holds no triangles");

    corner_source src = {d + STL_BODY_OFFSET + STL_VERTEX_OFFSET, STL_TRIANGLE_SIZE,
                         !mr_host_is_little_endian()};
    size_t bad = 0;
    mr_status st = weld_corners(&src, count, mesh, &bad, name, err);
    if (st == MR_ERR_PARSE) {
        size_t tri = bad / 3;
        int corner = (int)(bad % 3);
        uint64_t off = STL_BODY_OFFSET + (uint64_t)tri * STL_TRIANGLE_SIZE +
                       STL_VERTEX_OFFSET + 12u * (unsigned)corner;
        return mr_fail(err, MR_ERR_PARSE, name, MR_NO_POSITION, off,
                       "triangle %zu, vertex %d of 3 has a non-finite coordinate", tri,
                       corner + 1);
    }
    return st;
}

/* ------------------------------------------------------------------------ */
/* Ascii reader                                                             */
/* ------------------------------------------------------------------------ */

/*
 * Grammar (keywords in any case, tokens separated by any whitespace
 * including newlines; the names after "solid" and "endsolid" run to the end
 * of their line):
 *
 *   file  := solid+
 *   solid := "solid" [name] facet* "endsolid" [name]
 *   facet := "facet" "normal" n n n "outer" "loop"
 *            ("vertex" x y z){3} "endloop" "endfacet"
 *
 * Several solids in one file (multi-body exports) become one mesh. The
 * parser runs twice over the text: once to check it and count the facets,
 * then, with the exact array allocated, to store the corners.
 */
typedef struct ascii_parser {
    const char *begin, *p, *end;
    const char *name;
    mr_error *err;
    float *corners;   /* 9 floats per facet; NULL in the counting pass */
    size_t facets;
} ascii_parser;

/* Skip blanks and newlines. */
static void skip_space(ascii_parser *ps)
{
    const char *s = ps->p;
    while (s < ps->end && (mr_is_space(*s) || *s == '\n'))
        s++;
    ps->p = s;
}

/* Is the token at the cursor `kw` (lowercase letters), in any case? */
static bool token_is(const ascii_parser *ps, const char *kw)
{
    size_t n = strlen(kw);
    if ((size_t)(ps->end - ps->p) < n)
        return false;
    for (size_t i = 0; i < n; i++)
        if ((ps->p[i] | 0x20) != kw[i]) /* ASCII letters only: folds case */
            return false;
    return mr_at_token_end(ps->p + n, ps->end);
}

static mr_status syntax_error(ascii_parser *ps, const char *expected)
{
    if (ps->p >= ps->end) {
        /* Name the last line with text, not the empty one after the final
         * newline. */
        const char *last = ps->end > ps->begin ? ps->end - 1 : ps->end;
        return mr_fail(ps->err, MR_ERR_PARSE, ps->name, mr_line_of(ps->begin, last),
                       MR_NO_POSITION, "expected %s, found end of file", expected);
    }
    uint64_t line = mr_line_of(ps->begin, ps->p);
    char tok[32];
    mr_token_excerpt(ps->p, ps->end, tok, sizeof tok);
    return mr_fail(ps->err, MR_ERR_PARSE, ps->name, line, MR_NO_POSITION,
                   "expected %s, found '%s'", expected, tok);
}

/* Consume keyword `kw` or report what is there instead. */
static mr_status expect_keyword(ascii_parser *ps, const char *kw)
{
    skip_space(ps);
    if (!token_is(ps, kw)) {
        char what[24];
        snprintf(what, sizeof what, "'%s'", kw);
        return syntax_error(ps, what);
    }
    ps->p += strlen(kw);
    return MR_OK;
}

/* Parse one number. Vertex coordinates must be finite floats; facet
 * normals are discarded, so exporters' "nan" normals of degenerate facets
 * are let through. */
static mr_status parse_number(ascii_parser *ps, float *out, bool must_be_finite)
{
    skip_space(ps);
    const char *start = ps->p;
    if (!mr_parse_float(&ps->p, ps->end, out) || !mr_at_token_end(ps->p, ps->end)) {
        ps->p = start;
        return syntax_error(ps, "a number");
    }
    if (must_be_finite && !isfinite(*out)) {
        char tok[80];
        if (mr_number_too_large(start, ps->end, false)) {
            mr_number_excerpt(start, ps->end, tok, sizeof tok);
            return mr_fail(ps->err, MR_ERR_PARSE, ps->name, mr_line_of(ps->begin, start),
                           MR_NO_POSITION, "vertex coordinate %s is out of range", tok);
        }
        mr_token_excerpt(start, ps->end, tok, sizeof tok);
        return mr_fail(ps->err, MR_ERR_PARSE, ps->name, mr_line_of(ps->begin, start),
                       MR_NO_POSITION, "vertex coordinate '%s' is not a finite float", tok);
    }
    return MR_OK;
}

/* The vertices between "outer loop" and "endloop" (inclusive of the
 * latter): exactly three. */
static mr_status parse_loop(ascii_parser *ps)
{
    float xyz[9];
    int n = 0;
    for (;;) {
        skip_space(ps);
        if (token_is(ps, "endloop")) {
            if (n != 3)
                return mr_fail(ps->err, MR_ERR_PARSE, ps->name, mr_line_of(ps->begin, ps->p),
                               MR_NO_POSITION,
                               "facet has %d vertices; an STL facet is a triangle (3)", n);
            ps->p += strlen("endloop");
            break;
        }
        if (!token_is(ps, "vertex"))
            return syntax_error(ps, n < 3 ? "'vertex'" : "'endloop'");
        if (n == 3)
            return mr_fail(ps->err, MR_ERR_PARSE, ps->name, mr_line_of(ps->begin, ps->p),
                           MR_NO_POSITION,
                           "facet has a 4th vertex; an STL facet is a triangle (3)");
        ps->p += strlen("vertex");
        for (int i = 0; i < 3; i++) {
            mr_status st = parse_number(ps, &xyz[3 * n + i], true);
            if (st != MR_OK)
                return st;
        }
        n++;
    }
    if (ps->corners)
        memcpy(ps->corners + 9 * ps->facets, xyz, sizeof xyz);
    ps->facets++;
    return MR_OK;
}

/* One facet, after its "facet" keyword. */
static mr_status parse_facet(ascii_parser *ps)
{
    mr_status st = expect_keyword(ps, "normal");
    float ignored;
    for (int i = 0; i < 3 && st == MR_OK; i++)
        st = parse_number(ps, &ignored, false);
    if (st == MR_OK)
        st = expect_keyword(ps, "outer");
    if (st == MR_OK)
        st = expect_keyword(ps, "loop");
    if (st == MR_OK)
        st = parse_loop(ps);
    if (st == MR_OK)
        st = expect_keyword(ps, "endfacet");
    return st;
}

/* One solid, from "solid" to the end of the "endsolid" line. */
static mr_status parse_solid(ascii_parser *ps)
{
    mr_status st = expect_keyword(ps, "solid");
    if (st != MR_OK)
        return st;
    mr_skip_line(&ps->p, ps->end); /* the name */
    for (;;) {
        skip_space(ps);
        if (token_is(ps, "facet")) {
            ps->p += strlen("facet");
            if ((st = parse_facet(ps)) != MR_OK)
                return st;
        } else if (token_is(ps, "endsolid")) {
            mr_skip_line(&ps->p, ps->end); /* keyword and name */
            return MR_OK;
        } else {
            return syntax_error(ps, "'facet' or 'endsolid'");
        }
    }
}

static mr_status parse_ascii(ascii_parser *ps)
{
    do {
        mr_status st = parse_solid(ps);
        if (st != MR_OK)
            return st;
        skip_space(ps);
        if (ps->p < ps->end && !token_is(ps, "solid"))
            return syntax_error(ps, "'solid' or end of file after 'endsolid'");
    } while (ps->p < ps->end);
    return MR_OK;
}

static mr_status read_ascii(const char *data, size_t size, const char *name, mr_mesh *mesh,
                            mr_error *err)
{
    ascii_parser ps = {data, data, data + size, name, err, NULL, 0};
    mr_status st = parse_ascii(&ps);
    if (st != MR_OK)
        return st;
    if (ps.facets == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, name, "ascii STL holds no facets");
    size_t facets = ps.facets;
    float *corners = mr_alloc_array(facets, 9 * sizeof(float));
    if (!corners)
        return mr_fail_nomem(err, name, facets * 9 * sizeof(float));
    ps = (ascii_parser){data, data, data + size, name, err, corners, 0};
    st = parse_ascii(&ps); /* cannot fail: the same text passed above */
    if (st == MR_OK) {
        corner_source src = {(const unsigned char *)corners, 9 * sizeof(float), false};
        size_t bad = 0;
        st = weld_corners(&src, facets, mesh, &bad, name, err);
        if (st == MR_ERR_PARSE) /* unreachable: coordinates were checked */
            st = mr_fail_plain(err, MR_ERR_PARSE, name,
                               "facet %zu has a non-finite coordinate", bad / 3);
    }
    free(corners);
    return st;
}

/* ------------------------------------------------------------------------ */
/* Dispatch                                                                 */
/* ------------------------------------------------------------------------ */

/* Does the text start (after whitespace) with the keyword "solid"? */
static bool starts_with_solid(const char *data, size_t size)
{
    ascii_parser ps = {data, data, data + size, NULL, NULL, NULL, 0};
    skip_space(&ps);
    return token_is(&ps, "solid");
}

mr_status mr_read_stl(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err)
{
    (void)threads; /* welding is sequential: vertices are numbered by first use */
    const unsigned char *d = (const unsigned char *)data;
    if (size >= STL_BODY_OFFSET &&
        size - STL_BODY_OFFSET == (uint64_t)STL_TRIANGLE_SIZE * load_le32(d + STL_HEADER_SIZE))
        return read_binary(data, size, name, mesh, err);
    size_t head = size < STL_BODY_OFFSET ? size : STL_BODY_OFFSET;
    if (starts_with_solid(data, size) && !memchr(data, '\0', head))
        return read_ascii(data, size, name, mesh, err);
    return read_binary(data, size, name, mesh, err);
}

/* ------------------------------------------------------------------------ */
/* Writer                                                                   */
/* ------------------------------------------------------------------------ */

/* Unit normal of triangle abc (counter-clockwise), or zero when it is
 * degenerate. Computed in double so that small triangles do not underflow. */
static void facet_normal(const float *a, const float *b, const float *c, float n[3])
{
    double u[3], v[3];
    for (int i = 0; i < 3; i++) {
        u[i] = (double)b[i] - a[i];
        v[i] = (double)c[i] - a[i];
    }
    double x = u[1] * v[2] - u[2] * v[1];
    double y = u[2] * v[0] - u[0] * v[2];
    double z = u[0] * v[1] - u[1] * v[0];
    double len = sqrt(x * x + y * y + z * z);
    if (!(len > 0) || !isfinite(len)) {
        n[0] = n[1] = n[2] = 0.0f;
        return;
    }
    n[0] = (float)(x / len);
    n[1] = (float)(y / len);
    n[2] = (float)(z / len);
}

static void store_le_floats(unsigned char *p, const float *v, int n)
{
    for (int i = 0; i < n; i++) {
        uint32_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        store_le32(p + 4 * i, bits);
    }
}

/* Called straight after the failing call, while errno says why. */
static mr_status write_failed(const char *name, mr_error *err)
{
    return mr_fail_write(err, name, errno);
}

static mr_status write_binary(FILE *f, const mr_mesh *mesh, const char *name, mr_error *err)
{
    if (mesh->triangle_count > UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, name,
                             "%zu triangles exceed binary STL's 32-bit triangle count",
                             mesh->triangle_count);
    /* The header must not start with "solid": readers that decide by the
     * first bytes alone would take the file for ascii. */
    unsigned char header[STL_BODY_OFFSET] = {0};
    memcpy(header, "meshreduce", strlen("meshreduce"));
    store_le32(header + STL_HEADER_SIZE, (uint32_t)mesh->triangle_count);
    if (fwrite(header, 1, sizeof header, f) != sizeof header)
        return write_failed(name, err);

    enum { BATCH = 1024 }; /* triangles per fwrite */
    unsigned char buf[BATCH * STL_TRIANGLE_SIZE];
    size_t used = 0;
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *tri = mesh->indices + 3 * t;
        const float *a = mesh->positions + 3 * (size_t)tri[0];
        const float *b = mesh->positions + 3 * (size_t)tri[1];
        const float *c = mesh->positions + 3 * (size_t)tri[2];
        float n[3];
        facet_normal(a, b, c, n);
        unsigned char *rec = buf + used;
        store_le_floats(rec, n, 3);
        store_le_floats(rec + 12, a, 3);
        store_le_floats(rec + 24, b, 3);
        store_le_floats(rec + 36, c, 3);
        rec[48] = rec[49] = 0; /* attribute byte count */
        used += STL_TRIANGLE_SIZE;
        if (used == sizeof buf || t + 1 == mesh->triangle_count) {
            if (fwrite(buf, 1, used, f) != used)
                return write_failed(name, err);
            used = 0;
        }
    }
    return MR_OK;
}

/* " x y z" with the shortest round-tripping numbers, appended at `out`. */
static char *format_triple(char *out, const float *v)
{
    for (int i = 0; i < 3; i++) {
        *out++ = ' ';
        out += mr_format_float(out, v[i]);
    }
    return out;
}

static mr_status write_ascii(FILE *f, const mr_mesh *mesh, const char *name, mr_error *err)
{
    if (fputs("solid meshreduce\n", f) < 0)
        return write_failed(name, err);
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *tri = mesh->indices + 3 * t;
        const float *v[3];
        for (int i = 0; i < 3; i++)
            v[i] = mesh->positions + 3 * (size_t)tri[i];
        float n[3];
        facet_normal(v[0], v[1], v[2], n);
        char buf[512]; /* 4 lines of 3 numbers of at most 16 characters */
        char *o = buf;
        o += sprintf(o, "  facet normal");
        o = format_triple(o, n);
        o += sprintf(o, "\n    outer loop\n");
        for (int i = 0; i < 3; i++) {
            o += sprintf(o, "      vertex");
            o = format_triple(o, v[i]);
            *o++ = '\n';
        }
        o += sprintf(o, "    endloop\n  endfacet\n");
        size_t len = (size_t)(o - buf);
        if (fwrite(buf, 1, len, f) != len)
            return write_failed(name, err);
    }
    if (fputs("endsolid meshreduce\n", f) < 0)
        return write_failed(name, err);
    return MR_OK;
}

mr_status mr_write_stl(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err)
{
    mr_encoding enc = options ? options->encoding : MR_ENCODING_DEFAULT;
    switch (enc) {
    case MR_ENCODING_DEFAULT:
    case MR_ENCODING_BINARY_LE: return write_binary(f, mesh, name, err);
    case MR_ENCODING_ASCII: return write_ascii(f, mesh, name, err);
    case MR_ENCODING_BINARY_BE:
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, name, "STL has no big-endian encoding");
    }
    return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, name, "unknown encoding %d", (int)enc);
}
