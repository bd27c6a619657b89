/* An OBJ's material libraries (.mtl files) as the renderer draws them
 * (obj_materials.c; mr_obj_materials_read, the usemtl side, is public).
 * Internal. */
#ifndef MR_IO_OBJ_MATERIALS_H
#define MR_IO_OBJ_MATERIALS_H

#include "../core/internal.h"

#define MR_MTL_NAME_MAX 512

/* mr_obj_materials_read of an OBJ's bytes (path names it in messages). */
mr_status mr_obj_materials_parse(const char *data, size_t size, const char *path,
                                 mr_obj_materials *out, mr_error *err);

/* One newmtl: its Kd (clamped to [0, 1]; white where not given) and its
 * map_Kd file (a path from the library's folder, or ""), whose `-clamp
 * on` makes its wrap MR_WRAP_CLAMP. */
typedef struct mr_mtl_material {
    char name[MR_MTL_NAME_MAX];
    float color[4];
    char texture[2 * MR_MTL_NAME_MAX];
    mr_wrap wrap;
} mr_mtl_material;

/* The materials of the libraries named in `mtllib` (blank-separated, as
 * mr_obj_materials gives them; paths from the folder of the OBJ at
 * obj_path), in the order defined: *out (free it) and *count. An empty
 * library has none; one that cannot be read is an error naming it. */
mr_status mr_mtl_read_all(const char *obj_path, const char *mtllib, mr_mtl_material **out,
                          size_t *count, mr_error *err);

/* The last of them named `name` (later libraries override), or -1. */
long mr_mtl_find(const mr_mtl_material *m, size_t count, const char *name);

#endif
