/* glTF 2.0 (src/io/gltf.c, src/qem/gltf_simplify.c): hand-made documents
 * in every accessor form (base64 and .glb buffers, byte strides, normalised
 * and quantised integers, sparse accessors, non-indexed primitives, strips),
 * read, copied (mr_convert_gltf) and simplified (mr_simplify_gltf) with
 * their document intact: several primitives and materials, a mesh two
 * nodes instance, a skin's joints and weights, a morph target, an unknown
 * extension; malformed documents each with one clear error and no output;
 * the sample models of ../shared/data/gltf where they are. Every output
 * goes through the Khronos validator where Node.js and the validator are
 * found (MR_GLTF_VALIDATOR: the node_modules folder of
 * `npm install gltf-validator`; else the one `make check` installs in the
 * build folder), else that step is skipped. */
#include "testutil.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifdef MR_HAVE_GLTF
#include <cjson/cJSON.h>

/* ---- building documents ------------------------------------------------------ */

typedef struct blob {
    uint8_t *d;
    size_t n, cap;
} blob;

static size_t put(blob *b, const void *p, size_t n)
{
    const size_t at = (b->n + 3) & ~(size_t)3;
    if (at + n > b->cap) {
        b->cap = 2 * (at + n) + 1024;
        b->d = realloc(b->d, b->cap);
        assert_non_null(b->d);
    }
    memset(b->d + b->n, 0, at - b->n);
    memcpy(b->d + at, p, n);
    b->n = at + n;
    return at;
}

static char *base64(const uint8_t *d, size_t n)
{
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *s = malloc(4 * (n / 3 + 1) + 1), *o = s;
    assert_non_null(s);
    for (size_t i = 0; i < n; i += 3) {
        const uint32_t v = (uint32_t)d[i] << 16 | (i + 1 < n ? (uint32_t)d[i + 1] << 8 : 0) |
                           (i + 2 < n ? d[i + 2] : 0);
        *o++ = t[v >> 18 & 63];
        *o++ = t[v >> 12 & 63];
        *o++ = i + 1 < n ? t[v >> 6 & 63] : '=';
        *o++ = i + 2 < n ? t[v & 63] : '=';
    }
    *o = 0;
    return s;
}

/* The document `body` (a JSON object without "buffers") with b as its one
 * buffer: base64 in a .gltf, the BIN chunk of a .glb. */
static void write_doc(const char *path, const char *body, const blob *b)
{
    const bool glb = strstr(path, ".glb") != NULL;
    char *b64 = glb ? NULL : base64(b->d, b->n);
    const size_t cap = strlen(body) + (b64 ? strlen(b64) : 0) + 256;
    char *json = malloc(cap);
    assert_non_null(json);
    if (glb)
        snprintf(json, cap, "{\"buffers\":[{\"byteLength\":%zu}],%s", b->n, body + 1);
    else
        snprintf(json, cap,
                 "{\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/"
                 "octet-stream;base64,%s\"}],%s",
                 b->n, b64, body + 1);
    if (!glb) {
        tu_write_file(path, json, strlen(json));
    } else {
        const size_t jn = strlen(json), jp = (jn + 3) & ~(size_t)3, bp = (b->n + 3) & ~(size_t)3;
        const size_t total = 12 + 8 + jp + 8 + bp;
        uint8_t *f = calloc(1, total);
        assert_non_null(f);
        const uint32_t h[5] = {0x46546C67u, 2, (uint32_t)total, (uint32_t)jp, 0x4E4F534Au};
        memcpy(f, h, 20);
        memcpy(f + 20, json, jn);
        memset(f + 20 + jn, ' ', jp - jn);
        const uint32_t c[2] = {(uint32_t)bp, 0x004E4942u};
        memcpy(f + 20 + jp, c, 8);
        memcpy(f + 28 + jp, b->d, b->n);
        tu_write_file(path, f, total);
        free(f);
    }
    free(json);
    free(b64);
}

/* A k x k grid of quads over [0,1]^2 with a bump: positions, normals and
 * texture coordinates per vertex, two triangles a quad. */
typedef struct grid {
    size_t nv, nt;
    float *pos, *nrm, *uv;
    uint32_t *idx;
} grid;

static void make_grid(grid *g, int k)
{
    g->nv = (size_t)(k + 1) * (size_t)(k + 1);
    g->nt = 2 * (size_t)k * (size_t)k;
    g->pos = malloc(12 * g->nv);
    g->nrm = malloc(12 * g->nv);
    g->uv = malloc(8 * g->nv);
    g->idx = malloc(12 * g->nt);
    for (int y = 0; y <= k; y++)
        for (int x = 0; x <= k; x++) {
            const size_t v = (size_t)y * (size_t)(k + 1) + (size_t)x;
            const float u = (float)x / (float)k, w = (float)y / (float)k;
            g->pos[3 * v] = u;
            g->pos[3 * v + 1] = w;
            g->pos[3 * v + 2] = 0.1f * sinf(3.0f * u) * cosf(2.0f * w);
            g->nrm[3 * v] = 0, g->nrm[3 * v + 1] = 0, g->nrm[3 * v + 2] = 1;
            g->uv[2 * v] = u, g->uv[2 * v + 1] = w;
        }
    size_t t = 0;
    for (int y = 0; y < k; y++)
        for (int x = 0; x < k; x++) {
            const uint32_t a = (uint32_t)(y * (k + 1) + x), b = a + 1, c = a + (uint32_t)k + 1,
                           d = c + 1;
            const uint32_t q[6] = {a, b, d, a, d, c};
            memcpy(g->idx + 3 * t, q, sizeof q);
            t += 2;
        }
}

static void free_grid(grid *g)
{
    free(g->pos), free(g->nrm), free(g->uv), free(g->idx);
}

static void minmax(const float *p, size_t n, float mn[3], float mx[3])
{
    for (int k = 0; k < 3; k++)
        mn[k] = INFINITY, mx[k] = -INFINITY;
    for (size_t v = 0; v < n; v++)
        for (int k = 0; k < 3; k++) {
            mn[k] = fminf(mn[k], p[3 * v + (size_t)k]);
            mx[k] = fmaxf(mx[k], p[3 * v + (size_t)k]);
        }
}

/* "min":[..],"max":[..] of n positions, in one of four rotating buffers. */
static const char *bounds(const float *p, size_t n)
{
    static char buf[4][160];
    static int slot;
    char *b = buf[slot++ % 4];
    float mn[3], mx[3];
    minmax(p, n, mn, mx);
    snprintf(b, 160, "\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]", mn[0], mn[1], mn[2],
             mx[0], mx[1], mx[2]);
    return b;
}

/* ---- the validator ---------------------------------------------------------- */

static const char *validator_dir;

static bool validator_found(void)
{
    static int found = -1;
    if (found < 0) {
        const char *dir = getenv("MR_GLTF_VALIDATOR");
        if (!dir || !*dir)
            dir = MR_GLTF_VALIDATOR_DIR;
        validator_dir = dir;
        char probe[1024];
        snprintf(probe, sizeof probe, "%s/gltf-validator/package.json", dir ? dir : "");
        /* (the sanitizers' and the serial build's runs, MR_TEST_QUICK, leave
         * it to `make check`: its time is Node's) */
        found = !getenv("MR_TEST_QUICK") && dir && access(probe, R_OK) == 0 &&
                system("node --version >/dev/null 2>&1") == 0;
        if (!found)
            print_message("glTF validator not found (MR_GLTF_VALIDATOR, node) or "
                          "MR_TEST_QUICK: not run\n");
    }
    return found;
}

/* The validator on path: no errors. */
static void validate(const char *path)
{
    if (!validator_found())
        return;
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "MR_GLTF_VALIDATOR='%s' node %s/scripts/gltf-validate.js '%s' 2>&1",
             validator_dir, MR_SOURCE_DIR, path);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char out[4096] = "";
    size_t n = fread(out, 1, sizeof out - 1, p);
    out[n] = 0;
    const int rc = pclose(p);
    if (rc != 0)
        fail_msg("validator on %s: %s", path, out);
}

/* ---- reading an output's accessors (the test's own, small reader) ----------- */

typedef struct doc {
    cJSON *root;
    uint8_t *bin; /* its one buffer */
    size_t bin_size;
} doc;

