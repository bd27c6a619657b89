/*
 * PLY reader and writer (ascii, binary little and big endian).
 *
 * Reading goes in three steps:
 *   1. parse the header into elements and their properties, decide which
 *      properties feed the mesh (x y z, normals, texcoords, colors, face
 *      and triangle strip index lists), and check the counts the header
 *      announces against the bytes that follow before anything is
 *      allocated;
 *   2. locate every element in the body and count the triangles (binary:
 *      faces whose lists all have the same length are recognised as
 *      fixed-stride rows with a parallel check, others are walked row by
 *      row, leaving checkpoints for a parallel decode);
 *   3. allocate exact arrays and decode, in parallel where rows can be
 *      found without reading the ones before them.
 * Ascii bodies are read as a stream of whitespace-separated values, one
 * pass for vertices and two (count, then parse) for face lists.
 */
#include "io_internal.h"
#include "text.h"

#include <math.h>

/* ------------------------------------------------------------------------ */
/* Scalar types                                                             */
/* ------------------------------------------------------------------------ */

typedef enum ply_type {
    PT_NONE = 0,
    PT_I8,
    PT_U8,
    PT_I16,
    PT_U16,
    PT_I32,
    PT_U32,
    PT_F32,
    PT_F64
} ply_type;

static const unsigned type_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
static const int64_t type_min[] = {0, INT8_MIN, 0, INT16_MIN, 0, INT32_MIN, 0, 0, 0};
static const int64_t type_max[] = {0, INT8_MAX, UINT8_MAX, INT16_MAX, UINT16_MAX,
                                   INT32_MAX, UINT32_MAX, 0, 0};

static bool type_is_int(ply_type t) { return t >= PT_I8 && t <= PT_U32; }

/* Both naming schemes of the PLY specification and its later revision. */
static ply_type type_from_name(const char *s, size_t n)
{
    static const struct {
        const char *name;
        ply_type type;
    } names[] = {{"char", PT_I8},    {"int8", PT_I8},     {"uchar", PT_U8},
                 {"uint8", PT_U8},   {"short", PT_I16},   {"int16", PT_I16},
                 {"ushort", PT_U16}, {"uint16", PT_U16},  {"int", PT_I32},
                 {"int32", PT_I32},  {"uint", PT_U32},    {"uint32", PT_U32},
                 {"float", PT_F32},  {"float32", PT_F32}, {"double", PT_F64},
                 {"float64", PT_F64}};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (strlen(names[i].name) == n && memcmp(names[i].name, s, n) == 0)
            return names[i].type;
    return PT_NONE;
}

static inline uint16_t ld16(const unsigned char *p, bool swap)
{
    uint16_t v;
    memcpy(&v, p, 2);
    return swap ? mr_bswap16(v) : v;
}

static inline uint32_t ld32(const unsigned char *p, bool swap)
{
    uint32_t v;
    memcpy(&v, p, 4);
    return swap ? mr_bswap32(v) : v;
}

static inline uint64_t ld64(const unsigned char *p, bool swap)
{
    uint64_t v;
    memcpy(&v, p, 8);
    return swap ? mr_bswap64(v) : v;
}

/* A binary integer value (the header guarantees an integer type). */
static inline int64_t rd_int(const unsigned char *p, ply_type t, bool swap)
{
    switch (t) {
    case PT_I8: {
        int8_t v;
        memcpy(&v, p, 1);
        return v;
    }
    case PT_U8: return p[0];
    case PT_I16: {
        uint16_t u = ld16(p, swap);
        int16_t v;
        memcpy(&v, &u, 2);
        return v;
    }
    case PT_U16: return ld16(p, swap);
    case PT_I32: {
        uint32_t u = ld32(p, swap);
        int32_t v;
        memcpy(&v, &u, 4);
        return v;
    }
    case PT_U32: return ld32(p, swap);
    default: return -1;
    }
}

/* A binary value of any type, as a double (exact for every type). */
static inline double rd_real(const unsigned char *p, ply_type t, bool swap)
{
    if (t == PT_F32) {
        uint32_t u = ld32(p, swap);
        float f;
        memcpy(&f, &u, 4);
        return f;
    }
    if (t == PT_F64) {
        uint64_t u = ld64(p, swap);
        double d;
        memcpy(&d, &u, 8);
        return d;
    }
    return (double)rd_int(p, t, swap);
}

/* ------------------------------------------------------------------------ */
/* Header model                                                             */
/* ------------------------------------------------------------------------ */

/* Destinations of vertex properties: a row is gathered into float[SLOTS]. */
enum {
    SLOT_X = 0, SLOT_NX = 3, SLOT_U = 6, SLOT_RED = 8, SLOT_ALPHA = 11, SLOTS = 12
};

typedef struct ply_prop {
    const char *name; /* points into the file; name_len bytes */
    size_t name_len;
    ply_type type;       /* scalar type, or the item type of a list */
    ply_type count_type; /* PT_NONE for a scalar */
    int slot;            /* vertex element: SLOT_* destination, or -1 */
    double divisor;      /* vertex element: stored value = value / divisor */
    size_t row_off;      /* fixed-stride faces: offset in the row */
    int64_t fixed_count; /* fixed-stride faces: the list length of every row */
} ply_prop;

typedef enum elem_kind { EK_OTHER, EK_VERTEX, EK_FACE, EK_STRIPS } elem_kind;

/* Decoding of a face element is split at every CHUNK_ROWS rows so that
 * chunks can run in parallel; a chunk also records its first bad index so
 * that the error reported does not depend on the thread count. */
enum { CHUNK_ROWS = 16384 };

typedef struct ply_chunk {
    size_t off;       /* byte offset of the chunk's first row */
    uint64_t tri;     /* its first triangle, counted within the element */
    uint64_t bad_row; /* first row with a bad index, or UINT64_MAX */
    size_t bad_off;   /* where that index is */
    int64_t bad_value;
} ply_chunk;

typedef struct ply_elem {
    const char *name;
    size_t name_len;
    uint64_t count;
    uint64_t line;           /* header line, for messages */
    size_t prop_begin, prop_end;
    elem_kind kind;
    size_t index_prop;       /* face, strips: the vertex_indices list */
    bool fixed;              /* no lists: every row has row_size bytes */
    uint64_t row_size;       /* binary bytes per row (lists: at least) */
    uint64_t values;         /* values per row (lists: at least) */
    /* filled while locating the element in a binary body */
    size_t start;
    uint64_t tris;           /* faces: exact; strips: an upper bound */
    size_t stride;           /* faces whose rows all have one size, or 0 */
    ply_chunk *chunks;
    size_t chunk_count;
} ply_elem;

typedef enum ply_encoding { ENC_ASCII, ENC_LE, ENC_BE } ply_encoding;

typedef struct ply_reader {
    const char *data;
    size_t size;
    const char *name;
    int threads;
    mr_error *err;
    mr_mesh *mesh;

    ply_encoding enc;
    bool swap; /* binary byte order differs from the host's */
    ply_elem *elems;
    size_t elem_count, elem_cap;
    ply_prop *props;
    size_t prop_count, prop_cap;
    size_t body;        /* offset of the first byte after end_header */
    ply_elem *vertex;   /* NULL when the file has none */
    unsigned attrs;     /* MR_ATTR_* the vertex element provides */
    bool has_alpha;
    size_t tri_written; /* triangles decoded so far, over all face elements */
    /* the file's map when the rows that locating reads are to be released
     * as it goes (mr_ply_source: pages of a mapped file count in the
     * resident set), or NULL */
    const mr_mapped_file *release;
} ply_reader;

/* ------------------------------------------------------------------------ */
/* Errors                                                                   */
/* ------------------------------------------------------------------------ */

/* An error in the body at byte `offset`: a line number in ascii files, the
 * offset in binary ones. */
static mr_status fail_at(const ply_reader *r, mr_status st, size_t offset, const char *fmt,
                         ...) MR_PRINTF(4, 5);
static mr_status fail_at(const ply_reader *r, mr_status st, size_t offset, const char *fmt,
                         ...)
{
    char msg[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (r->enc == ENC_ASCII)
        return mr_fail(r->err, st, r->name, mr_line_of(r->data, r->data + offset),
                       MR_NO_POSITION, "%s", msg);
    return mr_fail(r->err, st, r->name, MR_NO_POSITION, offset, "%s", msg);
}

/* What the rows of an element are called in messages. */
static const char *row_noun(const ply_elem *e, bool plural, char *buf, size_t cap)
{
    switch (e->kind) {
    case EK_VERTEX: return plural ? "vertices" : "vertex";
    case EK_FACE: return plural ? "faces" : "face";
    case EK_STRIPS: return plural ? "triangle strips" : "triangle strip";
    default:
        snprintf(buf, cap, "'%.*s' element%s", (int)(e->name_len < 64 ? e->name_len : 64),
                 e->name, plural ? "s" : "");
        return buf;
    }
}

static int name_width(size_t len) { return (int)(len < 64 ? len : 64); }

/* ------------------------------------------------------------------------ */
/* Header                                                                   */
/* ------------------------------------------------------------------------ */

typedef struct token {
    const char *s;
    size_t n;
} token;

static token next_token(const char **p, const char *end)
{
    mr_skip_blanks(p, end);
    token t = {*p, 0};
    while (*p < end && !mr_is_space(**p)) {
        (*p)++;
        t.n++;
    }
    return t;
}

static bool token_is(token t, const char *word)
{
    return t.n == strlen(word) && memcmp(t.s, word, t.n) == 0;
}

static mr_status header_element(ply_reader *r, const char *p, const char *end, uint64_t line)
{
    token nm = next_token(&p, end), cnt = next_token(&p, end);
    int64_t count;
    const char *c = cnt.s;
    if (nm.n == 0 || cnt.n == 0 || !mr_parse_i64(&c, cnt.s + cnt.n, &count) ||
        c != cnt.s + cnt.n || count < 0 || next_token(&p, end).n != 0)
        return mr_fail(r->err, MR_ERR_PARSE, r->name, line, MR_NO_POSITION,
                       "expected 'element NAME COUNT' with a count >= 0");
    if (r->elem_count == r->elem_cap) {
        size_t cap = r->elem_cap ? 2 * r->elem_cap : 8;
        ply_elem *grown = mr_realloc_array(r->elems, cap, sizeof *grown);
        if (!grown)
            return mr_fail_nomem(r->err, r->name, cap * sizeof *grown);
        r->elems = grown;
        r->elem_cap = cap;
    }
    ply_elem *e = &r->elems[r->elem_count++];
    memset(e, 0, sizeof *e);
    e->name = nm.s;
    e->name_len = nm.n;
    e->count = (uint64_t)count;
    e->line = line;
    e->prop_begin = e->prop_end = r->prop_count;
    return MR_OK;
}

static mr_status header_property(ply_reader *r, const char *p, const char *end, uint64_t line)
{
    if (r->elem_count == 0)
        return mr_fail(r->err, MR_ERR_PARSE, r->name, line, MR_NO_POSITION,
                       "property before any element");
    ply_prop pr;
    memset(&pr, 0, sizeof pr);
    pr.slot = -1;
    token t = next_token(&p, end);
    if (token_is(t, "list")) {
        token ct = next_token(&p, end);
        pr.count_type = type_from_name(ct.s, ct.n);
        if (ct.n && pr.count_type == PT_NONE)
            return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, line, MR_NO_POSITION,
                           "unknown property type '%.*s'", name_width(ct.n), ct.s);
        if (ct.n && !type_is_int(pr.count_type))
            return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, line, MR_NO_POSITION,
                           "list count type '%.*s' is not an integer type",
                           name_width(ct.n), ct.s);
        t = next_token(&p, end);
    }
    token nm = next_token(&p, end);
    if (t.n == 0 || nm.n == 0 || next_token(&p, end).n != 0)
        return mr_fail(r->err, MR_ERR_PARSE, r->name, line, MR_NO_POSITION,
                       "expected 'property TYPE NAME' or "
                       "'property list COUNT_TYPE ITEM_TYPE NAME'");
    pr.type = type_from_name(t.s, t.n);
    if (pr.type == PT_NONE)
        return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, line, MR_NO_POSITION,
                       "unknown property type '%.*s'", name_width(t.n), t.s);
    pr.name = nm.s;
    pr.name_len = nm.n;
    if (r->prop_count == r->prop_cap) {
        size_t cap = r->prop_cap ? 2 * r->prop_cap : 16;
        ply_prop *grown = mr_realloc_array(r->props, cap, sizeof *grown);
        if (!grown)
            return mr_fail_nomem(r->err, r->name, cap * sizeof *grown);
        r->props = grown;
        r->prop_cap = cap;
    }
    r->props[r->prop_count++] = pr;
    r->elems[r->elem_count - 1].prop_end = r->prop_count;
    return MR_OK;
}

