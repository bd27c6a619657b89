/* An OBJ file's materials (mr_obj_materials_read): its mtllib lines and
 * each triangle's usemtl, for the writer to keep them through simplify
 * and convert, and for the renderer's look. */
#include "../core/internal.h"

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

/* Whether the line [s, e) (trimmed) starts with keyword kw and a blank;
 * *rest: the text after it, trimmed. */
static bool keyword(const char *s, const char *e, const char *kw, const char **rest)
{
    const size_t n = strlen(kw);
    if ((size_t)(e - s) <= n || memcmp(s, kw, n) != 0 || !isspace((unsigned char)s[n]))
        return false;
    const char *r = s + n;
    while (r < e && isspace((unsigned char)*r))
        r++;
    *rest = r;
    return r < e;
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
    size_t cap_names = 0, cap_faces = 0, lib_len = 0;
    uint32_t cur = UINT32_MAX;
    bool any_usemtl = false;
    for (const char *p = f.data, *end = f.data + f.size; p < end && st == MR_OK;) {
        const char *e = memchr(p, '\n', (size_t)(end - p));
        e = e ? e : end;
        const char *s = p, *le = e, *rest;
        p = e + 1;
        while (s < le && isspace((unsigned char)*s))
            s++;
        while (le > s && isspace((unsigned char)le[-1]))
            le--;
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
        } else if (keyword(s, le, "usemtl", &rest)) {
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
        } else if (keyword(s, le, "mtllib", &rest)) {
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
    mr_unmap_file(&f);
    if (st == MR_OK && !any_usemtl) {
        free(out->face_material); /* no usemtl: no materials */
        out->face_material = NULL;
    }
    if (st != MR_OK)
        mr_obj_materials_free(out);
    return st;
}
