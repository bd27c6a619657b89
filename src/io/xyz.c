/*
 * XYZ: a plain text point cloud, one point per line.
 *
 * The rule, kept deliberately simple so that a file means one thing:
 *   - blank lines and lines whose first non-blank character is '#' are
 *     skipped; a '#' after the numbers starts a trailing comment;
 *   - columns are separated by blanks, or by one ',' or ';' (with optional
 *     blanks around it), so CSV-like exports read too;
 *   - 3 columns are "x y z"; 6 columns are "x y z nx ny nz" (normals, as in
 *     Open3D's xyzn). Any other count -- including the "x y z r g b" colour
 *     layout some tools write, which cannot be told apart from normals by
 *     its values -- is an error naming the line and the count;
 *   - every data line has the same number of columns as the first one;
 *   - every value must be a finite float.
 * The result is a point cloud (triangle_count 0).
 *
 * Reading is two passes over whole-line chunks of the text, in parallel:
 * count the data lines of each chunk, allocate the exact arrays, then parse
 * each chunk into its slice. The first error in file order is reported, so
 * the outcome does not depend on the thread count.
 */
#include "io_internal.h"
#include "text.h"

#include <math.h>

enum {
    XYZ_MAX_COLUMNS = 6,             /* columns kept; more are counted only */
    XYZ_MIN_CHUNK = 1 << 20,         /* bytes per chunk worth a thread */
    XYZ_CHUNKS_PER_THREAD = 4        /* for balance: lines differ in length */
};

/* What every chunk needs to know. */
typedef struct xyz_context {
    const char *begin;  /* the whole buffer, for line numbers */
    const char *name;
    int columns;        /* 3 or 6, from the first data line */
    uint64_t first_line; /* line number of the first data line */
    mr_mesh *mesh;
} xyz_context;

typedef struct xyz_chunk {
    const char *from, *to; /* whole lines */
    size_t points;         /* data lines, counted in the first pass */
    size_t first;          /* index of the chunk's first point */
    mr_status status;
    mr_error err;
} xyz_chunk;

static const char *line_end(const char *p, const char *end)
{
    const char *nl = memchr(p, '\n', (size_t)(end - p));
    return nl ? nl : end;
}

/* Start of the line after the one ending at eol (or end). */
static const char *next_line(const char *eol, const char *end)
{
    return eol < end ? eol + 1 : end;
}

/* A line holding something other than blanks and a comment. */
static bool is_data_line(const char *p, const char *eol)
{
    mr_skip_blanks(&p, eol);
    return p < eol && *p != '#';
}

static bool at_field_end(const char *p, const char *eol)
{
    return p >= eol || mr_is_space(*p) || *p == ',' || *p == ';' || *p == '#';
}

static const char *field_end(const char *p, const char *eol)
{
    while (!at_field_end(p, eol))
        p++;
    return p;
}

static mr_status bad_number(const xyz_context *ctx, const char *at, const char *eol,
                            mr_error *err)
{
    uint64_t line = mr_line_of(ctx->begin, at);
    if (at >= eol || *at == '#')
        return mr_fail(err, MR_ERR_PARSE, ctx->name, line, MR_NO_POSITION,
                       "expected a number, found end of line");
    char tok[32];
    mr_token_excerpt(at, eol, tok, sizeof tok);
    return mr_fail(err, MR_ERR_PARSE, ctx->name, line, MR_NO_POSITION,
                   "expected a number, found '%s'", tok);
}

/*
 * Parse the data line [p, eol): store up to XYZ_MAX_COLUMNS values in v and
 * the number of columns in *columns. Reports a malformed or non-finite
 * value with its line.
 */