static mr_status header_format(ply_reader *r, const char *p, const char *end, uint64_t line)
{
    token enc = next_token(&p, end), ver = next_token(&p, end);
    if (token_is(enc, "ascii"))
        r->enc = ENC_ASCII;
    else if (token_is(enc, "binary_little_endian"))
        r->enc = ENC_LE;
    else if (token_is(enc, "binary_big_endian"))
        r->enc = ENC_BE;
    else
        return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, line, MR_NO_POSITION,
                       "unknown format '%.*s' (expected ascii, binary_little_endian or "
                       "binary_big_endian)",
                       name_width(enc.n), enc.s);
    if (!token_is(ver, "1.0") && !token_is(ver, "1"))
        return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, line, MR_NO_POSITION,
                       "format version '%.*s' is not supported (expected 1.0)",
                       name_width(ver.n), ver.s);
    r->swap = r->enc != ENC_ASCII && (r->enc == ENC_LE) != mr_host_is_little_endian();
    return MR_OK;
}

/* Parse the header up to and including the end_header line. */
static mr_status parse_header(ply_reader *r)
{
    const char *p = r->data, *end = r->data + r->size;
    bool have_format = false;
    for (uint64_t line = 1; p < end; line++) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        const char *le = nl ? nl : end, *s = p;
        p = nl ? nl + 1 : end;
        token kw = next_token(&s, le);
        mr_status st = MR_OK;
        if (line == 1) {
            if (!token_is(kw, "ply") || next_token(&s, le).n != 0)
                return mr_fail_plain(r->err, MR_ERR_PARSE, r->name,
                                     "not a PLY file (it does not start with 'ply')");
        } else if (kw.n == 0 || token_is(kw, "comment") || token_is(kw, "obj_info")) {
            continue;
        } else if (token_is(kw, "format")) {
            st = header_format(r, s, le, line);
            have_format = true;
        } else if (token_is(kw, "element")) {
            st = header_element(r, s, le, line);
        } else if (token_is(kw, "property")) {
            st = header_property(r, s, le, line);
        } else if (token_is(kw, "end_header")) {
            if (!have_format)
                return mr_fail(r->err, MR_ERR_PARSE, r->name, line, MR_NO_POSITION,
                               "the header has no format line");
            r->body = (size_t)(p - r->data);
            return MR_OK;
        } else {
            return mr_fail(r->err, MR_ERR_PARSE, r->name, line, MR_NO_POSITION,
                           "unexpected '%.*s' in the header", name_width(kw.n), kw.s);
        }
        if (st != MR_OK)
            return st;
    }
    return mr_fail_plain(r->err, MR_ERR_PARSE, r->name,
                         "the header has no end_header line (file truncated?)");
}

/* ------------------------------------------------------------------------ */
/* Which properties feed the mesh                                           */
/* ------------------------------------------------------------------------ */

static bool prop_named(const ply_prop *p, const char *name)
{
    return p->name_len == strlen(name) && memcmp(p->name, name, p->name_len) == 0;
}

/* The first property of `e` with one of the names (NULL-terminated), or
 * NULL. */
static ply_prop *find_prop(ply_reader *r, const ply_elem *e, const char *const *names)
{
    for (size_t i = e->prop_begin; i < e->prop_end; i++)
        for (const char *const *n = names; *n; n++)
            if (prop_named(&r->props[i], *n))
                return &r->props[i];
    return NULL;
}

/* Scalar property by one of the names, usable as a vertex attribute. */
static ply_prop *find_scalar(ply_reader *r, const ply_elem *e, const char *const *names)
{
    ply_prop *p = find_prop(r, e, names);
    return p && p->count_type == PT_NONE ? p : NULL;
}

/* Integer colors are fractions of their type's range; 8 and 32 bit
 * integers are taken as 0..255, the range every writer means by them. */
static double color_divisor(ply_type t)
{
    if (t == PT_F32 || t == PT_F64)
        return 1.0;
    if (t == PT_I16 || t == PT_U16)
        return 65535.0;
    return 255.0;
}

static mr_status map_vertex(ply_reader *r, ply_elem *e)
{
    static const char *const xyz[3][2] = {{"x", NULL}, {"y", NULL}, {"z", NULL}};
    for (int k = 0; k < 3; k++) {
        ply_prop *p = find_prop(r, e, xyz[k]);
        if (!p)
            return mr_fail(r->err, MR_ERR_PARSE, r->name, e->line, MR_NO_POSITION,
                           "the vertex element has no '%s' property", xyz[k][0]);
        if (p->count_type != PT_NONE)
            return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, e->line, MR_NO_POSITION,
                           "vertex property '%s' is a list, not a number", xyz[k][0]);
        p->slot = SLOT_X + k;
        p->divisor = 1.0;
    }

    static const char *const normal[3][2] = {{"nx", NULL}, {"ny", NULL}, {"nz", NULL}};
    ply_prop *n[3];
    for (int k = 0; k < 3; k++)
        n[k] = find_scalar(r, e, normal[k]);
    if (n[0] && n[1] && n[2]) {
        for (int k = 0; k < 3; k++) {
            n[k]->slot = SLOT_NX + k;
            n[k]->divisor = 1.0;
        }
        r->attrs |= MR_ATTR_NORMALS;
    }

    /* Texture coordinates: the first complete pair in this order. */
    static const char *const uv[4][2][2] = {{{"s", NULL}, {"t", NULL}},
                                            {{"u", NULL}, {"v", NULL}},
                                            {{"texture_u", NULL}, {"texture_v", NULL}},
                                            {{"texture_s", NULL}, {"texture_t", NULL}}};
    for (int k = 0; k < 4; k++) {
        ply_prop *u = find_scalar(r, e, uv[k][0]), *v = find_scalar(r, e, uv[k][1]);
        if (u && v) {
            u->slot = SLOT_U;
            v->slot = SLOT_U + 1;
            u->divisor = v->divisor = 1.0;
            r->attrs |= MR_ATTR_TEXCOORDS;
            break;
        }
    }

    static const char *const rgba[4][3] = {{"red", "diffuse_red", NULL},
                                           {"green", "diffuse_green", NULL},
                                           {"blue", "diffuse_blue", NULL},
                                           {"alpha", "diffuse_alpha", NULL}};
    ply_prop *c[4];
    for (int k = 0; k < 4; k++)
        c[k] = find_scalar(r, e, rgba[k]);
    if (c[0] && c[1] && c[2]) {
        for (int k = 0; k < 4; k++)
            if (c[k]) {
                c[k]->slot = SLOT_RED + k;
                c[k]->divisor = color_divisor(c[k]->type);
            }
        r->attrs |= MR_ATTR_COLORS;
        r->has_alpha = c[3] != NULL;
    }
    return MR_OK;
}

static mr_status map_faces(ply_reader *r, ply_elem *e)
{
    static const char *const names[] = {"vertex_indices", "vertex_index", NULL};
    ply_prop *p = find_prop(r, e, names);
    const char *noun = e->kind == EK_FACE ? "face" : "tristrips";
    if (!p)
        return mr_fail(r->err, MR_ERR_PARSE, r->name, e->line, MR_NO_POSITION,
                       "the %s element has no vertex_indices list", noun);
    if (p->count_type == PT_NONE)
        return mr_fail(r->err, MR_ERR_PARSE, r->name, e->line, MR_NO_POSITION,
                       "%s property '%.*s' is not a list", noun, name_width(p->name_len),
                       p->name);
    if (!type_is_int(p->type))
        return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, e->line, MR_NO_POSITION,
                       "%s vertex indices must be integers", noun);
    e->index_prop = (size_t)(p - r->props);
    return MR_OK;
}

/* Sizes of each element's rows, and the role of every element. */
static mr_status classify(ply_reader *r)
{
    for (size_t i = 0; i < r->elem_count; i++) {
        ply_elem *e = &r->elems[i];
        e->fixed = true;
        for (size_t k = e->prop_begin; k < e->prop_end; k++) {
            const ply_prop *p = &r->props[k];
            e->values++;
            if (p->count_type == PT_NONE) {
                e->row_size += type_size[p->type];
            } else {
                e->fixed = false;
                e->row_size += type_size[p->count_type];
            }
        }
        mr_status st = MR_OK;
        if (e->name_len == 6 && memcmp(e->name, "vertex", 6) == 0) {
            if (r->vertex)
                return mr_fail(r->err, MR_ERR_UNSUPPORTED, r->name, e->line, MR_NO_POSITION,
                               "more than one vertex element");
            e->kind = EK_VERTEX;
            r->vertex = e;
            st = map_vertex(r, e);
        } else if (e->name_len == 4 && memcmp(e->name, "face", 4) == 0) {
            e->kind = EK_FACE;
            st = map_faces(r, e);
        } else if (e->name_len == 9 && memcmp(e->name, "tristrips", 9) == 0) {
            e->kind = EK_STRIPS;
            st = map_faces(r, e);
        }
        if (st != MR_OK)
            return st;
    }
    return MR_OK;
}

