/*
 * Wavefront OBJ reader and writer.
 *
 * Reading is two passes over the buffer, both split into chunks at line
 * boundaries and run in parallel:
 *   pass 1 counts, per chunk, the v / vt / vn lines and the triangles its f
 *          lines fan into; prefix sums give every chunk its starting counts;
 *   pass 2 parses every chunk straight into the exact arrays, resolving
 *          relative (negative) indices with the chunk's starting counts.
 * Each chunk keeps only its first error; the error of the earliest failing
 * chunk is reported, so the result (mesh or message) does not depend on the
 * thread count.
 *
 * Output vertex i is the i-th `v` line. When faces use vt/vn, a serial pass
 * afterwards gives every (v, vt, vn) combination its own vertex: the first
 * combination a `v` is used with keeps its slot, later ones are appended
 * (UV seams, hard edges). Attributes come through the faces only, except in
 * a point cloud whose vt / vn lines match its v lines one to one.
 */
#include "io_internal.h"
#include "mapped.h"
#include "obj_materials.h"
#include "text.h"

#include <errno.h>

#include "../core/omp_compat.h"

/* Chunks smaller than this are not worth a thread of their own. (Can be
 * set on the command line to test chunk boundaries on small inputs.) */
#ifndef OBJ_MIN_CHUNK
#define OBJ_MIN_CHUNK ((size_t)32 * 1024)
#endif

/* "No index" in the per-corner vt/vn arrays. Real indices stay below it
 * because the counts are checked against UINT32_MAX - 2. */
#define OBJ_NONE UINT32_MAX

/* ------------------------------------------------------------------------ */
/* Line classification (shared by both passes, so that they agree)          */
/* ------------------------------------------------------------------------ */

typedef enum line_kind {
    LINE_EMPTY, /* blank or comment */
    LINE_V,
    LINE_VT,
    LINE_VN,
    LINE_F,
    LINE_OTHER, /* a keyword we accept and ignore (o, g, usemtl, vp, ...) */
    LINE_BAD    /* first token is not an identifier: not an OBJ line */
} line_kind;

static inline bool is_ident_start(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
}

static inline bool is_ident_char(char c) { return is_ident_start(c) || mr_is_digit(c); }

/* A number or index ends at a blank, a newline, a comment or the end. */
static inline bool is_delim(const char *s, const char *end)
{
    return s >= end || mr_is_space(*s) || *s == '\n' || *s == '#';
}

static inline bool at_eol(const char *s, const char *end)
{
    return s >= end || *s == '\n' || *s == '#';
}

/* Classify the line at *p and leave *p after its keyword (at the keyword
 * itself for LINE_BAD, so that the message can quote it). */
static inline line_kind classify(const char **p, const char *end)
{
    const char *s = *p;
    mr_skip_blanks(&s, end);
    *p = s;
    if (at_eol(s, end))
        return LINE_EMPTY;
    if (!is_ident_start(*s))
        return LINE_BAD;
    const char *k = s;
    do
        s++;
    while (s < end && is_ident_char(*s));
    if (!is_delim(s, end))
        return LINE_BAD;
    *p = s;
    size_t n = (size_t)(s - k);
    if (k[0] == 'v') {
        if (n == 1)
            return LINE_V;
        if (n == 2 && k[1] == 't')
            return LINE_VT;
        if (n == 2 && k[1] == 'n')
            return LINE_VN;
    } else if (k[0] == 'f' && n == 1) {
        return LINE_F;
    }
    return LINE_OTHER;
}

/* Past the end of the line; most lines are already at their '\n'. */
static inline void next_line(const char **p, const char *end)
{
    if (*p < end && **p == '\n')
        (*p)++;
    else
        mr_skip_line(p, end);
}

/* ------------------------------------------------------------------------ */
/* Chunks                                                                   */
/* ------------------------------------------------------------------------ */

typedef struct obj_chunk {
    const char *begin, *end;
    /* pass 1 */
    size_t nv, nvt, nvn, ntri;
    bool slash;      /* some face corner has a '/': vt or vn may be used */
    bool color_hint; /* the chunk's first v line has six or more tokens */
    /* prefix sums: global index of the chunk's first v, vt, vn, triangle */
    size_t v0, vt0, vn0, tri0;
    /* pass 2 */
    bool used_vt, used_vn; /* some corner referenced a vt / a vn */
    bool saw_color;        /* some v line had r g b */
    const char *err_pos;   /* first error, or NULL */
    mr_status err_status;
    char err_msg[256];
} obj_chunk;

/* Where pass 2 writes (shared, read-only for the chunks). */
typedef struct obj_dest {
    size_t nv, nvt, nvn, ntri; /* totals */
    float *pos, *col;          /* 3 and 4 per v line; col may be NULL */
    float *vt, *vn;            /* 2 per vt, 3 per vn line, or NULL */
    uint32_t *idx;             /* 3 per triangle: v index */
    uint32_t *cvt, *cvn;       /* 3 per triangle: vt / vn index, or NULL */
    size_t base_v, base_tri;   /* pos, col and idx (cvt, cvn) start at these
                                  (a window of the file: mr_obj_stream; else 0) */
    size_t base_vt, base_vn;   /* and vt, vn */
} obj_dest;

static bool chunk_fail(obj_chunk *c, const char *pos, mr_status st, const char *fmt, ...)
    MR_PRINTF(4, 5);

static bool chunk_fail(obj_chunk *c, const char *pos, mr_status st, const char *fmt, ...)
{
    c->err_pos = pos;
    c->err_status = st;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->err_msg, sizeof c->err_msg, fmt, ap);
    va_end(ap);
    return false;
}

/* Split [data, data + size) into at most `threads` chunks that start at
 * line starts. Returns the chunk count (>= 1). */
static size_t split_chunks(const char *data, size_t size, int threads, obj_chunk *chunks)
{
    size_t n = (size_t)threads;
    if (n > size / OBJ_MIN_CHUNK)
        n = size / OBJ_MIN_CHUNK;
    if (n < 1)
        n = 1;
    const char *end = data + size;
    const char *prev = data;
    for (size_t i = 0; i < n; i++) {
        const char *b = data + size / n * i;
        if (b < prev)
            b = prev;
        if (b > data && b[-1] != '\n')
            mr_skip_line(&b, end);
        chunks[i].begin = b;
        if (i > 0)
            chunks[i - 1].end = b;
        prev = b;
    }
    chunks[n - 1].end = end;
    return n;
}

typedef void (*chunk_fn)(obj_chunk *c, const obj_dest *d);

static void run_chunks(obj_chunk *chunks, size_t n, chunk_fn fn, const obj_dest *d)
{
    if (n == 1) {
        fn(&chunks[0], d);
        return;
    }
#pragma omp parallel for schedule(dynamic, 1) num_threads((int)n)
    for (long i = 0; i < (long)n; i++)
        fn(&chunks[i], d);
}

