/* glTF 2.0 documents (gltf.h). */
#include "gltf.h"
#include "mapped.h"
#include "obj_materials.h"
#include "output.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#ifndef MR_HAVE_GLTF

static mr_status not_built(mr_error *err, const char *name)
{
    return mr_fail_plain(err, MR_ERR_UNSUPPORTED, name,
                         "glTF support was not built (it needs cJSON: Debian libcjson-dev)");
}

mr_status mr_gltf_load(const void *data, size_t size, const char *name, const char *base_dir,
                       mr_gltf **out, mr_error *err)
{
    (void)data, (void)size, (void)base_dir;
    *out = NULL;
    return not_built(err, name);
}
mr_status mr_gltf_load_file(const char *path, mr_gltf **out, mr_error *err)
{
    *out = NULL;
    return not_built(err, path);
}
void mr_gltf_free(mr_gltf *g) { (void)g; }
mr_status mr_gltf_scene_mesh(const mr_gltf *g, mr_mesh *out, mr_error *err)
{
    (void)g, (void)out;
    return not_built(err, NULL);
}
size_t mr_gltf_primitive_count(const mr_gltf *g)
{
    (void)g;
    return 0;
}
mr_status mr_gltf_scene_look(const mr_gltf *g, mr_mesh *mesh, uint32_t **face_material,
                             mr_gltf_material **materials, size_t *material_count,
                             size_t *image_count, mr_error *err)
{
    (void)g;
    mr_mesh_init(mesh);
    *face_material = NULL;
    *materials = NULL;
    *material_count = *image_count = 0;
    return not_built(err, NULL);
}
mr_status mr_gltf_image(const mr_gltf *g, long long i, const char *what, uint8_t **bytes,
                        size_t *size, bool *owned, mr_error *err)
{
    (void)g, (void)i, (void)what;
    *bytes = NULL;
    *size = 0;
    *owned = false;
    return not_built(err, NULL);
}
mr_status mr_gltf_primitive_mesh(const mr_gltf *g, size_t i, mr_mesh *out, mr_error *err)
{
    (void)g, (void)i, (void)out;
    return not_built(err, NULL);
}
void mr_gltf_primitive_at(const mr_gltf *g, size_t i, size_t *mesh, size_t *primitive)
{
    (void)g, (void)i;
    *mesh = *primitive = 0;
}
mr_status mr_gltf_replace(mr_gltf *g, size_t i, const mr_mesh *m, const uint32_t *origin,
                          mr_error *err)
{
    (void)g, (void)i, (void)m, (void)origin;
    return not_built(err, NULL);
}
size_t mr_gltf_dropped_tangents(const mr_gltf *g)
{
    (void)g;
    return 0;
}
mr_status mr_gltf_add_lod(mr_gltf *g, const mr_mesh *levels, const uint32_t *const *origins,
                          size_t level, double error_rel, mr_error *err)
{
    (void)g, (void)levels, (void)origins, (void)level, (void)error_rel;
    return not_built(err, NULL);
}
mr_status mr_gltf_write(mr_gltf *g, const char *path, mr_error *err)
{
    (void)g;
    return not_built(err, path);
}
mr_status mr_gltf_write_mesh(const mr_mesh *m, const char *path,
                             const mr_write_options *options, mr_error *err)
{
    (void)m, (void)options;
    return not_built(err, path);
}

mr_status mr_gltf_mtl_export(const char *gltf_path, const char *obj_path, mr_gltf_mtl *out,
                             mr_error *err)
{
    (void)obj_path;
    memset(out, 0, sizeof *out);
    return not_built(err, gltf_path);
}

mr_status mr_gltf_mtl_commit(mr_gltf_mtl *m, mr_error *err)
{
    (void)m, (void)err;
    return MR_OK;
}
void mr_gltf_mtl_free(mr_gltf_mtl *m) { (void)m; }

mr_status mr_convert_gltf(const char *in_path, const char *out_path, size_t *primitives,
                          mr_error *err)
{
    (void)out_path;
    if (primitives)
        *primitives = 0;
    return not_built(err, in_path);
}

#else /* MR_HAVE_GLTF */

#include <cjson/cJSON.h>
#include <sys/stat.h>
#include <unistd.h>

enum {
    GL_BYTE = 5120,
    GL_UNSIGNED_BYTE = 5121,
    GL_SHORT = 5122,
    GL_UNSIGNED_SHORT = 5123,
    GL_UNSIGNED_INT = 5125,
    GL_FLOAT = 5126,
    GL_ARRAY_BUFFER = 34962,
    GL_ELEMENT_ARRAY_BUFFER = 34963
};

#define GLB_MAGIC 0x46546C67u /* "glTF" */
#define GLB_JSON 0x4E4F534Au  /* "JSON" */
#define GLB_BIN 0x004E4942u   /* "BIN\0" */

typedef struct gl_blob {
    uint8_t *data;
    size_t size;
} gl_blob;

/* A triangle primitive: its mesh and its place there. */
typedef struct gl_prim {
    size_t mesh, prim;
} gl_prim;

struct mr_gltf {
    cJSON *root;
    char *name;
    char *base;            /* the folder of relative URIs, or NULL: none read */
    gl_blob *buf;          /* each buffer's bytes (byteLength of them) */
    size_t nbuf;
    gl_prim *prims;
    size_t nprims;
    size_t input_views;    /* bufferViews of the input; those after are new */
    gl_blob *added;        /* the new bufferViews' bytes */
    size_t nadded, capadded;
    size_t dropped_tangents;
    int input_meshes, input_nodes; /* the input's (mr_gltf_add_lod adds more) */
};

/* ---- small helpers ----------------------------------------------------------- */

static uint32_t le32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static cJSON *member(const cJSON *o, const char *key)
{
    return o && cJSON_IsObject(o) ? cJSON_GetObjectItemCaseSensitive(o, key) : NULL;
}

static int array_size(const cJSON *a) { return a && cJSON_IsArray(a) ? cJSON_GetArraySize(a) : 0; }

/* root[key][i], or NULL where there is none. */
static cJSON *item(const cJSON *root, const char *key, long long i)
{
    const cJSON *a = member(root, key);
    if (!a || !cJSON_IsArray(a) || i < 0 || i >= cJSON_GetArraySize(a))
        return NULL;
    return cJSON_GetArrayItem(a, (int)i);
}

/* o[key] as a non-negative integer: 1, 0 where absent (*v = dflt), -1
 * where it is something else. */
static int get_index(const cJSON *o, const char *key, long long dflt, long long *v)
{
    const cJSON *x = member(o, key);
    *v = dflt;
    if (!x)
        return 0;
    if (!cJSON_IsNumber(x) || x->valuedouble < 0 || x->valuedouble > 9.0e15 ||
        x->valuedouble != floor(x->valuedouble))
        return -1;
    *v = (long long)x->valuedouble;
    return 1;
}

static mr_status bad(const mr_gltf *g, const char *fmt, const char *where, long long i,
                     const char *what, mr_error *err)
{
    char at[96];
    snprintf(at, sizeof at, fmt, where, i);
    return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: %s", at, what);
}

/* An integer member that must be there (or have a default: dflt >= 0). */
static mr_status need_index(const mr_gltf *g, const cJSON *o, const char *where, long long i,
                            const char *key, long long dflt, long long *v, mr_error *err)
{
    const int r = get_index(o, key, dflt, v);
    if (r < 0 || (r == 0 && dflt < 0)) {
        char what[96];
        snprintf(what, sizeof what, r < 0 ? "%s is not a non-negative integer" : "no %s", key);
        return bad(g, "%s[%lld]", where, i, what, err);
    }
    return MR_OK;
}

static const char *str(const cJSON *o, const char *key)
{
    const cJSON *x = member(o, key);
    return x && cJSON_IsString(x) ? x->valuestring : NULL;
}

static char *dup_str(const char *s)
{
    const size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

/* ---- reading files and URIs -------------------------------------------------- */

static mr_status read_whole(const char *path, const char *name, gl_blob *b, mr_error *err)
{
    mr_mapped_file f;
    mr_status st = mr_map_file(path, &f, err);
    if (st != MR_OK)
        return st;
    b->size = f.size;
    b->data = malloc(f.size + 1);
    if (!b->data) {
        mr_unmap_file(&f);
        return mr_fail_nomem(err, name, f.size);
    }
    if (f.size)
        memcpy(b->data, f.data, f.size);
    mr_unmap_file(&f);
    return MR_OK;
}

static int b64_value(int c)
{
    if (c >= 'A' && c <= 'Z')
        return c - 'A';
    if (c >= 'a' && c <= 'z')
        return c - 'a' + 26;
    if (c >= '0' && c <= '9')
        return c - '0' + 52;
    if (c == '+' || c == '-')
        return 62;
    if (c == '/' || c == '_')
        return 63;
    return -1;
}

static bool base64_decode(const char *s, gl_blob *b)
{
    const size_t n = strlen(s);
    b->data = malloc(n / 4 * 3 + 4);
    b->size = 0;
    if (!b->data)
        return false;
    uint32_t acc = 0;
    int bits = 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] == '=')
            break;
        const int v = b64_value((unsigned char)s[i]);
        if (v < 0) {
            free(b->data);
            b->data = NULL;
            return false;
        }
        acc = acc << 6 | (uint32_t)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            b->data[b->size++] = (uint8_t)(acc >> bits);
        }
    }
    return true;
}

static int hex_value(int c)
{
    return c >= '0' && c <= '9' ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
}

/* A relative URI as a path under base (percent-decoded), refusing one
 * that names a scheme, an absolute path or a folder above base. */
static mr_status uri_path(const mr_gltf *g, const char *uri, const char *what, char *path,
                          size_t cap, mr_error *err)
{
    char dec[4096];
    size_t n = 0;
    for (const char *p = uri; *p; p++) {
        int c = (unsigned char)*p;
        if (c == '%' && hex_value((unsigned char)p[1]) >= 0 && hex_value((unsigned char)p[2]) >= 0) {
            c = hex_value((unsigned char)p[1]) * 16 + hex_value((unsigned char)p[2]);
            p += 2;
        }
        if (c == 0 || n + 1 >= sizeof dec)
            return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: URI \"%.200s\" is not a file name",
                                 what, uri);
        dec[n++] = (char)c;
    }
    dec[n] = 0;
    const char *colon = strchr(dec, ':'), *slash = strchr(dec, '/');
    if (dec[0] == '/' || dec[0] == '\\' || (colon && (!slash || colon < slash)))
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, g->name,
                             "%s: URI \"%.200s\" is not a path relative to the file's folder",
                             what, uri);
    /* no step above the folder */
    int depth = 0;
    for (const char *p = dec; *p;) {
        const char *e = p;
        while (*e && *e != '/' && *e != '\\')
            e++;
        if (e - p == 2 && p[0] == '.' && p[1] == '.')
            depth--;
        else if (!(e - p == 1 && p[0] == '.') && e > p)
            depth++;
        if (depth < 0)
            return mr_fail_plain(err, MR_ERR_UNSUPPORTED, g->name,
                                 "%s: URI \"%.200s\" leaves the file's folder", what, uri);
        p = *e ? e + 1 : e;
    }
    if (!g->base)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, g->name,
                             "%s: external file \"%.200s\" cannot be read here (a document "
                             "read from memory reads only its own data)",
                             what, uri);
    if ((size_t)snprintf(path, cap, "%s/%s", g->base, dec) >= cap)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, g->name, "%s: path too long", what);
    return MR_OK;
}

/* The bytes a URI names: data: (base64) or a file beside the document. */
static mr_status uri_bytes(const mr_gltf *g, const char *uri, const char *what, gl_blob *b,
                           mr_error *err)
{
    memset(b, 0, sizeof *b);
    if (strncmp(uri, "data:", 5) == 0) {
        const char *comma = strchr(uri, ',');
        if (!comma || comma - uri < 12 || strncmp(comma - 7, ";base64", 7) != 0)
            return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                 "%s: a data: URI that is not base64", what);
        if (!base64_decode(comma + 1, b))
            return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: bad base64 in its data: URI",
                                 what);
        return MR_OK;
    }
    char path[4200];
    mr_status st = uri_path(g, uri, what, path, sizeof path, err);
    if (st != MR_OK)
        return st;
    st = read_whole(path, g->name, b, err);
    if (st != MR_OK && err) {
        char why[sizeof err->message]; /* copied first: the two share the buffer */
        snprintf(why, sizeof why, "%s", err->message);
        return mr_fail_plain(err, MR_ERR_IO, g->name, "%s: cannot read \"%.200s\" (%s)", what,
                             uri, why);
    }
    if (st != MR_OK)
        return st;
    return MR_OK;
}

/* ---- loading ------------------------------------------------------------------ */

static const char *const compressed[] = {"KHR_draco_mesh_compression", "EXT_meshopt_compression"};

static mr_status check_extensions(const mr_gltf *g, mr_error *err)
{
    static const char *const lists[2] = {"extensionsUsed", "extensionsRequired"};
    for (int l = 0; l < 2; l++) {
        const cJSON *a = member(g->root, lists[l]), *x;
        cJSON_ArrayForEach(x, a)
        {
            if (!cJSON_IsString(x))
                continue;
            for (size_t k = 0; k < sizeof compressed / sizeof *compressed; k++)
                if (strcmp(x->valuestring, compressed[k]) == 0)
                    return mr_fail_plain(
                        err, MR_ERR_UNSUPPORTED, g->name,
                        "its geometry is compressed (%s), which meshreduce does not decode: "
                        "write it uncompressed first (for instance `gltf-transform copy IN OUT` "
                        "or `gltfpack -i IN -o OUT -noq` without -cc)",
                        compressed[k]);
        }
    }
    return MR_OK;
}

static mr_status load_buffers(mr_gltf *g, const gl_blob *bin, mr_error *err)
{
    const cJSON *bufs = member(g->root, "buffers");
    g->nbuf = (size_t)array_size(bufs);
    g->buf = calloc(g->nbuf + 1, sizeof *g->buf);
    if (!g->buf)
        return mr_fail_nomem(err, g->name, g->nbuf * sizeof *g->buf);
    for (size_t i = 0; i < g->nbuf; i++) {
        const cJSON *b = cJSON_GetArrayItem(bufs, (int)i);
        long long length;
        mr_status st = need_index(g, b, "buffers", (long long)i, "byteLength", -1, &length, err);
        if (st != MR_OK)
            return st;
        const char *uri = str(b, "uri");
        char what[48];
        snprintf(what, sizeof what, "buffers[%zu]", i);
        gl_blob d = {0};
        if (!uri) {
            if (i != 0 || !bin)
                return bad(g, "%s[%lld]", "buffers", (long long)i,
                           "no uri (only a .glb's first buffer, its BIN chunk, has none)", err);
            d.data = malloc(bin->size + 1);
            if (!d.data)
                return mr_fail_nomem(err, g->name, bin->size);
            memcpy(d.data, bin->data, bin->size);
            d.size = bin->size;
        } else if ((st = uri_bytes(g, uri, what, &d, err)) != MR_OK) {
            return st;
        }
        if (d.size < (unsigned long long)length) {
            free(d.data);
            return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                 "buffers[%zu]: byteLength %lld, but its data holds %zu bytes", i,
                                 length, d.size);
        }
        d.size = (size_t)length;
        g->buf[i] = d;
    }
    return MR_OK;
}

