/* An OBJ file's materials (mr_obj_materials_read): its mtllib lines and
 * each triangle's usemtl, for the writer to keep them through simplify
 * and convert, and for the renderer's look. */
#include "obj_materials.h"

#include "mapped.h"

#include <ctype.h>

void mr_obj_materials_free(mr_obj_materials *m)
{
    if (!m)
        return;
    free(m->mtllib);
    for (size_t i = 0; i < m->count; i++)
        free(m->names[i]);
    free(m->names);
    free(m->face_material);
    memset(m, 0, sizeof *m);
}

/* The line [s, e) trimmed of blanks at both ends (and a '\r'). */
static void trim(const char **s, const char **e)
{
    while (*s < *e && isspace((unsigned char)**s))
        (*s)++;
    while (*e > *s && isspace((unsigned char)(*e)[-1]))
        (*e)--;
}

/* Whether the trimmed line [s, e) starts with keyword kw followed by a
 * blank or its end; *rest is the text after it, trimmed (maybe empty). */
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

/* Corners of a face line's rest (its tokens up to a '#'), as the reader
 * counts them. */
static size_t corner_count(const char *s, const char *e)
{
    size_t n = 0;
    bool blank = true;
    for (; s < e && *s != '#'; s++) {
        const bool b = isspace((unsigned char)*s);
        n += blank && !b;
        blank = b;
    }
    return n;
}

static char *dup_range(const char *s, const char *e)
{
    char *d = malloc((size_t)(e - s) + 1);
    if (d) {
        memcpy(d, s, (size_t)(e - s));
        d[e - s] = '\0';
    }
    return d;
}

mr_status mr_obj_materials_parse(const char *data, size_t size, const char *path,
                                 mr_obj_materials *out, mr_error *err)
{
    memset(out, 0, sizeof *out);
    mr_status st = MR_OK;
    size_t cap_names = 0, cap_faces = 0, lib_len = 0;
    uint32_t cur = UINT32_MAX;
    bool any_usemtl = false;
    for (const char *p = data, *end = data + size; p < end && st == MR_OK;) {
        const char *e = memchr(p, '\n', (size_t)(end - p));
        e = e ? e : end;
        const char *s = p, *le = e, *rest;
        p = e + 1;
        trim(&s, &le);
        if (s == le)
            continue;
        if (*s == 'f' && keyword(s, le, "f", &rest)) {
            const size_t c = corner_count(rest, le);
            if (c < 3)
                continue; /* the reader refuses it */
            if (out->triangle_count + c - 2 > cap_faces) {
                size_t nc = cap_faces ? 2 * cap_faces : 4096;
                while (nc < out->triangle_count + c - 2)
                    nc *= 2;
                uint32_t *nf = mr_realloc_array(out->face_material, nc, sizeof *nf);
                if (!nf) {
                    st = mr_fail_nomem(err, path, nc * sizeof *nf);
                    break;
                }
                out->face_material = nf;
                cap_faces = nc;
            }
            for (size_t k = 2; k < c; k++)
                out->face_material[out->triangle_count++] = cur;
        } else if (keyword(s, le, "usemtl", &rest) && rest < le) {
            any_usemtl = true;
            size_t i = 0;
            while (i < out->count && !(strlen(out->names[i]) == (size_t)(le - rest) &&
                                      !memcmp(out->names[i], rest, (size_t)(le - rest))))
                i++;
            if (i == out->count) {
                if (out->count == cap_names) {
                    const size_t nc = cap_names ? 2 * cap_names : 8;
                    char **nn = mr_realloc_array(out->names, nc, sizeof *nn);
                    if (!nn) {
                        st = mr_fail_nomem(err, path, nc * sizeof *nn);
                        break;
                    }
                    out->names = nn;
                    cap_names = nc;
                }
                if (!(out->names[out->count] = dup_range(rest, le))) {
                    st = mr_fail_nomem(err, path, (size_t)(le - rest) + 1);
                    break;
                }
                out->count++;
            }
            cur = (uint32_t)i;
        } else if (keyword(s, le, "mtllib", &rest) && rest < le) {
            const size_t n = (size_t)(le - rest);
            char *nl = realloc(out->mtllib, lib_len + n + 2);
            if (!nl) {
                st = mr_fail_nomem(err, path, lib_len + n + 2);
                break;
            }
            out->mtllib = nl;
            if (lib_len)
                nl[lib_len++] = ' ';
            memcpy(nl + lib_len, rest, n);
            lib_len += n;
            nl[lib_len] = '\0';
        }
    }
    if (st == MR_OK && !any_usemtl) {
        free(out->face_material); /* no usemtl: no materials */
        out->face_material = NULL;
    }
    if (st != MR_OK)
        mr_obj_materials_free(out);
    return st;
}