/* ------------------------------------------------------------------------ */
/* Pass 1: counting                                                         */
/* ------------------------------------------------------------------------ */

/* Number of tokens up to the end of the line (only for the color hint). */
static int count_tokens(const char *s, const char *end)
{
    int n = 0;
    for (;;) {
        mr_skip_blanks(&s, end);
        if (at_eol(s, end))
            return n;
        n++;
        while (!is_delim(s, end))
            s++;
    }
}

/* Byte classes for the pass 1 corner count. */
enum { CC_BLANK = 1, CC_STOP = 2, CC_SLASH = 4 };

static const unsigned char corner_class[256] = {
    [' '] = CC_BLANK, ['\t'] = CC_BLANK, ['\r'] = CC_BLANK, ['\v'] = CC_BLANK,
    ['\f'] = CC_BLANK, ['\n'] = CC_STOP,  ['#'] = CC_STOP,   ['/'] = CC_SLASH,
};

/* Count the corners (tokens) of a face line: the same tokens that pass 2
 * parses one by one, so that both agree on the triangle count. One table
 * look-up and one predictable branch per byte: this loop is a large part
 * of pass 1 on face-heavy files. */
static void count_face(const char **p, const char *end, obj_chunk *c)
{
    const char *s = *p;
    size_t corners = 0;
    unsigned prev_blank = 1, slash = 0; /* the keyword ended at a delimiter */
    for (; s < end; s++) {
        unsigned k = corner_class[(unsigned char)*s];
        if (k & CC_STOP)
            break;
        unsigned blank = k & CC_BLANK;
        corners += prev_blank & (blank ^ 1u);
        prev_blank = blank;
        slash |= k;
    }
    /* a face of fewer than 3 corners is an error that pass 2 reports */
    if (corners >= 3)
        c->ntri += corners - 2;
    c->slash |= (slash & CC_SLASH) != 0;
    *p = s;
}

static void count_chunk(obj_chunk *c, const obj_dest *d)
{
    (void)d;
    const char *p = c->begin, *end = c->end;
    while (p < end) {
        switch (classify(&p, end)) {
        case LINE_V:
            /* Colors are rare: look at one line per chunk, and let pass 2
             * ask for a second run when a later line has them. */
            if (c->nv++ == 0)
                c->color_hint = count_tokens(p, end) >= 6;
            break;
        case LINE_VT: c->nvt++; break;
        case LINE_VN: c->nvn++; break;
        case LINE_F: count_face(&p, end, c); break;
        default: break;
        }
        next_line(&p, end);
    }
}

/* ------------------------------------------------------------------------ */
/* Pass 2: parsing                                                          */
/* ------------------------------------------------------------------------ */

typedef enum num_result { NUM_OK, NUM_MALFORMED, NUM_TOO_MANY } num_result;

/* Read up to `max` numbers to the end of the line. On NUM_MALFORMED *p is
 * at the bad token. */
static inline num_result read_numbers(const char **p, const char *end, double *out, int max,
                                      int *count)
{
    const char *s = *p;
    int n = 0;
    for (;;) {
        mr_skip_blanks(&s, end);
        if (at_eol(s, end))
            break;
        if (n == max) {
            *p = s;
            *count = n;
            return NUM_TOO_MANY;
        }
        const char *t = s;
        /* a decimal too large for a double is out of range (fail_number
         * says so), not an infinite coordinate */
        if (!mr_parse_double(&t, end, &out[n]) || !is_delim(t, end) ||
            (isinf(out[n]) && mr_number_too_large(s, end, false))) {
            *p = s;
            return NUM_MALFORMED;
        }
        s = t;
        n++;
    }
    *p = s;
    *count = n;
    return NUM_OK;
}

static bool fail_number(obj_chunk *c, const char *pos, const char *end)
{
    char msg[160];
    mr_number_error(pos, end, false, msg, sizeof msg); /* malformed, or out of range */
    return chunk_fail(c, pos, MR_ERR_PARSE, "%s", msg);
}

static bool parse_v(const char **p, const char *end, obj_chunk *c, const obj_dest *d,
                    size_t v)
{
    const char *line = *p;
    double x[6];
    int n = 0;
    num_result r = read_numbers(p, end, x, 6, &n);
    if (r == NUM_MALFORMED)
        return fail_number(c, *p, end);
    if (r == NUM_TOO_MANY || n == 5)
        return chunk_fail(c, line, MR_ERR_PARSE,
                          "vertex has %s%d numbers (expected x y z, x y z w or x y z r g b)",
                          r == NUM_TOO_MANY ? "more than " : "", n);
    if (n < 3)
        return chunk_fail(c, line, MR_ERR_PARSE,
                          "vertex has too few coordinates (expected x y z)");
    float *out = d->pos + 3 * (v - d->base_v);
    for (int i = 0; i < 3; i++) {
        out[i] = (float)x[i];
        if (!isfinite(out[i]))
            return chunk_fail(c, line, MR_ERR_PARSE,
                              "vertex has a non-finite coordinate (%g)", x[i]);
    }
    if (n == 6) {
        for (int i = 3; i < 6; i++)
            if (!(x[i] >= 0.0 && x[i] <= 1.0))
                return chunk_fail(c, line, MR_ERR_PARSE,
                                  "vertex color %g is outside [0, 1]", x[i]);
        c->saw_color = true;
    }
    if (d->col) {
        float *col = d->col + 4 * (v - d->base_v);
        /* a vertex without a color among colored ones is white */
        col[0] = n == 6 ? (float)x[3] : 1.0f;
        col[1] = n == 6 ? (float)x[4] : 1.0f;
        col[2] = n == 6 ? (float)x[5] : 1.0f;
        col[3] = 1.0f;
    }
    return true;
}

static bool parse_vt(const char **p, const char *end, obj_chunk *c, const obj_dest *d,
                     size_t t)
{
    const char *line = *p;
    double x[3] = {0, 0, 0};
    int n = 0;
    num_result r = read_numbers(p, end, x, 3, &n);
    if (r == NUM_MALFORMED)
        return fail_number(c, *p, end);
    if (r == NUM_TOO_MANY || n == 0)
        return chunk_fail(c, line, MR_ERR_PARSE,
                          "texture coordinate has %s%d numbers (expected u [v [w]])",
                          r == NUM_TOO_MANY ? "more than " : "", n);
    float u = (float)x[0], w = (float)x[1];
    if (!isfinite(u) || !isfinite(w) || !isfinite(x[2]))
        return chunk_fail(c, line, MR_ERR_PARSE, "texture coordinate is not finite");
    if (d->vt) {
        d->vt[2 * (t - d->base_vt)] = u;
        d->vt[2 * (t - d->base_vt) + 1] = w;
    }
    return true;
}