static bool is_triangles(long long mode) { return mode == 4 || mode == 5 || mode == 6; }

static mr_status list_primitives(mr_gltf *g, mr_error *err)
{
    const cJSON *meshes = member(g->root, "meshes");
    size_t n = 0;
    for (int m = 0; m < array_size(meshes); m++)
        n += (size_t)array_size(member(cJSON_GetArrayItem(meshes, m), "primitives"));
    g->prims = calloc(n + 1, sizeof *g->prims);
    if (!g->prims)
        return mr_fail_nomem(err, g->name, n * sizeof *g->prims);
    for (int m = 0; m < array_size(meshes); m++) {
        const cJSON *prims = member(cJSON_GetArrayItem(meshes, m), "primitives");
        for (int p = 0; p < array_size(prims); p++) {
            long long mode;
            if (get_index(cJSON_GetArrayItem(prims, p), "mode", 4, &mode) < 0 || mode > 6)
                return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                     "meshes[%d].primitives[%d]: mode is not 0 to 6", m, p);
            if (is_triangles(mode))
                g->prims[g->nprims++] = (gl_prim){(size_t)m, (size_t)p};
        }
    }
    return MR_OK;
}

void mr_gltf_free(mr_gltf *g)
{
    if (!g)
        return;
    cJSON_Delete(g->root);
    for (size_t i = 0; i < g->nbuf; i++)
        free(g->buf[i].data);
    for (size_t i = 0; i < g->nadded; i++)
        free(g->added[i].data);
    free(g->buf);
    free(g->added);
    free(g->prims);
    free(g->name);
    free(g->base);
    free(g);
}

mr_status mr_gltf_load(const void *data, size_t size, const char *name, const char *base_dir,
                       mr_gltf **out, mr_error *err)
{
    *out = NULL;
    mr_gltf *g = calloc(1, sizeof *g);
    if (!g)
        return mr_fail_nomem(err, name, sizeof *g);
    g->name = dup_str(name ? name : "(glTF)");
    g->base = base_dir ? dup_str(base_dir) : NULL;
    if (!g->name || (base_dir && !g->base)) {
        mr_gltf_free(g);
        return mr_fail_nomem(err, name, 4096);
    }
    const uint8_t *d = data;
    const char *json = data;
    size_t json_size = size;
    gl_blob bin = {0};
    bool have_bin = false;
    mr_status st = MR_OK;
    if (size >= 4 && le32(d) == GLB_MAGIC) {
        /* .glb: a header, a JSON chunk, a BIN chunk perhaps */
        if (size < 20)
            st = mr_fail_plain(err, MR_ERR_PARSE, name, "offset 0: a .glb header of %zu bytes",
                               size);
        else if (le32(d + 4) != 2)
            st = mr_fail_plain(err, MR_ERR_UNSUPPORTED, name,
                               "offset 4: .glb version %u (meshreduce reads glTF 2.0)",
                               le32(d + 4));
        else if (le32(d + 8) > size || le32(d + 8) < 20)
            st = mr_fail_plain(err, MR_ERR_PARSE, name,
                               "offset 8: the .glb says %u bytes, the file has %zu", le32(d + 8),
                               size);
        else if (le32(d + 16) != GLB_JSON || (size_t)le32(d + 12) > (size_t)le32(d + 8) - 20)
            st = mr_fail_plain(err, MR_ERR_PARSE, name,
                               "offset 12: the first chunk is not JSON within the file");
        if (st == MR_OK) {
            const size_t total = le32(d + 8);
            json = (const char *)d + 20;
            json_size = le32(d + 12);
            size_t at = 20 + ((json_size + 3) & ~(size_t)3);
            if (at + 8 <= total && le32(d + at + 4) == GLB_BIN) {
                const size_t n = le32(d + at);
                if (n > total - at - 8)
                    st = mr_fail_plain(err, MR_ERR_PARSE, name,
                                       "offset %zu: a BIN chunk of %zu bytes past the file's end",
                                       at, n);
                bin.data = (uint8_t *)(d + at + 8);
                bin.size = n;
                have_bin = true;
            }
        }
    }
    if (st == MR_OK) {
        if (json_size >= 3 && memcmp(json, "\xEF\xBB\xBF", 3) == 0)
            json += 3, json_size -= 3; /* a UTF-8 byte-order mark */
        const char *end = NULL;
        g->root = cJSON_ParseWithLengthOpts(json, json_size, &end, false);
        if (!g->root) {
            const char *at = cJSON_GetErrorPtr();
            size_t off = at && at >= json && at <= json + json_size ? (size_t)(at - json) : 0;
            size_t line = 1;
            for (size_t i = 0; i < off; i++)
                line += json[i] == '\n';
            st = mr_fail_plain(err, MR_ERR_PARSE, name, "line %zu (offset %zu): bad JSON", line,
                               off);
        } else if (!cJSON_IsObject(g->root)) {
            st = mr_fail_plain(err, MR_ERR_PARSE, name, "the JSON is not an object");
        }
    }
    if (st == MR_OK) {
        const char *version = str(member(g->root, "asset"), "version");
        if (!version)
            st = mr_fail_plain(err, MR_ERR_PARSE, name, "no asset.version: not a glTF file");
        else if (strncmp(version, "2.", 2) != 0)
            st = mr_fail_plain(err, MR_ERR_UNSUPPORTED, name,
                               "glTF version %.20s (meshreduce reads glTF 2.0)", version);
    }
    if (st == MR_OK)
        st = check_extensions(g, err);
    if (st == MR_OK)
        st = load_buffers(g, have_bin ? &bin : NULL, err);
    if (st == MR_OK)
        st = list_primitives(g, err);
    g->input_views = (size_t)array_size(member(g->root, "bufferViews"));
    g->input_meshes = array_size(member(g->root, "meshes"));
    g->input_nodes = array_size(member(g->root, "nodes"));
    if (st != MR_OK) {
        mr_gltf_free(g);
        return st;
    }
    *out = g;
    return MR_OK;
}

mr_status mr_gltf_load_file(const char *path, mr_gltf **out, mr_error *err)
{
    *out = NULL;
    gl_blob b;
    mr_status st = read_whole(path, path, &b, err);
    if (st != MR_OK)
        return st;
    char dir[4200];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == path)
        snprintf(dir, sizeof dir, "/");
    else
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    st = b.size ? mr_gltf_load(b.data, b.size, path, dir, out, err)
                : mr_fail_plain(err, MR_ERR_EMPTY, path, "file is empty");
    free(b.data);
    return st;
}

/* ---- accessors ---------------------------------------------------------------- */

static int type_components(const char *type)
{
    static const struct {
        const char *name;
        int n;
    } t[] = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
             {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
    for (size_t i = 0; type && i < sizeof t / sizeof *t; i++)
        if (strcmp(type, t[i].name) == 0)
            return t[i].n;
    return 0;
}

static int component_size(long long ctype)
{
    switch (ctype) {
    case GL_BYTE:
    case GL_UNSIGNED_BYTE: return 1;
    case GL_SHORT:
    case GL_UNSIGNED_SHORT: return 2;
    case GL_UNSIGNED_INT:
    case GL_FLOAT: return 4;
    default: return 0;
    }
}

static double decode(const uint8_t *p, long long ctype, bool normalized)
{
    switch (ctype) {
    case GL_BYTE: {
        const double v = (int8_t)p[0];
        return normalized ? fmax(v / 127.0, -1.0) : v;
    }
    case GL_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
    case GL_SHORT: {
        const double v = (int16_t)(uint16_t)(p[0] | p[1] << 8);
        return normalized ? fmax(v / 32767.0, -1.0) : v;
    }
    case GL_UNSIGNED_SHORT: {
        const double v = (uint16_t)(p[0] | p[1] << 8);
        return normalized ? v / 65535.0 : v;
    }
    case GL_UNSIGNED_INT: return (double)le32(p);
    default: {
        const uint32_t b = le32(p);
        float f;
        memcpy(&f, &b, 4);
        return f;
    }
    }
}

typedef struct gl_acc {
    size_t count;
    int comps;
    long long ctype;
    bool normalized;
} gl_acc;

/* bufferViews[view]'s bytes: *bytes, *length; *stride (0: none given). */
static mr_status view_bytes(const mr_gltf *g, long long view, const uint8_t **bytes,
                            size_t *length, size_t *stride, mr_error *err)
{
    const cJSON *bv = item(g->root, "bufferViews", view);
    if (!bv)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "bufferViews[%lld]: there is none",
                             view);
    long long b, off, len, str;
    mr_status st;
    if ((st = need_index(g, bv, "bufferViews", view, "buffer", -1, &b, err)) != MR_OK ||
        (st = need_index(g, bv, "bufferViews", view, "byteOffset", 0, &off, err)) != MR_OK ||
        (st = need_index(g, bv, "bufferViews", view, "byteLength", -1, &len, err)) != MR_OK ||
        (st = need_index(g, bv, "bufferViews", view, "byteStride", 0, &str, err)) != MR_OK)
        return st;
    if ((size_t)b >= g->nbuf || b < 0)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                             "bufferViews[%lld]: buffer %lld, but there are %zu", view, b,
                             g->nbuf);
    if ((unsigned long long)off > g->buf[b].size ||
        (unsigned long long)len > g->buf[b].size - (size_t)off)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                             "bufferViews[%lld]: bytes %lld..%lld past buffers[%lld]'s %zu", view,
                             off, off + len, b, g->buf[b].size);
    if (str && (str < 4 || str > 252))
        return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                             "bufferViews[%lld]: byteStride %lld is not 4 to 252", view, str);
    *bytes = g->buf[b].data + off;
    *length = (size_t)len;
    *stride = (size_t)str;
    return MR_OK;
}

/* Accessor `index` decoded into a new array of count * comps doubles
 * (normalised integers scaled, the sparse substitutions made). */
static mr_status acc_read(const mr_gltf *g, long long index, double **out, gl_acc *info,
                          mr_error *err)
{
    *out = NULL;
    const cJSON *a = item(g->root, "accessors", index);
    if (!a)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "accessors[%lld]: there is none", index);
    long long ctype, count, off, view;
    mr_status st;
    if ((st = need_index(g, a, "accessors", index, "componentType", -1, &ctype, err)) != MR_OK ||
        (st = need_index(g, a, "accessors", index, "count", -1, &count, err)) != MR_OK ||
        (st = need_index(g, a, "accessors", index, "byteOffset", 0, &off, err)) != MR_OK)
        return st;
    const int has_view = get_index(a, "bufferView", -1, &view);
    const int comps = type_components(str(a, "type"));
    const int csize = component_size(ctype);
    if (!comps || !csize || has_view < 0)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                             "accessors[%lld]: type \"%.20s\", componentType %lld, bufferView: "
                             "not a valid combination",
                             index, str(a, "type") ? str(a, "type") : "(none)", ctype);
    if (comps > 4 && csize < 4)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, g->name,
                             "accessors[%lld]: matrices of 1- or 2-byte components", index);
    const cJSON *norm = member(a, "normalized");
    const bool normalized = norm && cJSON_IsTrue(norm);
    const size_t elem = (size_t)comps * (size_t)csize;
    /* an accessor without a view is zeros (and its sparse values): bound
     * its count by the data there is, so that a few bytes cannot ask for
     * gigabytes */
    size_t total = 0;
    for (size_t i = 0; i < g->nbuf; i++)
        total += g->buf[i].size;
    if (count < 1 || (unsigned long long)count > UINT32_MAX ||
        (has_view == 0 && (unsigned long long)count > 64 * (unsigned long long)total + 65536))
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "accessors[%lld]: count %lld", index,
                             count);
    const uint8_t *bytes = NULL;
    size_t length = 0, stride = 0;
    if (has_view == 1) {
        if ((st = view_bytes(g, view, &bytes, &length, &stride, err)) != MR_OK)
            return st;
        if (!stride)
            stride = elem;
        if (stride < elem || (unsigned long long)off > length || length - (size_t)off < elem ||
            (unsigned long long)(count - 1) > (length - (size_t)off - elem) / stride)
            return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                 "accessors[%lld]: %lld elements of %zu bytes from offset %lld, "
                                 "stride %zu, run past bufferViews[%lld] (%zu bytes)",
                                 index, count, elem, off, stride, view, length);
    }
    double *v = mr_alloc_array((size_t)count, (size_t)comps * sizeof *v);
    if (!v)
        return mr_fail_nomem(err, g->name, (size_t)count * (size_t)comps * sizeof *v);
    for (size_t e = 0; e < (size_t)count; e++)
        for (int c = 0; c < comps; c++)
            v[e * (size_t)comps + (size_t)c] =
                bytes ? decode(bytes + (size_t)off + e * stride + (size_t)c * (size_t)csize, ctype,
                               normalized)
                      : 0.0;
    const cJSON *sp = member(a, "sparse");
    if (sp) {
        long long n, iv, ioff, ictype, vv, voff;
        const cJSON *si = member(sp, "indices"), *sv = member(sp, "values");
        if ((st = need_index(g, sp, "accessors", index, "count", -1, &n, err)) != MR_OK ||
            (st = need_index(g, si, "accessors", index, "bufferView", -1, &iv, err)) != MR_OK ||
            (st = need_index(g, si, "accessors", index, "byteOffset", 0, &ioff, err)) != MR_OK ||
            (st = need_index(g, si, "accessors", index, "componentType", -1, &ictype, err)) !=
                MR_OK ||
            (st = need_index(g, sv, "accessors", index, "bufferView", -1, &vv, err)) != MR_OK ||
            (st = need_index(g, sv, "accessors", index, "byteOffset", 0, &voff, err)) != MR_OK) {
            free(v);
            return st;
        }
        const int isize = ictype == GL_UNSIGNED_BYTE || ictype == GL_UNSIGNED_SHORT ||
                                  ictype == GL_UNSIGNED_INT
                              ? component_size(ictype)
                              : 0;
        const uint8_t *ib, *vb;
        size_t il, vl, is, vs;
        if (st == MR_OK && (st = view_bytes(g, iv, &ib, &il, &is, err)) == MR_OK)
            st = view_bytes(g, vv, &vb, &vl, &vs, err);
        if (st == MR_OK &&
            (!isize || n < 1 || n > count || (unsigned long long)ioff > il ||
             (unsigned long long)n > (il - (size_t)ioff) / (size_t)isize ||
             (unsigned long long)voff > vl || (unsigned long long)n > (vl - (size_t)voff) / elem))
            st = mr_fail_plain(err, MR_ERR_PARSE, g->name,
                               "accessors[%lld].sparse: %lld entries do not fit their views or "
                               "the accessor",
                               index, n);
        for (long long k = 0; st == MR_OK && k < n; k++) {
            const double at = decode(ib + (size_t)ioff + (size_t)k * (size_t)isize, ictype, false);
            if (at >= (double)count) {
                st = mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                   "accessors[%lld].sparse: index %.0f past its %lld elements",
                                   index, at, count);
                break;
            }
            for (int c = 0; c < comps; c++)
                v[(size_t)at * (size_t)comps + (size_t)c] =
                    decode(vb + (size_t)voff + (size_t)k * elem + (size_t)c * (size_t)csize, ctype,
                           normalized);
        }
        if (st != MR_OK) {
            free(v);
            return st;
        }
    }
    for (size_t i = 0; i < (size_t)count * (size_t)comps; i++)
        if (!isfinite(v[i])) {
            free(v);
            return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                 "accessors[%lld]: element %zu is not finite", index,
                                 i / (size_t)comps);
        }
    info->count = (size_t)count;
    info->comps = comps;
    info->ctype = ctype;
    info->normalized = normalized;
    *out = v;
    return MR_OK;
}