/* Before anything is allocated: every row needs at least row_size bytes
 * (binary) or two characters per value (ascii: a digit and a separator),
 * so a header that announces more rows than the file can hold is refused
 * here, however large its counts. */
static mr_status check_counts(ply_reader *r)
{
    uint64_t avail = r->size - r->body, need = 0;
    if (r->enc == ENC_ASCII)
        avail++; /* the last value needs no separator */
    for (size_t i = 0; i < r->elem_count; i++) {
        ply_elem *e = &r->elems[i];
        uint64_t per = r->enc == ENC_ASCII ? 2 * e->values : e->row_size;
        if (per && e->count > (avail - need) / per) {
            char buf[96];
            /* binary: where the element would start at the earliest;
             * ascii: that guess means little, so the first body line */
            size_t at = r->enc == ENC_ASCII ? r->body : r->body + (size_t)need;
            return fail_at(r, MR_ERR_PARSE, at,
                           "file ends before the %llu %s its header announces",
                           (unsigned long long)e->count, row_noun(e, true, buf, sizeof buf));
        }
        need += e->count * per;
    }
    if (!r->vertex || r->vertex->count == 0)
        return mr_fail_plain(r->err, MR_ERR_EMPTY, r->name, "the file holds no vertices");
    if (r->vertex->count > (uint64_t)UINT32_MAX - 1)
        return mr_fail_plain(r->err, MR_ERR_TOO_LARGE, r->name,
                             "%llu vertices exceed the 32-bit index limit",
                             (unsigned long long)r->vertex->count);
    return MR_OK;
}

/* Allocate the vertex arrays (their contents are written by the decoders). */
static mr_status alloc_vertices(ply_reader *r)
{
    mr_mesh *m = r->mesh;
    size_t n = (size_t)r->vertex->count;
    m->vertex_count = n;
    m->positions = mr_alloc_array(n, 3 * sizeof(float));
    bool ok = m->positions != NULL;
    if (ok && (r->attrs & MR_ATTR_NORMALS))
        ok = (m->normals = mr_alloc_array(n, 3 * sizeof(float))) != NULL;
    if (ok && (r->attrs & MR_ATTR_TEXCOORDS))
        ok = (m->texcoords = mr_alloc_array(n, 2 * sizeof(float))) != NULL;
    if (ok && (r->attrs & MR_ATTR_COLORS))
        ok = (m->colors = mr_alloc_array(n, 4 * sizeof(float))) != NULL;
    return ok ? MR_OK : mr_fail_nomem(r->err, r->name, n * 48);
}

/* Grow the index array to hold `tris` more triangles than are written. */
static mr_status reserve_triangles(ply_reader *r, uint64_t tris)
{
    mr_mesh *m = r->mesh;
    if (tris > SIZE_MAX / 12 - r->tri_written)
        return mr_fail_plain(r->err, MR_ERR_TOO_LARGE, r->name, "too many triangles");
    /* always allocated (count 0 gives a valid pointer), so that decoders
     * may offset it */
    size_t total = r->tri_written + (size_t)tris;
    uint32_t *grown = mr_realloc_array(m->indices, total, 3 * sizeof(uint32_t));
    if (!grown)
        return mr_fail_nomem(r->err, r->name, total * 12);
    m->indices = grown;
    return MR_OK;
}

/* Where the vertex slots go: base pointer and components per vertex. */
typedef struct slot_map {
    float *dst[SLOTS];
    int stride[SLOTS];
} slot_map;

static void make_slot_map(const mr_mesh *m, slot_map *s)
{
    for (int k = 0; k < SLOTS; k++) {
        float *base = k < 3 ? m->positions : k < 6 ? m->normals : k < 8 ? m->texcoords
                                                                          : m->colors;
        int first = k < 3 ? 0 : k < 6 ? 3 : k < 8 ? 6 : 8;
        s->stride[k] = k < 6 ? 3 : k < 8 ? 2 : 4;
        s->dst[k] = base ? base + (k - first) : NULL;
    }
}

/* Colors without alpha are opaque. */
static void fill_alpha(float *colors, size_t begin, size_t end)
{
    for (size_t i = begin; i < end; i++)
        colors[4 * i + 3] = 1.0f;
}

/* Shared between the encodings: the strip rule. Triangle k of a strip is
 * (v[k], v[k+1], v[k+2]), with the first two swapped for odd k so that
 * every triangle has the strip's orientation; triangles that repeat a
 * vertex join strips (or turn them) and are dropped. */
typedef struct strip_state {
    uint32_t a, b; /* the two latest vertices */
    uint64_t n;    /* vertices so far in the current strip */
} strip_state;

static inline size_t strip_push(strip_state *s, uint32_t v, uint32_t *out)
{
    size_t emitted = 0;
    if (s->n >= 2 && s->a != s->b && s->a != v && s->b != v) {
        bool odd = (s->n & 1) != 0; /* triangle n - 2 */
        out[0] = odd ? s->b : s->a;
        out[1] = odd ? s->a : s->b;
        out[2] = v;
        emitted = 1;
    }
    s->a = s->b;
    s->b = v;
    s->n++;
    return emitted;
}

/* ------------------------------------------------------------------------ */
/* Binary bodies                                                            */
/* ------------------------------------------------------------------------ */

static mr_status truncated(const ply_reader *r, const ply_elem *e, uint64_t row, size_t at)
{
    char buf[96];
    return fail_at(r, MR_ERR_PARSE, at, "file ends inside %s %llu of %llu",
                   row_noun(e, false, buf, sizeof buf), (unsigned long long)row,
                   (unsigned long long)e->count);
}

/* A face needs three corners, as in OBJ: a shorter list is an error (at
 * the list's count), not a face silently dropped. Strips are not faces:
 * their short runs join strips and make no triangle by the strip rule. */
static mr_status short_face(const ply_reader *r, uint64_t row, int64_t n, size_t at)
{
    if (n == 0)
        return fail_at(r, MR_ERR_PARSE, at,
                       "face %llu has no vertex indices (a face needs at least 3)",
                       (unsigned long long)row);
    return fail_at(r, MR_ERR_PARSE, at,
                   "face %llu has only %lld vertex ind%s (a face needs at least 3)",
                   (unsigned long long)row, (long long)n, n == 1 ? "ex" : "ices");
}

/* Walk the rows of an element with lists from e->start, checking that each
 * fits in the file; sets e->tris (faces: exact, strips: an upper bound)
 * and *end. With `chunks`, records where every CHUNK_ROWS-th row starts. */
static mr_status walk_rows(ply_reader *r, ply_elem *e, ply_chunk *chunks, size_t *end)
{
    const unsigned char *d = (const unsigned char *)r->data;
    const size_t size = r->size;
    size_t pos = e->start, released = e->start;
    uint64_t tris = 0;
    for (uint64_t row = 0; row < e->count; row++) {
        if (chunks && row % CHUNK_ROWS == 0) {
            chunks[row / CHUNK_ROWS].off = pos;
            chunks[row / CHUNK_ROWS].tri = tris;
        }
        if (r->release && pos - released >= ((size_t)64 << 20)) {
            mr_release_mapped(r->release, released, pos);
            released = pos;
        }
        for (size_t i = e->prop_begin; i < e->prop_end; i++) {
            const ply_prop *p = &r->props[i];
            if (p->count_type == PT_NONE) {
                if (size - pos < type_size[p->type])
                    return truncated(r, e, row, pos);
                pos += type_size[p->type];
                continue;
            }
            if (size - pos < type_size[p->count_type])
                return truncated(r, e, row, pos);
            int64_t n = rd_int(d + pos, p->count_type, r->swap);
            if (n < 0) {
                char buf[96];
                return fail_at(r, MR_ERR_PARSE, pos, "%s %llu: negative list length %lld",
                               row_noun(e, false, buf, sizeof buf), (unsigned long long)row,
                               (long long)n);
            }
            if (i == e->index_prop && e->kind == EK_FACE && n < 3)
                return short_face(r, row, n, pos);
            pos += type_size[p->count_type];
            size_t isz = type_size[p->type];
            if ((uint64_t)n > (size - pos) / isz) {
                char buf[96];
                return fail_at(r, MR_ERR_PARSE, pos,
                               "file ends inside %s %llu: its list of %lld items needs "
                               "%llu bytes, %zu remain",
                               row_noun(e, false, buf, sizeof buf), (unsigned long long)row,
                               (long long)n, (unsigned long long)n * isz, size - pos);
            }
            pos += (size_t)n * isz;
            if (i == e->index_prop && n >= 3)
                tris += (uint64_t)n - 2;
        }
    }
    e->tris = tris;
    *end = pos;
    return MR_OK;
}

/* Faces whose lists have the same length in every row (the usual case:
 * all triangles) have a fixed stride; then rows need not be walked one
 * after another. Checking each row's counts against the first row's is
 * exactly what the walk would find, and it runs in parallel. */
static bool try_fixed_stride(ply_reader *r, ply_elem *e)
{
    const unsigned char *d = (const unsigned char *)r->data;
    size_t pos = e->start;
    for (size_t i = e->prop_begin; i < e->prop_end; i++) {
        ply_prop *p = &r->props[i];
        p->row_off = pos - e->start;
        if (p->count_type == PT_NONE) {
            if (r->size - pos < type_size[p->type])
                return false;
            pos += type_size[p->type];
            continue;
        }
        if (r->size - pos < type_size[p->count_type])
            return false;
        int64_t n = rd_int(d + pos, p->count_type, r->swap);
        pos += type_size[p->count_type];
        if (n < 0 || (uint64_t)n > (r->size - pos) / type_size[p->type])
            return false;
        if (i == e->index_prop && n < 3)
            return false; /* the walk reports the short face */
        p->fixed_count = n;
        pos += (size_t)n * type_size[p->type];
    }
    size_t stride = pos - e->start;
    if (e->count > (r->size - e->start) / stride)
        return false;

    const ply_prop *props = r->props + e->prop_begin;
    const size_t nprops = e->prop_end - e->prop_begin;
    const int64_t nblocks = (int64_t)((e->count + CHUNK_ROWS - 1) / CHUNK_ROWS);
    const bool swap = r->swap;
    int same = 1;
#pragma omp parallel for schedule(static) num_threads(r->threads) if (nblocks > 4) \
    reduction(&& : same)
    for (int64_t b = 0; b < nblocks; b++) {
        uint64_t r0 = (uint64_t)b * CHUNK_ROWS;
        uint64_t r1 = r0 + CHUNK_ROWS < e->count ? r0 + CHUNK_ROWS : e->count;
        int ok = 1;
        for (size_t k = 0; k < nprops && ok; k++) {
            if (props[k].count_type == PT_NONE)
                continue;
            const unsigned char *c = d + e->start + r0 * stride + props[k].row_off;
            const ply_type ct = props[k].count_type;
            const int64_t want = props[k].fixed_count;
            if (ct == PT_U8) { /* the common uchar count: a byte compare */
                for (uint64_t row = r0; row < r1; row++, c += stride)
                    ok &= *c == (unsigned char)want;
            } else {
                for (uint64_t row = r0; row < r1; row++, c += stride)
                    ok &= rd_int(c, ct, swap) == want;
            }
        }
        same = same && ok;
        if (r->release)
            mr_release_mapped(r->release, e->start + (size_t)(r0 * stride),
                              e->start + (size_t)(r1 * stride));
    }
    if (!same)
        return false;

    e->stride = stride;
    int64_t k = r->props[e->index_prop].fixed_count;
    e->tris = e->count * (uint64_t)(k >= 3 ? k - 2 : 0);
    return true;
}