static bool parse_vn(const char **p, const char *end, obj_chunk *c, const obj_dest *d,
                     size_t t)
{
    const char *line = *p;
    double x[3];
    int n = 0;
    num_result r = read_numbers(p, end, x, 3, &n);
    if (r == NUM_MALFORMED)
        return fail_number(c, *p, end);
    if (r == NUM_TOO_MANY || n != 3)
        return chunk_fail(c, line, MR_ERR_PARSE, "normal has %s%d numbers (expected x y z)",
                          r == NUM_TOO_MANY ? "more than " : "", n);
    float f[3];
    for (int i = 0; i < 3; i++) {
        f[i] = (float)x[i];
        if (!isfinite(f[i]))
            return chunk_fail(c, line, MR_ERR_PARSE, "normal is not finite");
    }
    if (d->vn)
        memcpy(d->vn + 3 * (t - d->base_vn), f, sizeof f);
    return true;
}

/* What a face index refers to, for messages. */
typedef struct index_space {
    const char *one, *many; /* "vertex", "vertices" */
    size_t so_far, total;   /* defined before this line, in the whole file */
} index_space;

/* Parse one index of a corner and resolve it to 0-based. */
static inline bool parse_index(const char **p, const char *end, obj_chunk *c,
                               const char *corner, const index_space *sp, uint32_t *out)
{
    int64_t k;
    if (!mr_parse_i64(p, end, &k)) {
        char tok[80];
        if (mr_number_too_large(*p, end, true)) {
            mr_number_excerpt(*p, end, tok, sizeof tok);
            return chunk_fail(c, corner, MR_ERR_PARSE, "face index %s is out of range", tok);
        }
        mr_token_excerpt(corner, end, tok, sizeof tok);
        return chunk_fail(c, corner, MR_ERR_PARSE, "malformed face corner '%s'", tok);
    }
    if (k > 0) {
        if ((uint64_t)k > sp->total)
            return chunk_fail(c, corner, MR_ERR_PARSE,
                              "face refers to %s %lld, but the file defines only %zu %s",
                              sp->one, (long long)k, sp->total, sp->many);
        *out = (uint32_t)(k - 1);
        return true;
    }
    if (k < 0) {
        /* mr_parse_i64 never yields INT64_MIN, so -k does not overflow */
        if ((uint64_t)-k > sp->so_far)
            return chunk_fail(c, corner, MR_ERR_PARSE,
                              "face refers to %s %lld, but only %zu %s are defined so far",
                              sp->one, (long long)k, sp->so_far, sp->many);
        *out = (uint32_t)(sp->so_far - (uint64_t)-k);
        return true;
    }
    return chunk_fail(c, corner, MR_ERR_PARSE,
                      "face index 0 is invalid (OBJ indices start at 1)");
}

typedef struct obj_corner {
    uint32_t v, vt, vn;
} obj_corner;

/* Parse a corner: v, v/vt, v//vn or v/vt/vn. */
static inline bool parse_corner(const char **p, const char *end, obj_chunk *c,
                                const index_space sp[3], obj_corner *out)
{
    const char *s = *p, *start = s;
    out->vt = out->vn = OBJ_NONE;
    if (!parse_index(&s, end, c, start, &sp[0], &out->v))
        return false;
    if (s < end && *s == '/') {
        s++;
        if (s < end && *s == '/') {
            s++;
            if (!parse_index(&s, end, c, start, &sp[2], &out->vn))
                return false;
        } else {
            if (!parse_index(&s, end, c, start, &sp[1], &out->vt))
                return false;
            if (s < end && *s == '/') {
                s++;
                if (!parse_index(&s, end, c, start, &sp[2], &out->vn))
                    return false;
            }
        }
    }
    if (!is_delim(s, end)) {
        char tok[32];
        mr_token_excerpt(start, end, tok, sizeof tok);
        return chunk_fail(c, start, MR_ERR_PARSE, "malformed face corner '%s'", tok);
    }
    *p = s;
    return true;
}

static inline void put_corner(const obj_dest *d, size_t at, const obj_corner *k)
{
    const size_t i = at - 3 * d->base_tri;
    d->idx[i] = k->v;
    if (d->cvt)
        d->cvt[i] = k->vt;
    if (d->cvn)
        d->cvn[i] = k->vn;
}

/* Parse a face and fan it into triangles (a,b,c), (a,c,d), ... at *tri. */
static bool parse_f(const char **p, const char *end, obj_chunk *c, const obj_dest *d,
                    const index_space sp[3], size_t *tri)
{
    const char *line = *p;
    const size_t tri_end = c->tri0 + c->ntri;
    obj_corner first = {0, 0, 0}, prev = {0, 0, 0}, cur = {0, 0, 0};
    size_t n = 0;
    for (;;) {
        mr_skip_blanks(p, end);
        if (at_eol(*p, end))
            break;
        if (!parse_corner(p, end, c, sp, &cur))
            return false;
        c->used_vt |= cur.vt != OBJ_NONE;
        c->used_vn |= cur.vn != OBJ_NONE;
        if (n == 0) {
            first = cur;
        } else if (n >= 2) {
            /* pass 1 counted the same tokens; this guards the arrays if
             * the two passes ever disagreed */
            if (*tri >= tri_end)
                return chunk_fail(c, line, MR_ERR_PARSE,
                                  "internal error: face count changed between passes");
            size_t at = 3 * (*tri)++;
            put_corner(d, at, &first);
            put_corner(d, at + 1, &prev);
            put_corner(d, at + 2, &cur);
        }
        prev = cur;
        n++;
    }
    if (n < 3)
        return chunk_fail(c, line, MR_ERR_PARSE,
                          "face has only %zu corner%s (at least 3 needed)", n,
                          n == 1 ? "" : "s");
    return true;
}

static void parse_chunk(obj_chunk *c, const obj_dest *d)
{
    const char *p = c->begin, *end = c->end;
    index_space sp[3] = {{"vertex", "vertices", c->v0, d->nv},
                         {"texture coordinate", "texture coordinates", c->vt0, d->nvt},
                         {"normal", "normals", c->vn0, d->nvn}};
    size_t tri = c->tri0;
    c->used_vt = c->used_vn = c->saw_color = false;
    c->err_pos = NULL;
    while (p < end) {
        bool ok = true;
        switch (classify(&p, end)) {
        case LINE_V: ok = parse_v(&p, end, c, d, sp[0].so_far++); break;
        case LINE_VT: ok = parse_vt(&p, end, c, d, sp[1].so_far++); break;
        case LINE_VN: ok = parse_vn(&p, end, c, d, sp[2].so_far++); break;
        case LINE_F: ok = parse_f(&p, end, c, d, sp, &tri); break;
        case LINE_BAD: {
            char tok[32];
            mr_token_excerpt(p, end, tok, sizeof tok);
            ok = chunk_fail(c, p, MR_ERR_PARSE, "not an OBJ line (it starts with '%s')", tok);
            break;
        }
        default: break;
        }
        if (!ok)
            return;
        next_line(&p, end);
    }
}

