/* A mesh with its look (mr_look_read): glTF's materials through the glTF
 * reader, an OBJ's usemtl groups and its mtllib files here, vertex
 * colours of every format. */
#include "../core/internal.h"

#include "../io/gltf.h"
#include "../io/mapped.h"

#include <ctype.h>
#include <stdio.h>

void mr_look_free(mr_look *look)
{
    if (!look)
        return;
    mr_mesh_free(&look->mesh);
    free(look->face_material);
    free(look->materials);
    for (size_t i = 0; i < look->image_count; i++)
        mr_image_free(&look->images[i]);
    free(look->images);
    memset(look, 0, sizeof *look);
}

/* ---- OBJ: mtllib, usemtl, and the .mtl files ------------------------------- */

#define NAME_MAX_LEN 512

/* err's message taken into a new one: "path: <prefix>: <old message>
 * (<hint>)" (the old text copied first: the two share the buffer). */
static mr_status rewrap(mr_error *err, mr_status st, const char *path, const char *prefix)
{
    if (!err)
        return st;
    char old[sizeof err->message];
    snprintf(old, sizeof old, "%s", err->message);
    return mr_fail_plain(err, st, path, "%s: %s (render --plain draws without it)", prefix,
                         old);
}

typedef struct obj_mat {
    char name[NAME_MAX_LEN];
    float color[4];
    char texture[NAME_MAX_LEN * 2]; /* path, or "" */
    mr_wrap wrap;
} obj_mat;

typedef struct mat_list {
    obj_mat *m;
    size_t n, cap;
} mat_list;

/* The line [s, e) trimmed of blanks at both ends (and a '\r'). */
static void trim(const char **s, const char **e)
{
    while (*s < *e && isspace((unsigned char)**s))
        (*s)++;
    while (*e > *s && isspace((unsigned char)(*e)[-1]))
        (*e)--;
}

/* Whether the line [s, e) starts with keyword kw followed by a blank;
 * *rest is the text after it, trimmed. */
static bool keyword(const char *s, const char *e, const char *kw, const char **rest)
{
    const size_t n = strlen(kw);
    if ((size_t)(e - s) < n || memcmp(s, kw, n) != 0 ||
        (s + n < e && !isspace((unsigned char)s[n])))
        return false;
    const char *r = s + n, *re = e;
    trim(&r, &re);
    *rest = r;
    return true;
}

/* dir + '/' + the name [s, e) (backslashes as slashes), or the name
 * alone where it is absolute. */
static bool join_path(const char *dir, const char *s, const char *e, char *out, size_t cap)
{
    size_t n = 0;
    if (*s != '/' && dir[0]) {
        int w = snprintf(out, cap, "%s/", dir);
        if (w < 0 || (size_t)w >= cap)
            return false;
        n = (size_t)w;
    }
    for (; s < e; s++) {
        if (n + 1 >= cap)
            return false;
        out[n++] = *s == '\\' ? '/' : *s;
    }
    out[n] = '\0';
    return true;
}

static void dir_of(const char *path, char *dir, size_t cap)
{
    const char *slash = strrchr(path, '/');
    size_t n = slash ? (size_t)(slash - path) : 0;
    if (n >= cap)
        n = cap - 1;
    memcpy(dir, path, n);
    dir[n] = '\0';
    if (slash && n == 0 && cap > 1) { /* the root */
        dir[0] = '/';
        dir[1] = '\0';
    }
}

/* The last blank-separated token of [s, e) and whether "-clamp on" came
 * before it (map_Kd's options precede the file name). */
static void map_file(const char *s, const char *e, const char **fs, bool *clamp)
{
    *clamp = false;
    const char *p = s;
    while (p < e) {
        while (p < e && isspace((unsigned char)*p))
            p++;
        const char *t = p;
        while (p < e && !isspace((unsigned char)*p))
            p++;
        if ((size_t)(p - t) == 6 && !memcmp(t, "-clamp", 6)) {
            while (p < e && isspace((unsigned char)*p))
                p++;
            *clamp = e - p >= 2 && !memcmp(p, "on", 2);
        }
    }
    /* the name: after the last option's arguments is not knowable in
     * general; take the last token (names with blanks are rare) */
    const char *t = e;
    while (t > s && !isspace((unsigned char)t[-1]))
        t--;
    *fs = t;
}