/* Locate a face element: its chunks, triangle count and end. */
static mr_status locate_faces(ply_reader *r, ply_elem *e, size_t *end)
{
    e->chunk_count = (size_t)((e->count + CHUNK_ROWS - 1) / CHUNK_ROWS);
    e->chunks = mr_calloc_array(e->chunk_count, sizeof *e->chunks);
    if (!e->chunks)
        return mr_fail_nomem(r->err, r->name, e->chunk_count * sizeof *e->chunks);
    if (e->count && try_fixed_stride(r, e)) {
        int64_t k = r->props[e->index_prop].fixed_count;
        uint64_t per = (uint64_t)(k >= 3 ? k - 2 : 0);
        for (size_t c = 0; c < e->chunk_count; c++) {
            e->chunks[c].off = e->start + c * CHUNK_ROWS * e->stride;
            e->chunks[c].tri = (uint64_t)c * CHUNK_ROWS * per;
        }
        *end = e->start + (size_t)e->count * e->stride;
        return MR_OK;
    }
    return walk_rows(r, e, e->chunks, end);
}

/* Find where every element starts and how many triangles the faces give. */
static mr_status locate_elements(ply_reader *r)
{
    size_t pos = r->body;
    for (size_t i = 0; i < r->elem_count; i++) {
        ply_elem *e = &r->elems[i];
        e->start = pos;
        mr_status st = MR_OK;
        if (e->kind == EK_FACE) {
            st = locate_faces(r, e, &pos);
        } else if (e->fixed) {
            /* check_counts saw the element fit after the least sizes of
             * those before it; lists before it may have used more. */
            if (e->row_size && e->count > (r->size - pos) / e->row_size)
                return truncated(r, e, (r->size - pos) / e->row_size, r->size);
            pos += (size_t)(e->count * e->row_size);
        } else {
            st = walk_rows(r, e, NULL, &pos);
        }
        if (st != MR_OK)
            return st;
    }
    return MR_OK;
}

/* One column of a fixed-size vertex element: n values of type t at src
 * (row stride `stride`) into dst (every ds floats), divided by div. The
 * common types get loops of their own, with the type known inside. */
static void decode_column(const unsigned char *src, size_t stride, ply_type t, bool swap,
                          double div, float *dst, int ds, size_t n)
{
    if (t == PT_F32 && !swap && div == 1.0) {
        for (size_t i = 0; i < n; i++, src += stride, dst += ds)
            memcpy(dst, src, sizeof(float));
        return;
    }
    switch (t) {
    case PT_U8:
        for (size_t i = 0; i < n; i++, src += stride, dst += ds)
            *dst = (float)(src[0] / div);
        break;
    case PT_F32:
        for (size_t i = 0; i < n; i++, src += stride, dst += ds)
            *dst = (float)(rd_real(src, PT_F32, swap) / div);
        break;
    default:
        for (size_t i = 0; i < n; i++, src += stride, dst += ds)
            *dst = (float)(rd_real(src, t, swap) / div);
        break;
    }
}

static uint64_t first_nonfinite(const float *pos, size_t begin, size_t end)
{
    for (size_t i = begin; i < end; i++)
        if (!isfinite(pos[3 * i]) || !isfinite(pos[3 * i + 1]) || !isfinite(pos[3 * i + 2]))
            return i;
    return UINT64_MAX;
}

static mr_status nonfinite_error(const ply_reader *r, uint64_t v, size_t at)
{
    const float *p = r->mesh->positions + 3 * v;
    return fail_at(r, MR_ERR_PARSE, at, "vertex %llu has a non-finite coordinate (%g %g %g)",
                   (unsigned long long)v, (double)p[0], (double)p[1], (double)p[2]);
}

/* The vertex element's columns that go somewhere in dst. */
typedef struct vertex_column {
    size_t off;
    ply_type type;
    double div;
    float *dst;
    int ds;
} vertex_column;

typedef struct vertex_columns {
    vertex_column cols[SLOTS];
    int ncols;
    bool xyz_first; /* x y z leading as host floats: 12 bytes a row */
    bool fill;      /* colors without alpha: alpha filled */
} vertex_columns;

static void vertex_columns_of(const ply_reader *r, const ply_elem *e, const mr_mesh *dst,
                              vertex_columns *vc)
{
    slot_map sm;
    make_slot_map(dst, &sm);
    vc->ncols = 0;
    size_t off = 0;
    for (size_t i = e->prop_begin; i < e->prop_end; i++) {
        const ply_prop *p = &r->props[i];
        if (p->slot >= 0 && sm.dst[p->slot] && vc->ncols < SLOTS)
            vc->cols[vc->ncols++] = (vertex_column){off, p->type, p->divisor, sm.dst[p->slot],
                                                    sm.stride[p->slot]};
        off += type_size[p->type];
    }
    const vertex_column *c = vc->cols;
    vc->xyz_first = !r->swap && vc->ncols >= 3 && c[0].off == 0 && c[1].off == 4 &&
                    c[2].off == 8 && c[0].dst == dst->positions &&
                    c[1].dst == dst->positions + 1 && c[2].dst == dst->positions + 2 &&
                    c[0].type == PT_F32 && c[1].type == PT_F32 && c[2].type == PT_F32;
    vc->fill = dst->colors && !r->has_alpha;
}

/* Rows a0..a1 into dst (whose row 0 is `first`): the first with a
 * non-finite position, or UINT64_MAX. */
static uint64_t decode_rows(const ply_reader *r, const ply_elem *e, const vertex_columns *vc,
                            const mr_mesh *dst, size_t first, size_t a0, size_t a1)
{
    const unsigned char *base = (const unsigned char *)r->data + e->start;
    const size_t stride = (size_t)e->row_size;
    int c = 0;
    if (vc->xyz_first) {
        float *pos = dst->positions + 3 * (a0 - first);
        if (stride == 12)
            memcpy(pos, base + a0 * 12, (a1 - a0) * 12);
        else
            for (size_t i = a0; i < a1; i++, pos += 3)
                memcpy(pos, base + i * stride, 12);
        c = 3;
    }
    for (; c < vc->ncols; c++)
        decode_column(base + a0 * stride + vc->cols[c].off, stride, vc->cols[c].type, r->swap,
                      vc->cols[c].div, vc->cols[c].dst + (a0 - first) * (size_t)vc->cols[c].ds,
                      vc->cols[c].ds, a1 - a0);
    if (vc->fill)
        fill_alpha(dst->colors, a0 - first, a1 - first);
    const uint64_t v = first_nonfinite(dst->positions, a0 - first, a1 - first);
    return v != UINT64_MAX ? v + first : UINT64_MAX;
}

/* Rows [i0, i1) of a vertex element without lists into dst's arrays, row
 * i at dst index i - first (attributes where dst has their arrays), column
 * by column, in blocks of rows spread over the threads. x y z as the first
 * three host-order floats is the common layout and is copied as is.
 * Returns the first row with a non-finite position, or UINT64_MAX. */
static uint64_t decode_vertex_range(const ply_reader *r, const ply_elem *e, const mr_mesh *dst,
                                    size_t first, size_t i0, size_t i1)
{
    vertex_columns vc;
    vertex_columns_of(r, e, dst, &vc);
    const int64_t nblocks = (int64_t)((i1 - i0 + CHUNK_ROWS - 1) / CHUNK_ROWS);
    uint64_t bad = UINT64_MAX;
#pragma omp parallel for schedule(static) num_threads(r->threads) if (nblocks > 4) \
    reduction(min : bad)
    for (int64_t b = 0; b < nblocks; b++) {
        size_t a0 = i0 + (size_t)b * CHUNK_ROWS, a1 = a0 + CHUNK_ROWS < i1 ? a0 + CHUNK_ROWS : i1;
        const uint64_t v = decode_rows(r, e, &vc, dst, first, a0, a1);
        if (v < bad)
            bad = v;
    }
    return bad;
}

static mr_status nonfinite_at(const ply_reader *r, const ply_elem *e, const float *p, uint64_t v)
{
    return fail_at(r, MR_ERR_PARSE, e->start + (size_t)v * (size_t)e->row_size,
                   "vertex %llu has a non-finite coordinate (%g %g %g)", (unsigned long long)v,
                   (double)p[0], (double)p[1], (double)p[2]);
}

/* A vertex element without lists, whole. */
static mr_status decode_vertices_fixed(ply_reader *r, const ply_elem *e)
{
    const uint64_t bad = decode_vertex_range(r, e, r->mesh, 0, 0, (size_t)e->count);
    if (bad != UINT64_MAX)
        return nonfinite_at(r, e, r->mesh->positions + 3 * bad, bad);
    return MR_OK;
}

/* A vertex element with lists (rare): row by row. */
static mr_status decode_vertices_rows(ply_reader *r, const ply_elem *e)
{
    const unsigned char *d = (const unsigned char *)r->data;
    slot_map sm;
    make_slot_map(r->mesh, &sm);
    size_t pos = e->start;
    for (size_t v = 0; v < (size_t)e->count; v++) {
        size_t row_start = pos;
        for (size_t i = e->prop_begin; i < e->prop_end; i++) {
            const ply_prop *p = &r->props[i];
            if (p->count_type != PT_NONE) { /* walk_rows checked the bounds */
                int64_t n = rd_int(d + pos, p->count_type, r->swap);
                pos += type_size[p->count_type] + (size_t)n * type_size[p->type];
                continue;
            }
            if (p->slot >= 0)
                sm.dst[p->slot][v * (size_t)sm.stride[p->slot]] =
                    (float)(rd_real(d + pos, p->type, r->swap) / p->divisor);
            pos += type_size[p->type];
        }
        if (r->mesh->colors && !r->has_alpha)
            r->mesh->colors[4 * v + 3] = 1.0f;
        if (first_nonfinite(r->mesh->positions, v, v + 1) != UINT64_MAX)
            return nonfinite_error(r, v, row_start);
    }
    return MR_OK;
}

/* Record a bad index in a chunk (the first one of the chunk wins). */
static void chunk_bad(ply_chunk *c, uint64_t row, size_t off, int64_t value)
{
    c->bad_row = row;
    c->bad_off = off;
    c->bad_value = value;
}

/* Rows [row0, row1) of a fixed-stride face element whose index lists all
 * hold three 32-bit indices: the common binary layout, in a tight loop. */