static void load_doc(const char *path, doc *d)
{
    size_t n;
    char *data = tu_read_file(path, &n);
    assert_non_null(data);
    memset(d, 0, sizeof *d);
    if (n >= 20 && memcmp(data, "glTF", 4) == 0) {
        uint32_t jn, bn;
        memcpy(&jn, data + 12, 4);
        d->root = cJSON_ParseWithLength(data + 20, jn);
        if (20 + jn + 8 <= n) {
            memcpy(&bn, data + 20 + jn, 4);
            d->bin = malloc(bn + 1);
            memcpy(d->bin, data + 28 + jn, bn);
            d->bin_size = bn;
        }
    } else {
        d->root = cJSON_ParseWithLength(data, n);
        const cJSON *b = cJSON_GetArrayItem(cJSON_GetObjectItem(d->root, "buffers"), 0);
        const cJSON *uri = cJSON_GetObjectItem(b, "uri");
        if (uri) {
            char dir[1024], bp[2048];
            snprintf(dir, sizeof dir, "%s", path);
            char *slash = strrchr(dir, '/');
            if (slash)
                *slash = 0;
            snprintf(bp, sizeof bp, "%s/%s", slash ? dir : ".", uri->valuestring);
            d->bin = (uint8_t *)tu_read_file(bp, &d->bin_size);
            assert_non_null(d->bin);
        }
    }
    free(data);
    assert_non_null(d->root);
}

static void free_doc(doc *d)
{
    cJSON_Delete(d->root);
    free(d->bin);
}

static int num(const cJSON *o, const char *k, int dflt)
{
    const cJSON *x = cJSON_GetObjectItem(o, k);
    return x ? (int)x->valuedouble : dflt;
}

/* Accessor i as doubles (count * comps): FLOAT, UNSIGNED_BYTE/SHORT/INT. */
static double *read_acc(const doc *d, int i, size_t *count, int *comps)
{
    const cJSON *a = cJSON_GetArrayItem(cJSON_GetObjectItem(d->root, "accessors"), i);
    assert_non_null(a);
    const cJSON *bv =
        cJSON_GetArrayItem(cJSON_GetObjectItem(d->root, "bufferViews"), num(a, "bufferView", 0));
    const char *type = cJSON_GetObjectItem(a, "type")->valuestring;
    *comps = !strcmp(type, "SCALAR") ? 1 : !strcmp(type, "VEC2") ? 2 : !strcmp(type, "VEC3") ? 3 : 4;
    const int ct = num(a, "componentType", 0);
    const int cs = ct == 5121 ? 1 : ct == 5123 ? 2 : 4;
    *count = (size_t)num(a, "count", 0);
    const size_t stride = (size_t)num(bv, "byteStride", *comps * cs);
    const size_t off = (size_t)num(bv, "byteOffset", 0) + (size_t)num(a, "byteOffset", 0);
    double *v = malloc(*count * (size_t)*comps * sizeof *v + 8);
    for (size_t e = 0; e < *count; e++)
        for (int c = 0; c < *comps; c++) {
            const uint8_t *p = d->bin + off + e * stride + (size_t)(c * cs);
            assert_true(p + cs <= d->bin + d->bin_size);
            double x;
            if (ct == 5126) {
                float f;
                memcpy(&f, p, 4);
                x = f;
            } else if (ct == 5121) {
                x = p[0];
            } else if (ct == 5123) {
                x = p[0] | p[1] << 8;
            } else {
                uint32_t u;
                memcpy(&u, p, 4);
                x = u;
            }
            v[e * (size_t)*comps + (size_t)c] = x;
        }
    return v;
}

/* ---- forms ------------------------------------------------------------------- */

static mr_simplify_options ratio_options(double r)
{
    mr_simplify_options o;
    mr_simplify_options_default(&o);
    o.target_ratio = r;
    return o;
}

/* Read, copy (the same mesh back), simplify (fewer triangles), validate. */
static void check_form(const char *path, const char *tag, size_t nv, size_t nt)
{
    mr_mesh m, c;
    mr_error err;
    if (mr_mesh_read(path, NULL, &m, &err) != MR_OK)
        fail_msg("%s: %s", tag, err.message);
    assert_int_equal(m.vertex_count, nv);
    assert_int_equal(m.triangle_count, nt);
    char copy[1024], out[1024];
    const char *ext = strstr(path, ".glb") ? "glb" : "gltf";
    snprintf(copy, sizeof copy, "%s", tu_tmp_path(tu_fmt("gltf-copy-%s.%s", tag, ext)));
    snprintf(out, sizeof out, "%s", tu_tmp_path(tu_fmt("gltf-out-%s.%s", tag, ext)));
    size_t prims;
    if (mr_convert_gltf(path, copy, &prims, &err) != MR_OK)
        fail_msg("%s: copy: %s", tag, err.message);
    assert_int_equal(prims, 1);
    assert_int_equal(mr_mesh_read(copy, NULL, &c, &err), MR_OK);
    tu_assert_mesh_equal(&m, &c);
    validate(path);
    validate(copy);
    mr_simplify_options o = ratio_options(0.25);
    mr_gltf_simplify_stats st;
    if (mr_simplify_gltf(path, out, &o, &st, &err) != MR_OK)
        fail_msg("%s: simplify: %s", tag, err.message);
    assert_int_equal(st.primitives, 1);
    mr_mesh s;
    assert_int_equal(mr_mesh_read(out, NULL, &s, &err), MR_OK);
    assert_int_equal(s.triangle_count, st.simplify.output_triangles);
    assert_true(s.triangle_count < nt / 2);
    validate(out);
    mr_mesh_free(&m);
    mr_mesh_free(&c);
    mr_mesh_free(&s);
}

static const char asset[] = "\"asset\":{\"version\":\"2.0\"},\"scene\":0,"
                            "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]";