/* ------------------------------------------------------------------------ */
/* Seams: one vertex per distinct (v, vt, vn)                               */
/* ------------------------------------------------------------------------ */

/* Key of a v slot that no corner has used yet. A corner without vt and vn
 * has the key (OBJ_NONE, OBJ_NONE), so this must differ from it: its halves
 * are UINT32_MAX - 1, which no index reaches (counts <= UINT32_MAX - 2). */
#define KEY_UNSET ((uint64_t)(UINT32_MAX - 1) << 32 | (UINT32_MAX - 1))

typedef struct seam_table {
    uint64_t *key;    /* (vt << 32 | vn) of every output vertex */
    uint32_t *next;   /* next vertex with the same position, or OBJ_NONE */
    uint32_t *origin; /* the v line an appended vertex copies */
    size_t count, cap;
} seam_table;

static void seam_free(seam_table *t)
{
    free(t->key);
    free(t->next);
    free(t->origin);
}

static bool seam_grow(seam_table *t)
{
    size_t cap = t->cap + t->cap / 2 + 64;
    uint64_t *key = mr_realloc_array(t->key, cap, sizeof *key);
    if (key)
        t->key = key;
    uint32_t *next = mr_realloc_array(t->next, cap, sizeof *next);
    if (next)
        t->next = next;
    uint32_t *origin = mr_realloc_array(t->origin, cap, sizeof *origin);
    if (origin)
        t->origin = origin;
    if (!key || !next || !origin)
        return false;
    t->cap = cap;
    return true;
}

/* The vertex for corner (v, key): v itself, a duplicate made earlier, or a
 * new duplicate appended. Returns OBJ_NONE when out of memory or space. */
static uint32_t seam_vertex(seam_table *t, uint32_t v, uint64_t key)
{
    if (t->key[v] == KEY_UNSET) {
        t->key[v] = key;
        return v;
    }
    uint32_t u = v;
    for (;;) {
        if (t->key[u] == key)
            return u;
        if (t->next[u] == OBJ_NONE)
            break;
        u = t->next[u];
    }
    if (t->count >= (size_t)UINT32_MAX - 1)
        return OBJ_NONE;
    if (t->count == t->cap && !seam_grow(t))
        return OBJ_NONE;
    uint32_t w = (uint32_t)t->count++;
    t->key[w] = key;
    t->next[w] = OBJ_NONE;
    t->origin[w] = v;
    t->next[u] = w;
    return w;
}

/* Copy positions and colors to the appended vertices and fill texcoords
 * and normals from the keys. */
static mr_status seam_apply(const seam_table *t, mr_mesh *m, const float *vt, const float *vn,
                            const char *name, mr_error *err)
{
    size_t n0 = m->vertex_count, n = t->count;
    float *pos = mr_realloc_array(m->positions, n * 3, sizeof(float));
    if (!pos)
        return mr_fail_nomem(err, name, n * 3 * sizeof(float));
    m->positions = pos;
    if (m->colors) {
        float *col = mr_realloc_array(m->colors, n * 4, sizeof(float));
        if (!col)
            return mr_fail_nomem(err, name, n * 4 * sizeof(float));
        m->colors = col;
    }
    for (size_t u = n0; u < n; u++) {
        memcpy(pos + 3 * u, pos + 3 * (size_t)t->origin[u], 3 * sizeof(float));
        if (m->colors)
            memcpy(m->colors + 4 * u, m->colors + 4 * (size_t)t->origin[u], 4 * sizeof(float));
    }
    if (vt && !(m->texcoords = mr_alloc_array(n * 2, sizeof(float))))
        return mr_fail_nomem(err, name, n * 2 * sizeof(float));
    if (vn && !(m->normals = mr_alloc_array(n * 3, sizeof(float))))
        return mr_fail_nomem(err, name, n * 3 * sizeof(float));
    for (size_t u = 0; u < n; u++) {
        uint64_t k = t->key[u];
        uint32_t a = k == KEY_UNSET ? OBJ_NONE : (uint32_t)(k >> 32);
        uint32_t b = k == KEY_UNSET ? OBJ_NONE : (uint32_t)k;
        if (vt) {
            m->texcoords[2 * u] = a == OBJ_NONE ? 0.0f : vt[2 * (size_t)a];
            m->texcoords[2 * u + 1] = a == OBJ_NONE ? 0.0f : vt[2 * (size_t)a + 1];
        }
        if (vn) {
            for (int i = 0; i < 3; i++)
                m->normals[3 * u + i] = b == OBJ_NONE ? 0.0f : vn[3 * (size_t)b + i];
        }
    }
    m->vertex_count = n;
    return MR_OK;
}

/* Rewrite the triangle indices so that every distinct (v, vt, vn) is its
 * own vertex. cvt / cvn are NULL when no corner uses them. Serial, in
 * corner order, so that the numbering is the same for every thread count. */
static mr_status split_seams(mr_mesh *m, const uint32_t *cvt, const uint32_t *cvn,
                             const float *vt, const float *vn, const char *name,
                             mr_error *err)
{
    seam_table t = {0};
    t.count = m->vertex_count;
    t.cap = m->vertex_count; /* seam_grow makes room for about half as many again */
    if (!seam_grow(&t)) {
        seam_free(&t);
        return mr_fail_nomem(err, name, t.cap * 16);
    }
    for (size_t u = 0; u < m->vertex_count; u++) {
        t.key[u] = KEY_UNSET;
        t.next[u] = OBJ_NONE;
        t.origin[u] = (uint32_t)u;
    }
    size_t corners = 3 * m->triangle_count;
    for (size_t i = 0; i < corners; i++) {
        uint64_t key = (uint64_t)(cvt ? cvt[i] : OBJ_NONE) << 32 | (cvn ? cvn[i] : OBJ_NONE);
        uint32_t u = seam_vertex(&t, m->indices[i], key);
        if (u == OBJ_NONE) {
            mr_status st = t.count >= (size_t)UINT32_MAX - 1
                               ? mr_fail_plain(err, MR_ERR_TOO_LARGE, name,
                                               "more than %u distinct vertex/texture/normal "
                                               "combinations",
                                               UINT32_MAX - 1)
                               : mr_fail_nomem(err, name, t.cap * 24);
            seam_free(&t);
            return st;
        }
        m->indices[i] = u;
    }
    mr_status st = seam_apply(&t, m, cvt ? vt : NULL, cvn ? vn : NULL, name, err);
    seam_free(&t);
    return st;
}