static void decode_tri32_chunk(const ply_reader *r, const ply_elem *e, ply_chunk *c,
                               uint64_t row0, uint64_t row1, uint32_t *out)
{
    const ply_prop *ip = &r->props[e->index_prop];
    const size_t stride = e->stride;
    const unsigned char *p =
        (const unsigned char *)r->data + c->off + ip->row_off + type_size[ip->count_type];
    /* A negative int32 reads as a large uint32, caught by the same bound. */
    const uint64_t vc = r->vertex->count;
    const uint32_t lim = (uint32_t)(ip->type == PT_I32 && vc > INT32_MAX ? (uint64_t)INT32_MAX + 1
                                                                          : vc);
    const bool swap = r->swap;
    for (uint64_t row = row0; row < row1; row++, p += stride, out += 3) {
        uint32_t t[3];
        memcpy(t, p, 12);
        if (swap) {
            t[0] = mr_bswap32(t[0]);
            t[1] = mr_bswap32(t[1]);
            t[2] = mr_bswap32(t[2]);
        }
        if (MR_UNLIKELY((t[0] >= lim) | (t[1] >= lim) | (t[2] >= lim))) {
            int k = t[0] >= lim ? 0 : t[1] >= lim ? 1 : 2;
            size_t at = (size_t)(p - (const unsigned char *)r->data) + 4 * (size_t)k;
            chunk_bad(c, row, at, rd_int(p + 4 * k, ip->type, swap));
            return;
        }
        memcpy(out, t, 12);
    }
}

/* Rows [row0, row1) of a face element, any layout: polygons are fans. */
static void decode_fan_chunk(const ply_reader *r, const ply_elem *e, ply_chunk *c,
                             uint64_t row0, uint64_t row1, uint32_t *out)
{
    const unsigned char *d = (const unsigned char *)r->data;
    const int64_t vc = (int64_t)r->vertex->count;
    const bool swap = r->swap;
    size_t pos = c->off;
    for (uint64_t row = row0; row < row1; row++) {
        for (size_t i = e->prop_begin; i < e->prop_end; i++) {
            const ply_prop *p = &r->props[i];
            if (p->count_type == PT_NONE) {
                pos += type_size[p->type];
                continue;
            }
            int64_t n = rd_int(d + pos, p->count_type, swap);
            pos += type_size[p->count_type];
            size_t isz = type_size[p->type];
            if (i == e->index_prop) {
                uint32_t first = 0, prev = 0;
                for (int64_t j = 0; j < n; j++) {
                    int64_t v = rd_int(d + pos + (size_t)j * isz, p->type, swap);
                    if (v < 0 || v >= vc) {
                        chunk_bad(c, row, pos + (size_t)j * isz, v);
                        return;
                    }
                    if (j == 0)
                        first = (uint32_t)v;
                    else if (j >= 2) {
                        out[0] = first;
                        out[1] = prev;
                        out[2] = (uint32_t)v;
                        out += 3;
                    }
                    prev = (uint32_t)v;
                }
            }
            pos += (size_t)n * isz;
        }
    }
}

static mr_status index_error(const ply_reader *r, const ply_elem *e, uint64_t row, size_t at,
                             int64_t v)
{
    char buf[96];
    const char *noun = row_noun(e, false, buf, sizeof buf);
    if (v < 0)
        return fail_at(r, MR_ERR_PARSE, at, "%s %llu: negative vertex index %lld", noun,
                       (unsigned long long)row, (long long)v);
    return fail_at(r, MR_ERR_PARSE, at,
                   "%s %llu: vertex index %lld is out of range (there are %llu vertices)",
                   noun, (unsigned long long)row, (long long)v,
                   (unsigned long long)r->vertex->count);
}

static mr_status decode_faces_binary(ply_reader *r, ply_elem *e)
{
    uint32_t *out = r->mesh->indices + 3 * r->tri_written;
    const ply_prop *ip = &r->props[e->index_prop];
    const bool tri32 = e->stride && ip->fixed_count == 3 && type_size[ip->type] == 4;
    const int64_t nchunks = (int64_t)e->chunk_count;
#pragma omp parallel for schedule(static) num_threads(r->threads) if (nchunks > 4)
    for (int64_t k = 0; k < nchunks; k++) {
        ply_chunk *c = &e->chunks[k];
        uint64_t row0 = (uint64_t)k * CHUNK_ROWS;
        uint64_t row1 = row0 + CHUNK_ROWS < e->count ? row0 + CHUNK_ROWS : e->count;
        c->bad_row = UINT64_MAX;
        if (tri32)
            decode_tri32_chunk(r, e, c, row0, row1, out + 3 * c->tri);
        else
            decode_fan_chunk(r, e, c, row0, row1, out + 3 * c->tri);
    }
    for (size_t k = 0; k < e->chunk_count; k++)
        if (e->chunks[k].bad_row != UINT64_MAX)
            return index_error(r, e, e->chunks[k].bad_row, e->chunks[k].bad_off,
                               e->chunks[k].bad_value);
    r->tri_written += (size_t)e->tris;
    return MR_OK;
}

/* Triangle strips: one list can hold a whole mesh, so this is sequential. */
static mr_status decode_strips_binary(ply_reader *r, const ply_elem *e)
{
    const unsigned char *d = (const unsigned char *)r->data;
    const int64_t vc = (int64_t)r->vertex->count;
    uint32_t *out = r->mesh->indices + 3 * r->tri_written;
    size_t written = 0, pos = e->start;
    for (uint64_t row = 0; row < e->count; row++) {
        for (size_t i = e->prop_begin; i < e->prop_end; i++) {
            const ply_prop *p = &r->props[i];
            if (p->count_type == PT_NONE) {
                pos += type_size[p->type];
                continue;
            }
            int64_t n = rd_int(d + pos, p->count_type, r->swap);
            pos += type_size[p->count_type];
            size_t isz = type_size[p->type];
            if (i == e->index_prop) {
                strip_state s = {0, 0, 0};
                for (int64_t j = 0; j < n; j++, pos += isz) {
                    int64_t v = rd_int(d + pos, p->type, r->swap);
                    if (v == -1) {
                        s.n = 0; /* restart */
                    } else if (v < 0 || v >= vc) {
                        return index_error(r, e, row, pos, v);
                    } else {
                        written += strip_push(&s, (uint32_t)v, out + 3 * written);
                    }
                }
            } else {
                pos += (size_t)n * isz;
            }
        }
    }
    r->tri_written += written;
    return MR_OK;
}

static mr_status read_binary(ply_reader *r)
{
    mr_status st = locate_elements(r);
    if (st != MR_OK)
        return st;
    uint64_t tris = 0;
    for (size_t i = 0; i < r->elem_count; i++)
        if (r->elems[i].kind == EK_FACE || r->elems[i].kind == EK_STRIPS)
            tris += r->elems[i].tris; /* each is below the file size */
    if ((st = alloc_vertices(r)) != MR_OK || (st = reserve_triangles(r, tris)) != MR_OK)
        return st;
    st = r->vertex->fixed ? decode_vertices_fixed(r, r->vertex)
                          : decode_vertices_rows(r, r->vertex);
    for (size_t i = 0; i < r->elem_count && st == MR_OK; i++) {
        ply_elem *e = &r->elems[i];
        if (e->kind == EK_FACE)
            st = decode_faces_binary(r, e);
        else if (e->kind == EK_STRIPS)
            st = decode_strips_binary(r, e);
    }
    return st;
}

/* ------------------------------------------------------------------------ */
/* Ascii bodies                                                             */
/* ------------------------------------------------------------------------ */

typedef struct ascii_cursor {
    const char *p, *end;
} ascii_cursor;

/* Values are separated by any white space, newlines included. */
static void asc_skip_ws(ascii_cursor *c)
{
    while (c->p < c->end && (mr_is_space(*c->p) || *c->p == '\n'))
        c->p++;
}

static size_t asc_off(const ply_reader *r, const ascii_cursor *c)
{
    return (size_t)(c->p - r->data);
}

static mr_status asc_missing(const ply_reader *r, const ascii_cursor *c, const ply_elem *e,
                             uint64_t row, const ply_prop *p)
{
    /* report the line of the last value, not the empty one after it */
    const char *at = c->p, *body = r->data + r->body;
    while (at > body && (mr_is_space(at[-1]) || at[-1] == '\n'))
        at--;
    char buf[96];
    return fail_at(r, MR_ERR_PARSE, (size_t)(at - r->data),
                   "file ends inside %s %llu of %llu (expected a value for '%.*s')",
                   row_noun(e, false, buf, sizeof buf), (unsigned long long)row,
                   (unsigned long long)e->count, name_width(p->name_len), p->name);
}

static mr_status asc_bad(const ply_reader *r, const ascii_cursor *c, const ply_elem *e,
                         uint64_t row, const ply_prop *p, const char *expected)
{
    char buf[96], tok[32];
    mr_token_excerpt(c->p, c->end, tok, sizeof tok);
    return fail_at(r, MR_ERR_PARSE, asc_off(r, c), "%s %llu: expected %s for '%.*s', found '%s'",
                   row_noun(e, false, buf, sizeof buf), (unsigned long long)row, expected,
                   name_width(p->name_len), p->name, tok);
}

static const char *const type_names[] = {"",      "char", "uchar", "short", "ushort",
                                         "int",   "uint", "float", "double"};

/* A value at the cursor too large for the type t of property p: however
 * many digits it has, it is out of range rather than malformed. */
static mr_status asc_range(const ply_reader *r, const ascii_cursor *c, const ply_elem *e,
                           uint64_t row, const ply_prop *p, ply_type t)
{
    char buf[96], num[80];
    mr_number_excerpt(c->p, c->end, num, sizeof num);
    return fail_at(r, MR_ERR_PARSE, asc_off(r, c),
                   "%s %llu: value %s of '%.*s' is out of range for its type %s",
                   row_noun(e, false, buf, sizeof buf), (unsigned long long)row, num,
                   name_width(p->name_len), p->name, type_names[t]);
}

/* The next value as an integer of type t (range-checked). */
static mr_status asc_int(const ply_reader *r, ascii_cursor *c, ply_type t, const ply_elem *e,
                         uint64_t row, const ply_prop *p, int64_t *out)
{
    asc_skip_ws(c);
    if (c->p >= c->end)
        return asc_missing(r, c, e, row, p);
    const char *s = c->p;
    int64_t v;
    if (!mr_parse_i64(&s, c->end, &v) || !mr_at_token_end(s, c->end)) {
        if (mr_number_too_large(c->p, c->end, true))
            return asc_range(r, c, e, row, p, t);
        return asc_bad(r, c, e, row, p, "an integer");
    }
    if (v < type_min[t] || v > type_max[t]) {
        char buf[96];
        return fail_at(r, MR_ERR_PARSE, asc_off(r, c),
                       "%s %llu: value %lld of '%.*s' is out of range for its type %s",
                       row_noun(e, false, buf, sizeof buf), (unsigned long long)row,
                       (long long)v, name_width(p->name_len), p->name, type_names[t]);
    }
    c->p = s;
    *out = v;
    return MR_OK;
}