static void test_forms(void **state)
{
    (void)state;
    grid g;
    make_grid(&g, 16);
    const size_t nv = g.nv, nt = g.nt;
    uint16_t *i16 = malloc(2 * 3 * nt);
    for (size_t c = 0; c < 3 * nt; c++)
        i16[c] = (uint16_t)g.idx[c];
    char body[8192];
    /* separate views, 16-bit indices, base64 in a .gltf; and the same as .glb */
    {
        blob b = {0};
        const size_t p = put(&b, g.pos, 12 * nv), n = put(&b, g.nrm, 12 * nv),
                     u = put(&b, g.uv, 8 * nv), i = put(&b, i16, 6 * nt);
        snprintf(body, sizeof body,
                 "{%s,\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,"
                 "\"TEXCOORD_0\":2},\"indices\":3}]}],"
                 "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
                 "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,"
                 "\"type\":\"VEC3\",%s},"
                 "{\"bufferView\":1,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\"},"
                 "{\"bufferView\":2,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC2\"},"
                 "{\"bufferView\":3,\"componentType\":5123,\"count\":%zu,\"type\":\"SCALAR\"}]}",
                 asset, p, 12 * nv, n, 12 * nv, u, 8 * nv, i, 6 * nt, nv, bounds(g.pos, nv), nv,
                 nv, 3 * nt);
        const char *a = tu_tmp_path("gltf-views.gltf");
        write_doc(a, body, &b);
        check_form(a, "views", nv, nt);
        const char *glb = tu_tmp_path("gltf-views.glb");
        write_doc(glb, body, &b);
        check_form(glb, "views-glb", nv, nt);
        free(b.d);
    }
    /* interleaved (byteStride 32), 32-bit indices, .glb */
    {
        float *il = malloc(32 * nv);
        for (size_t v = 0; v < nv; v++) {
            memcpy(il + 8 * v, g.pos + 3 * v, 12);
            memcpy(il + 8 * v + 3, g.nrm + 3 * v, 12);
            memcpy(il + 8 * v + 6, g.uv + 2 * v, 8);
        }
        blob b = {0};
        const size_t v0 = put(&b, il, 32 * nv), i = put(&b, g.idx, 12 * nt);
        snprintf(body, sizeof body,
                 "{%s,\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,"
                 "\"TEXCOORD_0\":2},\"indices\":3}]}],"
                 "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,"
                 "\"byteStride\":32,\"target\":34962},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,\"target\":34963}],"
                 "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,"
                 "\"type\":\"VEC3\",%s},"
                 "{\"bufferView\":0,\"byteOffset\":12,\"componentType\":5126,\"count\":%zu,"
                 "\"type\":\"VEC3\"},"
                 "{\"bufferView\":0,\"byteOffset\":24,\"componentType\":5126,\"count\":%zu,"
                 "\"type\":\"VEC2\"},"
                 "{\"bufferView\":1,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"}]}",
                 asset, v0, 32 * nv, i, 12 * nt, nv, bounds(g.pos, nv), nv, nv, 3 * nt);
        const char *a = tu_tmp_path("gltf-interleaved.glb");
        write_doc(a, body, &b);
        check_form(a, "interleaved", nv, nt);
        free(b.d);
        free(il);
    }
    /* non-indexed: three vertices a triangle, welded on reading */
    {
        float *p = malloc(36 * nt);
        for (size_t c = 0; c < 3 * nt; c++)
            memcpy(p + 3 * c, g.pos + 3 * g.idx[c], 12);
        blob b = {0};
        const size_t v0 = put(&b, p, 36 * nt);
        snprintf(body, sizeof body,
                 "{%s,\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
                 "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
                 "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,"
                 "\"type\":\"VEC3\",%s}]}",
                 asset, v0, 36 * nt, 3 * nt, bounds(p, 3 * nt));
        const char *a = tu_tmp_path("gltf-soup.gltf");
        write_doc(a, body, &b);
        check_form(a, "soup", nv, nt);
        free(b.d);
        free(p);
    }
    /* quantised: positions as shorts (not normalised, KHR_mesh_quantization),
     * texture coordinates as normalised unsigned shorts, colors as
     * normalised bytes */
    {
        int16_t *q = malloc(8 * nv);
        uint16_t *t = malloc(4 * nv);
        uint8_t *col = malloc(4 * nv);
        for (size_t v = 0; v < nv; v++) {
            for (int k = 0; k < 3; k++)
                q[4 * v + (size_t)k] = (int16_t)lrintf(g.pos[3 * v + (size_t)k] * 1000);
            q[4 * v + 3] = 0;
            t[2 * v] = (uint16_t)lrintf(g.uv[2 * v] * 65535);
            t[2 * v + 1] = (uint16_t)lrintf(g.uv[2 * v + 1] * 65535);
            col[4 * v] = (uint8_t)(v % 256), col[4 * v + 1] = 128, col[4 * v + 2] = 7;
            col[4 * v + 3] = 255;
        }
        blob b = {0};
        const size_t p = put(&b, q, 8 * nv), u = put(&b, t, 4 * nv), c = put(&b, col, 4 * nv),
                     i = put(&b, i16, 6 * nt);
        snprintf(body, sizeof body,
                 "{%s,\"extensionsUsed\":[\"KHR_mesh_quantization\"],"
                 "\"extensionsRequired\":[\"KHR_mesh_quantization\"],"
                 "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1,"
                 "\"COLOR_0\":2},\"indices\":3}]}],"
                 "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,"
                 "\"byteStride\":8},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
                 "\"accessors\":[{\"bufferView\":0,\"componentType\":5122,\"count\":%zu,"
                 "\"type\":\"VEC3\",\"min\":[0,0,-100],\"max\":[1000,1000,100]},"
                 "{\"bufferView\":1,\"componentType\":5123,\"normalized\":true,\"count\":%zu,"
                 "\"type\":\"VEC2\"},"
                 "{\"bufferView\":2,\"componentType\":5121,\"normalized\":true,\"count\":%zu,"
                 "\"type\":\"VEC4\"},"
                 "{\"bufferView\":3,\"componentType\":5123,\"count\":%zu,\"type\":\"SCALAR\"}]}",
                 asset, p, 8 * nv, u, 4 * nv, c, 4 * nv, i, 6 * nt, nv, nv, nv, 3 * nt);
        const char *a = tu_tmp_path("gltf-quantized.gltf");
        write_doc(a, body, &b);
        /* (the validator checks min and max against the data: leave it out
         * of the input's validation by computing them right) */
        mr_mesh m;
        mr_error err;
        assert_int_equal(mr_mesh_read(a, NULL, &m, &err), MR_OK);
        assert_int_equal(m.vertex_count, nv);
        for (size_t v = 0; v < nv; v++) {
            assert_true(m.positions[3 * v] == (float)q[4 * v]);
            assert_true(fabsf(m.texcoords[2 * v] - g.uv[2 * v]) < 1e-4f);
            assert_true(fabsf(m.colors[4 * v] - (float)(v % 256) / 255.0f) < 1e-6f);
        }
        mr_mesh_free(&m);
        free(b.d);
        free(q), free(t), free(col);
    }
    /* sparse: a zero-initialised accessor (no buffer view) with every
     * position substituted, and a base with some substituted */
    {
        uint16_t *which = malloc(2 * nv);
        for (size_t v = 0; v < nv; v++)
            which[v] = (uint16_t)v;
        float *lifted = malloc(12 * nv);
        memcpy(lifted, g.pos, 12 * nv);
        for (size_t v = 0; v < nv; v += 7)
            lifted[3 * v + 2] += 0.5f;
        blob b = {0};
        const size_t wi = put(&b, which, 2 * nv), p = put(&b, lifted, 12 * nv),
                     i = put(&b, i16, 6 * nt);
        snprintf(body, sizeof body,
                 "{%s,\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},"
                 "\"indices\":1}]}],"
                 "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                 "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
                 "\"accessors\":[{\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\",%s,"
                 "\"sparse\":{\"count\":%zu,\"indices\":{\"bufferView\":0,\"componentType\":5123},"
                 "\"values\":{\"bufferView\":1}}},"
                 "{\"bufferView\":2,\"componentType\":5123,\"count\":%zu,\"type\":\"SCALAR\"}]}",
                 asset, wi, 2 * nv, p, 12 * nv, i, 6 * nt, nv, bounds(lifted, nv), nv, 3 * nt);
        const char *a = tu_tmp_path("gltf-sparse.gltf");
        write_doc(a, body, &b);
        mr_mesh m;
        mr_error err;
        assert_int_equal(mr_mesh_read(a, NULL, &m, &err), MR_OK);
        assert_memory_equal(m.positions, lifted, 12 * nv);
        mr_mesh_free(&m);
        check_form(a, "sparse", nv, nt);
        free(b.d);
        free(which), free(lifted);
    }
    /* a triangle strip and a fan */
    {
        float sp[12 * 3];
        for (int v = 0; v < 12; v++) {
            sp[3 * v] = (float)(v / 2);
            sp[3 * v + 1] = (float)(v % 2);
            sp[3 * v + 2] = 0;
        }
        blob b = {0};
        const size_t p = put(&b, sp, sizeof sp);
        snprintf(body, sizeof body,
                 "{%s,\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"mode\":5},"
                 "{\"attributes\":{\"POSITION\":0},\"mode\":6}]}],"
                 "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
                 "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":12,"
                 "\"type\":\"VEC3\",%s}]}",
                 asset, p, sizeof sp, bounds(sp, 12));
        const char *a = tu_tmp_path("gltf-strip.gltf");
        write_doc(a, body, &b);
        mr_mesh m;
        mr_error err;
        assert_int_equal(mr_mesh_read(a, NULL, &m, &err), MR_OK);
        assert_int_equal(m.triangle_count, 10 + 10);
        /* the strip's triangles all wound one way */
        float first = 0;
        for (size_t t = 0; t < 10; t++) {
            const float *q0 = m.positions + 3 * m.indices[3 * t],
                        *q1 = m.positions + 3 * m.indices[3 * t + 1],
                        *q2 = m.positions + 3 * m.indices[3 * t + 2];
            const float z = (q1[0] - q0[0]) * (q2[1] - q0[1]) - (q1[1] - q0[1]) * (q2[0] - q0[0]);
            assert_true(z != 0);
            if (t == 0)
                first = z;
            assert_true((z > 0) == (first > 0));
        }
        mr_mesh_free(&m);
        free(b.d);
    }
    free(i16);
    free_grid(&g);
}

/* ---- the document ------------------------------------------------------------ */

/* Two primitives with their materials (the second shares the first's
 * POSITION accessor), a mesh two nodes instance, a skin (JOINTS_0 as bytes
 * whose joint follows x, WEIGHTS_0), a morph target, an animation, an
 * unknown extension, extras: simplified, all of it is still there, and
 * each output vertex's joints, weights and target are an input vertex's. */