static mr_status parse_line(const xyz_context *ctx, const char *p, const char *eol,
                            float v[XYZ_MAX_COLUMNS], size_t *columns, mr_error *err)
{
    size_t n = 0;
    for (;;) {
        mr_skip_blanks(&p, eol);
        const char *start = p;
        float f; /* a finite double beyond float range becomes infinite */
        bool ok = mr_parse_float(&p, eol, &f);
        /* The strtod path refuses tokens of 127+ characters, which a long
         * number followed by comma-separated fields without blanks can
         * make: try again with the number bounded by its field. */
        if (!ok)
            ok = mr_parse_float(&p, field_end(p, eol), &f);
        if (!ok || !at_field_end(p, eol))
            return bad_number(ctx, start, eol, err);
        if (!isfinite(f)) {
            char tok[80];
            if (mr_number_too_large(start, eol, false)) {
                mr_number_excerpt(start, eol, tok, sizeof tok);
                return mr_fail(err, MR_ERR_PARSE, ctx->name, mr_line_of(ctx->begin, start),
                               MR_NO_POSITION, "value %s is out of range", tok);
            }
            mr_token_excerpt(start, eol, tok, sizeof tok);
            return mr_fail(err, MR_ERR_PARSE, ctx->name, mr_line_of(ctx->begin, start),
                           MR_NO_POSITION, "value '%s' is not a finite float", tok);
        }
        if (n < XYZ_MAX_COLUMNS)
            v[n] = f;
        n++;
        mr_skip_blanks(&p, eol);
        if (p >= eol || *p == '#')
            break;
        if (*p == ',' || *p == ';')
            p++; /* a number must follow: checked by the next iteration */
    }
    *columns = n;
    return MR_OK;
}

static mr_status column_count_error(const xyz_context *ctx, const char *line, size_t columns,
                                    mr_error *err)
{
    return mr_fail(err, MR_ERR_PARSE, ctx->name, mr_line_of(ctx->begin, line),
                   MR_NO_POSITION,
                   "found %zu column%s; an XYZ line holds 3 (x y z) or 6 "
                   "(x y z nx ny nz)",
                   columns, columns == 1 ? "" : "s");
}

/* Count the data lines of a chunk (first pass). */
static void count_chunk(xyz_chunk *c)
{
    size_t n = 0;
    for (const char *p = c->from; p < c->to;) {
        const char *eol = line_end(p, c->to);
        n += is_data_line(p, eol);
        p = next_line(eol, c->to);
    }
    c->points = n;
}

/* Parse a chunk's lines into its slice of the mesh (second pass). */
static void parse_chunk(const xyz_context *ctx, xyz_chunk *c)
{
    mr_mesh *m = ctx->mesh;
    size_t i = c->first;
    c->status = MR_OK;
    for (const char *p = c->from; p < c->to;) {
        const char *eol = line_end(p, c->to);
        if (is_data_line(p, eol)) {
            float v[XYZ_MAX_COLUMNS];
            size_t columns;
            c->status = parse_line(ctx, p, eol, v, &columns, &c->err);
            if (c->status == MR_OK && columns != (size_t)ctx->columns)
                c->status = mr_fail(&c->err, MR_ERR_PARSE, ctx->name,
                                    mr_line_of(ctx->begin, p), MR_NO_POSITION,
                                    "found %zu columns, but line %llu has %d; every line "
                                    "must have the same columns",
                                    columns, (unsigned long long)ctx->first_line,
                                    ctx->columns);
            if (c->status != MR_OK)
                return;
            memcpy(m->positions + 3 * i, v, 3 * sizeof(float));
            if (m->normals)
                memcpy(m->normals + 3 * i, v + 3, 3 * sizeof(float));
            i++;
        }
        p = next_line(eol, c->to);
    }
}

/* Find the first data line and take its column count as the file's. */
static mr_status read_layout(xyz_context *ctx, const char *end, mr_error *err)
{
    for (const char *p = ctx->begin; p < end;) {
        const char *eol = line_end(p, end);
        if (is_data_line(p, eol)) {
            float v[XYZ_MAX_COLUMNS];
            size_t columns;
            mr_status st = parse_line(ctx, p, eol, v, &columns, err);
            if (st != MR_OK)
                return st;
            if (columns != 3 && columns != 6)
                return column_count_error(ctx, p, columns, err);
            ctx->columns = (int)columns;
            ctx->first_line = mr_line_of(ctx->begin, p);
            return MR_OK;
        }
        p = next_line(eol, end);
    }
    return mr_fail_plain(err, MR_ERR_EMPTY, ctx->name, "XYZ file holds no points");
}