/* The next value of type t as a double. */
static mr_status asc_real(const ply_reader *r, ascii_cursor *c, ply_type t, const ply_elem *e,
                          uint64_t row, const ply_prop *p, double *out)
{
    if (type_is_int(t)) {
        int64_t v;
        mr_status st = asc_int(r, c, t, e, row, p, &v);
        *out = (double)v;
        return st;
    }
    asc_skip_ws(c);
    if (c->p >= c->end)
        return asc_missing(r, c, e, row, p);
    const char *s = c->p;
    if (!mr_parse_double(&s, c->end, out) || !mr_at_token_end(s, c->end))
        return asc_bad(r, c, e, row, p, "a number");
    if (isinf(*out) && mr_number_too_large(c->p, c->end, false))
        return asc_range(r, c, e, row, p, t);
    c->p = s;
    return MR_OK;
}

/* Skip one value without parsing it. */
static mr_status asc_skip_value(const ply_reader *r, ascii_cursor *c, const ply_elem *e,
                                uint64_t row, const ply_prop *p)
{
    asc_skip_ws(c);
    if (c->p >= c->end)
        return asc_missing(r, c, e, row, p);
    while (c->p < c->end && !mr_is_space(*c->p) && *c->p != '\n')
        c->p++;
    return MR_OK;
}

/* Skip the rows of an element, counting the triangles of its index list
 * (faces: exact, strips: an upper bound). */
static mr_status asc_walk(const ply_reader *r, ascii_cursor *c, const ply_elem *e,
                          uint64_t *tris)
{
    uint64_t t = 0;
    /* rows without properties take no text, however many are announced */
    const uint64_t rows = e->prop_begin < e->prop_end ? e->count : 0;
    for (uint64_t row = 0; row < rows; row++)
        for (size_t i = e->prop_begin; i < e->prop_end; i++) {
            const ply_prop *p = &r->props[i];
            mr_status st;
            if (p->count_type == PT_NONE) {
                if ((st = asc_skip_value(r, c, e, row, p)) != MR_OK)
                    return st;
                continue;
            }
            int64_t n;
            if ((st = asc_int(r, c, p->count_type, e, row, p, &n)) != MR_OK)
                return st;
            if (n < 0)
                return fail_at(r, MR_ERR_PARSE, asc_off(r, c), "negative list length %lld",
                               (long long)n);
            if (i == e->index_prop && e->kind == EK_FACE && n < 3) {
                ascii_cursor at = *c; /* the count itself, not the blank after it */
                while (at.p > r->data + r->body && !mr_is_space(at.p[-1]) && at.p[-1] != '\n')
                    at.p--;
                return short_face(r, row, n, asc_off(r, &at));
            }
            for (int64_t j = 0; j < n; j++)
                if ((st = asc_skip_value(r, c, e, row, p)) != MR_OK)
                    return st;
            if (i == e->index_prop && n >= 3)
                t += (uint64_t)n - 2;
        }
    if (tris)
        *tris = t;
    return MR_OK;
}

static mr_status asc_vertices(ply_reader *r, ascii_cursor *c, const ply_elem *e)
{
    slot_map sm;
    make_slot_map(r->mesh, &sm);
    for (size_t v = 0; v < (size_t)e->count; v++) {
        for (size_t i = e->prop_begin; i < e->prop_end; i++) {
            const ply_prop *p = &r->props[i];
            mr_status st;
            if (p->count_type != PT_NONE) {
                int64_t n;
                double ignored;
                if ((st = asc_int(r, c, p->count_type, e, v, p, &n)) != MR_OK)
                    return st;
                for (int64_t j = 0; j < n; j++)
                    if ((st = asc_real(r, c, p->type, e, v, p, &ignored)) != MR_OK)
                        return st;
                continue;
            }
            const char *at = c->p;
            double x;
            if ((st = asc_real(r, c, p->type, e, v, p, &x)) != MR_OK)
                return st;
            if (p->slot < 0)
                continue;
            float f = (float)(x / p->divisor);
            if (p->slot < 3 && !isfinite(f)) {
                ascii_cursor here = {at, c->end};
                asc_skip_ws(&here);
                return fail_at(r, MR_ERR_PARSE, asc_off(r, &here),
                               "vertex %zu has a non-finite coordinate (%g)", v, x);
            }
            sm.dst[p->slot][v * (size_t)sm.stride[p->slot]] = f;
        }
        if (r->mesh->colors && !r->has_alpha)
            r->mesh->colors[4 * v + 3] = 1.0f;
    }
    return MR_OK;
}

/* Faces or strips: count the triangles, make room, then parse. */
static mr_status asc_faces(ply_reader *r, ascii_cursor *c, const ply_elem *e)
{
    ascii_cursor first = *c;
    uint64_t tris;
    mr_status st = asc_walk(r, c, e, &tris);
    if (st != MR_OK || (st = reserve_triangles(r, tris)) != MR_OK)
        return st;
    *c = first;
    const int64_t vc = (int64_t)r->vertex->count;
    uint32_t *out = r->mesh->indices + 3 * r->tri_written;
    size_t written = 0;
    for (uint64_t row = 0; row < e->count; row++)
        for (size_t i = e->prop_begin; i < e->prop_end; i++) {
            const ply_prop *p = &r->props[i];
            double ignored;
            if (p->count_type == PT_NONE) {
                if ((st = asc_real(r, c, p->type, e, row, p, &ignored)) != MR_OK)
                    return st;
                continue;
            }
            int64_t n;
            if ((st = asc_int(r, c, p->count_type, e, row, p, &n)) != MR_OK)
                return st;
            if (i != e->index_prop) {
                for (int64_t j = 0; j < n; j++)
                    if ((st = asc_real(r, c, p->type, e, row, p, &ignored)) != MR_OK)
                        return st;
                continue;
            }
            strip_state s = {0, 0, 0};
            uint32_t fan_first = 0, prev = 0;
            for (int64_t j = 0; j < n; j++) {
                int64_t v;
                if ((st = asc_int(r, c, p->type, e, row, p, &v)) != MR_OK)
                    return st;
                if (e->kind == EK_STRIPS && v == -1) {
                    s.n = 0;
                    continue;
                }
                if (v < 0 || v >= vc) {
                    /* point at the index itself, not the blank before it */
                    ascii_cursor at = *c;
                    while (at.p > first.p && !mr_is_space(at.p[-1]) && at.p[-1] != '\n')
                        at.p--;
                    return index_error(r, e, row, asc_off(r, &at), v);
                }
                if (e->kind == EK_STRIPS) {
                    written += strip_push(&s, (uint32_t)v, out + 3 * written);
                    continue;
                }
                if (j == 0)
                    fan_first = (uint32_t)v;
                else if (j >= 2) {
                    uint32_t *t = out + 3 * written++;
                    t[0] = fan_first;
                    t[1] = prev;
                    t[2] = (uint32_t)v;
                }
                prev = (uint32_t)v;
            }
        }
    r->tri_written += written;
    return MR_OK;
}

static mr_status read_ascii(ply_reader *r)
{
    mr_status st = alloc_vertices(r);
    ascii_cursor c = {r->data + r->body, r->data + r->size};
    for (size_t i = 0; i < r->elem_count && st == MR_OK; i++) {
        const ply_elem *e = &r->elems[i];
        switch (e->kind) {
        case EK_VERTEX: st = asc_vertices(r, &c, e); break;
        case EK_FACE:
        case EK_STRIPS: st = asc_faces(r, &c, e); break;
        default: st = asc_walk(r, &c, e, NULL); break;
        }
    }
    if (st != MR_OK)
        return st;
    /* Values left over mean the rows did not have the announced shape. */
    asc_skip_ws(&c);
    if (c.p < c.end) {
        char tok[32];
        mr_token_excerpt(c.p, c.end, tok, sizeof tok);
        return fail_at(r, MR_ERR_PARSE, asc_off(r, &c),
                       "unexpected '%s' after the last element the header announces", tok);
    }
    return MR_OK;
}

/* ------------------------------------------------------------------------ */
/* Reader entry point                                                       */
/* ------------------------------------------------------------------------ */

static mr_status read_ply(ply_reader *r)
{
    mr_status st;
    if ((st = parse_header(r)) != MR_OK || (st = classify(r)) != MR_OK ||
        (st = check_counts(r)) != MR_OK)
        return st;
    st = r->enc == ENC_ASCII ? read_ascii(r) : read_binary(r);
    if (st != MR_OK)
        return st;
    mr_mesh *m = r->mesh;
    m->triangle_count = r->tri_written;
    if (m->triangle_count == 0) { /* a point cloud */
        free(m->indices);
        m->indices = NULL;
    } else {
        /* Strips may give fewer triangles than reserved: give back the rest. */
        uint32_t *shrunk = mr_realloc_array(m->indices, m->triangle_count, 3 * sizeof(uint32_t));
        if (shrunk)
            m->indices = shrunk;
    }
    return MR_OK;
}

mr_status mr_read_ply(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err)
{
    ply_reader r;
    memset(&r, 0, sizeof r);
    r.data = data;
    r.size = size;
    r.name = name;
    r.threads = threads > 0 ? threads : 1;
    r.err = err;
    r.mesh = mesh;
    mr_status st = read_ply(&r);
    for (size_t i = 0; i < r.elem_count; i++)
        free(r.elems[i].chunks);
    free(r.elems);
    free(r.props);
    return st;
}

/* ------------------------------------------------------------------------ */
/* A binary PLY file read in pieces (mr_ply_source)                         */
/* ------------------------------------------------------------------------ */

struct mr_ply_source {
    ply_reader r;
    mr_mapped_file file;
    uint64_t triangles;      /* over every face element */
    size_t max_chunk;        /* the most triangles one face chunk gives */
    size_t elem, chunk;      /* the next face chunk */
    size_t released;         /* the map released up to here (face bytes) */
    size_t xyz_off[3];       /* x y z in a vertex row */
    ply_type xyz_type[3];
};

static mr_status source_unsupported(const mr_ply_source *s, const char *what)
{
    return mr_fail_plain(s->r.err, MR_ERR_UNSUPPORTED, s->r.name,
                         "%s: it is read whole instead (without the out-of-core path), or "
                         "converted to binary PLY first (meshreduce convert IN OUT.ply)",
                         what);
}