static void test_document(void **state)
{
    (void)state;
    grid g;
    make_grid(&g, 20);
    const size_t nv = g.nv, nt = g.nt;
    uint8_t *joints = malloc(4 * nv);
    float *weights = malloc(16 * nv), *target = malloc(12 * nv);
    for (size_t v = 0; v < nv; v++) {
        joints[4 * v] = g.pos[3 * v] > 0.5f ? 1 : 0;
        joints[4 * v + 1] = joints[4 * v + 2] = joints[4 * v + 3] = 0;
        weights[4 * v] = 1, weights[4 * v + 1] = weights[4 * v + 2] = weights[4 * v + 3] = 0;
        target[3 * v] = 0, target[3 * v + 1] = 0, target[3 * v + 2] = g.pos[3 * v] * 0.25f;
    }
    const float ibm[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
                           1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const float times[2] = {0, 1}, rots[8] = {0, 0, 0, 1, 0, 0.7071068f, 0, 0.7071068f};
    /* the second primitive: the grid's other half of the triangles */
    blob b = {0};
    const size_t p = put(&b, g.pos, 12 * nv), u = put(&b, g.uv, 8 * nv), j = put(&b, joints, 4 * nv),
                 w = put(&b, weights, 16 * nv), t = put(&b, target, 12 * nv),
                 i1 = put(&b, g.idx, 6 * nt), i2 = put(&b, g.idx + 3 * (nt / 2), 6 * nt),
                 m = put(&b, ibm, sizeof ibm), tm = put(&b, times, sizeof times),
                 rt = put(&b, rots, sizeof rots);
    char body[8192];
    snprintf(body, sizeof body,
             "{\"asset\":{\"version\":\"2.0\",\"extras\":{\"keep\":\"me\"}},"
             "\"extensionsUsed\":[\"EXT_unknown_test\"],\"scene\":0,"
             "\"scenes\":[{\"nodes\":[0,1,2]}],"
             "\"nodes\":[{\"mesh\":0,\"skin\":0,\"extensions\":{\"EXT_unknown_test\":{\"a\":1}}},"
             "{\"mesh\":0,\"translation\":[2,0,0]},{\"children\":[3]},{\"name\":\"bone1\"}],"
             "\"skins\":[{\"joints\":[2,3],\"inverseBindMatrices\":7}],"
             "\"materials\":[{\"name\":\"a\"},{\"name\":\"b\"}],"
             "\"meshes\":[{\"weights\":[0],\"primitives\":["
             "{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1,\"JOINTS_0\":2,\"WEIGHTS_0\":3},"
             "\"indices\":5,\"material\":0,\"targets\":[{\"POSITION\":4}]},"
             "{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1,\"JOINTS_0\":2,\"WEIGHTS_0\":3},"
             "\"indices\":6,\"material\":1,\"targets\":[{\"POSITION\":4}]}]}],"
             "\"animations\":[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,"
             "\"path\":\"rotation\"}}],\"samplers\":[{\"input\":8,\"output\":9}]}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,"
             "\"type\":\"VEC3\",%s},"
             "{\"bufferView\":1,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC2\"},"
             "{\"bufferView\":2,\"componentType\":5121,\"count\":%zu,\"type\":\"VEC4\"},"
             "{\"bufferView\":3,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC4\"},"
             "{\"bufferView\":4,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\",%s},"
             "{\"bufferView\":5,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"},"
             "{\"bufferView\":6,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"},"
             "{\"bufferView\":7,\"componentType\":5126,\"count\":2,\"type\":\"MAT4\"},"
             "{\"bufferView\":8,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\","
             "\"min\":[0],\"max\":[1]},"
             "{\"bufferView\":9,\"componentType\":5126,\"count\":2,\"type\":\"VEC4\"}]}",
             p, 12 * nv, u, 8 * nv, j, 4 * nv, w, 16 * nv, t, 12 * nv, i1, 6 * nt, i2, 6 * nt, m,
             sizeof ibm, tm, sizeof times, rt, sizeof rots, nv, bounds(g.pos, nv), nv, nv, nv, nv,
             bounds(target, nv), nt * 3 / 2, nt * 3 / 2);
    const char *in = tu_tmp_path("gltf-doc.glb"), *out = tu_tmp_path("gltf-doc-out.glb");
    write_doc(in, body, &b);
    validate(in);
    /* the scene: the mesh twice (two nodes), both primitives each time */
    mr_mesh s;
    mr_error err;
    assert_int_equal(mr_mesh_read(in, NULL, &s, &err), MR_OK);
    assert_int_equal(s.triangle_count, 2 * (nt / 2 + nt / 2));
    mr_mesh_free(&s);
    mr_simplify_options o = ratio_options(0.2);
    mr_gltf_simplify_stats st;
    if (mr_simplify_gltf(in, out, &o, &st, &err) != MR_OK)
        fail_msg("simplify: %s", err.message);
    assert_int_equal(st.primitives, 2);
    validate(out);
    doc a, c;
    load_doc(in, &a);
    load_doc(out, &c);
    /* what simplification does not touch is as it was */
    static const char *const same[] = {"asset", "scenes", "nodes", "skins", "materials",
                                       "extensionsUsed", "scene"};
    for (size_t k = 0; k < sizeof same / sizeof *same; k++)
        if (!cJSON_Compare(cJSON_GetObjectItem(a.root, same[k]),
                           cJSON_GetObjectItem(c.root, same[k]), true))
            fail_msg("%s changed", same[k]);
    /* (the unknown extension: nothing dropped, the old accessors kept) */
    assert_true(cJSON_GetArraySize(cJSON_GetObjectItem(c.root, "accessors")) >= 10);
    const cJSON *prims =
        cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(c.root, "meshes"), 0),
                            "primitives");
    assert_int_equal(cJSON_GetArraySize(prims), 2);
    /* the animation's and the skin's accessors still read as before */
    for (int k = 7; k <= 9; k++) {
        size_t n1, n2;
        int c1, c2;
        double *x = read_acc(&a, k, &n1, &c1), *y = read_acc(&c, k, &n2, &c2);
        assert_int_equal(n1, n2);
        assert_memory_equal(x, y, n1 * (size_t)c1 * sizeof *x);
        free(x), free(y);
    }
    for (int q = 0; q < 2; q++) {
        const cJSON *pr = cJSON_GetArrayItem(prims, q);
        assert_int_equal(num(pr, "material", -1), q);
        const cJSON *at = cJSON_GetObjectItem(pr, "attributes");
        size_t n, n2, n3, n4;
        int comps, c2, c3, c4;
        double *pos = read_acc(&c, num(at, "POSITION", -1), &n, &comps);
        double *jo = read_acc(&c, num(at, "JOINTS_0", -1), &n2, &c2);
        double *we = read_acc(&c, num(at, "WEIGHTS_0", -1), &n3, &c3);
        const cJSON *tg = cJSON_GetArrayItem(cJSON_GetObjectItem(pr, "targets"), 0);
        double *dz = read_acc(&c, num(tg, "POSITION", -1), &n4, &c4);
        assert_true(n < nv && n2 == n && n3 == n && n4 == n && c2 == 4 && c3 == 4);
        assert_true(cJSON_GetObjectItem(pr, "indices") != NULL);
        for (size_t v = 0; v < n; v++) {
            /* an input vertex's: joint 0 or 1, weight (1, 0, 0, 0), the
             * target's dz = x/4 of some input vertex */
            assert_true(jo[4 * v] == 0 || jo[4 * v] == 1);
            assert_true(jo[4 * v + 1] == 0 && we[4 * v] == 1 && we[4 * v + 1] == 0);
            const double x = dz[3 * v + 2] * 4;
            assert_true(x >= -1e-6 && x <= 1 + 1e-6);
            assert_true(fabs(x * 20 - floor(x * 20 + 0.5)) < 1e-4); /* a grid column */
        }
        free(pos), free(jo), free(we), free(dz);
    }
    free_doc(&c);
    /* levels of detail in one document (MSFT_lod): the mesh twice more, each
     * node with a mesh an LOD node per level, the rest as it was */
    {
        const char *lods = tu_tmp_path("gltf-doc-lods.glb");
        mr_simplify_options lo;
        mr_simplify_options_default(&lo);
        const double fr[2] = {0.5, 0.2};
        mr_lod_level lv[2];
        if (mr_simplify_gltf_lods(in, lods, fr, 2, &lo, 20000, lv, &err) != MR_OK)
            fail_msg("lods: %s", err.message);
        validate(lods);
        assert_true(lv[0].stats.output_triangles < lv[0].stats.input_triangles);
        assert_true(lv[1].stats.output_triangles < lv[0].stats.output_triangles);
        assert_true(lv[0].error_rel > 0 && lv[1].error_rel >= lv[0].error_rel);
        assert_true(lv[1].error_rel == fmax(lv[0].hausdorff_rel, lv[1].hausdorff_rel));
        load_doc(lods, &c);
        const cJSON *meshes = cJSON_GetObjectItem(c.root, "meshes"),
                    *nodes = cJSON_GetObjectItem(c.root, "nodes");
        assert_int_equal(cJSON_GetArraySize(meshes), 3);
        assert_true(cJSON_Compare(cJSON_GetArrayItem(meshes, 0),
                                  cJSON_GetArrayItem(cJSON_GetObjectItem(a.root, "meshes"), 0),
                                  true)); /* the input's mesh as it was */
        assert_int_equal(cJSON_GetArraySize(nodes), 4 + 2 * 2);
        const cJSON *used = cJSON_GetObjectItem(c.root, "extensionsUsed");
        assert_int_equal(cJSON_GetArraySize(used), 2);
        assert_string_equal(cJSON_GetArrayItem(used, 1)->valuestring, "MSFT_lod");
        for (int n = 0; n < 2; n++) {
            const cJSON *node = cJSON_GetArrayItem(nodes, n);
            const cJSON *ids = cJSON_GetObjectItem(
                cJSON_GetObjectItem(cJSON_GetObjectItem(node, "extensions"), "MSFT_lod"), "ids");
            assert_int_equal(cJSON_GetArraySize(ids), 2);
            for (int k = 0; k < 2; k++) {
                const cJSON *lod = cJSON_GetArrayItem(nodes, cJSON_GetArrayItem(ids, k)->valueint);
                assert_int_equal(num(lod, "mesh", -1), 1 + k);
                assert_int_equal(num(lod, "skin", -1), num(node, "skin", -1));
                const cJSON *t1 = cJSON_GetObjectItem(lod, "translation"),
                            *t2 = cJSON_GetObjectItem(node, "translation");
                assert_true(t1 == t2 || cJSON_Compare(t1, t2, true)); /* NULL for node 0 */
                const cJSON *ex = cJSON_GetObjectItem(lod, "extras");
                assert_int_equal(num(ex, "lod", -1), k + 1);
                assert_true(cJSON_GetObjectItem(ex, "lod_error")->valuedouble == lv[k].error_rel);
                /* the level's primitives: fewer vertices, their joints an
                 * input vertex's */
                const cJSON *pr = cJSON_GetArrayItem(
                    cJSON_GetObjectItem(cJSON_GetArrayItem(meshes, 1 + k), "primitives"), 0);
                const cJSON *at = cJSON_GetObjectItem(pr, "attributes");
                size_t n1;
                int c1;
                double *jo = read_acc(&c, num(at, "JOINTS_0", -1), &n1, &c1);
                assert_true(n1 < nv && c1 == 4);
                for (size_t v = 0; v < n1; v++)
                    assert_true((jo[4 * v] == 0 || jo[4 * v] == 1) && jo[4 * v + 1] == 0);
                free(jo);
            }
        }
        free_doc(&c);
        /* a document with levels already is refused */
        assert_int_equal(mr_simplify_gltf_lods(lods, tu_tmp_path("gltf-doc-lods2.glb"), fr, 2,
                                               &lo, 20000, lv, &err),
                         MR_ERR_UNSUPPORTED);
        tu_assert_contains(err.message, "MSFT_lod");
        assert_false(tu_file_exists(tu_tmp_path("gltf-doc-lods2.glb")));
    }
    free_doc(&a);
    /* without the unknown extension the old accessors go */
    char *plain = malloc(strlen(body) + 1);
    strcpy(plain, body);
    static const char *const cut[] = {"\"extensionsUsed\":[\"EXT_unknown_test\"],",
                                       ",\"extensions\":{\"EXT_unknown_test\":{\"a\":1}}"};
    for (int k = 0; k < 2; k++) {
        char *e = strstr(plain, cut[k]);
        assert_non_null(e);
        memmove(e, e + strlen(cut[k]), strlen(e + strlen(cut[k])) + 1);
    }
    const char *in2 = tu_tmp_path("gltf-doc2.gltf"), *out2 = tu_tmp_path("gltf-doc2-out.gltf");
    write_doc(in2, plain, &b);
    assert_int_equal(mr_simplify_gltf(in2, out2, &o, &st, &err), MR_OK);
    validate(out2);
    load_doc(out2, &c);
    /* the skin's, the animation's (3), the shared UV... : the primitives'
     * 2 x (POSITION, TEXCOORD_0, JOINTS_0, WEIGHTS_0, target, indices) + 3 */
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(c.root, "accessors")), 2 * 6 + 3);
    free_doc(&c);
    free(plain);
    free(b.d);
    free(joints), free(weights), free(target);
    free_grid(&g);
}