/* ------------------------------------------------------------------------ */
/* The reader                                                               */
/* ------------------------------------------------------------------------ */

typedef struct obj_temp {
    obj_chunk *chunks;
    float *vt, *vn;
    uint32_t *cvt, *cvn;
} obj_temp;

static void temp_free(obj_temp *t)
{
    free(t->chunks);
    free(t->vt);
    free(t->vn);
    free(t->cvt);
    free(t->cvn);
}

/* Sum the chunks' counts into starting offsets and totals. */
static void prefix_sums(obj_chunk *chunks, size_t n, obj_dest *d, bool *slash, bool *color)
{
    d->nv = d->nvt = d->nvn = d->ntri = 0;
    *slash = *color = false;
    for (size_t i = 0; i < n; i++) {
        obj_chunk *c = &chunks[i];
        c->v0 = d->nv;
        c->vt0 = d->nvt;
        c->vn0 = d->nvn;
        c->tri0 = d->ntri;
        d->nv += c->nv;
        d->nvt += c->nvt;
        d->nvn += c->nvn;
        d->ntri += c->ntri;
        *slash |= c->slash;
        *color |= c->color_hint;
    }
}

/* The earliest chunk's error, with its line number, or MR_OK. */
static mr_status first_error(const obj_chunk *chunks, size_t n, const char *data,
                             const char *name, mr_error *err)
{
    for (size_t i = 0; i < n; i++)
        if (chunks[i].err_pos)
            return mr_fail(err, chunks[i].err_status, name,
                           mr_line_of(data, chunks[i].err_pos),
                           (uint64_t)(chunks[i].err_pos - data), "%s", chunks[i].err_msg);
    return MR_OK;
}

/* Allocate the mesh and the temporary attribute arrays for pass 2. */
static mr_status allocate(const obj_dest *counts, bool slash, bool color, mr_mesh *mesh,
                          obj_temp *t, obj_dest *d, const char *name, mr_error *err)
{
    if (mr_mesh_alloc(mesh, counts->nv, counts->ntri, color ? MR_ATTR_COLORS : 0, NULL) !=
        MR_OK)
        return mr_fail_nomem(err, name, counts->nv * 28 + counts->ntri * 12);
    *d = *counts;
    d->pos = mesh->positions;
    d->col = mesh->colors;
    d->idx = mesh->indices;
    /* vt / vn values matter when some corner can refer to them, or when a
     * point cloud has one per vertex (then they are the vertices'). */
    bool cloud = counts->ntri == 0;
    bool need_cvt = slash && counts->nvt > 0, need_cvn = slash && counts->nvn > 0;
    bool need_vt = need_cvt || (cloud && counts->nvt > 0 && counts->nvt == counts->nv);
    bool need_vn = need_cvn || (cloud && counts->nvn > 0 && counts->nvn == counts->nv);
    size_t corners = 3 * counts->ntri;
    if ((need_vt && !(t->vt = mr_alloc_array(counts->nvt * 2, sizeof(float)))) ||
        (need_vn && !(t->vn = mr_alloc_array(counts->nvn * 3, sizeof(float)))) ||
        (need_cvt && !(t->cvt = mr_alloc_array(corners, sizeof(uint32_t)))) ||
        (need_cvn && !(t->cvn = mr_alloc_array(corners, sizeof(uint32_t)))))
        return mr_fail_nomem(err, name, corners * sizeof(uint32_t));
    d->vt = t->vt;
    d->vn = t->vn;
    d->cvt = t->cvt;
    d->cvn = t->cvn;
    return MR_OK;
}

static mr_status check_counts(const obj_dest *d, const char *name, mr_error *err)
{
    if (d->nv > (size_t)UINT32_MAX - 1)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, name,
                             "%zu vertices exceed the 32-bit index limit", d->nv);
    if (d->nvt > (size_t)UINT32_MAX - 2 || d->nvn > (size_t)UINT32_MAX - 2)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, name,
                             "too many texture coordinates or normals for 32-bit indices");
    if (d->ntri > SIZE_MAX / 12)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, name, "%zu triangles are too many",
                             d->ntri);
    return MR_OK;
}

static mr_status read_obj(const char *data, size_t size, const char *name, int threads,
                          mr_mesh *mesh, obj_temp *t, mr_error *err)
{
    const char *begin = data;
    if (size >= 3 && memcmp(data, "\xEF\xBB\xBF", 3) == 0)
        begin += 3; /* UTF-8 byte order mark, written by some editors */
    size_t body = size - (size_t)(begin - data);

    if (threads < 1)
        threads = 1;
    t->chunks = mr_calloc_array((size_t)threads, sizeof *t->chunks);
    if (!t->chunks)
        return mr_fail_nomem(err, name, (size_t)threads * sizeof *t->chunks);
    size_t n = split_chunks(begin, body, threads, t->chunks);

    run_chunks(t->chunks, n, count_chunk, NULL);
    obj_dest counts = {0};
    bool slash, color;
    prefix_sums(t->chunks, n, &counts, &slash, &color);
    mr_status st = check_counts(&counts, name, err);
    if (st != MR_OK)
        return st;

    obj_dest d;
    if ((st = allocate(&counts, slash, color, mesh, t, &d, name, err)) != MR_OK)
        return st;
    run_chunks(t->chunks, n, parse_chunk, &d);
    if ((st = first_error(t->chunks, n, data, name, err)) != MR_OK)
        return st;

    bool used_vt = false, used_vn = false, saw_color = false;
    for (size_t i = 0; i < n; i++) {
        used_vt |= t->chunks[i].used_vt;
        used_vn |= t->chunks[i].used_vn;
        saw_color |= t->chunks[i].saw_color;
    }
    if (saw_color && !mesh->colors) {
        /* a color appeared where the hint did not look: parse again with
         * a color array (errors cannot differ the second time) */
        if (!(mesh->colors = mr_alloc_array(counts.nv * 4, sizeof(float))))
            return mr_fail_nomem(err, name, counts.nv * 4 * sizeof(float));
        d.col = mesh->colors;
        run_chunks(t->chunks, n, parse_chunk, &d);
    }

    if (counts.nv == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, name, "contains no vertices");
    if (counts.ntri == 0) {
        /* a point cloud: vt / vn lines that match the v lines one to one
         * are per-vertex attributes (this is how the writer stores them) */
        if (counts.nvt == counts.nv) {
            mesh->texcoords = t->vt;
            t->vt = NULL;
        }
        if (counts.nvn == counts.nv) {
            mesh->normals = t->vn;
            t->vn = NULL;
        }
        return MR_OK;
    }
    if (used_vt || used_vn)
        return split_seams(mesh, used_vt ? t->cvt : NULL, used_vn ? t->cvn : NULL, t->vt,
                           t->vn, name, err);
    return MR_OK;
}