/* Split [data, data + size) into n chunks of whole lines. */
static void split_chunks(const char *data, size_t size, xyz_chunk *chunks, size_t n)
{
    const char *end = data + size, *prev = data;
    for (size_t i = 0; i < n; i++) {
        const char *to = i + 1 == n ? end : data + (size / n) * (i + 1);
        if (to < prev)
            to = prev;
        if (to > prev && to < end && to[-1] != '\n') { /* move past the newline */
            const char *nl = memchr(to, '\n', (size_t)(end - to));
            to = nl ? nl + 1 : end;
        }
        chunks[i].from = prev;
        chunks[i].to = to;
        prev = to;
    }
}

mr_status mr_read_xyz(const char *data, size_t size, const char *name, int threads,
                      mr_mesh *mesh, mr_error *err)
{
    xyz_context ctx = {data, name, 0, 0, mesh};
    mr_status st = read_layout(&ctx, data + size, err);
    if (st != MR_OK)
        return st;

    size_t n = 1;
    if (threads > 1 && size >= 2 * (size_t)XYZ_MIN_CHUNK) {
        n = (size_t)threads * XYZ_CHUNKS_PER_THREAD;
        if (n > size / XYZ_MIN_CHUNK)
            n = size / XYZ_MIN_CHUNK;
    }
    xyz_chunk *chunks = mr_calloc_array(n, sizeof *chunks);
    if (!chunks)
        return mr_fail_nomem(err, name, n * sizeof *chunks);
    split_chunks(data, size, chunks, n);

    int nc = (int)n;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) if (nc > 1)
    for (int i = 0; i < nc; i++)
        count_chunk(&chunks[i]);

    size_t points = 0;
    for (size_t i = 0; i < n; i++) {
        chunks[i].first = points;
        points += chunks[i].points;
    }
    st = mr_mesh_alloc(mesh, points, 0, ctx.columns == 6 ? MR_ATTR_NORMALS : 0u, NULL);
    if (st != MR_OK) {
        free(chunks);
        return st == MR_ERR_TOO_LARGE
                   ? mr_fail_plain(err, st, name,
                                   "%zu points exceed the 32-bit index limit", points)
                   : mr_fail_nomem(err, name, points * (ctx.columns == 6 ? 24 : 12));
    }

#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) if (nc > 1)
    for (int i = 0; i < nc; i++)
        parse_chunk(&ctx, &chunks[i]);

    /* The first failing chunk holds the first error in file order. */
    for (size_t i = 0; i < n && st == MR_OK; i++)
        if (chunks[i].status != MR_OK) {
            st = chunks[i].status;
            if (err)
                *err = chunks[i].err;
        }
    free(chunks);
    return st;
}

/*
 * Writer: "x y z" per vertex, or "x y z nx ny nz" when the mesh has normals
 * and options->write_normals is set, with the shortest numbers that read
 * back bit-exactly. XYZ is a point format: a mesh's triangles (and its
 * texture coordinates and colours) are not written, which is the point of
 * choosing it, so this is not an error.
 */
mr_status mr_write_xyz(FILE *f, const mr_mesh *mesh, const mr_write_options *options,
                       const char *name, mr_error *err)
{
    bool normals = mesh->normals && (!options || options->write_normals);
    int values = normals ? 6 : 3;
    for (size_t i = 0; i < mesh->vertex_count; i++) {
        char buf[6 * 32 + 2];
        char *o = buf;
        for (int j = 0; j < values; j++) {
            const float *src = j < 3 ? mesh->positions + 3 * i : mesh->normals + 3 * i;
            if (j)
                *o++ = ' ';
            o += mr_format_float(o, src[j % 3]);
        }
        *o++ = '\n';
        size_t len = (size_t)(o - buf);
        if (fwrite(buf, 1, len, f) != len)
            return mr_fail_write(err, name, errno);
    }
    return MR_OK;
}
