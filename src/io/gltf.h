/*
 * glTF 2.0 (gltf.c): a document read whole (.gltf with external or
 * base64 buffers, or .glb), its triangle primitives as meshes, their
 * replacement by simplified ones, and the document written back with
 * everything else as it was (scene, nodes, materials, images, skins,
 * animations, extras, extensions). Built with cJSON (Debian libcjson-dev);
 * without it every entry point fails with MR_ERR_UNSUPPORTED ("glTF
 * support was not built"). Internal.
 */
#ifndef MR_IO_GLTF_H
#define MR_IO_GLTF_H

#include "../core/internal.h"

typedef struct mr_gltf mr_gltf;

/* Load a document from `size` bytes at `data`. `name` names it in
 * messages; `base_dir` is the folder its relative URIs are read from, or
 * NULL, where only the .glb's own chunk and data: URIs are read (an
 * external buffer is then an error): reading from memory, the fuzzer. */
mr_status mr_gltf_load(const void *data, size_t size, const char *name, const char *base_dir,
                       mr_gltf **out, mr_error *err);
/* Load the file at path (its folder is the base for its URIs). */
mr_status mr_gltf_load_file(const char *path, mr_gltf **out, mr_error *err);
void mr_gltf_free(mr_gltf *g);

/* The default scene's triangles (points and lines left out; strips and
 * fans as triangles) as one mesh in world space: each node's mesh under
 * its transform, an instanced mesh once per node. Normals and texture
 * coordinates (TEXCOORD_0) where every primitive has them, colors
 * (COLOR_0; white where a primitive has none) where one has. */
mr_status mr_gltf_scene_mesh(const mr_gltf *g, mr_mesh *out, mr_error *err);

/* A material as the renderer draws it (mr_look_read): its base colour
 * (display values) and its base-colour texture's image and sampler. */
typedef struct mr_gltf_material {
    float color[4];
    long long image;   /* images[] of its baseColorTexture on TEXCOORD_0, or -1 */
    mr_wrap wrap_s, wrap_t;
} mr_gltf_material;

/* The scene mesh for the look: texture coordinates where any primitive
 * has them (zero elsewhere), colours as display values; each triangle's
 * material (*face_material: an index into *materials, the document's
 * materials in order, or UINT32_MAX); *image_count the document's
 * images. */
mr_status mr_gltf_scene_look(const mr_gltf *g, mr_mesh *mesh, uint32_t **face_material,
                             mr_gltf_material **materials, size_t *material_count,
                             size_t *image_count, mr_error *err);
/* images[i]'s bytes (its URI's, or its buffer view's in the document):
 * *owned says whether they were read for this call (free them). `what`
 * names the asker in messages. */
mr_status mr_gltf_image(const mr_gltf *g, long long i, const char *what, uint8_t **bytes,
                        size_t *size, bool *owned, mr_error *err);

/* The triangle primitives of every mesh (each mesh once, however many
 * nodes instance it), in the order of meshes and their primitives. */
size_t mr_gltf_primitive_count(const mr_gltf *g);
/* Primitive i in its mesh's own space, as a mesh: positions, NORMAL,
 * TEXCOORD_0, COLOR_0 (as rgba), indices (strips and fans as triangles;
 * implicit ones made). Its other attributes (TEXCOORD_1.., COLOR_1..,
 * JOINTS_n, WEIGHTS_n, morph targets) are carried by mr_gltf_replace. */
mr_status mr_gltf_primitive_mesh(const mr_gltf *g, size_t i, mr_mesh *out, mr_error *err);
/* Which mesh and which of its primitives primitive i is. */
void mr_gltf_primitive_at(const mr_gltf *g, size_t i, size_t *mesh, size_t *primitive);

/* Replace primitive i's geometry by m (its triangles, positions, normals,
 * TEXCOORD_0 and COLOR_0 as the primitive had them), where origin[v] is
 * output vertex v's vertex of the primitive's mesh (mr_gltf_primitive_mesh):
 * every other attribute and each morph target's displacement is that
 * vertex's. A TANGENT is dropped (clients compute MikkTSpace tangents
 * where a material needs them); *dropped_tangents counts such primitives. */
mr_status mr_gltf_replace(mr_gltf *g, size_t i, const mr_mesh *m, const uint32_t *origin,
                          mr_error *err);
size_t mr_gltf_dropped_tangents(const mr_gltf *g);

/* Level of detail `level` (1, 2, ...: call them in order): every mesh
 * once more (named NAME_lodK), its triangle primitives replaced by
 * levels[i] for primitive i (origin as mr_gltf_replace's, into primitive
 * i's vertices); every node with a mesh gets an LOD node (its transform,
 * the copy's mesh, its skin and morph weights; no children; extras "lod"
 * and "lod_error") appended to its MSFT_lod ids; MSFT_lod joins
 * extensionsUsed. The document's primitives stay as they were. */
mr_status mr_gltf_add_lod(mr_gltf *g, const mr_mesh *levels, const uint32_t *const *origins,
                          size_t level, double error_rel, mr_error *err);

/* Write the document: .glb by the path's extension (else .gltf, with its
 * buffer in PATH's name with .bin, and its external images copied beside
 * it where it goes to another folder; a .glb takes them into its buffer).
 * Accessors and buffer views that nothing uses any more are dropped (the
 * others renumbered), the buffers joined into one. */
mr_status mr_gltf_write(mr_gltf *g, const char *path, mr_error *err);

/* A glTF file's materials for an OBJ written from its mesh
 * (mr_write_options.materials_from): OBJ's name with .mtl beside it, a
 * newmtl per material (names made unique, blanks as '_'; Kd and d from
 * baseColorFactor in display values; map_Kd the base colour texture on
 * TEXCOORD_0 where it is PNG or JPEG, beside as OBJBASE_K.ext, K the
 * image's index). mtllib is the .mtl's file name, names[i] material i's;
 * the files are staged (output.h): mr_gltf_mtl_commit moves them into
 * place, mr_gltf_mtl_free removes those not committed. */
typedef struct mr_gltf_mtl {
    char *mtllib;
    char **names;
    size_t count;
    struct mr_output_file *files;
    char **paths;
    size_t nfiles;
} mr_gltf_mtl;
mr_status mr_gltf_mtl_export(const char *gltf_path, const char *obj_path, mr_gltf_mtl *out,
                             mr_error *err);
mr_status mr_gltf_mtl_commit(mr_gltf_mtl *m, mr_error *err);
void mr_gltf_mtl_free(mr_gltf_mtl *m);

/* A plain mesh as a glTF document of one mesh, node and scene. */
mr_status mr_gltf_write_mesh(const mr_mesh *m, const char *path,
                             const mr_write_options *options, mr_error *err);

#endif /* MR_IO_GLTF_H */