/* ---- primitives ----------------------------------------------------------------- */

typedef struct gl_attr {
    const char *name;   /* the key in "attributes" (the document's string) */
    long long accessor;
    double *data;
    gl_acc info;
} gl_attr;

typedef struct gl_prim_data {
    const cJSON *json;
    size_t nv;          /* the vertices (POSITION's count) */
    gl_attr *attr;      /* "attributes", in the document's order */
    int nattr;
    gl_attr *target;    /* each morph target's attributes, flat */
    int *target_start;  /* ntarget + 1 */
    int ntarget;
    uint32_t *tri;      /* triangles, by welded vertex */
    size_t nt;
    /* the vertices welded: those equal in every attribute and target are
     * one (a non-indexed primitive's corners, an exporter's copies) */
    uint32_t *first;    /* welded vertex -> its first vertex */
    size_t nw;
} gl_prim_data;

static void prim_free(gl_prim_data *p)
{
    for (int i = 0; i < p->nattr; i++)
        free(p->attr[i].data);
    for (int i = 0; p->target_start && i < p->target_start[p->ntarget]; i++)
        free(p->target[i].data);
    free(p->attr);
    free(p->target);
    free(p->target_start);
    free(p->tri);
    free(p->first);
    memset(p, 0, sizeof *p);
}

static const gl_attr *find_attr(const gl_prim_data *p, const char *name)
{
    for (int i = 0; i < p->nattr; i++)
        if (strcmp(p->attr[i].name, name) == 0)
            return &p->attr[i];
    return NULL;
}

static mr_status read_attrs(const mr_gltf *g, const cJSON *obj, const char *where, size_t nv,
                            gl_attr *out, int *n, mr_error *err)
{
    const cJSON *x;
    *n = 0;
    cJSON_ArrayForEach(x, obj)
    {
        gl_attr *a = &out[*n];
        a->name = x->string;
        if (!cJSON_IsNumber(x) || x->valuedouble < 0 || x->valuedouble > 2147483647.0 ||
            x->valuedouble != floor(x->valuedouble))
            return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: attribute %s is not an index",
                                 where, x->string);
        a->accessor = (long long)x->valuedouble;
        mr_status st = acc_read(g, a->accessor, &a->data, &a->info, err);
        if (st != MR_OK)
            return st;
        (*n)++;
        if (nv && a->info.count != nv)
            return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                 "%s: attribute %s has %zu elements, POSITION %zu", where,
                                 x->string, a->info.count, nv);
    }
    return MR_OK;
}

/* Vertex v's value k of all its attributes and targets. */
static bool same_vertex(const gl_prim_data *p, size_t a, size_t b)
{
    for (int i = 0; i < p->nattr; i++) {
        const size_t c = (size_t)p->attr[i].info.comps;
        if (memcmp(p->attr[i].data + c * a, p->attr[i].data + c * b, c * sizeof(double)) != 0)
            return false;
    }
    for (int i = 0; i < p->target_start[p->ntarget]; i++) {
        const size_t c = (size_t)p->target[i].info.comps;
        if (memcmp(p->target[i].data + c * a, p->target[i].data + c * b, c * sizeof(double)) != 0)
            return false;
    }
    return true;
}

static uint64_t vertex_hash(const gl_prim_data *p, size_t v)
{
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int i = 0; i < p->nattr + p->target_start[p->ntarget]; i++) {
        const gl_attr *a = i < p->nattr ? &p->attr[i] : &p->target[i - p->nattr];
        const size_t c = (size_t)a->info.comps;
        for (size_t k = 0; k < c; k++) {
            uint64_t bits;
            memcpy(&bits, a->data + c * v + k, 8);
            h = (h ^ bits) * 0xFF51AFD7ED558CCDull;
            h ^= h >> 32;
        }
    }
    return h;
}

/* p->first and p->nw: the vertices the triangles use, equal ones once, in
 * the vertices' order (a primitive without copies keeps its own); p->tri
 * renumbered. */
static mr_status weld(const mr_gltf *g, gl_prim_data *p, mr_error *err)
{
    size_t cap = 16;
    while (cap < 2 * p->nv)
        cap *= 2;
    uint32_t *slot = mr_alloc_array(cap, sizeof *slot), *to = mr_alloc_array(p->nv + 1, sizeof *to);
    p->first = mr_alloc_array(p->nv + 1, sizeof *p->first);
    if (!slot || !to || !p->first) {
        free(slot), free(to);
        return mr_fail_nomem(err, g->name, cap * 4 + p->nv * 8);
    }
    memset(slot, 0xFF, cap * sizeof *slot);
    memset(to, 0, (p->nv + 1) * sizeof *to);
    for (size_t c = 0; c < 3 * p->nt; c++)
        to[p->tri[c]] = 1; /* used */
    p->nw = 0;
    for (size_t v = 0; v < p->nv; v++) {
        if (!to[v])
            continue;
        size_t s = (size_t)vertex_hash(p, v) & (cap - 1);
        while (slot[s] != UINT32_MAX && !same_vertex(p, p->first[slot[s]], v))
            s = (s + 1) & (cap - 1);
        if (slot[s] == UINT32_MAX) {
            slot[s] = (uint32_t)p->nw;
            p->first[p->nw++] = (uint32_t)v;
        }
        to[v] = slot[s];
    }
    for (size_t c = 0; c < 3 * p->nt; c++)
        p->tri[c] = to[p->tri[c]];
    free(slot);
    free(to);
    return MR_OK;
}

static mr_status prim_read(const mr_gltf *g, size_t mi, size_t pi, gl_prim_data *p,
                           mr_error *err)
{
    memset(p, 0, sizeof *p);
    char where[96];
    snprintf(where, sizeof where, "meshes[%zu].primitives[%zu]", mi, pi);
    const cJSON *prim = cJSON_GetArrayItem(member(item(g->root, "meshes", (long long)mi), "primitives"),
                                           (int)pi);
    p->json = prim;
    const cJSON *attrs = member(prim, "attributes");
    const cJSON *pos = member(attrs, "POSITION");
    if (!pos)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: no POSITION attribute", where);
    const int na = cJSON_GetArraySize(attrs);
    p->attr = calloc((size_t)na + 1, sizeof *p->attr);
    if (!p->attr)
        return mr_fail_nomem(err, g->name, 64);
    mr_status st = read_attrs(g, attrs, where, 0, p->attr, &p->nattr, err);
    if (st != MR_OK)
        return st;
    const gl_attr *P = find_attr(p, "POSITION");
    if (P->info.comps != 3)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: POSITION is not VEC3", where);
    p->nv = P->info.count;
    for (int i = 0; i < p->nattr; i++)
        if (p->attr[i].info.count != p->nv)
            return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                 "%s: attribute %s has %zu elements, POSITION %zu", where,
                                 p->attr[i].name, p->attr[i].info.count, p->nv);
    /* morph targets */
    const cJSON *targets = member(prim, "targets");
    p->ntarget = array_size(targets);
    int nta = 0;
    for (int t = 0; t < p->ntarget; t++)
        nta += cJSON_GetArraySize(cJSON_GetArrayItem(targets, t));
    p->target = calloc((size_t)nta + 1, sizeof *p->target);
    p->target_start = calloc((size_t)p->ntarget + 1, sizeof *p->target_start);
    if (!p->target || !p->target_start)
        return mr_fail_nomem(err, g->name, 64);
    for (int t = 0; t < p->ntarget; t++) {
        int n = 0;
        char tw[128];
        snprintf(tw, sizeof tw, "%s.targets[%d]", where, t);
        st = read_attrs(g, cJSON_GetArrayItem(targets, t), tw, p->nv,
                        p->target + p->target_start[t], &n, err);
        p->target_start[t + 1] = p->target_start[t] + n;
        if (st != MR_OK) {
            /* the ones read so far are freed with the rest */
            for (int k = t + 1; k <= p->ntarget; k++)
                p->target_start[k] = p->target_start[t] + n;
            return st;
        }
    }
    /* the corners, then the triangles by the mode */
    long long mode, idx;
    get_index(prim, "mode", 4, &mode);
    const int has_idx = get_index(prim, "indices", -1, &idx);
    if (has_idx < 0)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: indices is not an index", where);
    size_t nc = p->nv;
    double *ci = NULL;
    if (has_idx == 1) {
        gl_acc info;
        if ((st = acc_read(g, idx, &ci, &info, err)) != MR_OK)
            return st;
        if (info.comps != 1 || (info.ctype != GL_UNSIGNED_BYTE && info.ctype != GL_UNSIGNED_SHORT &&
                                info.ctype != GL_UNSIGNED_INT)) {
            free(ci);
            return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                 "%s: indices (accessors[%lld]) are not unsigned integer scalars",
                                 where, idx);
        }
        nc = info.count;
        for (size_t c = 0; c < nc; c++)
            if (ci[c] >= (double)p->nv) {
                const double bad_index = ci[c];
                free(ci);
                return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                     "%s: index %zu is %.0f, but there are %zu vertices", where, c,
                                     bad_index, p->nv);
            }
    }
    const size_t max_t = mode == 4 ? nc / 3 : nc >= 3 ? nc - 2 : 0;
    p->tri = mr_alloc_array(max_t + 1, 3 * sizeof *p->tri);
    if (!p->tri) {
        free(ci);
        return mr_fail_nomem(err, g->name, max_t * 12);
    }
    if (mode == 4 && nc % 3) {
        free(ci);
        return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                             "%s: %zu corners for triangles, not a multiple of 3", where, nc);
    }
    for (size_t t = 0; t < max_t; t++) {
        size_t c[3];
        if (mode == 4)
            c[0] = 3 * t, c[1] = 3 * t + 1, c[2] = 3 * t + 2;
        else if (mode == 5)
            c[0] = t + (t & 1), c[1] = t + 1 - (t & 1), c[2] = t + 2;
        else
            c[0] = 0, c[1] = t + 1, c[2] = t + 2;
        uint32_t v[3];
        for (int k = 0; k < 3; k++)
            v[k] = ci ? (uint32_t)ci[c[k]] : (uint32_t)c[k];
        if (mode != 4 && (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]))
            continue; /* a strip's or fan's stitch */
        memcpy(p->tri + 3 * p->nt++, v, sizeof v);
    }
    free(ci);
    return weld(g, p, err);
}

size_t mr_gltf_primitive_count(const mr_gltf *g) { return g ? g->nprims : 0; }

void mr_gltf_primitive_at(const mr_gltf *g, size_t i, size_t *mesh, size_t *primitive)
{
    *mesh = g->prims[i].mesh;
    *primitive = g->prims[i].prim;
}

/* The mesh of a read primitive, its positions (and normals) under the
 * 4x4 column-major matrix x (NULL: as they are). */
static mr_status prim_mesh(const mr_gltf *g, const gl_prim_data *p, const double *x,
                           long long material, mr_mesh *out, mr_error *err)
{
    const gl_attr *N = find_attr(p, "NORMAL"), *T = find_attr(p, "TEXCOORD_0"),
                  *C = find_attr(p, "COLOR_0"), *P = find_attr(p, "POSITION"),
                  *TA = find_attr(p, "TANGENT"), *J = find_attr(p, "JOINTS_0"),
                  *W = find_attr(p, "WEIGHTS_0"), *TM[MR_MORE_TEXCOORDS];
    if (N && N->info.comps != 3)
        N = NULL;
    if (T && T->info.comps != 2)
        T = NULL;
    if (C && C->info.comps != 3 && C->info.comps != 4)
        C = NULL;
    if (TA && TA->info.comps != 4)
        TA = NULL;
    if (!J || !W || J->info.comps != 4 || W->info.comps != 4)
        J = W = NULL;
    if (material >= (long long)UINT32_MAX)
        material = -1;
    unsigned flags = (N ? MR_ATTR_NORMALS : 0) | (T ? MR_ATTR_TEXCOORDS : 0) |
                     (C ? MR_ATTR_COLORS : 0) | (TA ? MR_ATTR_TANGENTS : 0) |
                     (J ? MR_ATTR_SKIN : 0) | (material >= 0 ? MR_ATTR_MATERIALS : 0);
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++) {
        char name[16];
        snprintf(name, sizeof name, "TEXCOORD_%d", k + 1);
        TM[k] = find_attr(p, name);
        if (TM[k] && TM[k]->info.comps != 2)
            TM[k] = NULL;
        flags |= TM[k] ? MR_ATTR_TEXCOORDS1 << k : 0;
    }
    mr_status st = mr_mesh_alloc(out, p->nw, p->nt, flags, err);
    if (st != MR_OK)
        return st;
    double n3[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (x) {
        /* the normals' matrix: the inverse transpose of x's 3x3 */
        const double a = x[0], b = x[4], c = x[8], d = x[1], e = x[5], f = x[9], gg = x[2],
                     h = x[6], i = x[10];
        n3[0] = e * i - f * h, n3[1] = -(b * i - c * h), n3[2] = b * f - c * e;
        n3[3] = -(d * i - f * gg), n3[4] = a * i - c * gg, n3[5] = -(a * f - c * d);
        n3[6] = d * h - e * gg, n3[7] = -(a * h - b * gg), n3[8] = a * e - b * d;
        /* rows of the cofactor matrix = columns of the inverse transpose
         * (up to the determinant, which normalising removes) */
    }
    for (size_t w = 0; w < p->nw; w++) {
        const size_t v = p->first[w];
        const double *q = P->data + 3 * v;
        for (int k = 0; k < 3; k++)
            out->positions[3 * w + (size_t)k] =
                x ? (float)(x[k] * q[0] + x[4 + k] * q[1] + x[8 + k] * q[2] + x[12 + k])
                  : (float)q[k];
        if (N) {
            const double *m = N->data + 3 * v;
            double nn[3];
            for (int k = 0; k < 3; k++)
                nn[k] = n3[3 * k] * m[0] + n3[3 * k + 1] * m[1] + n3[3 * k + 2] * m[2];
            const double l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
            if (l > 0 && x)
                nn[0] /= l, nn[1] /= l, nn[2] /= l;
            for (int k = 0; k < 3; k++)
                out->normals[3 * w + (size_t)k] = (float)nn[k];
        }
        for (int k = 0; T && k < 2; k++)
            out->texcoords[2 * w + (size_t)k] = (float)T->data[2 * v + (size_t)k];
        for (int k = 0; C && k < 4; k++) /* rgb: alpha 1 */
            out->colors[4 * w + (size_t)k] =
                k < C->info.comps ? (float)C->data[(size_t)C->info.comps * v + (size_t)k] : 1.0f;
        for (int s = 0; s < MR_MORE_TEXCOORDS; s++)
            for (int k = 0; TM[s] && k < 2; k++)
                out->more_texcoords[s][2 * w + (size_t)k] = (float)TM[s]->data[2 * v + (size_t)k];
        for (int k = 0; J && k < 4; k++) {
            const double j = J->data[4 * v + (size_t)k];
            out->joints[4 * w + (size_t)k] = j >= 0 && j <= 65535 ? (uint16_t)j : 0;
            out->weights[4 * w + (size_t)k] = (float)W->data[4 * v + (size_t)k];
        }
    }
    const bool flip = x && (x[0] * (x[5] * x[10] - x[9] * x[6]) -
                            x[4] * (x[1] * x[10] - x[9] * x[2]) +
                            x[8] * (x[1] * x[6] - x[5] * x[2])) < 0;
    /* tangents: directions under x's 3x3 (a mirror turns the bitangent) */
    for (size_t w = 0; TA && w < p->nw; w++) {
        const double *q = TA->data + 4 * p->first[w];
        double t[3] = {q[0], q[1], q[2]};
        if (x) {
            for (int k = 0; k < 3; k++)
                t[k] = x[k] * q[0] + x[4 + k] * q[1] + x[8 + k] * q[2];
            const double l = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
            if (l > 0)
                t[0] /= l, t[1] /= l, t[2] /= l;
        }
        for (int k = 0; k < 3; k++)
            out->tangents[4 * w + (size_t)k] = (float)t[k];
        out->tangents[4 * w + 3] = (float)(flip ? -q[3] : q[3]);
    }
    for (size_t t = 0; out->materials && t < p->nt; t++)
        out->materials[t] = (uint32_t)material;
    for (size_t t = 0; t < p->nt; t++) {
        out->indices[3 * t] = p->tri[3 * t];
        out->indices[3 * t + 1] = p->tri[3 * t + (flip ? 2 : 1)];
        out->indices[3 * t + 2] = p->tri[3 * t + (flip ? 1 : 2)];
    }
    return MR_OK;
}