/* Whether "usemtl" starts a line of the data. */
static bool any_usemtl(const char *data, size_t size)
{
    for (const char *p = data, *end = data + size;
         (p = memchr(p, 'u', (size_t)(end - p))) != NULL; p++)
        if ((size_t)(end - p) >= 6 && !memcmp(p, "usemtl", 6) &&
            (p == data || p[-1] == '\n' || p[-1] == ' ' || p[-1] == '\t'))
            return true;
    return false;
}

mr_status mr_read_obj(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err)
{
    obj_temp t = {0};
    mr_status st = read_obj(data, size, name, threads, mesh, &t, err);
    temp_free(&t);
    /* usemtl groups: each triangle's material (names by
     * mr_obj_materials_read) */
    if (st == MR_OK && mesh->triangle_count && any_usemtl(data, size)) {
        mr_obj_materials m;
        st = mr_obj_materials_parse(data, size, name, &m, err);
        if (st == MR_OK && m.face_material && m.triangle_count == mesh->triangle_count) {
            mesh->materials = m.face_material;
            m.face_material = NULL;
        }
        if (st == MR_OK)
            mr_obj_materials_free(&m);
        else
            mr_mesh_free(mesh);
    }
    return st;
}

/* ------------------------------------------------------------------------ */
/* The writer                                                               */
/* ------------------------------------------------------------------------ */

/* Elements are formatted in blocks, the blocks of a batch in parallel
 * (shortest round-trip float formatting is the slow part), and written in
 * order, so that the file is the same for every thread count. */
#define OBJ_WRITE_BLOCK 8192
#define OBJ_WRITE_MAX_LINE 256 /* longest line: "v" + 6 floats of <= 32 bytes */
#define OBJ_WRITE_MAX_THREADS 64

typedef struct obj_writer {
    const mr_mesh *m;
    bool normals, texcoords, colors;
    const mr_write_options *o; /* its materials' names */
    const uint32_t *fm;        /* each face's: the options', else the mesh's */
} obj_writer;

typedef size_t (*format_fn)(const obj_writer *w, size_t first, size_t count, char *out);

static inline char *put_float(char *p, float v)
{
    *p++ = ' ';
    return p + mr_format_float(p, v);
}

static inline char *put_u64(char *p, uint64_t v)
{
    return p + mr_format_u64(p, v);
}

static size_t format_v(const obj_writer *w, size_t first, size_t count, char *out)
{
    char *p = out;
    for (size_t i = first; i < first + count; i++) {
        *p++ = 'v';
        for (int k = 0; k < 3; k++)
            p = put_float(p, w->m->positions[3 * i + k]);
        if (w->colors)
            for (int k = 0; k < 3; k++)
                p = put_float(p, w->m->colors[4 * i + k]);
        *p++ = '\n';
    }
    return (size_t)(p - out);
}

static size_t format_vt(const obj_writer *w, size_t first, size_t count, char *out)
{
    char *p = out;
    for (size_t i = first; i < first + count; i++) {
        *p++ = 'v';
        *p++ = 't';
        p = put_float(p, w->m->texcoords[2 * i]);
        p = put_float(p, w->m->texcoords[2 * i + 1]);
        *p++ = '\n';
    }
    return (size_t)(p - out);
}

static size_t format_vn(const obj_writer *w, size_t first, size_t count, char *out)
{
    char *p = out;
    for (size_t i = first; i < first + count; i++) {
        *p++ = 'v';
        *p++ = 'n';
        for (int k = 0; k < 3; k++)
            p = put_float(p, w->m->normals[3 * i + k]);
        *p++ = '\n';
    }
    return (size_t)(p - out);
}

/* Face i's material, or UINT32_MAX. */
static uint32_t face_group(const obj_writer *w, size_t i)
{
    const mr_write_options *o = w->o;
    if (!w->fm || !o->material_names)
        return UINT32_MAX;
    const uint32_t g = w->fm[i];
    return g < o->material_count ? g : UINT32_MAX;
}

static size_t format_f(const obj_writer *w, size_t first, size_t count, char *out)
{
    char *p = out;
    for (size_t i = first; i < first + count; i++) {
        /* a usemtl line where the material changes (decided from the
         * faces alone: the same lines whatever the blocks) */
        const uint32_t g = face_group(w, i);
        if (i == 0 ? g != UINT32_MAX : g != face_group(w, i - 1)) {
            /* OBJ has no way back to no material: faces without one after
             * a group take "None" (as Blender writes them) */
            const char *name = g == UINT32_MAX ? "None" : w->o->material_names[g];
            const size_t n = strlen(name);
            memcpy(p, "usemtl ", 7);
            memcpy(p + 7, name, n);
            p += 7 + n;
            *p++ = '\n';
        }
        *p++ = 'f';
        for (int k = 0; k < 3; k++) {
            /* attributes are per vertex: the same index for v, vt, vn */
            uint64_t idx = (uint64_t)w->m->indices[3 * i + k] + 1;
            *p++ = ' ';
            p = put_u64(p, idx);
            if (w->texcoords || w->normals) {
                *p++ = '/';
                if (w->texcoords)
                    p = put_u64(p, idx);
                if (w->normals) {
                    *p++ = '/';
                    p = put_u64(p, idx);
                }
            }
        }
        *p++ = '\n';
    }
    return (size_t)(p - out);
}

static mr_status write_section(FILE *f, const obj_writer *w, size_t total, format_fn fn,
                               char **bufs, int nbuf, const char *name, mr_error *err)
{
    size_t len[OBJ_WRITE_MAX_THREADS];
    size_t batch = (size_t)nbuf * OBJ_WRITE_BLOCK;
    for (size_t base = 0; base < total; base += batch) {
        size_t blocks = (total - base + OBJ_WRITE_BLOCK - 1) / OBJ_WRITE_BLOCK;
        if (blocks > (size_t)nbuf)
            blocks = (size_t)nbuf;
#pragma omp parallel for schedule(static, 1) num_threads(nbuf) if (blocks > 1)
        for (long b = 0; b < (long)blocks; b++) {
            size_t first = base + (size_t)b * OBJ_WRITE_BLOCK;
            size_t count = total - first < OBJ_WRITE_BLOCK ? total - first : OBJ_WRITE_BLOCK;
            len[b] = fn(w, first, count, bufs[b]);
        }
        for (size_t b = 0; b < blocks; b++)
            if (fwrite(bufs[b], 1, len[b], f) != len[b])
                return mr_fail_write(err, name, errno);
    }
    return MR_OK;
}