static mr_status read_mtl(const char *path, mat_list *ml, mr_error *err)
{
    mr_mapped_file f;
    mr_status st = mr_map_file(path, &f, err);
    if (st == MR_ERR_EMPTY) {
        mr_error_clear(err);
        return MR_OK; /* an empty library: no materials */
    }
    if (st != MR_OK)
        return st;
    char dir[NAME_MAX_LEN];
    dir_of(path, dir, sizeof dir);
    obj_mat *cur = NULL;
    size_t line = 0;
    for (const char *p = f.data, *end = f.data + f.size; p < end && st == MR_OK;) {
        const char *e = memchr(p, '\n', (size_t)(end - p));
        e = e ? e : end;
        const char *s = p, *le = e;
        p = e + 1;
        line++;
        trim(&s, &le);
        const char *rest;
        if (keyword(s, le, "newmtl", &rest)) {
            if (ml->n == ml->cap) {
                size_t nc = ml->cap ? 2 * ml->cap : 8;
                obj_mat *nm = realloc(ml->m, nc * sizeof *nm);
                if (!nm) {
                    st = mr_fail_nomem(err, path, nc * sizeof *nm);
                    break;
                }
                ml->m = nm;
                ml->cap = nc;
            }
            cur = &ml->m[ml->n++];
            memset(cur, 0, sizeof *cur);
            snprintf(cur->name, sizeof cur->name, "%.*s", (int)(le - rest), rest);
            cur->color[0] = cur->color[1] = cur->color[2] = cur->color[3] = 1;
        } else if (!cur) {
            continue; /* before the first material: nothing to set */
        } else if (keyword(s, le, "Kd", &rest)) {
            float c[3];
            char *q = (char *)rest;
            for (int k = 0; k < 3; k++) {
                char *next;
                c[k] = strtof(q, &next);
                if (next == q || !isfinite(c[k]))
                    c[k] = k ? c[k - 1] : 1; /* "Kd r" is grey r */
                q = next;
            }
            for (int k = 0; k < 3; k++)
                cur->color[k] = c[k] < 0 ? 0 : c[k] > 1 ? 1 : c[k];
        } else if (keyword(s, le, "map_Kd", &rest)) {
            const char *fs;
            bool clamp;
            map_file(rest, le, &fs, &clamp);
            if (fs == le || !join_path(dir, fs, le, cur->texture, sizeof cur->texture))
                st = mr_fail_plain(err, MR_ERR_PARSE, path,
                                   "line %zu: map_Kd of material '%s' names no usable file",
                                   line, cur->name);
            cur->wrap = clamp ? MR_WRAP_CLAMP : MR_WRAP_REPEAT;
        }
    }
    mr_unmap_file(&f);
    return st;
}

static long find_mat(const mat_list *ml, const char *name)
{
    /* the last definition of a name wins, as later libraries override */
    for (size_t i = ml->n; i-- > 0;)
        if (!strcmp(ml->m[i].name, name))
            return (long)i;
    return -1;
}

static mr_status obj_look(const char *path, mr_look *look, mr_error *err)
{
    mr_obj_materials om;
    mr_status st = mr_obj_materials_read(path, &om, err);
    if (st != MR_OK)
        return st;
    char dir[NAME_MAX_LEN];
    dir_of(path, dir, sizeof dir);
    mat_list ml = {NULL, 0, 0};
    /* the libraries, blank-separated */
    for (const char *t = om.mtllib; t && *t && st == MR_OK;) {
        const char *te = t;
        while (*te && !isspace((unsigned char)*te))
            te++;
        char lib[NAME_MAX_LEN * 2];
        if (!join_path(dir, t, te, lib, sizeof lib))
            st = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path, "mtllib path too long");
        else
            st = read_mtl(lib, &ml, err);
        if (st != MR_OK)
            st = rewrap(err, st, path, "its material library");
        t = te;
        while (*t && isspace((unsigned char)*t))
            t++;
    }
    const size_t nt = look->mesh.triangle_count;
    /* each usemtl name's definition; faces of a name no library defines
     * are plain (and faces that do not line up with the reader's: all) */
    long *def = NULL;
    if (st == MR_OK && om.face_material && om.triangle_count == nt && om.count) {
        def = malloc(om.count * sizeof *def);
        look->face_material = malloc((nt ? nt : 1) * sizeof *look->face_material);
        look->materials = calloc(om.count, sizeof *look->materials);
        look->images = calloc(om.count, sizeof *look->images);
        if (!def || !look->face_material || !look->materials || !look->images)
            st = mr_fail_nomem(err, path, nt * sizeof *look->face_material);
        else
            look->material_count = look->image_count = om.count;
    }
    for (size_t g = 0; st == MR_OK && g < look->material_count; g++)
        def[g] = find_mat(&ml, om.names[g]);
    for (size_t t = 0; st == MR_OK && look->face_material && t < nt; t++) {
        const uint32_t g = om.face_material[t];
        look->face_material[t] = g != UINT32_MAX && def[g] >= 0 ? g : UINT32_MAX;
    }
    for (size_t g = 0; st == MR_OK && g < look->material_count; g++) {
        mr_render_material *rm = &look->materials[g];
        rm->v_up = 1;
        rm->color[0] = rm->color[1] = rm->color[2] = rm->color[3] = 1;
        if (def[g] < 0)
            continue;
        const obj_mat *d = &ml.m[def[g]];
        memcpy(rm->color, d->color, sizeof rm->color);
        rm->wrap_s = rm->wrap_t = d->wrap;
        if (!d->texture[0] || !look->mesh.texcoords)
            continue;
        st = mr_image_read(d->texture, &look->images[g], err);
        if (st == MR_ERR_UNSUPPORTED) {
            st = MR_OK; /* another image format, or one not built: the colour */
            mr_error_clear(err);
            continue;
        }
        if (st != MR_OK) {
            char prefix[NAME_MAX_LEN + 40];
            snprintf(prefix, sizeof prefix, "material '%s': its texture", d->name);
            st = rewrap(err, st, path, prefix);
        } else {
            rm->texture = &look->images[g];
        }
    }
    free(def);
    free(ml.m);
    mr_obj_materials_free(&om);
    return st;
}