/* ---- malformed documents -------------------------------------------------------- */

static void expect_bad(const char *name, const char *content, const char *says)
{
    const char *path = tu_tmp_path(name);
    tu_write_file(path, content, strlen(content));
    mr_mesh m;
    mr_error err;
    const mr_status st = mr_mesh_read(path, NULL, &m, &err);
    if (st == MR_OK)
        fail_msg("%s read", name);
    tu_assert_contains(err.message, says);
    tu_assert_contains(err.message, name);
    const char *out = tu_tmp_path("gltf-bad-out.glb");
    unlink(out);
    mr_simplify_options o = ratio_options(0.5);
    assert_int_not_equal(mr_simplify_gltf(path, out, &o, NULL, &err), MR_OK);
    tu_assert_contains(err.message, says);
    assert_false(tu_file_exists(out));
}

static void test_malformed(void **state)
{
    (void)state;
    /* a triangle: 3 floats x 3, then 3 shorts of indices */
    static const char tri_b64[] = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA=";
    char text[4096];
#define TRI_DOC(EXTRA, ACC, IDX)                                                                \
    snprintf(text, sizeof text,                                                                 \
             "{\"asset\":{\"version\":\"2.0\"}%s,\"buffers\":[{\"byteLength\":44,\"uri\":"      \
             "\"data:application/octet-stream;base64,%s\"}],\"bufferViews\":[{\"buffer\":0,"    \
             "\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],"            \
             "\"accessors\":[%s,%s],\"meshes\":[{\"primitives\":[{\"attributes\":"              \
             "{\"POSITION\":0},\"indices\":1}]}]}",                                             \
             EXTRA, tri_b64, ACC, IDX)
    const char *acc = "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}";
    const char *idx = "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}";
    TRI_DOC("", acc, idx);
    {
        const char *ok = tu_tmp_path("gltf-ok.gltf");
        tu_write_file(ok, text, strlen(text));
        mr_mesh m;
        mr_error err;
        assert_int_equal(mr_mesh_read(ok, NULL, &m, &err), MR_OK);
        assert_int_equal(m.triangle_count, 1);
        mr_mesh_free(&m);
    }
    expect_bad("gltf-json.gltf", "{\"asset\":{\"version\":\"2.0\"},\n\"meshes\":[}", "line 2");
    expect_bad("gltf-version.gltf", "{\"asset\":{\"version\":\"1.0\"}}", "glTF version 1.0");
    TRI_DOC("", "{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"}", idx);
    expect_bad("gltf-bounds.gltf", text, "accessors[0]: 4 elements");
    TRI_DOC("", acc, "{\"bufferView\":1,\"byteOffset\":2,\"componentType\":5123,\"count\":3,"
                     "\"type\":\"SCALAR\"}");
    expect_bad("gltf-bounds2.gltf", text, "run past bufferViews[1]");
    /* the positions' bytes as indices: the 8th (bytes 14-15 of 1.0f) is 16256 */
    TRI_DOC("", acc, "{\"bufferView\":0,\"componentType\":5123,\"count\":9,\"type\":\"SCALAR\"}");
    expect_bad("gltf-index.gltf", text, "index 7 is 16256, but there are 3 vertices");
    TRI_DOC("", acc, "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"SCALAR\"}");
    expect_bad("gltf-itype.gltf", text, "not unsigned integer scalars");
    TRI_DOC("", "{\"bufferView\":0,\"componentType\":5127,\"count\":3,\"type\":\"VEC3\"}", idx);
    expect_bad("gltf-ctype.gltf", text, "componentType 5127");
    TRI_DOC(",\"extensionsUsed\":[\"KHR_draco_mesh_compression\"]", acc, idx);
    expect_bad("gltf-draco.gltf", text, "KHR_draco_mesh_compression");
    expect_bad("gltf-missing.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":8,\"uri\":"
               "\"no-such-file.bin\"}]}",
               "cannot read \"no-such-file.bin\"");
    expect_bad("gltf-escape.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":8,\"uri\":"
               "\"../../etc/passwd\"}]}",
               "leaves the file's folder");
    expect_bad("gltf-scheme.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":8,\"uri\":"
               "\"https://example.com/a.bin\"}]}",
               "not a path relative");
    TRI_DOC(",\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"children\":[1]},"
            "{\"children\":[0],\"mesh\":0}]",
            acc, idx);
    {
        const char *path = tu_tmp_path("gltf-cycle.gltf");
        tu_write_file(path, text, strlen(text));
        mr_mesh m;
        mr_error err;
        assert_int_not_equal(mr_mesh_read(path, NULL, &m, &err), MR_OK);
        tu_assert_contains(err.message, "cycle");
    }
    /* a .glb cut short */
    {
        const char *path = tu_tmp_path("gltf-short.glb");
        const uint32_t h[5] = {0x46546C67u, 2, 400, 100, 0x4E4F534Au};
        tu_write_file(path, h, sizeof h);
        mr_mesh m;
        mr_error err;
        assert_int_not_equal(mr_mesh_read(path, NULL, &m, &err), MR_OK);
        tu_assert_contains(err.message, "offset 8");
    }
    /* a .glb whose header says fewer bytes than the header itself: the JSON
     * chunk's bound must not wrap (a fuzzer's find) */
    {
        const char *path = tu_tmp_path("gltf-tiny.glb");
        const uint8_t h[23] = {'g', 'l', 'T', 'F', 2, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0x60,
                               'J', 'S', 'O', 'N', '{', '"', 'b'};
        tu_write_file(path, h, sizeof h);
        mr_mesh m;
        mr_error err;
        assert_int_not_equal(mr_mesh_read(path, NULL, &m, &err), MR_OK);
        tu_assert_contains(err.message, "offset 8");
    }
    /* from memory, an external buffer is not read */
    {
        const char *mem = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":8,"
                          "\"uri\":\"a.bin\"}]}";
        mr_read_options ro;
        mr_read_options_default(&ro);
        ro.format = MR_FORMAT_GLTF;
        mr_mesh m;
        mr_error err;
        assert_int_not_equal(mr_mesh_read_memory(mem, strlen(mem), "mem.gltf", &ro, &m, &err),
                             MR_OK);
        tu_assert_contains(err.message, "cannot be read here");
    }
#undef TRI_DOC
}