mr_status mr_gltf_primitive_mesh(const mr_gltf *g, size_t i, mr_mesh *out, mr_error *err)
{
    mr_mesh_init(out);
    gl_prim_data p;
    mr_status st = prim_read(g, g->prims[i].mesh, g->prims[i].prim, &p, err);
    long long material = -1;
    if (st == MR_OK && get_index(p.json, "material", -1, &material) != 1)
        material = -1;
    if (st == MR_OK)
        st = prim_mesh(g, &p, NULL, material, out, err);
    prim_free(&p);
    if (st != MR_OK)
        mr_mesh_free(out);
    return st;
}

/* ---- the scene ------------------------------------------------------------------ */

static void mat_mul(const double *a, const double *b, double *c)
{
    double r[16];
    for (int col = 0; col < 4; col++)
        for (int row = 0; row < 4; row++) {
            double s = 0;
            for (int k = 0; k < 4; k++)
                s += a[4 * k + row] * b[4 * col + k];
            r[4 * col + row] = s;
        }
    memcpy(c, r, sizeof r);
}

static bool numbers(const cJSON *a, int n, double *out)
{
    if (array_size(a) != n)
        return false;
    for (int i = 0; i < n; i++) {
        const cJSON *x = cJSON_GetArrayItem(a, i);
        if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble))
            return false;
        out[i] = x->valuedouble;
    }
    return true;
}

/* Node n's local matrix (matrix, or translation * rotation * scale). */
static mr_status node_matrix(const mr_gltf *g, const cJSON *node, long long n, double *m,
                             mr_error *err)
{
    static const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    memcpy(m, id, sizeof id);
    const cJSON *mx = member(node, "matrix");
    if (mx) {
        if (!numbers(mx, 16, m))
            return bad(g, "%s[%lld]", "nodes", n, "matrix is not 16 numbers", err);
        return MR_OK;
    }
    double t[3] = {0, 0, 0}, r[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    if ((member(node, "translation") && !numbers(member(node, "translation"), 3, t)) ||
        (member(node, "rotation") && !numbers(member(node, "rotation"), 4, r)) ||
        (member(node, "scale") && !numbers(member(node, "scale"), 3, s)))
        return bad(g, "%s[%lld]", "nodes", n, "translation, rotation or scale malformed", err);
    const double x = r[0], y = r[1], z = r[2], w = r[3];
    const double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                         2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                         2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    for (int c = 0; c < 3; c++)
        for (int row = 0; row < 3; row++)
            m[4 * c + row] = R[3 * c + row] * s[c];
    m[12] = t[0], m[13] = t[1], m[14] = t[2];
    return MR_OK;
}

typedef struct scene_acc {
    const mr_gltf *g;
    mr_mesh *parts;
    long long *material; /* each part's material, or -1 */
    size_t nparts, cap;
    uint8_t *on_path; /* per node: on the current path (a cycle) */
} scene_acc;

/* Room for one more part; its mesh empty, its material -1. */
static mr_status more_parts(scene_acc *s, mr_error *err)
{
    if (s->nparts == s->cap) {
        const size_t nc = s->cap ? 2 * s->cap : 8;
        mr_mesh *np = realloc(s->parts, nc * sizeof *np);
        if (np)
            s->parts = np;
        long long *nm = realloc(s->material, nc * sizeof *nm);
        if (nm)
            s->material = nm;
        if (!np || !nm)
            return mr_fail_nomem(err, s->g->name, nc * sizeof *np);
        s->cap = nc;
    }
    mr_mesh_init(&s->parts[s->nparts]);
    s->material[s->nparts] = -1;
    return MR_OK;
}

static mr_status visit(scene_acc *s, long long n, const double *parent, int depth, mr_error *err)
{
    const mr_gltf *g = s->g;
    const cJSON *node = item(g->root, "nodes", n);
    if (!node)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "nodes[%lld]: there is none", n);
    if (s->on_path[n] || depth > 4096)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                             "nodes[%lld]: the node hierarchy has a cycle", n);
    s->on_path[n] = 1;
    double local[16], world[16];
    mr_status st = node_matrix(g, node, n, local, err);
    if (st == MR_OK)
        mat_mul(parent, local, world);
    long long mi;
    const int has_mesh = get_index(node, "mesh", -1, &mi);
    if (st == MR_OK && has_mesh < 0)
        st = bad(g, "%s[%lld]", "nodes", n, "mesh is not an index", err);
    if (st == MR_OK && has_mesh == 1) {
        const cJSON *mesh = item(g->root, "meshes", mi);
        if (!mesh)
            st = mr_fail_plain(err, MR_ERR_PARSE, g->name, "nodes[%lld]: mesh %lld, there is none",
                               n, mi);
        const cJSON *prims = member(mesh, "primitives");
        for (int p = 0; st == MR_OK && p < array_size(prims); p++) {
            long long mode;
            get_index(cJSON_GetArrayItem(prims, p), "mode", 4, &mode);
            if (!is_triangles(mode))
                continue;
            if ((st = more_parts(s, err)) != MR_OK)
                break;
            gl_prim_data pd;
            get_index(cJSON_GetArrayItem(prims, p), "material", -1, &s->material[s->nparts]);
            st = prim_read(g, (size_t)mi, (size_t)p, &pd, err);
            /* (an identity transform leaves the positions' bits as they are) */
            static const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
            if (st == MR_OK)
                st = prim_mesh(g, &pd, memcmp(world, id, sizeof id) ? world : NULL,
                               s->material[s->nparts], &s->parts[s->nparts], err);
            prim_free(&pd);
            s->nparts++;
        }
    }
    const cJSON *children = member(node, "children");
    for (int c = 0; st == MR_OK && c < array_size(children); c++) {
        const cJSON *x = cJSON_GetArrayItem(children, c);
        if (!cJSON_IsNumber(x) || x->valuedouble < 0 ||
            x->valuedouble >= array_size(member(g->root, "nodes")))
            st = bad(g, "%s[%lld]", "nodes", n, "a child that is no node", err);
        else
            st = visit(s, (long long)x->valuedouble, world, depth + 1, err);
    }
    s->on_path[n] = 0;
    return st;
}

/* The default scene joined into one mesh (mr_gltf_scene_mesh). With
 * face_material (the look), texture coordinates are kept where any part
 * has them (zero elsewhere), colours become display values, and
 * *face_material receives each triangle's material (UINT32_MAX: none). */
static mr_status scene_join(const mr_gltf *g, mr_mesh *out, uint32_t **face_material,
                            mr_error *err)
{
    mr_mesh_init(out);
    scene_acc s = {g, NULL, NULL, 0, 0, NULL};
    const int nnodes = array_size(member(g->root, "nodes"));
    s.on_path = calloc((size_t)nnodes + 1, 1);
    if (!s.on_path)
        return mr_fail_nomem(err, g->name, (size_t)nnodes);
    static const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    mr_status st = MR_OK;
    const cJSON *scenes = member(g->root, "scenes");
    long long sc;
    const int has_scene = get_index(g->root, "scene", 0, &sc);
    if (has_scene < 0 || (array_size(scenes) && !item(g->root, "scenes", sc)))
        st = mr_fail_plain(err, MR_ERR_PARSE, g->name, "scene %lld: there is none", sc);
    if (st == MR_OK && array_size(scenes)) {
        const cJSON *roots = member(cJSON_GetArrayItem(scenes, (int)sc), "nodes");
        for (int r = 0; st == MR_OK && r < array_size(roots); r++) {
            const cJSON *x = cJSON_GetArrayItem(roots, r);
            if (!cJSON_IsNumber(x) || x->valuedouble < 0 || x->valuedouble >= nnodes)
                st = mr_fail_plain(err, MR_ERR_PARSE, g->name,
                                   "scenes[%lld]: a root that is no node", sc);
            else
                st = visit(&s, (long long)x->valuedouble, id, 0, err);
        }
    } else if (st == MR_OK) {
        /* no scene: every mesh once, as it is */
        for (size_t i = 0; st == MR_OK && i < g->nprims; i++) {
            if ((st = more_parts(&s, err)) != MR_OK)
                break;
            const cJSON *prim = cJSON_GetArrayItem(
                member(item(g->root, "meshes", (long long)g->prims[i].mesh), "primitives"),
                (int)g->prims[i].prim);
            get_index(prim, "material", -1, &s.material[s.nparts]);
            st = mr_gltf_primitive_mesh(g, i, &s.parts[s.nparts++], err);
        }
    }
    /* the parts joined: normals and texture coordinates where all have
     * them, colors where one has */
    size_t nv = 0, nt = 0;
    unsigned all = MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS | MR_ATTR_TEXCOORDS1 | MR_ATTR_TEXCOORDS2 |
                   MR_ATTR_TEXCOORDS3 | MR_ATTR_TANGENTS | MR_ATTR_SKIN,
             any = 0;
    for (size_t i = 0; i < s.nparts; i++) {
        nv += s.parts[i].vertex_count;
        nt += s.parts[i].triangle_count;
        all &= mr_mesh_attributes(&s.parts[i]);
        any |= mr_mesh_attributes(&s.parts[i]);
    }
    if (st == MR_OK && nv > UINT32_MAX)
        st = mr_fail_plain(err, MR_ERR_TOO_LARGE, g->name,
                           "%zu vertices in the scene exceed the 32-bit index limit", nv);
    if (st == MR_OK && nt == 0)
        st = mr_fail_plain(err, MR_ERR_EMPTY, g->name, "its scene holds no triangles");
    const unsigned flags = face_material ? (all & MR_ATTR_NORMALS) |
                                               (any & (MR_ATTR_TEXCOORDS | MR_ATTR_COLORS))
                                         : all | (any & (MR_ATTR_COLORS | MR_ATTR_MATERIALS));
    if (st == MR_OK)
        st = mr_mesh_alloc(out, nv, nt, flags, err);
    if (st == MR_OK && face_material) {
        *face_material = malloc(nt * sizeof **face_material);
        if (!*face_material)
            st = mr_fail_nomem(err, g->name, nt * sizeof **face_material);
    }
    size_t v0 = 0, t0 = 0;
    for (size_t i = 0; st == MR_OK && i < s.nparts; i++) {
        const mr_mesh *m = &s.parts[i];
        memcpy(out->positions + 3 * v0, m->positions, 12 * m->vertex_count);
        if (out->normals)
            memcpy(out->normals + 3 * v0, m->normals, 12 * m->vertex_count);
        /* v up, as OBJ and PLY have it: glTF's v points down the image */
        for (size_t v = 0; out->texcoords && m->texcoords && v < m->vertex_count; v++) {
            out->texcoords[2 * (v0 + v)] = m->texcoords[2 * v];
            out->texcoords[2 * (v0 + v) + 1] = 1.0f - m->texcoords[2 * v + 1];
        }
        if (out->texcoords && !m->texcoords)
            memset(out->texcoords + 2 * v0, 0, 8 * m->vertex_count);
        mr_mesh_copy_more(out, v0, m, 0, m->vertex_count);
        for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
            for (size_t v = 0; out->more_texcoords[k] && v < m->vertex_count; v++)
                out->more_texcoords[k][2 * (v0 + v) + 1] =
                    1.0f - out->more_texcoords[k][2 * (v0 + v) + 1];
        for (size_t t = 0; out->materials && t < m->triangle_count; t++)
            out->materials[t0 + t] = m->materials ? m->materials[t] : UINT32_MAX;
        for (size_t v = 0; out->colors && v < m->vertex_count; v++)
            for (int k = 0; k < 4; k++) {
                float c = m->colors ? m->colors[4 * v + (size_t)k] : 1.0f;
                if (face_material && k < 3) /* linear light to display values */
                    c = mr_linear_to_srgb(c);
                out->colors[4 * (v0 + v) + (size_t)k] = c;
            }
        for (size_t c = 0; c < 3 * m->triangle_count; c++)
            out->indices[3 * t0 + c] = m->indices[c] + (uint32_t)v0;
        for (size_t t = 0; face_material && t < m->triangle_count; t++)
            (*face_material)[t0 + t] = s.material[i] >= 0 ? (uint32_t)s.material[i] : UINT32_MAX;
        v0 += m->vertex_count;
        t0 += m->triangle_count;
    }
    for (size_t i = 0; i < s.nparts; i++)
        mr_mesh_free(&s.parts[i]);
    free(s.parts);
    free(s.material);
    free(s.on_path);
    if (st != MR_OK) {
        mr_mesh_free(out);
        if (face_material) {
            free(*face_material);
            *face_material = NULL;
        }
    }
    return st;
}

mr_status mr_gltf_scene_mesh(const mr_gltf *g, mr_mesh *out, mr_error *err)
{
    return scene_join(g, out, NULL, err);
}

/* ---- the look: materials and their base-colour textures ---------------------- */

static mr_wrap wrap_of(const cJSON *sampler, const char *key)
{
    long long w;
    get_index(sampler, key, 10497, &w);
    return w == 33071 ? MR_WRAP_CLAMP : w == 33648 ? MR_WRAP_MIRROR : MR_WRAP_REPEAT;
}

