/* A mesh with its look (mr_look_read): glTF's materials through the glTF
 * reader, an OBJ's usemtl groups and mtllib files through the OBJ's
 * (io/obj_materials.c), their textures decoded here; vertex colours of
 * every format. */
#include "../core/internal.h"

#include "../io/gltf.h"
#include "../io/obj_materials.h"

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

static mr_status obj_look(const char *path, mr_look *look, mr_error *err)
{
    mr_obj_materials om;
    mr_status st = mr_obj_materials_read(path, &om, err);
    if (st != MR_OK)
        return st;
    mr_mtl_material *defs = NULL;
    size_t ndefs = 0;
    st = mr_mtl_read_all(path, om.mtllib, &defs, &ndefs, err);
    if (st != MR_OK)
        st = rewrap(err, st, path, "its material library");
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
        def[g] = mr_mtl_find(defs, ndefs, om.names[g]);
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
        const mr_mtl_material *d = &defs[def[g]];
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
            char prefix[MR_MTL_NAME_MAX + 40];
            snprintf(prefix, sizeof prefix, "material '%s': its texture", d->name);
            st = rewrap(err, st, path, prefix);
        } else {
            rm->texture = &look->images[g];
        }
    }
    free(def);
    free(defs);
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