/* ---- the sample models and the CLI --------------------------------------------- */

static void test_samples(void **state)
{
    (void)state;
    static const char *const models[] = {
        "gltf/Duck/glTF/Duck.gltf",
        "gltf/Duck/glTF-Binary/Duck.glb",
        "gltf/Duck/glTF-Quantized/Duck.gltf",
        "gltf/DamagedHelmet/glTF-Binary/DamagedHelmet.glb",
        "gltf/Fox/glTF/Fox.gltf",
        "gltf/BoxInterleaved/glTF-Binary/BoxInterleaved.glb",
        "gltf/BoxTextured/glTF/BoxTextured.gltf",
        "gltf/BoxVertexColors/glTF-Binary/BoxVertexColors.glb",
        "gltf/MeshPrimitiveModes/glTF/MeshPrimitiveModes.gltf",
        "gltf/MorphPrimitivesTest/glTF-Binary/MorphPrimitivesTest.glb",
        "gltf/SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf",
        "gltf/TriangleWithoutIndices/glTF/TriangleWithoutIndices.gltf"};
    if (!tu_shared_data(models[0])) {
        print_message("../shared/data/gltf not found: the sample models are skipped\n");
        skip();
    }
    for (size_t k = 0; k < sizeof models / sizeof *models; k++) {
        const char *in = tu_shared_data(models[k]);
        if (!in)
            fail_msg("%s: missing from ../shared/data", models[k]);
        char path[1024];
        snprintf(path, sizeof path, "%s", in);
        for (int f = 0; f < 2; f++) {
            char out[1024], cmd[3072];
            snprintf(out, sizeof out, "%s", tu_tmp_path(tu_fmt("sample-%zu.%s", k, f ? "glb" : "gltf")));
            snprintf(cmd, sizeof cmd, "simplify '%s' -o '%s' --ratio 10%% -q", path, out);
            char *text = NULL;
            const int rc = tu_run_cli(cmd, &text);
            if (rc != 0)
                fail_msg("%s: %s", models[k], text ? text : "");
            free(text);
            validate(out);
            snprintf(cmd, sizeof cmd, "convert '%s' '%s' -q", path, out);
            assert_int_equal(tu_run_cli(cmd, NULL), 0);
            validate(out);
        }
    }
    /* compressed: the clear error, exit 1, no output */
    const char *draco = tu_shared_data("gltf/Duck/glTF-Draco/Duck.gltf");
    if (draco) {
        const char *out = tu_tmp_path("sample-draco.glb");
        unlink(out);
        char *text = NULL;
        const int rc =
            tu_run_cli(tu_fmt("simplify '%s' -o '%s' --ratio 10%%", draco, out), &text);
        assert_int_equal(rc, 1);
        tu_assert_contains(text, "KHR_draco_mesh_compression");
        assert_false(tu_file_exists(out));
        free(text);
    }
}

/* Texture coordinates have v up in the mesh (glTF's v points down): read
 * flipped, written flipped back, so glTF -> OBJ -> glTF keeps them; and
 * the look: each triangle's material, its base-colour texture from a
 * data: URI, a texture on TEXCOORD_1 left out. */
static void test_texcoords_and_look(void **state)
{
    (void)state;
    blob b = {NULL, 0, 0};
    const float pos[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
    const float uv[8] = {0.25f, 0.125f, 0.75f, 0.5f, 0.5f, 1.0f, 1.0f, 0.0f};
    const uint16_t idx[6] = {0, 1, 2, 1, 3, 2};
    const size_t op = put(&b, pos, sizeof pos), ou = put(&b, uv, sizeof uv),
                 oi = put(&b, idx, sizeof idx);
    /* a 3 x 2 PNG as a data: URI */
    const uint8_t px[24] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255,
                            9, 9, 9, 255, 99, 99, 99, 255, 199, 199, 199, 255};
    const char *png = tu_tmp_path("look-tex.png");
    mr_error err;
    assert_int_equal(mr_png_write(png, px, 3, 2, &err), MR_OK);
    size_t pn;
    char *pbytes = tu_read_file(png, &pn);
    char *p64 = base64((const uint8_t *)pbytes, pn);
    free(pbytes);
    char *body = malloc(strlen(p64) + 4096);
    sprintf(body,
            "{\"asset\":{\"version\":\"2.0\"},"
            "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":48},"
            "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":32},"
            "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":12}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":"
            "\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},"
            "{\"bufferView\":1,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"},"
            "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"},"
            "{\"bufferView\":2,\"byteOffset\":6,\"componentType\":5123,\"count\":3,"
            "\"type\":\"SCALAR\"}],"
            "\"images\":[{\"uri\":\"data:image/png;base64,%s\"}],"
            "\"samplers\":[{\"wrapS\":33071,\"wrapT\":33648}],"
            "\"textures\":[{\"source\":0,\"sampler\":0}],"
            "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,1,1,1],"
            "\"baseColorTexture\":{\"index\":0}}},"
            "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0,\"texCoord\":1}}}],"
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},"
            "\"indices\":2,\"material\":1},"
            "{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":3,\"material\":0}]}],"
            "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
            op, ou, oi, p64);
    const char *path = tu_tmp_path("look.gltf");
    write_doc(path, body, &b);
    free(body);
    free(p64);
    free(b.d);

    mr_mesh m;
    assert_int_equal(mr_mesh_read(path, NULL, &m, &err), MR_OK);
    assert_non_null(m.texcoords);
    /* the first primitive's vertex 0 is input vertex 0: (0.25, 1 - 0.125) */
    assert_float_equal(m.texcoords[0], 0.25, 0);
    assert_float_equal(m.texcoords[1], 0.875, 0);
    /* into OBJ: vt as the mesh has them; back into glTF and read: the same */
    const char *obj = tu_tmp_path("look-uv.obj"), *back = tu_tmp_path("look-back.glb");
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' '%s' -q", path, obj), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt("convert '%s' '%s' -q", obj, back), NULL), 0);
    char *text = tu_read_file(obj, NULL);
    tu_assert_contains(text, "vt 0.25 0.875");
    free(text);
    mr_mesh m2;
    assert_int_equal(mr_mesh_read(back, NULL, &m2, &err), MR_OK);
    assert_int_equal(m2.triangle_count, m.triangle_count);
    for (size_t c = 0; c < 3 * m.triangle_count; c++) /* each corner's, bit for bit */
        assert_memory_equal(m2.texcoords + 2 * m2.indices[c], m.texcoords + 2 * m.indices[c], 8);
    mr_mesh_free(&m2);

    mr_look look;
    assert_int_equal(mr_look_read(path, &look, &err), MR_OK);
    assert_int_equal(look.mesh.triangle_count, 2);
    assert_memory_equal(look.mesh.texcoords, m.texcoords, 8 * m.vertex_count);
    assert_int_equal(look.material_count, 2);
    assert_int_equal(look.face_material[0], 1);
    assert_int_equal(look.face_material[1], 0);
    const mr_render_material *mat = &look.materials[0];
    assert_non_null(mat->texture);
    assert_int_equal(mat->texture->width, 3);
    assert_int_equal(mat->texture->height, 2);
    assert_memory_equal(mat->texture->rgba, px, sizeof px);
    assert_int_equal(mat->wrap_s, MR_WRAP_CLAMP);
    assert_int_equal(mat->wrap_t, MR_WRAP_MIRROR);
    assert_int_equal(mat->v_up, 1);
    /* linear 0.5 is display 0.7354 */
    assert_float_equal(mat->color[0], 0.7354, 1e-3);
    assert_float_equal(mat->color[1], 1, 0);
    assert_null(look.materials[1].texture); /* TEXCOORD_1 */
    mr_look_free(&look);
    mr_mesh_free(&m);
    /* and it renders */
    const char *out = tu_tmp_path("look-gltf.png");
    assert_int_equal(tu_run_cli(tu_fmt("render '%s' -o '%s' --size 60x60 -q", path, out), NULL),
                     0);
    assert_true(tu_file_exists(out));
    /* its materials went into the OBJ's library, its texture beside it: the
     * OBJ, and the glTF made from the OBJ, draw as the document does
     * (tu_tmp_path's buffers rotate: the paths kept) */
    char doc_path[1024], obj_path[1024], back_path[1024], png_path[1024];
    snprintf(doc_path, sizeof doc_path, "%s", path);
    snprintf(obj_path, sizeof obj_path, "%s", obj);
    snprintf(back_path, sizeof back_path, "%s", back);
    snprintf(png_path, sizeof png_path, "%s", png);
    path = doc_path, obj = obj_path, back = back_path, png = png_path;
    text = tu_read_file(obj, NULL);
    tu_assert_contains(text, "mtllib look-uv.mtl\n");
    tu_assert_contains(text, "usemtl material_0\n");
    tu_assert_contains(text, "usemtl material_1\n");
    free(text);
    char *lib = tu_read_file(tu_tmp_path("look-uv.mtl"), NULL);
    tu_assert_contains(lib, "newmtl material_0\nKd 0.735");
    tu_assert_contains(lib, "map_Kd -clamp on look-uv_0.png\n");
    tu_assert_contains(lib, "newmtl material_1\nKd 1 1 1\n"); /* its texture: set 1 */
    assert_null(strstr(strstr(lib, "newmtl material_1"), "map_Kd"));
    free(lib);
    size_t n1, n2;
    char *t1 = tu_read_file(png, &n1), *t2 = tu_read_file(tu_tmp_path("look-uv_0.png"), &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(t1, t2, n1);
    free(t1), free(t2);
    char img_doc[1024], img_obj[1024], img_back[1024];
    snprintf(img_doc, sizeof img_doc, "%s", tu_tmp_path("look-doc.png"));
    snprintf(img_obj, sizeof img_obj, "%s", tu_tmp_path("look-obj.png"));
    snprintf(img_back, sizeof img_back, "%s", tu_tmp_path("look-back.png"));
    const char *fmt = "render '%s' -o '%s' --size 48x48 --supersample 1 -q";
    assert_int_equal(tu_run_cli(tu_fmt(fmt, path, img_doc), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt(fmt, obj, img_obj), NULL), 0);
    assert_int_equal(tu_run_cli(tu_fmt(fmt, back, img_back), NULL), 0);
    t1 = tu_read_file(img_doc, &n1);
    t2 = tu_read_file(img_obj, &n2);
    size_t n3;
    char *t3 = tu_read_file(img_back, &n3);
    assert_true(n1 == n2 && n2 == n3);
    assert_memory_equal(t1, t2, n1);
    assert_memory_equal(t1, t3, n1);
    free(t1), free(t2), free(t3);
    validate(back);
    /* a library that cannot be written: no OBJ, no library, no texture */
    const char *bad = tu_tmp_path("no-such-dir/x.obj");
    assert_true(tu_run_cli(tu_fmt("convert '%s' '%s' -q", path, bad), NULL) != 0);
    assert_false(tu_file_exists(tu_tmp_path("no-such-dir/x.mtl")));
}