mr_status mr_ply_source_open(const char *path, int threads, mr_ply_source **out, mr_error *err)
{
    *out = NULL;
    mr_ply_source *s = mr_calloc_array(1, sizeof *s);
    if (!s)
        return mr_fail_nomem(err, path, sizeof *s);
    mr_status st = mr_map_file(path, &s->file, err);
    if (st != MR_OK) {
        free(s);
        return st;
    }
    ply_reader *r = &s->r;
    r->data = s->file.data;
    r->size = s->file.size;
    r->name = path;
    r->threads = threads > 0 ? threads : 1;
    r->err = err;
    r->release = &s->file;
    if ((st = parse_header(r)) != MR_OK || (st = classify(r)) != MR_OK ||
        (st = check_counts(r)) != MR_OK)
        goto fail;
    if (r->enc == ENC_ASCII) {
        st = source_unsupported(s, "an ascii PLY file is not read in pieces");
        goto fail;
    }
    if (!r->vertex->fixed) {
        st = source_unsupported(s, "a vertex element with lists is not read in pieces");
        goto fail;
    }
    for (size_t i = 0; i < r->elem_count; i++)
        if (r->elems[i].kind == EK_STRIPS) {
            st = source_unsupported(s, "triangle strips are not read in pieces");
            goto fail;
        }
    if ((st = locate_elements(r)) != MR_OK)
        goto fail;
    mr_release_mapped(&s->file, 0, s->file.size); /* what locating the rows read */
    for (size_t i = 0; i < r->elem_count; i++) {
        const ply_elem *e = &r->elems[i];
        if (e->kind != EK_FACE)
            continue;
        s->triangles += e->tris;
        for (size_t c = 0; c < e->chunk_count; c++) {
            const uint64_t t1 = c + 1 < e->chunk_count ? e->chunks[c + 1].tri : e->tris;
            const uint64_t n = t1 - e->chunks[c].tri;
            s->max_chunk = n > s->max_chunk ? (size_t)n : s->max_chunk;
        }
    }
    if (s->triangles > UINT32_MAX) {
        st = mr_fail_plain(err, MR_ERR_TOO_LARGE, path,
                           "%llu triangles exceed the 32-bit index limit",
                           (unsigned long long)s->triangles);
        goto fail;
    }
    size_t off = 0;
    for (size_t i = r->vertex->prop_begin; i < r->vertex->prop_end; i++) {
        const ply_prop *p = &r->props[i];
        if (p->slot >= SLOT_X && p->slot < SLOT_X + 3) {
            s->xyz_off[p->slot - SLOT_X] = off;
            s->xyz_type[p->slot - SLOT_X] = p->type;
        }
        off += type_size[p->type];
    }
    *out = s;
    return MR_OK;
fail:
    mr_ply_source_close(s);
    return st;
}

void mr_ply_source_close(mr_ply_source *s)
{
    if (!s)
        return;
    for (size_t i = 0; i < s->r.elem_count; i++)
        free(s->r.elems[i].chunks);
    free(s->r.elems);
    free(s->r.props);
    mr_unmap_file(&s->file);
    free(s);
}

size_t mr_ply_source_vertex_count(const mr_ply_source *s) { return (size_t)s->r.vertex->count; }

size_t mr_ply_source_triangle_count(const mr_ply_source *s) { return (size_t)s->triangles; }

unsigned mr_ply_source_attributes(const mr_ply_source *s) { return s->r.attrs; }

size_t mr_ply_source_max_faces(const mr_ply_source *s) { return s->max_chunk; }

mr_status mr_ply_source_vertices(mr_ply_source *s, size_t first, size_t count,
                                 const mr_mesh *block, mr_error *err)
{
    s->r.err = err;
    const ply_elem *e = s->r.vertex;
    if (first + count > e->count)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, s->r.name,
                             "vertices %zu..%zu past the %llu the file holds", first,
                             first + count, (unsigned long long)e->count);
    const size_t begin = e->start + first * (size_t)e->row_size,
                 end = e->start + (first + count) * (size_t)e->row_size;
    mr_populate_mapped(&s->file, begin, end);
    const uint64_t bad = decode_vertex_range(&s->r, e, block, first, first, first + count);
    /* decoded: the rows' pages go (mapped pages count in the resident set) */
    mr_release_mapped(&s->file, begin, end);
    if (bad != UINT64_MAX)
        return nonfinite_at(&s->r, e, block->positions + 3 * (bad - first), bad);
    return MR_OK;
}

void mr_ply_source_position(const mr_ply_source *s, uint32_t v, float p[3])
{
    const ply_elem *e = s->r.vertex;
    const unsigned char *row =
        (const unsigned char *)s->r.data + e->start + (size_t)v * (size_t)e->row_size;
    for (int k = 0; k < 3; k++) {
        const unsigned char *c = row + s->xyz_off[k];
        if (s->xyz_type[k] == PT_F32 && !s->r.swap)
            memcpy(&p[k], c, sizeof(float));
        else
            p[k] = (float)rd_real(c, s->xyz_type[k], s->r.swap);
    }
}

void mr_ply_source_vertex(const mr_ply_source *s, uint32_t v, const mr_mesh *one)
{
    /* one row, on the calling thread (no parallel region a vertex) */
    vertex_columns vc;
    vertex_columns_of(&s->r, s->r.vertex, one, &vc);
    (void)decode_rows(&s->r, s->r.vertex, &vc, one, v, v, (size_t)v + 1);
}

mr_status mr_ply_source_next_faces(mr_ply_source *s, uint32_t *idx, size_t *count,
                                   mr_error *err)
{
    ply_reader *r = &s->r;
    r->err = err;
    *count = 0;
    while (s->elem < r->elem_count &&
           (r->elems[s->elem].kind != EK_FACE || s->chunk >= r->elems[s->elem].chunk_count)) {
        s->elem++;
        s->chunk = 0;
    }
    if (s->elem >= r->elem_count)
        return MR_OK; /* every face read */
    ply_elem *e = &r->elems[s->elem];
    ply_chunk *c = &e->chunks[s->chunk];
    const uint64_t row0 = (uint64_t)s->chunk * CHUNK_ROWS;
    const uint64_t row1 = row0 + CHUNK_ROWS < e->count ? row0 + CHUNK_ROWS : e->count;
    const uint64_t t1 = s->chunk + 1 < e->chunk_count ? e->chunks[s->chunk + 1].tri : e->tris;
    const ply_prop *ip = &r->props[e->index_prop];
    c->bad_row = UINT64_MAX;
    mr_populate_mapped(&s->file, c->off,
                       s->chunk + 1 < e->chunk_count ? e->chunks[s->chunk + 1].off : r->size);
    if (e->stride && ip->fixed_count == 3 && type_size[ip->type] == 4)
        decode_tri32_chunk(r, e, c, row0, row1, idx);
    else
        decode_fan_chunk(r, e, c, row0, row1, idx);
    if (c->bad_row != UINT64_MAX)
        return index_error(r, e, c->bad_row, c->bad_off, c->bad_value);
    *count = (size_t)(t1 - c->tri);
    s->chunk++;
    /* the chunk's bytes are read: give their pages back */
    if (s->chunk < e->chunk_count && e->chunks[s->chunk].off > s->released) {
        const size_t end = e->chunks[s->chunk].off;
        mr_release_mapped(&s->file, s->released, end);
        s->released = end;
    }
    return MR_OK;
}

mr_status mr_ply_source_next_batch(mr_ply_source *s, uint32_t *idx, size_t cap,
                                   size_t max_chunks, size_t *count, size_t *chunks,
                                   mr_error *err)
{
    ply_reader *r = &s->r;
    r->err = err;
    *count = 0;
    *chunks = 0;
    while (s->elem < r->elem_count &&
           (r->elems[s->elem].kind != EK_FACE || s->chunk >= r->elems[s->elem].chunk_count)) {
        s->elem++;
        s->chunk = 0;
    }
    if (s->elem >= r->elem_count || max_chunks == 0)
        return MR_OK; /* every face read */
    ply_elem *e = &r->elems[s->elem];
    const size_t c0 = s->chunk;
    const uint64_t tri0 = e->chunks[c0].tri;
    size_t c1 = c0;
    while (c1 < e->chunk_count && c1 - c0 < max_chunks) {
        const uint64_t t1 = c1 + 1 < e->chunk_count ? e->chunks[c1 + 1].tri : e->tris;
        if (c1 > c0 && t1 - tri0 > cap)
            break;
        c1++;
    }
    const uint64_t tri1 = c1 < e->chunk_count ? e->chunks[c1].tri : e->tris;
    const ply_prop *ip = &r->props[e->index_prop];
    const bool tri32 = e->stride && ip->fixed_count == 3 && type_size[ip->type] == 4;
    mr_populate_mapped(&s->file, e->chunks[c0].off,
                       c1 < e->chunk_count ? e->chunks[c1].off : r->size);
    const ptrdiff_t n = (ptrdiff_t)(c1 - c0);
#pragma omp parallel for schedule(dynamic, 1) num_threads(r->threads) if (n > 1)
    for (ptrdiff_t k = 0; k < n; k++) {
        const size_t ck = c0 + (size_t)k;
        ply_chunk *c = &e->chunks[ck];
        const uint64_t row0 = (uint64_t)ck * CHUNK_ROWS;
        const uint64_t row1 = row0 + CHUNK_ROWS < e->count ? row0 + CHUNK_ROWS : e->count;
        c->bad_row = UINT64_MAX;
        uint32_t *out = idx + 3 * (size_t)(c->tri - tri0);
        if (tri32)
            decode_tri32_chunk(r, e, c, row0, row1, out);
        else
            decode_fan_chunk(r, e, c, row0, row1, out);
    }
    for (size_t k = c0; k < c1; k++)
        if (e->chunks[k].bad_row != UINT64_MAX)
            return index_error(r, e, e->chunks[k].bad_row, e->chunks[k].bad_off,
                               e->chunks[k].bad_value);
    *count = (size_t)(tri1 - tri0);
    *chunks = c1 - c0;
    s->chunk = c1;
    /* the chunks' bytes are read: give their pages back */
    if (s->chunk < e->chunk_count && e->chunks[s->chunk].off > s->released) {
        const size_t end = e->chunks[s->chunk].off;
        mr_release_mapped(&s->file, s->released, end);
        s->released = end;
    }
    return MR_OK;
}

void mr_ply_source_release(mr_ply_source *s) { mr_release_mapped(&s->file, 0, s->file.size); }

void mr_ply_source_rewind(mr_ply_source *s)
{
    s->elem = 0;
    s->chunk = 0;
    s->released = 0;
}

size_t mr_ply_source_face_chunks(const mr_ply_source *s)
{
    size_t n = 0;
    for (size_t i = 0; i < s->r.elem_count; i++)
        if (s->r.elems[i].kind == EK_FACE)
            n += s->r.elems[i].chunk_count;
    return n;
}

void mr_ply_source_seek(mr_ply_source *s, size_t k)
{
    s->elem = 0;
    s->chunk = 0;
    s->released = 0;
    for (size_t i = 0; i < s->r.elem_count; i++) {
        const ply_elem *e = &s->r.elems[i];
        if (e->kind != EK_FACE)
            continue;
        if (k < e->chunk_count) {
            s->elem = i;
            s->chunk = k;
            s->released = e->chunks[k].off;
            return;
        }
        k -= e->chunk_count;
    }
    s->elem = s->r.elem_count; /* past the last: no faces */
}