/* images[i]'s bytes: its URI's or its buffer view's (*owned set when the
 * bytes were read and must be freed). */
static mr_status image_bytes(const mr_gltf *g, long long i, const char *what, gl_blob *b,
                             bool *owned, mr_error *err)
{
    const cJSON *img = item(g->root, "images", i);
    *owned = false;
    if (!img)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "%s: images[%lld], there is none", what,
                             i);
    const char *uri = str(img, "uri");
    long long view;
    if (uri) {
        *owned = true;
        return uri_bytes(g, uri, what, b, err);
    }
    if (get_index(img, "bufferView", -1, &view) != 1)
        return mr_fail_plain(err, MR_ERR_PARSE, g->name,
                             "%s: images[%lld] has neither a uri nor a bufferView", what, i);
    const uint8_t *bytes;
    size_t len, stride;
    mr_status st = view_bytes(g, view, &bytes, &len, &stride, err);
    b->data = (uint8_t *)bytes;
    b->size = len;
    return st;
}

mr_status mr_gltf_image(const mr_gltf *g, long long i, const char *what, uint8_t **bytes,
                        size_t *size, bool *owned, mr_error *err)
{
    gl_blob b = {NULL, 0};
    mr_status st = image_bytes(g, i, what, &b, owned, err);
    *bytes = b.data;
    *size = b.size;
    return st;
}

/* A material's base colour in display values (baseColorFactor's rgb from
 * linear light; alpha clamped) and its base colour texture's image on
 * TEXCOORD_0 (*image, or -1: none, another set, or a source only an
 * extension names: KTX2, WebP) with its sampler (or NULL). */
static void base_color(const mr_gltf *g, const cJSON *mat, float color[4], long long *image,
                       const cJSON **sampler)
{
    const cJSON *pbr = member(mat, "pbrMetallicRoughness");
    double f[4] = {1, 1, 1, 1};
    numbers(member(pbr, "baseColorFactor"), 4, f);
    for (int k = 0; k < 4; k++)
        color[k] = k < 3 ? mr_linear_to_srgb((float)f[k])
                         : (float)(f[k] <= 0 ? 0 : f[k] >= 1 ? 1 : f[k]);
    *image = -1;
    *sampler = NULL;
    const cJSON *info = member(pbr, "baseColorTexture");
    long long ti, set, src, smp;
    if (!info || get_index(info, "index", -1, &ti) != 1)
        return;
    get_index(info, "texCoord", 0, &set);
    const cJSON *tex = item(g->root, "textures", ti);
    if (set != 0 || !tex || get_index(tex, "source", -1, &src) != 1 ||
        src >= array_size(member(g->root, "images")))
        return;
    *image = src;
    *sampler = get_index(tex, "sampler", -1, &smp) == 1 ? item(g->root, "samplers", smp) : NULL;
}

mr_status mr_gltf_scene_look(const mr_gltf *g, mr_mesh *mesh, uint32_t **face_material,
                             mr_gltf_material **materials, size_t *material_count,
                             size_t *image_count, mr_error *err)
{
    *materials = NULL;
    *material_count = 0;
    *image_count = (size_t)array_size(member(g->root, "images"));
    mr_status st = scene_join(g, mesh, face_material, err);
    const cJSON *mats = member(g->root, "materials");
    const int nm = array_size(mats);
    if (st == MR_OK && nm) {
        *materials = calloc((size_t)nm, sizeof **materials);
        if (!*materials)
            st = mr_fail_nomem(err, g->name, (size_t)nm * sizeof **materials);
        else
            *material_count = (size_t)nm;
    }
    for (int m = 0; st == MR_OK && m < nm; m++) {
        mr_gltf_material *gm = &(*materials)[m];
        const cJSON *sampler;
        base_color(g, cJSON_GetArrayItem(mats, m), gm->color, &gm->image, &sampler);
        gm->wrap_s = wrap_of(sampler, "wrapS");
        gm->wrap_t = wrap_of(sampler, "wrapT");
    }
    if (st != MR_OK) {
        mr_mesh_free(mesh);
        free(*face_material);
        *face_material = NULL;
        free(*materials);
        *materials = NULL;
        *material_count = 0;
    }
    return st;
}

/* ---- new accessors ---------------------------------------------------------------- */

/* A new buffer view over `bytes` (taken) and an accessor over it; its
 * index, or -1 with err set. */
static long long add_accessor(mr_gltf *g, uint8_t *bytes, size_t nbytes, size_t count,
                              int ctype, const char *type, bool normalized, int target,
                              const float *minmax, int comps, mr_error *err)
{
    if (g->nadded == g->capadded) {
        const size_t nc = g->capadded ? 2 * g->capadded : 16;
        gl_blob *na = realloc(g->added, nc * sizeof *na);
        if (!na) {
            free(bytes);
            mr_fail_nomem(err, g->name, nc * sizeof *na);
            return -1;
        }
        g->added = na;
        g->capadded = nc;
    }
    cJSON *views = member(g->root, "bufferViews");
    if (!views) {
        views = cJSON_AddArrayToObject(g->root, "bufferViews");
    }
    cJSON *accs = member(g->root, "accessors");
    if (!accs)
        accs = cJSON_AddArrayToObject(g->root, "accessors");
    cJSON *bv = cJSON_CreateObject(), *a = cJSON_CreateObject();
    if (!views || !accs || !bv || !a) {
        free(bytes);
        cJSON_Delete(bv);
        cJSON_Delete(a);
        mr_fail_nomem(err, g->name, 256);
        return -1;
    }
    const long long view = cJSON_GetArraySize(views);
    cJSON_AddNumberToObject(bv, "buffer", 0);
    cJSON_AddNumberToObject(bv, "byteLength", (double)nbytes);
    if (target)
        cJSON_AddNumberToObject(bv, "target", target);
    cJSON_AddItemToArray(views, bv);
    g->added[g->nadded++] = (gl_blob){bytes, nbytes};
    cJSON_AddNumberToObject(a, "bufferView", (double)view);
    cJSON_AddNumberToObject(a, "componentType", ctype);
    if (normalized)
        cJSON_AddTrueToObject(a, "normalized");
    cJSON_AddNumberToObject(a, "count", (double)count);
    cJSON_AddStringToObject(a, "type", type);
    if (minmax) {
        cJSON *mn = cJSON_AddArrayToObject(a, "min"), *mx = cJSON_AddArrayToObject(a, "max");
        for (int k = 0; k < comps; k++) {
            cJSON_AddItemToArray(mn, cJSON_CreateNumber(minmax[k]));
            cJSON_AddItemToArray(mx, cJSON_CreateNumber(minmax[comps + k]));
        }
    }
    const long long index = cJSON_GetArraySize(accs);
    cJSON_AddItemToArray(accs, a);
    return index;
}

static const char *type_name(int comps)
{
    return comps == 1 ? "SCALAR" : comps == 2 ? "VEC2" : comps == 3 ? "VEC3" : "VEC4";
}

/* n elements of `comps` floats as a FLOAT accessor (with min and max when
 * asked: POSITION's). */
static long long float_accessor(mr_gltf *g, const float *v, size_t n, int comps, bool bounds,
                                int target, mr_error *err)
{
    const size_t bytes = n * (size_t)comps * 4;
    uint8_t *d = malloc(bytes + 1);
    if (!d) {
        mr_fail_nomem(err, g->name, bytes);
        return -1;
    }
    memcpy(d, v, bytes);
    float mm[8];
    for (int k = 0; k < comps; k++)
        mm[k] = INFINITY, mm[comps + k] = -INFINITY;
    for (size_t e = 0; bounds && e < n; e++)
        for (int k = 0; k < comps; k++) {
            const float x = v[e * (size_t)comps + (size_t)k];
            mm[k] = x < mm[k] ? x : mm[k];
            mm[comps + k] = x > mm[comps + k] ? x : mm[comps + k];
        }
    return add_accessor(g, d, bytes, n, GL_FLOAT, type_name(comps), false, target,
                        bounds && n ? mm : NULL, comps, err);
}

static long long index_accessor(mr_gltf *g, const uint32_t *idx, size_t n, size_t nv,
                                mr_error *err)
{
    const bool shorts = nv <= 65535;
    const size_t bytes = n * (shorts ? 2 : 4);
    uint8_t *d = malloc(bytes + 4);
    if (!d) {
        mr_fail_nomem(err, g->name, bytes);
        return -1;
    }
    for (size_t i = 0; i < n; i++) {
        if (shorts) {
            d[2 * i] = (uint8_t)idx[i];
            d[2 * i + 1] = (uint8_t)(idx[i] >> 8);
        } else {
            for (int k = 0; k < 4; k++)
                d[4 * i + (size_t)k] = (uint8_t)(idx[i] >> (8 * k));
        }
    }
    return add_accessor(g, d, bytes, n, shorts ? GL_UNSIGNED_SHORT : GL_UNSIGNED_INT, "SCALAR",
                        false, GL_ELEMENT_ARRAY_BUFFER, NULL, 1, err);
}

/* An attribute's values at the output's vertices (origin), in its own
 * component type where it is an integer one that is not normalised
 * (JOINTS_n), else as floats. */
static long long carried_accessor(mr_gltf *g, const gl_attr *a, const uint32_t *origin,
                                  size_t n, bool bounds, mr_error *err)
{
    const int comps = a->info.comps;
    const bool ints = !a->info.normalized && (a->info.ctype == GL_UNSIGNED_BYTE ||
                                              a->info.ctype == GL_UNSIGNED_SHORT);
    if (ints) {
        const int cs = component_size(a->info.ctype);
        const size_t elem = (size_t)(comps * cs), padded = (elem + 3) & ~(size_t)3;
        uint8_t *d = calloc(n + 1, padded);
        if (!d) {
            mr_fail_nomem(err, g->name, n * padded);
            return -1;
        }
        for (size_t v = 0; v < n; v++)
            for (int k = 0; k < comps; k++) {
                const uint32_t x = (uint32_t)a->data[(size_t)comps * origin[v] + (size_t)k];
                uint8_t *p = d + v * padded + (size_t)(k * cs);
                p[0] = (uint8_t)x;
                if (cs == 2)
                    p[1] = (uint8_t)(x >> 8);
            }
        /* vertex attributes are 4-byte aligned: a padded stride */
        const long long acc = add_accessor(g, d, n * padded, n, (int)a->info.ctype,
                                           type_name(comps), false, GL_ARRAY_BUFFER, NULL, comps,
                                           err);
        if (acc >= 0 && padded != elem) {
            cJSON *views = member(g->root, "bufferViews");
            cJSON_AddNumberToObject(cJSON_GetArrayItem(views, cJSON_GetArraySize(views) - 1),
                                    "byteStride", (double)padded);
        }
        return acc;
    }
    float *f = mr_alloc_array(n + 1, (size_t)comps * sizeof *f);
    if (!f) {
        mr_fail_nomem(err, g->name, n * (size_t)comps * 4);
        return -1;
    }
    for (size_t v = 0; v < n; v++)
        for (int k = 0; k < comps; k++)
            f[(size_t)comps * v + (size_t)k] = (float)a->data[(size_t)comps * origin[v] + (size_t)k];
    const long long acc = float_accessor(g, f, n, comps, bounds, GL_ARRAY_BUFFER, err);
    free(f);
    return acc;
}

static bool set_index(cJSON *o, const char *key, long long v)
{
    cJSON *n = cJSON_CreateNumber((double)v);
    if (!n)
        return false;
    if (member(o, key))
        return cJSON_ReplaceItemInObjectCaseSensitive(o, key, n);
    return cJSON_AddItemToObject(o, key, n);
}

/* mr_gltf_replace into dst, a copy of primitive i's JSON (a level of
 * detail's), or into primitive i itself (dst NULL): its data are read from
 * primitive i as it is. */
static mr_status replace_into(mr_gltf *g, size_t i, cJSON *dst, const mr_mesh *m,
                              const uint32_t *origin, mr_error *err)
{
    gl_prim_data p;
    mr_status st = prim_read(g, g->prims[i].mesh, g->prims[i].prim, &p, err);
    if (st != MR_OK) {
        prim_free(&p);
        return st;
    }
    cJSON *prim = dst ? dst : (cJSON *)p.json;
    cJSON *attrs = member(prim, "attributes");
    const size_t n = m->vertex_count;
    uint32_t *from = mr_alloc_array(n + 1, sizeof *from); /* the primitive's own vertices */
    if (!from) {
        prim_free(&p);
        return mr_fail_nomem(err, g->name, n * 4);
    }
    for (size_t v = 0; v < n; v++) {
        if (origin[v] >= p.nw) {
            prim_free(&p);
            free(from);
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, g->name,
                                 "replace: output vertex %zu from vertex %u of %zu", v, origin[v],
                                 p.nw);
        }
        from[v] = p.first[origin[v]];
    }
    origin = from;
    bool tangent = false;
    for (int k = 0; k < p.nattr && st == MR_OK; k++) {
        const gl_attr *a = &p.attr[k];
        long long acc = -1;
        if (strcmp(a->name, "TANGENT") == 0) {
            tangent = true;
            continue;
        }
        if (strcmp(a->name, "POSITION") == 0)
            acc = float_accessor(g, m->positions, n, 3, true, GL_ARRAY_BUFFER, err);
        else if (strcmp(a->name, "NORMAL") == 0 && a->info.comps == 3 && m->normals)
            acc = float_accessor(g, m->normals, n, 3, false, GL_ARRAY_BUFFER, err);
        else if (strcmp(a->name, "TEXCOORD_0") == 0 && a->info.comps == 2 && m->texcoords)
            acc = float_accessor(g, m->texcoords, n, 2, false, GL_ARRAY_BUFFER, err);
        else if (strcmp(a->name, "COLOR_0") == 0 && m->colors &&
                 (a->info.comps == 3 || a->info.comps == 4)) {
            float *c = mr_alloc_array(n + 1, 4 * sizeof *c);
            if (!c) {
                st = mr_fail_nomem(err, g->name, n * 16);
                break;
            }
            const int comps = a->info.comps;
            for (size_t v = 0; v < n; v++)
                for (int q = 0; q < comps; q++)
                    c[(size_t)comps * v + (size_t)q] = m->colors[4 * v + (size_t)q];
            acc = float_accessor(g, c, n, comps, false, GL_ARRAY_BUFFER, err);
            free(c);
        } else {
            acc = carried_accessor(g, a, origin, n, false, err);
        }
        if (acc < 0 || !set_index(attrs, a->name, acc))
            st = acc < 0 ? MR_ERR_NO_MEMORY : mr_fail_nomem(err, g->name, 64);
    }
    if (st == MR_OK && tangent) {
        cJSON_DeleteItemFromObjectCaseSensitive(attrs, "TANGENT");
        g->dropped_tangents++;
    }
    /* morph targets: each vertex's displacement is its origin's */
    cJSON *targets = member(prim, "targets");
    for (int t = 0; st == MR_OK && t < p.ntarget; t++) {
        cJSON *obj = cJSON_GetArrayItem(targets, t);
        for (int k = p.target_start[t]; st == MR_OK && k < p.target_start[t + 1]; k++) {
            const gl_attr *a = &p.target[k];
            if (strcmp(a->name, "TANGENT") == 0) {
                cJSON_DeleteItemFromObjectCaseSensitive(obj, "TANGENT");
                continue;
            }
            const long long acc =
                carried_accessor(g, a, origin, n, strcmp(a->name, "POSITION") == 0, err);
            if (acc < 0 || !set_index(obj, a->name, acc))
                st = acc < 0 ? MR_ERR_NO_MEMORY : mr_fail_nomem(err, g->name, 64);
        }
    }
    if (st == MR_OK) {
        const long long acc = index_accessor(g, m->indices, 3 * m->triangle_count, n, err);
        if (acc < 0 || !set_index(prim, "indices", acc))
            st = acc < 0 ? MR_ERR_NO_MEMORY : mr_fail_nomem(err, g->name, 64);
        cJSON_DeleteItemFromObjectCaseSensitive(prim, "mode"); /* triangles */
    }
    prim_free(&p);
    free(from);
    return st;
}