/* ---- the data model (mr_mesh's texture sets, tangents, skin, materials) ------ */

/* A grid in two primitives (materials 0 and 1, the halves of its
 * triangles) with NORMAL, TANGENT, TEXCOORD_0, TEXCOORD_1, JOINTS_0 (joint
 * 1 where x > 0.5) and WEIGHTS_0: read into mr_mesh with all of them;
 * simplified, each triangle keeps its material (grouped, none lost), each
 * vertex its origin's second texture set, joints and weights, and the
 * tangents are left out; written as a plain mesh's glTF, one primitive per
 * material, read back bit for bit. */
static void test_data_model(void **state)
{
    (void)state;
    grid g;
    make_grid(&g, 24);
    const size_t nv = g.nv, nt = g.nt;
    uint8_t *joints = malloc(4 * nv);
    float *weights = malloc(16 * nv), *tan = malloc(16 * nv), *uv1 = malloc(8 * nv);
    for (size_t v = 0; v < nv; v++) {
        joints[4 * v] = g.pos[3 * v] > 0.5f ? 1 : 0;
        joints[4 * v + 1] = joints[4 * v + 2] = joints[4 * v + 3] = 0;
        weights[4 * v] = 1, weights[4 * v + 1] = weights[4 * v + 2] = weights[4 * v + 3] = 0;
        tan[4 * v] = 1, tan[4 * v + 1] = tan[4 * v + 2] = 0, tan[4 * v + 3] = v % 2 ? 1 : -1;
        uv1[2 * v] = 0.5f * g.pos[3 * v] + 0.25f, uv1[2 * v + 1] = 0.5f * g.pos[3 * v + 1];
    }
    const float ibm[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
                           1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    blob b = {0};
    const size_t p = put(&b, g.pos, 12 * nv), n = put(&b, g.nrm, 12 * nv),
                 ta = put(&b, tan, 16 * nv), u0 = put(&b, g.uv, 8 * nv),
                 u1 = put(&b, uv1, 8 * nv), j = put(&b, joints, 4 * nv),
                 w = put(&b, weights, 16 * nv), i1 = put(&b, g.idx, 6 * nt),
                 i2 = put(&b, g.idx + 3 * (nt / 2), 6 * nt), m = put(&b, ibm, sizeof ibm);
    char body[8192];
    snprintf(body, sizeof body,
             "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,1]}],"
             "\"nodes\":[{\"mesh\":0,\"skin\":0},{\"name\":\"root\",\"children\":[2]},"
             "{\"name\":\"bone\"}],"
             "\"skins\":[{\"joints\":[1,2],\"inverseBindMatrices\":9}],"
             "\"materials\":[{\"name\":\"left\"},{\"name\":\"right\"}],"
             "\"meshes\":[{\"primitives\":["
             "{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TANGENT\":2,\"TEXCOORD_0\":3,"
             "\"TEXCOORD_1\":4,\"JOINTS_0\":5,\"WEIGHTS_0\":6},\"indices\":7,\"material\":0},"
             "{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TANGENT\":2,\"TEXCOORD_0\":3,"
             "\"TEXCOORD_1\":4,\"JOINTS_0\":5,\"WEIGHTS_0\":6},\"indices\":8,\"material\":1}]}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,"
             "\"type\":\"VEC3\",%s},"
             "{\"bufferView\":1,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\"},"
             "{\"bufferView\":2,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC4\"},"
             "{\"bufferView\":3,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC2\"},"
             "{\"bufferView\":4,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC2\"},"
             "{\"bufferView\":5,\"componentType\":5121,\"count\":%zu,\"type\":\"VEC4\"},"
             "{\"bufferView\":6,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC4\"},"
             "{\"bufferView\":7,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"},"
             "{\"bufferView\":8,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"},"
             "{\"bufferView\":9,\"componentType\":5126,\"count\":2,\"type\":\"MAT4\"}]}",
             p, 12 * nv, n, 12 * nv, ta, 16 * nv, u0, 8 * nv, u1, 8 * nv, j, 4 * nv, w, 16 * nv,
             i1, 6 * nt, i2, 6 * nt, m, sizeof ibm, nv, bounds(g.pos, nv), nv, nv, nv, nv, nv,
             nv, nt * 3 / 2, nt * 3 / 2);
    const char *in = tu_tmp_path("gltf-model.glb"), *out = tu_tmp_path("gltf-model-out.glb"),
               *back = tu_tmp_path("gltf-model-simplified.gltf");
    write_doc(in, body, &b);
    validate(in);
    mr_mesh s;
    mr_error err;
    assert_int_equal(mr_mesh_read(in, NULL, &s, &err), MR_OK);
    assert_int_equal(mr_mesh_attributes(&s),
                     MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_TEXCOORDS1 | MR_ATTR_TANGENTS |
                         MR_ATTR_SKIN | MR_ATTR_MATERIALS);
    assert_int_equal(s.triangle_count, nt);
    for (size_t t = 0; t < nt; t++)
        assert_int_equal(s.materials[t], t < nt / 2 ? 0 : 1);
    for (size_t v = 0; v < s.vertex_count; v++) {
        /* the scene's vertices are the primitives' (each welded on its
         * own): find this one's input by position */
        const float *q = s.positions + 3 * v;
        size_t i = 0;
        while (i < nv && memcmp(g.pos + 3 * i, q, 12) != 0)
            i++;
        assert_true(i < nv);
        assert_memory_equal(s.tangents + 4 * v, tan + 4 * i, 16);
        assert_true(s.more_texcoords[0][2 * v] == uv1[2 * i]);
        assert_true(s.more_texcoords[0][2 * v + 1] == 1.0f - uv1[2 * i + 1]); /* v up */
        assert_int_equal(s.joints[4 * v], joints[4 * i]);
        assert_true(s.weights[4 * v] == 1 && s.weights[4 * v + 1] == 0);
    }
    /* simplified: materials grouped and kept, the rest the origin's */
    mr_simplify_options o = ratio_options(0.15);
    mr_mesh r;
    uint32_t *origin = NULL;
    assert_int_equal(mr_mesh_simplify(&s, &o, &r, &origin, NULL, &err), MR_OK);
    assert_null(r.tangents);
    assert_non_null(r.materials);
    assert_non_null(r.more_texcoords[0]);
    assert_non_null(r.joints);
    double area[2] = {0, 0}, area_in[2] = {0, 0};
    for (size_t t = 0; t < r.triangle_count; t++) {
        assert_true(r.materials[t] <= 1);
        if (t)
            assert_true(r.materials[t] >= r.materials[t - 1]);
        const float *a = r.positions + 3 * r.indices[3 * t], *bb = r.positions + 3 * r.indices[3 * t + 1],
                    *c = r.positions + 3 * r.indices[3 * t + 2];
        area[r.materials[t]] += 0.5 * fabs((double)(bb[0] - a[0]) * (c[1] - a[1]) -
                                           (double)(c[0] - a[0]) * (bb[1] - a[1]));
    }
    for (size_t t = 0; t < nt; t++) {
        const float *a = s.positions + 3 * s.indices[3 * t], *bb = s.positions + 3 * s.indices[3 * t + 1],
                    *c = s.positions + 3 * s.indices[3 * t + 2];
        area_in[s.materials[t]] += 0.5 * fabs((double)(bb[0] - a[0]) * (c[1] - a[1]) -
                                              (double)(c[0] - a[0]) * (bb[1] - a[1]));
    }
    for (int k = 0; k < 2; k++) /* the border between them stays where it was */
        assert_true(fabs(area[k] - area_in[k]) < 1e-3 * (area_in[0] + area_in[1]));
    for (size_t v = 0; v < r.vertex_count; v++) {
        const uint32_t i = origin[v];
        assert_true(i < s.vertex_count);
        assert_memory_equal(r.more_texcoords[0] + 2 * v, s.more_texcoords[0] + 2 * i, 8);
        assert_memory_equal(r.joints + 4 * v, s.joints + 4 * i, 8);
        assert_memory_equal(r.weights + 4 * v, s.weights + 4 * i, 16);
    }
    /* the same at 1, 2, 3 and 8 threads: materials, carried arrays, origin */
    static const int teams[4] = {1, 2, 3, 8};
    for (int k = 0; k < 4; k++) {
        mr_simplify_options ot = o;
        ot.threads = teams[k];
        mr_mesh rt;
        uint32_t *ort = NULL;
        assert_int_equal(mr_mesh_simplify(&s, &ot, &rt, &ort, NULL, &err), MR_OK);
        assert_int_equal(rt.vertex_count, r.vertex_count);
        assert_int_equal(rt.triangle_count, r.triangle_count);
        assert_memory_equal(rt.indices, r.indices, 12 * r.triangle_count);
        assert_memory_equal(rt.positions, r.positions, 12 * r.vertex_count);
        assert_memory_equal(rt.materials, r.materials, 4 * r.triangle_count);
        assert_memory_equal(rt.more_texcoords[0], r.more_texcoords[0], 8 * r.vertex_count);
        assert_memory_equal(rt.joints, r.joints, 8 * r.vertex_count);
        assert_memory_equal(ort, origin, 4 * r.vertex_count);
        free(ort);
        mr_mesh_free(&rt);
    }
    free(origin);
    /* a plain mesh's glTF: a primitive per material; read back the same */
    assert_int_equal(mr_mesh_write(out, &s, NULL, &err), MR_OK);
    validate(out);
    assert_int_equal(mr_mesh_write(back, &r, NULL, &err), MR_OK);
    validate(back);
    doc d;
    load_doc(out, &d);
    const cJSON *prims = cJSON_GetObjectItem(
        cJSON_GetArrayItem(cJSON_GetObjectItem(d.root, "meshes"), 0), "primitives");
    assert_int_equal(cJSON_GetArraySize(prims), 2);
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(d.root, "materials")), 2);
    cJSON_Delete(d.root);
    free(d.bin);
    mr_mesh x;
    assert_int_equal(mr_mesh_read(out, NULL, &x, &err), MR_OK);
    assert_int_equal(x.vertex_count, s.vertex_count);
    assert_int_equal(x.triangle_count, s.triangle_count);
    assert_int_equal(mr_mesh_attributes(&x) & ~MR_ATTR_SKIN,
                     mr_mesh_attributes(&s) & ~MR_ATTR_SKIN); /* no skin: not written */
    assert_memory_equal(x.tangents, s.tangents, 16 * s.vertex_count);
    assert_memory_equal(x.more_texcoords[0], s.more_texcoords[0], 8 * s.vertex_count);
    assert_memory_equal(x.materials, s.materials, 4 * s.triangle_count);
    assert_memory_equal(x.indices, s.indices, 12 * s.triangle_count);
    mr_mesh c2;
    assert_int_equal(mr_mesh_copy(&c2, &x, &err), MR_OK);
    assert_memory_equal(c2.tangents, x.tangents, 16 * x.vertex_count);
    assert_memory_equal(c2.materials, x.materials, 4 * x.triangle_count);
    mr_mesh_free(&c2);
    mr_mesh_free(&x);
    mr_mesh_free(&r);
    mr_mesh_free(&s);
    free(b.d);
    free(joints), free(weights), free(tan), free(uv1);
    free_grid(&g);
}