/* ---- glTF: its materials, their base-colour textures decoded ---------------- */

static mr_status gltf_look(const mr_gltf *g, const char *path, mr_look *look, mr_error *err)
{
    mr_gltf_material *gm = NULL;
    size_t nm = 0, ni = 0;
    mr_status st = mr_gltf_scene_look(g, &look->mesh, &look->face_material, &gm, &nm, &ni, err);
    if (st == MR_OK && nm) {
        look->materials = calloc(nm, sizeof *look->materials);
        look->images = calloc(ni + 1, sizeof *look->images);
        if (!look->materials || !look->images)
            st = mr_fail_nomem(err, NULL, nm * sizeof *look->materials);
        else {
            look->material_count = nm;
            look->image_count = ni;
        }
    }
    for (size_t m = 0; st == MR_OK && m < nm; m++) {
        mr_render_material *rm = &look->materials[m];
        memcpy(rm->color, gm[m].color, sizeof rm->color);
        rm->wrap_s = gm[m].wrap_s;
        rm->wrap_t = gm[m].wrap_t;
        rm->v_up = 1; /* the scene mesh's v points up */
        const long long src = gm[m].image;
        if (src < 0)
            continue;
        mr_image *im = &look->images[src];
        if (!im->rgba) {
            char what[96];
            snprintf(what, sizeof what, "materials[%zu]'s base colour texture", m);
            uint8_t *bytes;
            size_t size;
            bool owned;
            st = mr_gltf_image(g, src, what, &bytes, &size, &owned, err);
            if (st == MR_OK) {
                char name[1200];
                snprintf(name, sizeof name, "%.1000s: %s, images[%lld]", path, what, src);
                st = mr_image_decode(bytes, size, name, im, err);
            }
            if (owned)
                free(bytes);
            if (st == MR_ERR_UNSUPPORTED) {
                /* another image format, or one not built: the colour */
                st = MR_OK;
                mr_error_clear(err);
                continue;
            }
        }
        if (st == MR_OK)
            rm->texture = im;
    }
    free(gm);
    return st;
}

mr_status mr_look_read(const char *path, mr_look *look, mr_error *err)
{
    mr_error_clear(err);
    if (!look || !path)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "look", "no path or look given");
    memset(look, 0, sizeof *look);
    mr_status st;
    const mr_format fmt = mr_format_from_path(path);
    if (fmt == MR_FORMAT_GLTF) {
        mr_gltf *g;
        st = mr_gltf_load_file(path, &g, err);
        if (st == MR_OK)
            st = gltf_look(g, path, look, err);
        mr_gltf_free(g);
        if (st != MR_OK)
            mr_look_free(look);
        return st;
    }
    st = mr_mesh_read(path, NULL, &look->mesh, err);
    if (st == MR_OK && fmt == MR_FORMAT_OBJ && look->mesh.triangle_count)
        st = obj_look(path, look, err);
    if (st != MR_OK)
        mr_look_free(look);
    return st;
}