mr_status mr_obj_materials_read(const char *path, mr_obj_materials *out, mr_error *err)
{
    mr_error_clear(err);
    if (!out)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path, "no materials given");
    memset(out, 0, sizeof *out);
    mr_mapped_file f;
    mr_status st = mr_map_file(path, &f, err);
    if (st != MR_OK)
        return st;
    st = mr_obj_materials_parse(f.data, f.size, path, out, err);
    mr_unmap_file(&f);
    return st;
}

/* ---- the .mtl libraries ----------------------------------------------------- */

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

typedef struct mtl_list {
    mr_mtl_material *m;
    size_t n, cap;
} mtl_list;

static mr_status read_mtl(const char *path, mtl_list *ml, mr_error *err)
{
    mr_mapped_file f;
    mr_status st = mr_map_file(path, &f, err);
    if (st == MR_ERR_EMPTY) {
        mr_error_clear(err);
        return MR_OK; /* an empty library: no materials */
    }
    if (st != MR_OK)
        return st;
    char dir[MR_MTL_NAME_MAX];
    dir_of(path, dir, sizeof dir);
    mr_mtl_material *cur = NULL;
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
                mr_mtl_material *nm = mr_realloc_array(ml->m, nc, sizeof *nm);
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
            /* the numbers from a copy of the line: the map has no
             * terminating NUL for strtof to stop at */
            char text[256];
            snprintf(text, sizeof text, "%.*s", (int)(le - rest), rest);
            float c[3];
            char *q = text;
            for (int k = 0; k < 3; k++) {
                char *next;
                c[k] = strtof(q, &next);
                if (next == q || !isfinite(c[k]))
                    c[k] = k ? c[k - 1] : 1; /* "Kd r" is grey r */
                q = next;
            }
            for (int k = 0; k < 3; k++)
                cur->color[k] = c[k] < 0 ? 0 : c[k] > 1 ? 1 : c[k];
        } else if (keyword(s, le, "d", &rest) || keyword(s, le, "Tr", &rest)) {
            /* opacity: d, or Tr its complement */
            char text[64];
            snprintf(text, sizeof text, "%.*s", (int)(le - rest), rest);
            char *next;
            float a = strtof(text, &next);
            if (next != text && isfinite(a)) {
                a = *s == 'T' ? 1 - a : a;
                cur->color[3] = a < 0 ? 0 : a > 1 ? 1 : a;
            }
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

mr_status mr_mtl_read_all(const char *obj_path, const char *mtllib, mr_mtl_material **out,
                          size_t *count, mr_error *err)
{
    char dir[MR_MTL_NAME_MAX];
    dir_of(obj_path, dir, sizeof dir);
    mtl_list ml = {NULL, 0, 0};
    mr_status st = MR_OK;
    for (const char *t = mtllib; t && *t && st == MR_OK;) {
        const char *te = t;
        while (*te && !isspace((unsigned char)*te))
            te++;
        char lib[2 * MR_MTL_NAME_MAX];
        if (!join_path(dir, t, te, lib, sizeof lib))
            st = mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, obj_path, "mtllib path too long");
        else
            st = read_mtl(lib, &ml, err);
        t = te;
        while (*t && isspace((unsigned char)*t))
            t++;
    }
    if (st != MR_OK) {
        free(ml.m);
        ml.m = NULL;
        ml.n = 0;
    }
    *out = ml.m;
    *count = ml.n;
    return st;
}

long mr_mtl_find(const mr_mtl_material *m, size_t count, const char *name)
{
    for (size_t i = count; i-- > 0;)
        if (!strcmp(m[i].name, name))
            return (long)i;
    return -1;
}