mr_status mr_gltf_replace(mr_gltf *g, size_t i, const mr_mesh *m, const uint32_t *origin,
                          mr_error *err)
{
    return replace_into(g, i, NULL, m, origin, err);
}

size_t mr_gltf_dropped_tangents(const mr_gltf *g) { return g ? g->dropped_tangents : 0; }

/* Append value to the array root[key] (made where absent). */
static bool append_to(cJSON *root, const char *key, cJSON *value)
{
    cJSON *a = member(root, key);
    if (!a) {
        a = cJSON_AddArrayToObject(root, key);
        if (!a)
            return false;
    }
    return cJSON_IsArray(a) && cJSON_AddItemToArray(a, value);
}

mr_status mr_gltf_add_lod(mr_gltf *g, const mr_mesh *levels, const uint32_t *const *origins,
                          size_t level, double error_rel, mr_error *err)
{
    cJSON *meshes = member(g->root, "meshes"), *nodes = member(g->root, "nodes");
    const int nm = g->input_meshes; /* the input's meshes and nodes, not the levels' */
    if (level == 1) {
        const cJSON *x;
        cJSON_ArrayForEach(x, member(g->root, "extensionsUsed"))
        {
            if (cJSON_IsString(x) && strcmp(x->valuestring, "MSFT_lod") == 0)
                return mr_fail_plain(err, MR_ERR_UNSUPPORTED, g->name,
                                     "it has levels of detail already (MSFT_lod): simplify its "
                                     "own levels instead");
        }
    }
    long long *copy = mr_alloc_array((size_t)nm + 1, sizeof *copy);
    if (!copy)
        return mr_fail_nomem(err, g->name, (size_t)nm * 8);
    mr_status st = MR_OK;
    /* each mesh once more, its triangle primitives replaced by the level */
    for (int j = 0; j < nm && st == MR_OK; j++) {
        cJSON *dup = cJSON_Duplicate(cJSON_GetArrayItem(meshes, j), true);
        copy[j] = array_size(meshes);
        if (!dup || !cJSON_AddItemToArray(meshes, dup)) {
            cJSON_Delete(dup);
            st = mr_fail_nomem(err, g->name, 4096);
            break;
        }
        const char *name = str(dup, "name");
        char buf[512];
        snprintf(buf, sizeof buf, "%s_lod%zu", name ? name : "mesh", level);
        cJSON *nn = cJSON_CreateString(buf);
        if (!nn || !(member(dup, "name") ? cJSON_ReplaceItemInObjectCaseSensitive(dup, "name", nn)
                                          : cJSON_AddItemToObject(dup, "name", nn)))
            st = mr_fail_nomem(err, g->name, 64);
    }
    for (size_t i = 0; i < g->nprims && st == MR_OK; i++) {
        if (levels[i].triangle_count == 0)
            continue; /* nothing to simplify: the copy keeps the primitive's own */
        cJSON *dup = cJSON_GetArrayItem(meshes, (int)copy[g->prims[i].mesh]);
        cJSON *prim = cJSON_GetArrayItem(member(dup, "primitives"), (int)g->prims[i].prim);
        st = replace_into(g, i, prim, &levels[i], origins[i], err);
    }
    /* each node with a mesh: an LOD node (its transform, the level's mesh,
     * its skin and weights; no children) listed by its MSFT_lod */
    const int nn = g->input_nodes;
    for (int n = 0; n < nn && st == MR_OK; n++) {
        cJSON *node = cJSON_GetArrayItem(nodes, n);
        long long mi;
        if (get_index(node, "mesh", -1, &mi) < 0 || mi < 0 || mi >= nm)
            continue;
        cJSON *lod = cJSON_CreateObject();
        static const char *const keep[] = {"matrix", "translation", "rotation", "scale", "skin",
                                           "weights"};
        bool ok = lod != NULL;
        for (size_t k = 0; ok && k < sizeof keep / sizeof *keep; k++) {
            const cJSON *v = member(node, keep[k]);
            if (v) {
                cJSON *d = cJSON_Duplicate(v, true);
                ok = d && cJSON_AddItemToObject(lod, keep[k], d);
            }
        }
        const char *name = str(node, "name");
        char buf[512];
        snprintf(buf, sizeof buf, "%s_lod%zu", name ? name : "node", level);
        ok = ok && cJSON_AddStringToObject(lod, "name", buf) &&
             cJSON_AddNumberToObject(lod, "mesh", (double)copy[mi]);
        cJSON *extras = ok ? cJSON_AddObjectToObject(lod, "extras") : NULL;
        ok = extras && cJSON_AddNumberToObject(extras, "lod", (double)level) &&
             cJSON_AddNumberToObject(extras, "lod_error", error_rel);
        const long long index = array_size(nodes);
        if (!ok || !cJSON_AddItemToArray(nodes, lod)) {
            cJSON_Delete(lod);
            st = mr_fail_nomem(err, g->name, 4096);
            break;
        }
        cJSON *ext = member(node, "extensions");
        if (!ext)
            ext = cJSON_AddObjectToObject(node, "extensions");
        cJSON *msft = ext ? member(ext, "MSFT_lod") : NULL;
        if (ext && !msft)
            msft = cJSON_AddObjectToObject(ext, "MSFT_lod");
        cJSON *id = cJSON_CreateNumber((double)index);
        if (!msft || !id || !append_to(msft, "ids", id)) {
            cJSON_Delete(id);
            st = mr_fail_nomem(err, g->name, 64);
        }
    }
    if (st == MR_OK && level == 1) {
        cJSON *name = cJSON_CreateString("MSFT_lod");
        if (!name || !append_to(g->root, "extensionsUsed", name)) {
            cJSON_Delete(name);
            st = mr_fail_nomem(err, g->name, 64);
        }
    }
    free(copy);
    return st;
}

/* ---- writing ---------------------------------------------------------------------- */

/* Extensions whose references to accessors and buffer views are known
 * here (or that hold none): with any other one used, nothing is dropped
 * (an unknown extension may hold such references). */
static bool known_extension(const char *name)
{
    static const char *const known[] = {
        "KHR_texture_transform", "KHR_lights_punctual", "KHR_mesh_quantization",
        "KHR_texture_basisu",    "EXT_texture_webp",    "EXT_texture_avif",
        "EXT_mesh_gpu_instancing", "KHR_xmp_json_ld",   "EXT_lights_image_based",
        "KHR_animation_pointer",   "MSFT_lod"};
    if (strncmp(name, "KHR_materials_", 14) == 0)
        return true;
    for (size_t i = 0; i < sizeof known / sizeof *known; i++)
        if (strcmp(name, known[i]) == 0)
            return true;
    return false;
}

static bool drop_unused(const mr_gltf *g)
{
    const cJSON *x;
    cJSON_ArrayForEach(x, member(g->root, "extensionsUsed"))
    {
        if (cJSON_IsString(x) && !known_extension(x->valuestring))
            return false;
    }
    return true;
}

/* Call f on every member that holds an accessor index. */
typedef void (*ref_fn)(cJSON *holder, cJSON *value, void *user);

static void each_in_object(cJSON *o, ref_fn f, void *user)
{
    cJSON *x;
    cJSON_ArrayForEach(x, o)
    {
        if (cJSON_IsNumber(x))
            f(o, x, user);
    }
}

static void each_accessor_ref(cJSON *root, ref_fn f, void *user)
{
    cJSON *mesh, *prim, *t, *skin, *anim, *s, *node;
    cJSON_ArrayForEach(mesh, member(root, "meshes"))
    {
        cJSON_ArrayForEach(prim, member(mesh, "primitives"))
        {
            each_in_object(member(prim, "attributes"), f, user);
            if (member(prim, "indices") && cJSON_IsNumber(member(prim, "indices")))
                f(prim, member(prim, "indices"), user);
            cJSON_ArrayForEach(t, member(prim, "targets")) each_in_object(t, f, user);
        }
    }
    cJSON_ArrayForEach(skin, member(root, "skins"))
    {
        cJSON *x = member(skin, "inverseBindMatrices");
        if (x && cJSON_IsNumber(x))
            f(skin, x, user);
    }
    cJSON_ArrayForEach(anim, member(root, "animations"))
    {
        cJSON_ArrayForEach(s, member(anim, "samplers"))
        {
            cJSON *in = member(s, "input"), *out = member(s, "output");
            if (in && cJSON_IsNumber(in))
                f(s, in, user);
            if (out && cJSON_IsNumber(out))
                f(s, out, user);
        }
    }
    cJSON_ArrayForEach(node, member(root, "nodes"))
    {
        each_in_object(member(member(member(node, "extensions"), "EXT_mesh_gpu_instancing"),
                              "attributes"),
                       f, user);
    }
}

typedef struct remap {
    long long *to; /* old index -> new, -1: dropped */
    size_t n;
    bool bad;      /* a reference past the array */
} remap;

static void mark_ref(cJSON *holder, cJSON *value, void *user)
{
    (void)holder;
    remap *r = user;
    const double v = value->valuedouble;
    if (v >= 0 && v < (double)r->n && v == floor(v))
        r->to[(size_t)v] = 1;
    else
        r->bad = true;
}

static void apply_ref(cJSON *holder, cJSON *value, void *user)
{
    (void)holder;
    remap *r = user;
    const double v = value->valuedouble;
    if (v >= 0 && v < (double)r->n)
        cJSON_SetNumberValue(value, (double)r->to[(size_t)v]);
}

/* Keep the marked entries of root[key] (r->to[i] != 0), renumbered. */
static void compact(cJSON *root, const char *key, remap *r)
{
    cJSON *a = member(root, key);
    long long next = 0;
    for (size_t i = 0; i < r->n; i++)
        r->to[i] = r->to[i] ? next++ : -1;
    for (size_t i = r->n; i-- > 0;)
        if (r->to[i] < 0)
            cJSON_DeleteItemFromArray(a, (int)i);
}

static void each_view_ref(cJSON *root, ref_fn f, void *user)
{
    cJSON *a, *img;
    cJSON_ArrayForEach(a, member(root, "accessors"))
    {
        cJSON *x = member(a, "bufferView");
        if (x && cJSON_IsNumber(x))
            f(a, x, user);
        cJSON *sp = member(a, "sparse");
        cJSON *si = member(member(sp, "indices"), "bufferView"),
              *sv = member(member(sp, "values"), "bufferView");
        if (si && cJSON_IsNumber(si))
            f(sp, si, user);
        if (sv && cJSON_IsNumber(sv))
            f(sp, sv, user);
    }
    cJSON_ArrayForEach(img, member(root, "images"))
    {
        cJSON *x = member(img, "bufferView");
        if (x && cJSON_IsNumber(x))
            f(img, x, user);
    }
}

/* The entries of root[key] that the references `walk` finds, renumbered
 * (the others dropped): r->to[i] is entry i's new index, -1 where it went.
 * `what` names the entries in the error for a reference past them. */
static mr_status renumber(mr_gltf *g, const char *key, void (*walk)(cJSON *, ref_fn, void *),
                          const char *what, remap *r, mr_error *err)
{
    r->n = (size_t)array_size(member(g->root, key));
    r->to = calloc(r->n + 1, sizeof *r->to);
    r->bad = false;
    if (!r->to)
        return mr_fail_nomem(err, g->name, r->n * 8);
    walk(g->root, mark_ref, r);
    if (r->bad) {
        free(r->to);
        r->to = NULL;
        return mr_fail_plain(err, MR_ERR_PARSE, g->name, "a reference to %s that is none", what);
    }
    compact(g->root, key, r);
    walk(g->root, apply_ref, r);
    return MR_OK;
}

static mr_status drop_and_renumber(mr_gltf *g, mr_error *err)
{
    if (!drop_unused(g))
        return MR_OK;
    remap r;
    mr_status st = renumber(g, "accessors", each_accessor_ref, "an accessor", &r, err);
    free(r.to);
    /* the buffer views the accessors and images left use */
    if (st == MR_OK)
        st = renumber(g, "bufferViews", each_view_ref, "a buffer view", &r, err);
    if (st != MR_OK)
        return st;
    /* the new views' bytes follow the views they become */
    size_t kept_old = 0, kept_new = 0;
    for (size_t i = 0; i < r.n; i++) {
        if (i < g->input_views)
            kept_old += r.to[i] >= 0;
        else if (r.to[i] >= 0)
            g->added[kept_new++] = g->added[i - g->input_views];
        else
            free(g->added[i - g->input_views].data);
    }
    g->input_views = kept_old;
    g->nadded = kept_new;
    free(r.to);
    return MR_OK;
}

/* Every number as its shortest text that reads back as the same double
 * (cJSON's own printing may drop the last bit): a raw item. */
static bool exact_numbers(cJSON *node)
{
    for (cJSON *x = node; x; x = x->next) {
        if (cJSON_IsNumber(x)) {
            char buf[40];
            const double v = x->valuedouble;
            if (v == floor(v) && fabs(v) < 1e15)
                snprintf(buf, sizeof buf, "%.0f", v);
            else
                for (int digits = 15; digits <= 17; digits++) {
                    snprintf(buf, sizeof buf, "%.*g", digits, v);
                    if (strtod(buf, NULL) == v)
                        break;
                }
            char *t = dup_str(buf);
            if (!t)
                return false;
            x->type = cJSON_Raw;
            x->valuestring = t;
        } else if (x->child && !exact_numbers(x->child)) {
            return false;
        }
    }
    return true;
}

typedef struct out_buffer {
    uint8_t *data;
    size_t size, cap;
} out_buffer;

static bool out_append(out_buffer *b, const void *d, size_t n)
{
    const size_t at = (b->size + 3) & ~(size_t)3;
    if (at + n + 4 > b->cap) {
        size_t nc = b->cap ? b->cap : 1 << 16;
        while (nc < at + n + 4)
            nc *= 2;
        uint8_t *nd = realloc(b->data, nc);
        if (!nd)
            return false;
        b->data = nd;
        b->cap = nc;
    }
    memset(b->data + b->size, 0, at - b->size);
    if (n)
        memcpy(b->data + at, d, n);
    b->size = at + n;
    return true;
}