static mr_status write_all(FILE *f, const obj_writer *w, char **bufs, int nbuf,
                           const char *name, mr_error *err)
{
    const mr_mesh *m = w->m;
    char head[160];
    int n = snprintf(head, sizeof head, "# meshreduce %s: %zu vertices, %zu triangles\n",
                     mr_version(), m->vertex_count, m->triangle_count);
    if (fwrite(head, 1, (size_t)n, f) != (size_t)n)
        return mr_fail_write(err, name, errno);
    if (w->o->mtllib && w->o->mtllib[0] &&
        fprintf(f, "mtllib %s\n", w->o->mtllib) < 0)
        return mr_fail_write(err, name, errno);
    mr_status st = write_section(f, w, m->vertex_count, format_v, bufs, nbuf, name, err);
    if (st == MR_OK && w->texcoords)
        st = write_section(f, w, m->vertex_count, format_vt, bufs, nbuf, name, err);
    if (st == MR_OK && w->normals)
        st = write_section(f, w, m->vertex_count, format_vn, bufs, nbuf, name, err);
    if (st == MR_OK)
        st = write_section(f, w, m->triangle_count, format_f, bufs, nbuf, name, err);
    return st;
}

mr_status mr_write_obj(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err)
{
    mr_write_options defaults;
    if (!options) {
        mr_write_options_default(&defaults);
        options = &defaults;
    }
    obj_writer w = {mesh, options->write_normals && mesh->normals,
                    options->write_texcoords && mesh->texcoords,
                    options->write_colors && mesh->colors, options,
                    options->face_material ? options->face_material : mesh->materials};
    /* a face line may follow a usemtl line: room for the longest name */
    size_t longest = 0;
    for (size_t i = 0; w.fm && options->material_names &&
                       i < options->material_count; i++) {
        const size_t n = options->material_names[i] ? strlen(options->material_names[i]) : 0;
        if (!options->material_names[i] || memchr(options->material_names[i], '\n', n))
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, name,
                                 "material %zu has no name, or a line break in it", i);
        longest = n > longest ? n : longest;
    }
    longest = longest < 4 ? 4 : longest; /* "None" (format_f) */

    size_t elements = mesh->vertex_count > mesh->triangle_count ? mesh->vertex_count
                                                                : mesh->triangle_count;
    size_t blocks = (elements + OBJ_WRITE_BLOCK - 1) / OBJ_WRITE_BLOCK;
    int nbuf = mr_thread_count(0);
    if (nbuf > OBJ_WRITE_MAX_THREADS)
        nbuf = OBJ_WRITE_MAX_THREADS;
    if ((size_t)nbuf > blocks)
        nbuf = blocks ? (int)blocks : 1;

    char *bufs[OBJ_WRITE_MAX_THREADS] = {0};
    const size_t bufsize = (size_t)OBJ_WRITE_BLOCK * (OBJ_WRITE_MAX_LINE + longest + 8);
    mr_status st = MR_OK;
    for (int i = 0; i < nbuf && st == MR_OK; i++)
        if (!(bufs[i] = malloc(bufsize)))
            st = mr_fail_nomem(err, name, bufsize);
    if (st == MR_OK)
        st = write_all(f, &w, bufs, nbuf, name, err);
    for (int i = 0; i < nbuf; i++)
        free(bufs[i]);
    return st;
}

/* ------------------------------------------------------------------------ */
/* The reader in windows (mr_obj_stream)                                    */
/* ------------------------------------------------------------------------ */

typedef struct obj_window {
    size_t off, end;       /* bytes of the body */
    size_t v0, vt0, vn0, tri0, nv, nvt, nvn, ntri;
} obj_window;

struct mr_obj_stream {
    mr_mapped_file file;
    const char *data, *begin; /* the map; the body (after a byte order mark) */
    size_t body;
    const char *name;
    int threads;
    obj_window *win;
    size_t nwin, next, most_v, most_tri;
    obj_dest counts;
    obj_chunk *chunks;
    float *pos;
    uint32_t *idx;
    /* mr_obj_stream_keep: the windows' attributes too */
    unsigned keep;
    float *col, *vt, *vn;
    uint32_t *cvt, *cvn;
    size_t most_vt, most_vn;
    bool used_vt, used_vn, saw_color, color_hint;
};

/* Count a window's chunks and give them their starting counts. */
static size_t window_chunks(mr_obj_stream *s, const obj_window *w)
{
    const size_t n = split_chunks(s->begin + w->off, w->end - w->off, s->threads, s->chunks);
    for (size_t i = 0; i < n; i++) {
        obj_chunk *c = &s->chunks[i];
        const char *b = c->begin, *e = c->end;
        memset(c, 0, sizeof *c);
        c->begin = b;
        c->end = e;
    }
    run_chunks(s->chunks, n, count_chunk, NULL);
    size_t v = w->v0, vt = w->vt0, vn = w->vn0, t = w->tri0;
    for (size_t i = 0; i < n; i++) {
        obj_chunk *c = &s->chunks[i];
        c->v0 = v, c->vt0 = vt, c->vn0 = vn, c->tri0 = t;
        v += c->nv, vt += c->nvt, vn += c->nvn, t += c->ntri;
    }
    return n;
}