/* An OBJ's usemtl groups into glTF: a primitive per material, named, its
 * Kd the base colour; a map_Kd that is no PNG or JPEG leaves the colour. */
static void test_obj_materials_to_gltf(void **state)
{
    (void)state;
    const char *obj = tu_tmp_path("mat-quads.obj"), *mtl = tu_tmp_path("mat-quads.mtl"),
               *out = tu_tmp_path("mat-quads.gltf"), *bad_tex = tu_tmp_path("mat-quads.tga");
    const char *text = "mtllib mat-quads.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
                       "v 2 1 0\nusemtl red\nf 1 2 3 4\nusemtl blue\nf 2 5 6 3\n";
    tu_write_file(obj, text, strlen(text));
    const char *lib = "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n";
    tu_write_file(mtl, lib, strlen(lib));
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read(obj, NULL, &m, &err), MR_OK);
    assert_non_null(m.materials);
    const uint32_t want[4] = {0, 0, 1, 1};
    assert_memory_equal(m.materials, want, sizeof want);
    mr_obj_materials om;
    assert_int_equal(mr_obj_materials_read(obj, &om, &err), MR_OK);
    mr_write_options w;
    mr_write_options_default(&w);
    w.mtllib = om.mtllib;
    w.material_names = (const char *const *)om.names;
    w.material_count = om.count;
    w.materials_from = obj;
    assert_int_equal(mr_mesh_write(out, &m, &w, &err), MR_OK);
    validate(out);
    doc d;
    load_doc(out, &d);
    const cJSON *mats = cJSON_GetObjectItem(d.root, "materials");
    assert_int_equal(cJSON_GetArraySize(mats), 2);
    const cJSON *blue = cJSON_GetArrayItem(mats, 1);
    assert_string_equal(cJSON_GetObjectItem(blue, "name")->valuestring, "blue");
    const cJSON *f = cJSON_GetObjectItem(cJSON_GetObjectItem(blue, "pbrMetallicRoughness"),
                                         "baseColorFactor");
    assert_true(cJSON_GetArrayItem(f, 2)->valuedouble == 1 &&
                cJSON_GetArrayItem(f, 0)->valuedouble == 0);
    cJSON_Delete(d.root);
    free(d.bin);
    /* a texture glTF cannot hold (a TGA) leaves the material its colour;
     * the names and libraries found from the OBJ alone (materials_from) */
    const char *lib2 = "newmtl red\nKd 1 0 0\nmap_Kd mat-quads.tga\nnewmtl blue\nKd 0 0 1\n";
    tu_write_file(mtl, lib2, strlen(lib2));
    tu_write_file(bad_tex, "TGA?", 4);
    remove(out);
    mr_write_options only_from;
    mr_write_options_default(&only_from);
    only_from.materials_from = obj;
    assert_int_equal(mr_mesh_write(out, &m, &only_from, &err), MR_OK);
    validate(out);
    load_doc(out, &d);
    mats = cJSON_GetObjectItem(d.root, "materials");
    assert_int_equal(cJSON_GetArraySize(mats), 2);
    const cJSON *red = cJSON_GetArrayItem(mats, 0);
    assert_string_equal(cJSON_GetObjectItem(red, "name")->valuestring, "red");
    const cJSON *rp = cJSON_GetObjectItem(red, "pbrMetallicRoughness");
    assert_null(cJSON_GetObjectItem(rp, "baseColorTexture"));
    assert_true(cJSON_GetArrayItem(cJSON_GetObjectItem(rp, "baseColorFactor"), 0)->valuedouble ==
                1);
    cJSON_Delete(d.root);
    free(d.bin);
    mr_obj_materials_free(&om);
    mr_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forms),
        cmocka_unit_test(test_document),
        cmocka_unit_test(test_malformed),
        cmocka_unit_test(test_samples),
        cmocka_unit_test(test_texcoords_and_look),
        cmocka_unit_test(test_data_model),
        cmocka_unit_test(test_obj_materials_to_gltf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#else /* no cJSON */

static void test_not_built(void **state)
{
    (void)state;
    const char *path = tu_tmp_path("gltf-none.gltf");
    tu_write_file(path, "{}", 2);
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read(path, NULL, &m, &err), MR_ERR_UNSUPPORTED);
    tu_assert_contains(err.message, "glTF support was not built");
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_not_built)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#endif