static const char *mime_of(const char *uri)
{
    const char *dot = strrchr(uri, '.');
    if (dot && (strcasecmp(dot, ".jpg") == 0 || strcasecmp(dot, ".jpeg") == 0))
        return "image/jpeg";
    if (dot && strcasecmp(dot, ".webp") == 0)
        return "image/webp";
    if (dot && strcasecmp(dot, ".ktx2") == 0)
        return "image/ktx2";
    return "image/png";
}

static bool same_dir(const char *a, const char *b)
{
    struct stat sa, sb;
    return stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev &&
           sa.st_ino == sb.st_ino;
}

static mr_status copy_file(const mr_gltf *g, const char *from, const char *to, mr_error *err)
{
    gl_blob b;
    mr_status st = read_whole(from, g->name, &b, err);
    if (st != MR_OK)
        return st;
    /* the folders on its way */
    char dir[4200];
    snprintf(dir, sizeof dir, "%s", to);
    for (char *p = dir + 1; *p; p++)
        if (*p == '/') {
            *p = 0;
            mkdir(dir, 0777);
            *p = '/';
        }
    mr_output_file of;
    st = mr_output_open(&of, to, err);
    if (st == MR_OK) {
        if (b.size && fwrite(b.data, 1, b.size, of.f) != b.size)
            st = mr_fail_write(err, to, errno);
        st = mr_output_close(&of, to, st, err);
    }
    free(b.data);
    return st;
}

mr_status mr_gltf_write(mr_gltf *g, const char *path, mr_error *err)
{
    mr_status st = drop_and_renumber(g, err);
    if (st != MR_OK)
        return st;
    const size_t plen = strlen(path);
    const bool glb = plen >= 4 && strcasecmp(path + plen - 4, ".glb") == 0;
    char out_dir[4200];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(out_dir, sizeof out_dir, ".");
    else
        snprintf(out_dir, sizeof out_dir, "%.*s", (int)(slash - path + (slash == path)), path);
    /* every view's bytes into one buffer */
    out_buffer ob = {0};
    cJSON *views = member(g->root, "bufferViews");
    const int nviews = array_size(views);
    for (int i = 0; i < nviews && st == MR_OK; i++) {
        cJSON *bv = cJSON_GetArrayItem(views, i);
        const uint8_t *bytes;
        size_t length, stride;
        if ((size_t)i >= g->input_views) {
            const gl_blob *b = &g->added[(size_t)i - g->input_views];
            bytes = b->data;
            length = b->size;
        } else if ((st = view_bytes(g, i, &bytes, &length, &stride, err)) != MR_OK) {
            break;
        }
        if (!out_append(&ob, bytes, length)) {
            st = mr_fail_nomem(err, g->name, length);
            break;
        }
        if (!set_index(bv, "buffer", 0) || !set_index(bv, "byteOffset", (long long)(ob.size - length)))
            st = mr_fail_nomem(err, g->name, 64);
    }
    /* external images: into a .glb's buffer, or copied beside a .gltf
     * that goes to another folder */
    cJSON *img;
    int ii = 0;
    cJSON_ArrayForEach(img, member(g->root, "images"))
    {
        const char *uri = str(img, "uri");
        if (st != MR_OK || !uri || strncmp(uri, "data:", 5) == 0) {
            ii++;
            continue;
        }
        char what[48], from[4200];
        snprintf(what, sizeof what, "images[%d]", ii++);
        if ((st = uri_path(g, uri, what, from, sizeof from, err)) != MR_OK)
            break;
        if (glb) {
            gl_blob b;
            if ((st = uri_bytes(g, uri, what, &b, err)) != MR_OK)
                break;
            const bool ok = out_append(&ob, b.data, b.size);
            free(b.data);
            cJSON *bv = cJSON_CreateObject();
            if (!ok || !bv) {
                cJSON_Delete(bv);
                st = mr_fail_nomem(err, g->name, b.size);
                break;
            }
            cJSON_AddNumberToObject(bv, "buffer", 0);
            cJSON_AddNumberToObject(bv, "byteOffset", (double)(ob.size - b.size));
            cJSON_AddNumberToObject(bv, "byteLength", (double)b.size);
            if (!views)
                views = cJSON_AddArrayToObject(g->root, "bufferViews");
            cJSON_AddItemToArray(views, bv);
            if (!str(img, "mimeType"))
                cJSON_AddStringToObject(img, "mimeType", mime_of(uri));
            set_index(img, "bufferView", cJSON_GetArraySize(views) - 1);
            cJSON_DeleteItemFromObjectCaseSensitive(img, "uri");
        } else if (!same_dir(g->base ? g->base : ".", out_dir)) {
            char to[4200];
            if ((size_t)snprintf(to, sizeof to, "%s/%s", out_dir, from + strlen(g->base) + 1) >=
                sizeof to) {
                st = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path, "%s: path too long", what);
                break;
            }
            if ((st = copy_file(g, from, to, err)) != MR_OK)
                break;
        }
    }
    /* the one buffer */
    char bin_name[4200] = "";
    if (st == MR_OK) {
        cJSON_DeleteItemFromObjectCaseSensitive(g->root, "buffers");
        if (ob.size) {
            cJSON *bufs = cJSON_AddArrayToObject(g->root, "buffers"), *b = cJSON_CreateObject();
            cJSON_AddNumberToObject(b, "byteLength", (double)ob.size);
            if (!glb) {
                const char *base = slash ? slash + 1 : path;
                size_t n = strlen(base);
                if (n >= 5 && strcasecmp(base + n - 5, ".gltf") == 0)
                    n -= 5;
                snprintf(bin_name, sizeof bin_name, "%.*s.bin", (int)n, base);
                cJSON_AddStringToObject(b, "uri", bin_name);
            }
            cJSON_AddItemToArray(bufs, b);
        }
    }
    if (st == MR_OK && !exact_numbers(g->root))
        st = mr_fail_nomem(err, g->name, 1 << 20);
    char *json = st == MR_OK ? (glb ? cJSON_PrintUnformatted(g->root) : cJSON_Print(g->root))
                             : NULL;
    if (st == MR_OK && !json)
        st = mr_fail_nomem(err, g->name, 1 << 20);
    /* the files: a .gltf's buffer first, so that the .gltf appears last */
    char bin_path[4200];
    mr_output_file bf;
    bool bin_open = false;
    if (st == MR_OK && !glb && ob.size) {
        if ((size_t)snprintf(bin_path, sizeof bin_path, "%s/%s", out_dir, bin_name) >=
            sizeof bin_path)
            st = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path, "path too long");
        else if ((st = mr_output_open(&bf, bin_path, err)) == MR_OK) {
            bin_open = true;
            if (fwrite(ob.data, 1, ob.size, bf.f) != ob.size)
                st = mr_fail_write(err, bin_path, errno);
        }
    }
    mr_output_file of;
    if (st == MR_OK && (st = mr_output_open(&of, path, err)) == MR_OK) {
        const size_t jn = strlen(json);
        if (glb) {
            const size_t jpad = (jn + 3) & ~(size_t)3, bpad = (ob.size + 3) & ~(size_t)3;
            const size_t total = 12 + 8 + jpad + (ob.size ? 8 + bpad : 0);
            uint32_t h[5] = {GLB_MAGIC, 2, (uint32_t)total, (uint32_t)jpad, GLB_JSON};
            if (total > UINT32_MAX)
                st = mr_fail_plain(err, MR_ERR_TOO_LARGE, path, "a .glb of %zu bytes", total);
            static const char spaces[4] = {' ', ' ', ' ', ' '};
            static const uint8_t zeros[4] = {0, 0, 0, 0};
            if (st == MR_OK &&
                (fwrite(h, 4, 5, of.f) != 5 || fwrite(json, 1, jn, of.f) != jn ||
                 fwrite(spaces, 1, jpad - jn, of.f) != jpad - jn))
                st = mr_fail_write(err, path, errno);
            if (st == MR_OK && ob.size) {
                const uint32_t c[2] = {(uint32_t)bpad, GLB_BIN};
                if (fwrite(c, 4, 2, of.f) != 2 || fwrite(ob.data, 1, ob.size, of.f) != ob.size ||
                    fwrite(zeros, 1, bpad - ob.size, of.f) != bpad - ob.size)
                    st = mr_fail_write(err, path, errno);
            }
        } else if (fwrite(json, 1, jn, of.f) != jn || fputc('\n', of.f) == EOF) {
            st = mr_fail_write(err, path, errno);
        }
        if (bin_open) {
            st = mr_output_close(&bf, bin_path, st, err);
            bin_open = false;
        }
        st = mr_output_close(&of, path, st, err);
        if (st != MR_OK && bin_name[0])
            unlink(bin_path);
    }
    if (bin_open)
        mr_output_close(&bf, bin_path, st == MR_OK ? MR_ERR_IO : st, err);
    cJSON_free(json);
    free(ob.data);
    return st;
}

mr_status mr_convert_gltf(const char *in_path, const char *out_path, size_t *primitives,
                          mr_error *err)
{
    mr_error_clear(err);
    if (primitives)
        *primitives = 0;
    if (!in_path || !out_path)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no path given");
    mr_gltf *g;
    mr_status st = mr_gltf_load_file(in_path, &g, err);
    if (st != MR_OK)
        return st;
    if (primitives)
        *primitives = g->nprims;
    st = mr_gltf_write(g, out_path, err);
    mr_gltf_free(g);
    return st;
}

/* A buffer view of raw bytes (an image's): its index, or -1. */
static long long add_view(mr_gltf *g, uint8_t *bytes, size_t nbytes, mr_error *err)
{
    /* an accessor's view without the accessor */
    const long long a = add_accessor(g, bytes, nbytes, 1, GL_UNSIGNED_BYTE, "SCALAR", false, 0,
                                     NULL, 1, err);
    if (a < 0)
        return -1;
    cJSON *accs = member(g->root, "accessors");
    const long long view = (long long)cJSON_GetNumberValue(member(cJSON_GetArrayItem(accs, (int)a),
                                                                  "bufferView"));
    cJSON_DeleteItemFromArray(accs, (int)a);
    return view;
}

/* An OBJ material's texture (map_Kd) as a glTF texture: its image's bytes
 * in the buffer (PNG or JPEG, which glTF takes), once per file; its index
 * or -1 (with the error). */
typedef struct gl_tex {
    char path[2 * MR_MTL_NAME_MAX];
    mr_wrap wrap;
    long long index;
} gl_tex;

static long long obj_texture(mr_gltf *g, const mr_mtl_material *d, gl_tex **tex, size_t *ntex,
                             mr_error *err)
{
    for (size_t i = 0; i < *ntex; i++)
        if (strcmp((*tex)[i].path, d->texture) == 0 && (*tex)[i].wrap == d->wrap)
            return (*tex)[i].index;
    /* a texture that cannot be read, or that glTF cannot hold (neither PNG
     * nor JPEG: TGA, BMP), leaves the material its colour: -2 */
    gl_blob b;
    mr_error ignored;
    if (read_whole(d->texture, g->name, &b, &ignored) != MR_OK)
        return -2;
    const bool png = b.size >= 8 && memcmp(b.data, "\x89PNG", 4) == 0;
    const bool jpeg = b.size >= 3 && b.data[0] == 0xFF && b.data[1] == 0xD8 && b.data[2] == 0xFF;
    if (!png && !jpeg) {
        free(b.data);
        return -2;
    }
    const long long view = add_view(g, b.data, b.size, err);
    cJSON *images = member(g->root, "images"), *textures = member(g->root, "textures"),
          *samplers = member(g->root, "samplers");
    if (!images)
        images = cJSON_AddArrayToObject(g->root, "images");
    if (!textures)
        textures = cJSON_AddArrayToObject(g->root, "textures");
    if (!samplers)
        samplers = cJSON_AddArrayToObject(g->root, "samplers");
    gl_tex *nt = realloc(*tex, (*ntex + 1) * sizeof *nt);
    cJSON *img = cJSON_CreateObject(), *t = cJSON_CreateObject(), *sm = cJSON_CreateObject();
    if (view < 0 || !images || !textures || !samplers || !nt || !img || !t || !sm) {
        if (nt)
            *tex = nt;
        cJSON_Delete(img), cJSON_Delete(t), cJSON_Delete(sm);
        if (view >= 0)
            mr_fail_nomem(err, g->name, 4096);
        return -1;
    }
    *tex = nt;
    cJSON_AddNumberToObject(img, "bufferView", (double)view);
    cJSON_AddStringToObject(img, "mimeType", png ? "image/png" : "image/jpeg");
    cJSON_AddItemToArray(images, img);
    const int wrap = d->wrap == MR_WRAP_CLAMP ? 33071 : 10497;
    cJSON_AddNumberToObject(sm, "wrapS", wrap);
    cJSON_AddNumberToObject(sm, "wrapT", wrap);
    cJSON_AddItemToArray(samplers, sm);
    cJSON_AddNumberToObject(t, "source", cJSON_GetArraySize(images) - 1);
    cJSON_AddNumberToObject(t, "sampler", cJSON_GetArraySize(samplers) - 1);
    cJSON_AddItemToArray(textures, t);
    gl_tex *e = &nt[(*ntex)++];
    snprintf(e->path, sizeof e->path, "%s", d->texture);
    e->wrap = d->wrap;
    e->index = cJSON_GetArraySize(textures) - 1;
    return e->index;
}

/* glTF material for the mesh's material id: its name (the options'), and
 * where the options name an OBJ's libraries, its Kd as the base colour
 * (in linear light) and its map_Kd as the base colour texture; not
 * metallic. */
static mr_status add_material(mr_gltf *g, uint32_t id, const mr_write_options *o,
                              const mr_mtl_material *defs, size_t ndefs, gl_tex **tex,
                              size_t *ntex, mr_error *err)
{
    cJSON *mats = member(g->root, "materials");
    if (!mats)
        mats = cJSON_AddArrayToObject(g->root, "materials");
    cJSON *mat = cJSON_CreateObject(), *pbr = cJSON_CreateObject();
    if (!mats || !mat || !pbr) {
        cJSON_Delete(mat), cJSON_Delete(pbr);
        return mr_fail_nomem(err, g->name, 256);
    }
    char name[64];
    snprintf(name, sizeof name, "material_%u", id);
    const char *nm = o->material_names && id < o->material_count && o->material_names[id]
                         ? o->material_names[id]
                         : name;
    cJSON_AddStringToObject(mat, "name", nm);
    cJSON_AddItemToObject(mat, "pbrMetallicRoughness", pbr);
    cJSON_AddItemToArray(mats, mat);
    const long d = defs ? mr_mtl_find(defs, ndefs, nm) : -1;
    if (d >= 0) {
        cJSON *f = cJSON_AddArrayToObject(pbr, "baseColorFactor");
        for (int k = 0; k < 4; k++)
            cJSON_AddItemToArray(f, cJSON_CreateNumber(k < 3 ? mr_srgb_to_linear(defs[d].color[k])
                                                             : defs[d].color[3]));
        const long long t = defs[d].texture[0] ? obj_texture(g, &defs[d], tex, ntex, err) : -2;
        if (t == -1)
            return err ? err->status : MR_ERR_NO_MEMORY;
        if (t >= 0) {
            cJSON *bt = cJSON_CreateObject();
            if (!bt)
                return mr_fail_nomem(err, g->name, 64);
            cJSON_AddNumberToObject(bt, "index", (double)t);
            cJSON_AddItemToObject(pbr, "baseColorTexture", bt);
        }
    }
    cJSON_AddNumberToObject(pbr, "metallicFactor", 0);
    if (d >= 0 && defs[d].color[3] < 1) /* an OBJ's d (or Tr): see-through */
        cJSON_AddStringToObject(mat, "alphaMode", "BLEND");
    return MR_OK;
}