void mr_ply_source_prefetch(const mr_ply_source *s, uint32_t first, uint32_t last)
{
    const ply_elem *e = s->r.vertex;
    mr_populate_mapped(&s->file, e->start + (size_t)first * (size_t)e->row_size,
                       e->start + ((size_t)last + 1) * (size_t)e->row_size);
}

/* ------------------------------------------------------------------------ */
/* Writer                                                                   */
/* ------------------------------------------------------------------------ */

typedef mr_ply_writer ply_writer;

/* Rows are encoded into blocks of about BLOCK_BYTES, then written in
 * order. Ascii formatting is the slow part of writing: its blocks are
 * formatted a batch at a time in parallel, which does not change the
 * output. */
enum { BLOCK_BYTES = 1 << 20 };

typedef size_t (*encode_fn)(const ply_writer *w, size_t begin, size_t end, char *out);

static unsigned char color_byte(float c)
{
    float v = c * 255.0f;
    if (!(v > 0.0f)) /* also NaN */
        return 0;
    if (v >= 255.0f)
        return 255;
    return (unsigned char)(v + 0.5f);
}

static size_t put_f32(char *out, float v, bool swap)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    if (swap)
        u = mr_bswap32(u);
    memcpy(out, &u, 4);
    return 4;
}

static size_t put_uint(char *out, uint32_t v)
{
    return (size_t)mr_format_u64(out, v);
}

/* Floats of one vertex in file order (x y z [nx ny nz] [s t]). */
static int vertex_floats(const ply_writer *w, size_t i, float *f)
{
    const mr_mesh *m = w->mesh;
    int n = 0;
    for (int k = 0; k < 3; k++)
        f[n++] = m->positions[3 * i + k];
    if (w->normals)
        for (int k = 0; k < 3; k++)
            f[n++] = m->normals[3 * i + k];
    if (w->texcoords)
        for (int k = 0; k < 2; k++)
            f[n++] = m->texcoords[2 * i + k];
    return n;
}

static size_t encode_vertices(const ply_writer *w, size_t begin, size_t end, char *out)
{
    char *o = out;
    for (size_t i = begin; i < end; i++) {
        float f[8];
        int nf = vertex_floats(w, i, f);
        for (int k = 0; k < nf; k++) {
            if (!w->ascii) {
                o += put_f32(o, f[k], w->swap);
                continue;
            }
            if (k)
                *o++ = ' ';
            o += mr_format_float(o, f[k]);
        }
        if (w->colors)
            for (int k = 0; k < 4; k++) {
                unsigned char b = color_byte(w->mesh->colors[4 * i + k]);
                if (!w->ascii) {
                    *o++ = (char)b;
                    continue;
                }
                *o++ = ' ';
                o += put_uint(o, b);
            }
        if (w->ascii)
            *o++ = '\n';
    }
    return (size_t)(o - out);
}

static size_t encode_faces(const ply_writer *w, size_t begin, size_t end, char *out)
{
    const uint32_t *idx = w->mesh->indices;
    char *o = out;
    for (size_t t = begin; t < end; t++) {
        if (w->ascii) {
            *o++ = '3';
            for (int k = 0; k < 3; k++) {
                *o++ = ' ';
                o += put_uint(o, idx[3 * t + k]);
            }
            *o++ = '\n';
            continue;
        }
        *o++ = 3;
        for (int k = 0; k < 3; k++) {
            uint32_t v = w->swap ? mr_bswap32(idx[3 * t + k]) : idx[3 * t + k];
            memcpy(o, &v, 4);
            o += 4;
        }
    }
    return (size_t)(o - out);
}

static mr_status write_rows(FILE *f, const ply_writer *w, size_t rows, size_t max_row,
                            encode_fn encode, const char *name, mr_error *err)
{
    if (rows == 0)
        return MR_OK;
    const size_t block_rows = BLOCK_BYTES / max_row ? BLOCK_BYTES / max_row : 1;
    const size_t block_cap = block_rows * max_row;
    size_t nblocks = (rows + block_rows - 1) / block_rows;
    int threads = mr_thread_count(0);
    size_t batch = (size_t)threads < nblocks ? (size_t)threads : nblocks;
    char *buf = mr_alloc_array(batch, block_cap);
    size_t *len = mr_alloc_array(batch, sizeof *len);
    if (!buf || !len) {
        free(buf);
        free(len);
        return mr_fail_nomem(err, name, batch * block_cap);
    }
    mr_status st = MR_OK;
    for (size_t first = 0; first < nblocks && st == MR_OK; first += batch) {
        int64_t nb = (int64_t)(nblocks - first < batch ? nblocks - first : batch);
        /* binary rows are a copy, faster than waking threads for */
#pragma omp parallel for schedule(static) num_threads(threads) if (nb > 1 && w->ascii)
        for (int64_t b = 0; b < nb; b++) {
            size_t r0 = (first + (size_t)b) * block_rows;
            size_t r1 = r0 + block_rows < rows ? r0 + block_rows : rows;
            len[b] = encode(w, r0, r1, buf + (size_t)b * block_cap);
        }
        for (int64_t b = 0; b < nb && st == MR_OK; b++)
            if (fwrite(buf + (size_t)b * block_cap, 1, len[b], f) != len[b])
                st = mr_fail_write(err, name, errno);
    }
    free(buf);
    free(len);
    return st;
}

/* The writer's settings for a mesh of these attributes (mesh: the arrays
 * the rows come from, set per block when streaming). */
static mr_status writer_init(ply_writer *w, unsigned attributes,
                             const mr_write_options *options, const char *name,
                             const char **format, mr_error *err)
{
    memset(w, 0, sizeof *w);
    switch (options->encoding) {
    case MR_ENCODING_ASCII:
        w->ascii = true;
        *format = "ascii";
        break;
    case MR_ENCODING_DEFAULT:
    case MR_ENCODING_BINARY_LE:
        w->swap = !mr_host_is_little_endian();
        *format = "binary_little_endian";
        break;
    case MR_ENCODING_BINARY_BE:
        w->swap = mr_host_is_little_endian();
        *format = "binary_big_endian";
        break;
    default:
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, name, "unknown PLY encoding %d",
                             (int)options->encoding);
    }
    w->normals = options->write_normals && (attributes & MR_ATTR_NORMALS);
    w->texcoords = options->write_texcoords && (attributes & MR_ATTR_TEXCOORDS);
    w->colors = options->write_colors && (attributes & MR_ATTR_COLORS);
    return MR_OK;
}

static mr_status write_header(FILE *f, const ply_writer *w, const char *format,
                              size_t vertex_count, size_t triangle_count, const char *name,
                              mr_error *err)
{
    fprintf(f, "ply\nformat %s 1.0\ncomment generated by meshreduce\n", format);
    fprintf(f, "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n",
            vertex_count);
    if (w->normals)
        fputs("property float nx\nproperty float ny\nproperty float nz\n", f);
    if (w->texcoords)
        fputs("property float s\nproperty float t\n", f);
    if (w->colors)
        fputs("property uchar red\nproperty uchar green\nproperty uchar blue\n"
              "property uchar alpha\n",
              f);
    if (triangle_count)
        /* int indices, as most readers expect; uint only when int cannot
         * hold them */
        fprintf(f, "element face %zu\nproperty list uchar %s vertex_indices\n",
                triangle_count, vertex_count > (size_t)INT32_MAX + 1 ? "uint" : "int");
    if (fputs("end_header\n", f) < 0 || ferror(f))
        return mr_fail_write(err, name, errno);
    return MR_OK;
}

/* ascii: up to 8 floats of at most 32 characters (with the separator) and
 * 4 color values of at most 4 */
static size_t vertex_row_bytes(const ply_writer *w)
{
    return w->ascii ? 8 * 32 + 4 * 4 + 2 : 8 * 4 + 4;
}

static size_t face_row_bytes(const ply_writer *w) { return w->ascii ? 1 + 3 * 11 + 1 : 13; }

mr_status mr_write_ply(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err)
{
    ply_writer w;
    const char *format = NULL;
    mr_status st = writer_init(&w, mr_mesh_attributes(mesh), options, name, &format, err);
    if (st == MR_OK)
        st = write_header(f, &w, format, mesh->vertex_count, mesh->triangle_count, name, err);
    w.mesh = mesh;
    if (st == MR_OK)
        st = write_rows(f, &w, mesh->vertex_count, vertex_row_bytes(&w), encode_vertices, name,
                        err);
    if (st == MR_OK)
        st = write_rows(f, &w, mesh->triangle_count, face_row_bytes(&w), encode_faces, name,
                        err);
    return st;
}

/* ---- streaming ----------------------------------------------------------- */

mr_status mr_ply_stream_begin(mr_ply_stream *s, FILE *f, size_t vertex_count,
                              size_t triangle_count, unsigned attributes,
                              const mr_write_options *options, const char *name, mr_error *err)
{
    memset(s, 0, sizeof *s);
    s->f = f;
    s->name = name;
    s->vertex_count = vertex_count;
    s->triangle_count = triangle_count;
    const char *format = NULL;
    mr_status st = writer_init(&s->w, attributes, options, name, &format, err);
    if (st == MR_OK)
        st = write_header(f, &s->w, format, vertex_count, triangle_count, name, err);
    return st;
}

mr_status mr_ply_stream_vertices(mr_ply_stream *s, const mr_mesh *block, mr_error *err)
{
    if (s->vertices_written + block->vertex_count > s->vertex_count ||
        s->triangles_written)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, s->name,
                             "streamed vertices past the header's %zu, or after faces",
                             s->vertex_count);
    s->w.mesh = block;
    s->vertices_written += block->vertex_count;
    return write_rows(s->f, &s->w, block->vertex_count, vertex_row_bytes(&s->w),
                      encode_vertices, s->name, err);
}

mr_status mr_ply_stream_faces(mr_ply_stream *s, const uint32_t *indices, size_t count,
                              mr_error *err)
{
    if (s->vertices_written != s->vertex_count ||
        s->triangles_written + count > s->triangle_count)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, s->name,
                             "streamed faces before every vertex or past the header's %zu",
                             s->triangle_count);
    const mr_mesh view = {.triangle_count = count, .indices = (uint32_t *)indices};
    s->w.mesh = &view;
    s->triangles_written += count;
    mr_status st = write_rows(s->f, &s->w, count, face_row_bytes(&s->w), encode_faces,
                              s->name, err);
    s->w.mesh = NULL;
    return st;
}

mr_status mr_ply_stream_end(mr_ply_stream *s, mr_error *err)
{
    if (s->vertices_written != s->vertex_count || s->triangles_written != s->triangle_count)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, s->name,
                             "streamed %zu of %zu vertices and %zu of %zu faces",
                             s->vertices_written, s->vertex_count, s->triangles_written,
                             s->triangle_count);
    return MR_OK;
}