mr_status mr_obj_stream_open(const char *path, int threads, size_t window,
                             mr_obj_stream **out, mr_error *err)
{
    *out = NULL;
    mr_obj_stream *s = mr_calloc_array(1, sizeof *s);
    if (!s)
        return mr_fail_nomem(err, path, sizeof *s);
    mr_status st = mr_map_file(path, &s->file, err);
    if (st != MR_OK) {
        free(s);
        return st;
    }
    s->data = s->file.data;
    s->begin = s->data;
    if (s->file.size >= 3 && memcmp(s->data, "\xEF\xBB\xBF", 3) == 0)
        s->begin += 3;
    s->body = s->file.size - (size_t)(s->begin - s->data);
    s->name = path;
    s->threads = threads < 1 ? 1 : threads;
    window = window < 4096 ? 4096 : window;
    const size_t nwin_max = s->body / window + 2;
    s->win = mr_calloc_array(nwin_max, sizeof *s->win);
    s->chunks = mr_calloc_array((size_t)s->threads, sizeof *s->chunks);
    if (!s->win || !s->chunks) {
        mr_obj_stream_close(s);
        return mr_fail_nomem(err, path, nwin_max * sizeof *s->win);
    }
    /* the windows at line starts, each counted (pass 1) */
    const char *end = s->begin + s->body;
    size_t at = 0;
    bool slash = false;
    while (at < s->body) {
        obj_window *w = &s->win[s->nwin++];
        w->off = at;
        const char *e = s->begin + (s->body - at > window ? at + window : s->body);
        if (e < end && e[-1] != '\n')
            mr_skip_line(&e, end);
        w->end = (size_t)(e - s->begin);
        w->v0 = s->counts.nv, w->vt0 = s->counts.nvt, w->vn0 = s->counts.nvn;
        w->tri0 = s->counts.ntri;
        const size_t n = window_chunks(s, w);
        bool first_v = true;
        for (size_t i = 0; i < n; i++) {
            const obj_chunk *c = &s->chunks[i];
            s->counts.nv += c->nv, s->counts.nvt += c->nvt, s->counts.nvn += c->nvn;
            s->counts.ntri += c->ntri;
            slash |= c->slash;
            /* the window's first v line (whatever the chunks): a color? */
            if (first_v && c->nv) {
                s->color_hint |= c->color_hint;
                first_v = false;
            }
        }
        w->nv = s->counts.nv - w->v0;
        w->nvt = s->counts.nvt - w->vt0;
        w->nvn = s->counts.nvn - w->vn0;
        w->ntri = s->counts.ntri - w->tri0;
        s->most_vt = w->nvt > s->most_vt ? w->nvt : s->most_vt;
        s->most_vn = w->nvn > s->most_vn ? w->nvn : s->most_vn;
        s->most_v = w->nv > s->most_v ? w->nv : s->most_v;
        s->most_tri = w->ntri > s->most_tri ? w->ntri : s->most_tri;
        mr_release_mapped(&s->file, (size_t)(s->begin - s->data) + w->off,
                          (size_t)(s->begin - s->data) + w->end);
        at = w->end;
    }
    (void)slash;
    if ((st = check_counts(&s->counts, path, err)) != MR_OK) {
        mr_obj_stream_close(s);
        return st;
    }
    if (s->counts.nv == 0) {
        mr_obj_stream_close(s);
        return mr_fail_plain(err, MR_ERR_EMPTY, path, "contains no vertices");
    }
    s->pos = mr_alloc_array(s->most_v + 1, 3 * sizeof *s->pos);
    s->idx = mr_alloc_array(s->most_tri + 1, 3 * sizeof *s->idx);
    if (!s->pos || !s->idx) {
        mr_obj_stream_close(s);
        return mr_fail_nomem(err, path, s->most_v * 12 + s->most_tri * 12);
    }
    *out = s;
    return MR_OK;
}

void mr_obj_stream_close(mr_obj_stream *s)
{
    if (!s)
        return;
    mr_unmap_file(&s->file);
    free(s->win);
    free(s->chunks);
    free(s->pos);
    free(s->idx);
    free(s->col);
    free(s->vt);
    free(s->vn);
    free(s->cvt);
    free(s->cvn);
    free(s);
}

mr_status mr_obj_stream_keep(mr_obj_stream *s, unsigned attributes, mr_error *err)
{
    const size_t corners = 3 * (s->most_tri + 1);
    s->keep = attributes;
    if (((attributes & MR_ATTR_COLORS) &&
         !(s->col = mr_alloc_array(s->most_v + 1, 4 * sizeof *s->col))) ||
        ((attributes & MR_ATTR_TEXCOORDS) &&
         (!(s->vt = mr_alloc_array(s->most_vt + 1, 2 * sizeof *s->vt)) ||
          !(s->cvt = mr_alloc_array(corners, sizeof *s->cvt)))) ||
        ((attributes & MR_ATTR_NORMALS) &&
         (!(s->vn = mr_alloc_array(s->most_vn + 1, 3 * sizeof *s->vn)) ||
          !(s->cvn = mr_alloc_array(corners, sizeof *s->cvn)))))
        return mr_fail_nomem(err, s->name, s->most_v * 16 + corners * 8);
    return MR_OK;
}

size_t mr_obj_stream_vertex_count(const mr_obj_stream *s) { return s->counts.nv; }
size_t mr_obj_stream_triangle_count(const mr_obj_stream *s) { return s->counts.ntri; }
size_t mr_obj_stream_max_vertices(const mr_obj_stream *s) { return s->most_v; }
size_t mr_obj_stream_max_triangles(const mr_obj_stream *s) { return s->most_tri; }

unsigned mr_obj_stream_may_have(const mr_obj_stream *s)
{
    return (s->color_hint ? MR_ATTR_COLORS : 0) | (s->counts.nvt ? MR_ATTR_TEXCOORDS : 0) |
           (s->counts.nvn ? MR_ATTR_NORMALS : 0);
}

unsigned mr_obj_stream_attributes(const mr_obj_stream *s)
{
    return (s->saw_color ? MR_ATTR_COLORS : 0) | (s->used_vt ? MR_ATTR_TEXCOORDS : 0) |
           (s->used_vn ? MR_ATTR_NORMALS : 0);
}

mr_status mr_obj_stream_next(mr_obj_stream *s, mr_obj_window *w, mr_error *err)
{
    memset(w, 0, sizeof *w);
    if (s->next >= s->nwin)
        return MR_OK;
    const obj_window *win = &s->win[s->next++];
    const size_t n = window_chunks(s, win);
    obj_dest d = s->counts;
    d.pos = s->pos;
    d.col = s->col;
    d.vt = s->vt;
    d.vn = s->vn;
    d.idx = s->idx;
    d.cvt = s->cvt;
    d.cvn = s->cvn;
    d.base_v = win->v0;
    d.base_tri = win->tri0;
    d.base_vt = win->vt0;
    d.base_vn = win->vn0;
    run_chunks(s->chunks, n, parse_chunk, &d);
    mr_status st = first_error(s->chunks, n, s->data, s->name, err);
    for (size_t i = 0; i < n; i++) {
        s->used_vt |= s->chunks[i].used_vt;
        s->used_vn |= s->chunks[i].used_vn;
        s->saw_color |= s->chunks[i].saw_color;
    }
    mr_release_mapped(&s->file, (size_t)(s->begin - s->data) + win->off,
                      (size_t)(s->begin - s->data) + win->end);
    if (st != MR_OK)
        return st;
    w->first_vertex = win->v0;
    w->vertex_count = win->nv;
    w->positions = s->pos;
    w->first_triangle = win->tri0;
    w->triangle_count = win->ntri;
    w->indices = s->idx;
    w->colors = s->col;
    w->corner_texcoords = s->cvt;
    w->corner_normals = s->cvn;
    w->first_texcoord = win->vt0;
    w->texcoord_count = s->vt ? win->nvt : 0;
    w->texcoords = s->vt;
    w->first_normal = win->vn0;
    w->normal_count = s->vn ? win->nvn : 0;
    w->normals = s->vn;
    return MR_OK;
}