/* The triangles as one primitive per material (none first, then by id),
 * each with the attributes of `prim` (which becomes the first). */
static mr_status material_primitives(mr_gltf *g, const mr_mesh *m, const uint32_t *fm,
                                     const mr_write_options *o, cJSON *prim, mr_error *err)
{
    const size_t nt = m->triangle_count;
    mr_mtl_material *defs = NULL;
    size_t ndefs = 0;
    mr_status st = MR_OK;
    /* an OBJ's libraries: as the options name them, else as its mtllib
     * lines do (and its usemtl names, where the options give none); a
     * library that cannot be read leaves the names alone */
    mr_obj_materials om;
    memset(&om, 0, sizeof om);
    mr_write_options named = *o;
    mr_error ignored;
    const size_t fl = o->materials_from ? strlen(o->materials_from) : 0;
    if (fl > 4 && strcasecmp(o->materials_from + fl - 4, ".obj") == 0 &&
        (!o->mtllib || !o->material_names) &&
        mr_obj_materials_read(o->materials_from, &om, &ignored) == MR_OK) {
        if (!named.mtllib)
            named.mtllib = om.mtllib;
        if (!named.material_names) {
            named.material_names = (const char *const *)om.names;
            named.material_count = om.count;
        }
        o = &named;
    }
    if (o->mtllib && o->materials_from &&
        mr_mtl_read_all(o->materials_from, o->mtllib, &defs, &ndefs, &ignored) != MR_OK)
        defs = NULL, ndefs = 0;
    uint32_t *key = NULL, *order = NULL;
    uint32_t *idx = mr_alloc_array(3 * nt + 1, sizeof *idx);
    st = idx ? mr_material_order(fm, nt, &key, &order, err) : mr_fail_nomem(err, g->name, nt * 12);
    cJSON *prims = member(cJSON_GetArrayItem(member(g->root, "meshes"), 0), "primitives");
    cJSON *templ = st == MR_OK ? cJSON_Duplicate(prim, true) : NULL;
    if (st == MR_OK && !templ)
        st = mr_fail_nomem(err, g->name, 256);
    gl_tex *tex = NULL;
    size_t ntex = 0, nmat = 0;
    for (size_t i = 0, first = 1; st == MR_OK && i < nt; first = 0) {
        const uint32_t g1 = key[i];
        size_t j = i;
        for (; j < nt && key[j] == g1; j++)
            memcpy(idx + 3 * (j - i), m->indices + 3 * (size_t)order[j], 12);
        cJSON *p = first ? prim : cJSON_Duplicate(templ, true);
        if (!p) {
            st = mr_fail_nomem(err, g->name, 256);
            break;
        }
        if (!first)
            cJSON_AddItemToArray(prims, p);
        const long long acc = index_accessor(g, idx, 3 * (j - i), m->vertex_count, err);
        if (acc < 0 || !set_index(p, "indices", acc)) {
            st = MR_ERR_NO_MEMORY;
            break;
        }
        if (g1 != 0) { /* a material (0: none) */
            if (!set_index(p, "material", (long long)nmat++)) {
                st = mr_fail_nomem(err, g->name, 64);
                break;
            }
            st = add_material(g, g1 - 1, o, defs, ndefs, &tex, &ntex, err);
        }
        i = j;
    }
    cJSON_Delete(templ);
    free(tex);
    free(defs);
    free(key);
    free(order);
    free(idx);
    mr_obj_materials_free(&om);
    return st;
}

mr_status mr_gltf_write_mesh(const mr_mesh *m, const char *path,
                             const mr_write_options *options, mr_error *err)
{
    mr_write_options defaults;
    if (!options) {
        mr_write_options_default(&defaults);
        options = &defaults;
    }
    mr_gltf *g = calloc(1, sizeof *g);
    if (!g)
        return mr_fail_nomem(err, path, sizeof *g);
    g->name = dup_str(path);
    g->root = cJSON_Parse("{\"asset\":{\"version\":\"2.0\",\"generator\":\"meshreduce\"},"
                          "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                          "\"meshes\":[{\"primitives\":[{\"attributes\":{}}]}]}");
    if (!g->name || !g->root) {
        mr_gltf_free(g);
        return mr_fail_nomem(err, path, 4096);
    }
    cJSON *prim = cJSON_GetArrayItem(member(cJSON_GetArrayItem(member(g->root, "meshes"), 0),
                                            "primitives"),
                                     0);
    cJSON *attrs = member(prim, "attributes");
    mr_status st = MR_OK;
    const size_t n = m->vertex_count;
    long long acc = float_accessor(g, m->positions, n, 3, true, GL_ARRAY_BUFFER, err);
    if (acc < 0 || !set_index(attrs, "POSITION", acc))
        st = MR_ERR_NO_MEMORY;
    if (st == MR_OK && m->normals && options->write_normals) {
        acc = float_accessor(g, m->normals, n, 3, false, GL_ARRAY_BUFFER, err);
        st = acc < 0 || !set_index(attrs, "NORMAL", acc) ? MR_ERR_NO_MEMORY : MR_OK;
    }
    /* tangents go with the normals (glTF asks for both) */
    if (st == MR_OK && m->tangents && m->normals && options->write_normals) {
        acc = float_accessor(g, m->tangents, n, 4, false, GL_ARRAY_BUFFER, err);
        st = acc < 0 || !set_index(attrs, "TANGENT", acc) ? MR_ERR_NO_MEMORY : MR_OK;
    }
    /* the sets present, numbered from 0 without gaps (as glTF asks) */
    int sets_written = 0;
    for (int set = 0; set <= MR_MORE_TEXCOORDS && st == MR_OK && options->write_texcoords; set++) {
        const float *tc = set ? m->more_texcoords[set - 1] : m->texcoords;
        if (!tc)
            continue;
        /* the mesh's v points up (OBJ's way); glTF's points down */
        float *uv = mr_alloc_array(2 * n, sizeof *uv);
        for (size_t i = 0; uv && i < n; i++) {
            uv[2 * i] = tc[2 * i];
            uv[2 * i + 1] = 1.0f - tc[2 * i + 1];
        }
        acc = uv ? float_accessor(g, uv, n, 2, false, GL_ARRAY_BUFFER, err)
                 : (mr_fail_nomem(err, path, 8 * n), -1);
        free(uv);
        char name[24];
        snprintf(name, sizeof name, "TEXCOORD_%d", sets_written++);
        st = acc < 0 || !set_index(attrs, name, acc) ? MR_ERR_NO_MEMORY : MR_OK;
    }
    if (st == MR_OK && m->colors && options->write_colors) {
        acc = float_accessor(g, m->colors, n, 4, false, GL_ARRAY_BUFFER, err);
        st = acc < 0 || !set_index(attrs, "COLOR_0", acc) ? MR_ERR_NO_MEMORY : MR_OK;
    }
    const uint32_t *fm = options->face_material ? options->face_material : m->materials;
    if (st == MR_OK && m->triangle_count && fm) {
        st = material_primitives(g, m, fm, options, prim, err);
    } else if (st == MR_OK && m->triangle_count) {
        acc = index_accessor(g, m->indices, 3 * m->triangle_count, n, err);
        st = acc < 0 || !set_index(prim, "indices", acc) ? MR_ERR_NO_MEMORY : MR_OK;
    } else if (st == MR_OK) {
        set_index(prim, "mode", 0); /* points */
    }
    if (st == MR_OK)
        st = mr_gltf_write(g, path, err);
    mr_gltf_free(g);
    return st;
}


/* ---- materials into an OBJ's library ---------------------------------------------- */

mr_status mr_gltf_mtl_commit(mr_gltf_mtl *m, mr_error *err)
{
    mr_status st = MR_OK;
    for (size_t i = 0; i < m->nfiles; i++) {
        const mr_status s1 = mr_output_commit(&m->files[i], m->paths[i], err);
        st = st == MR_OK ? s1 : st;
    }
    return st;
}

void mr_gltf_mtl_free(mr_gltf_mtl *m)
{
    if (!m)
        return;
    for (size_t i = 0; i < m->count; i++)
        free(m->names[i]);
    for (size_t i = 0; i < m->nfiles; i++) {
        mr_output_abandon(&m->files[i]); /* those not committed */
        free(m->paths[i]);
    }
    free(m->names);
    free(m->files);
    free(m->paths);
    free(m->mtllib);
    memset(m, 0, sizeof *m);
}

/* Write `n` bytes to path, staged (whole or not at all); recorded in m. */
static mr_status write_bytes(mr_gltf_mtl *m, const char *path, const void *data, size_t n,
                             mr_error *err)
{
    mr_output_file *nf = realloc(m->files, (m->nfiles + 1) * sizeof *nf);
    if (nf)
        m->files = nf;
    char **np = realloc(m->paths, (m->nfiles + 1) * sizeof *np);
    if (np)
        m->paths = np;
    char *name = dup_str(path);
    if (!nf || !np || !name) {
        free(name);
        return mr_fail_nomem(err, path, 4096);
    }
    mr_output_file *of = &m->files[m->nfiles];
    mr_status st = mr_output_open(of, path, err);
    if (st != MR_OK) {
        free(name);
        return st;
    }
    if (n && fwrite(data, 1, n, of->f) != n)
        st = mr_fail_write(err, path, errno);
    st = mr_output_finish(of, path, st, err);
    if (st != MR_OK) {
        free(name);
        return st;
    }
    m->paths[m->nfiles++] = name;
    return MR_OK;
}

/* Material i's name for the library: its own (blanks and controls as
 * '_'), or material_I; a later duplicate gets _I. */
static char *mtl_name(const cJSON *mat, size_t i, char *const *before)
{
    const char *n = str(mat, "name");
    char buf[256];
    if (!n || !*n)
        snprintf(buf, sizeof buf, "material_%zu", i);
    else
        snprintf(buf, sizeof buf, "%s", n);
    for (char *p = buf; *p; p++)
        if ((unsigned char)*p <= ' ' || *p == 127)
            *p = '_';
    for (size_t j = 0; j < i; j++)
        if (strcmp(before[j], buf) == 0) {
            const size_t l = strlen(buf);
            snprintf(buf + (l < 200 ? l : 200), sizeof buf - (l < 200 ? l : 200), "_%zu", i);
            break;
        }
    return dup_str(buf);
}

mr_status mr_gltf_mtl_export(const char *gltf_path, const char *obj_path, mr_gltf_mtl *out,
                             mr_error *err)
{
    memset(out, 0, sizeof *out);
    mr_gltf *g;
    mr_status st = mr_gltf_load_file(gltf_path, &g, err);
    if (st != MR_OK)
        return st;
    /* OUT's folder and base name */
    char dir[4200], base[1024];
    const char *slash = strrchr(obj_path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - obj_path) : 1, slash ? obj_path : ".");
    if (slash == obj_path)
        snprintf(dir, sizeof dir, "/");
    const char *b = slash ? slash + 1 : obj_path;
    size_t bl = strlen(b);
    const char *dot = strrchr(b, '.');
    if (dot && dot > b)
        bl = (size_t)(dot - b);
    snprintf(base, sizeof base, "%.*s", (int)(bl < 1000 ? bl : 1000), b);
    const cJSON *mats = member(g->root, "materials");
    const size_t nm = (size_t)array_size(mats);
    const size_t ni = (size_t)array_size(member(g->root, "images"));
    char *mtl = NULL;
    size_t len = 0, cap = 0;
    FILE *mf = open_memstream(&mtl, &cap);
    out->names = calloc(nm + 1, sizeof *out->names);
    char (*tex)[1100] = calloc(ni + 1, sizeof *tex); /* each image's file, once written */
    if (!mf || !out->names || !tex)
        st = mr_fail_nomem(err, gltf_path, 4096 + nm * 8);
    if (mf)
        fprintf(mf, "# materials of %s (meshreduce)\n",
                strrchr(gltf_path, '/') ? strrchr(gltf_path, '/') + 1 : gltf_path);
    for (size_t i = 0; st == MR_OK && i < nm; i++) {
        const cJSON *mat = cJSON_GetArrayItem(mats, (int)i);
        if (!(out->names[i] = mtl_name(mat, i, out->names))) {
            st = mr_fail_nomem(err, gltf_path, 256);
            break;
        }
        out->count = i + 1;
        float c[4];
        long long src;
        const cJSON *sampler;
        base_color(g, mat, c, &src, &sampler);
        fprintf(mf, "\nnewmtl %s\nKd %.6g %.6g %.6g\n", out->names[i], (double)c[0], (double)c[1],
                (double)c[2]);
        if (c[3] < 1)
            fprintf(mf, "d %.6g\n", (double)c[3]);
        if (src < 0)
            continue;
        if (!tex[src][0]) {
            char what[48];
            snprintf(what, sizeof what, "materials[%zu]", i);
            gl_blob img;
            bool owned;
            if ((st = image_bytes(g, src, what, &img, &owned, err)) != MR_OK)
                break;
            const bool png = img.size >= 8 && memcmp(img.data, "\x89PNG", 4) == 0;
            const bool jpeg = img.size >= 3 && img.data[0] == 0xFF && img.data[1] == 0xD8;
            if (png || jpeg) {
                char path[5400];
                snprintf(tex[src], sizeof tex[src], "%.1000s_%lld.%s", base, src,
                         png ? "png" : "jpg");
                snprintf(path, sizeof path, "%s/%s", dir, tex[src]);
                st = write_bytes(out, path, img.data, img.size, err);
            }
            if (owned)
                free(img.data);
            if (st != MR_OK || !tex[src][0])
                continue;
        }
        fprintf(mf, "map_Kd %s%s\n",
                wrap_of(sampler, "wrapS") == MR_WRAP_CLAMP ? "-clamp on " : "", tex[src]);
    }
    if (mf && fclose(mf) != 0 && st == MR_OK)
        st = mr_fail_nomem(err, gltf_path, cap);
    len = mtl ? strlen(mtl) : 0;
    if (st == MR_OK) {
        char path[5400], name[1100];
        snprintf(name, sizeof name, "%s.mtl", base);
        snprintf(path, sizeof path, "%s/%s", dir, name);
        st = write_bytes(out, path, mtl, len, err);
        if (st == MR_OK && !(out->mtllib = dup_str(name)))
            st = mr_fail_nomem(err, path, 64);
    }
    free(mtl);
    free(tex);
    mr_gltf_free(g);
    if (st != MR_OK)
        mr_gltf_mtl_free(out);
    return st;
}

#endif /* MR_HAVE_GLTF */
