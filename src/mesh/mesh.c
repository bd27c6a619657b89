/* The owning mesh container. */
#include "../core/internal.h"
#include "adjacency.h"

void mr_mesh_init(mr_mesh *mesh)
{
    memset(mesh, 0, sizeof *mesh);
}

void mr_mesh_free(mr_mesh *mesh)
{
    if (!mesh)
        return;
    free(mesh->positions);
    free(mesh->normals);
    free(mesh->texcoords);
    free(mesh->colors);
    free(mesh->indices);
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        free(mesh->more_texcoords[k]);
    free(mesh->tangents);
    free(mesh->joints);
    free(mesh->weights);
    free(mesh->materials);
    mr_mesh_init(mesh);
}

unsigned mr_mesh_attributes(const mr_mesh *mesh)
{
    unsigned f = 0;
    if (mesh->normals)
        f |= MR_ATTR_NORMALS;
    if (mesh->texcoords)
        f |= MR_ATTR_TEXCOORDS;
    if (mesh->colors)
        f |= MR_ATTR_COLORS;
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        if (mesh->more_texcoords[k])
            f |= MR_ATTR_TEXCOORDS1 << k;
    if (mesh->tangents)
        f |= MR_ATTR_TANGENTS;
    if (mesh->joints && mesh->weights)
        f |= MR_ATTR_SKIN;
    if (mesh->materials)
        f |= MR_ATTR_MATERIALS;
    return f;
}

mr_status mr_mesh_alloc(mr_mesh *mesh, size_t vertex_count, size_t triangle_count,
                        unsigned attr_flags, mr_error *err)
{
    if (!mesh)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "mesh is NULL");
    if (vertex_count > (size_t)UINT32_MAX - 1)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                             "%zu vertices exceed the 32-bit index limit", vertex_count);
    if (triangle_count > SIZE_MAX / 12)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "%zu triangles are too many",
                             triangle_count);

    mr_mesh m;
    mr_mesh_init(&m);
    m.vertex_count = vertex_count;
    m.triangle_count = triangle_count;
    m.positions = mr_alloc_array(vertex_count * 3, sizeof(float));
    m.indices = mr_alloc_array(triangle_count * 3, sizeof(uint32_t));
    bool ok = m.positions && m.indices;
    if (attr_flags & MR_ATTR_NORMALS)
        ok = ok && (m.normals = mr_alloc_array(vertex_count * 3, sizeof(float)));
    if (attr_flags & MR_ATTR_TEXCOORDS)
        ok = ok && (m.texcoords = mr_alloc_array(vertex_count * 2, sizeof(float)));
    if (attr_flags & MR_ATTR_COLORS)
        ok = ok && (m.colors = mr_alloc_array(vertex_count * 4, sizeof(float)));
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        if (attr_flags & (MR_ATTR_TEXCOORDS1 << k))
            ok = ok && (m.more_texcoords[k] = mr_alloc_array(vertex_count * 2, sizeof(float)));
    if (attr_flags & MR_ATTR_TANGENTS)
        ok = ok && (m.tangents = mr_alloc_array(vertex_count * 4, sizeof(float)));
    if (attr_flags & MR_ATTR_SKIN) {
        ok = ok && (m.joints = mr_alloc_array(vertex_count * 4, sizeof(uint16_t)));
        ok = ok && (m.weights = mr_alloc_array(vertex_count * 4, sizeof(float)));
    }
    if (attr_flags & MR_ATTR_MATERIALS)
        ok = ok && (m.materials = mr_alloc_array(triangle_count, sizeof(uint32_t)));
    if (!ok) {
        mr_mesh_free(&m);
        return mr_fail_nomem(err, NULL, vertex_count * 48 + triangle_count * 12);
    }
    *mesh = m;
    return MR_OK;
}

mr_status mr_mesh_copy(mr_mesh *dst, const mr_mesh *src, mr_error *err)
{
    mr_status st = mr_mesh_alloc(dst, src->vertex_count, src->triangle_count,
                                 mr_mesh_attributes(src), err);
    if (st != MR_OK)
        return st;
    size_t n = src->vertex_count;
    memcpy(dst->positions, src->positions, n * 3 * sizeof(float));
    if (src->normals)
        memcpy(dst->normals, src->normals, n * 3 * sizeof(float));
    if (src->texcoords)
        memcpy(dst->texcoords, src->texcoords, n * 2 * sizeof(float));
    if (src->colors)
        memcpy(dst->colors, src->colors, n * 4 * sizeof(float));
    mr_mesh_copy_more(dst, 0, src, 0, n);
    memcpy(dst->indices, src->indices, src->triangle_count * 3 * sizeof(uint32_t));
    if (src->materials)
        memcpy(dst->materials, src->materials, src->triangle_count * sizeof(uint32_t));
    return MR_OK;
}

void mr_mesh_copy_more(mr_mesh *dst, size_t at, const mr_mesh *src, size_t from, size_t n)
{
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        if (dst->more_texcoords[k] && src->more_texcoords[k])
            memmove(dst->more_texcoords[k] + 2 * at, src->more_texcoords[k] + 2 * from,
                    n * 2 * sizeof(float));
    if (dst->tangents && src->tangents)
        memmove(dst->tangents + 4 * at, src->tangents + 4 * from, n * 4 * sizeof(float));
    if (dst->joints && src->joints)
        memmove(dst->joints + 4 * at, src->joints + 4 * from, n * 4 * sizeof(uint16_t));
    if (dst->weights && src->weights)
        memmove(dst->weights + 4 * at, src->weights + 4 * from, n * 4 * sizeof(float));
}

void mr_mesh_compact_vertices(mr_mesh *mesh, const uint32_t *remap, size_t new_count)
{
    /* new index <= old index, so a forward pass moves every vertex down
     * without overwriting one that is still to be read. */
    for (size_t i = 0; i < mesh->vertex_count; i++) {
        uint32_t j = remap[i];
        if (j == UINT32_MAX || j == i)
            continue;
        memcpy(mesh->positions + 3 * (size_t)j, mesh->positions + 3 * i, 3 * sizeof(float));
        if (mesh->normals)
            memcpy(mesh->normals + 3 * (size_t)j, mesh->normals + 3 * i, 3 * sizeof(float));
        if (mesh->texcoords)
            memcpy(mesh->texcoords + 2 * (size_t)j, mesh->texcoords + 2 * i,
                   2 * sizeof(float));
        if (mesh->colors)
            memcpy(mesh->colors + 4 * (size_t)j, mesh->colors + 4 * i, 4 * sizeof(float));
        mr_mesh_copy_more(mesh, j, mesh, i, 1);
    }
    mesh->vertex_count = new_count;
}

size_t mr_mesh_material_count(const mr_mesh *mesh)
{
    if (!mesh || !mesh->materials || !mesh->triangle_count)
        return 0;
    uint32_t *key, *order;
    if (mr_material_order(mesh->materials, mesh->triangle_count, &key, &order, NULL) != MR_OK)
        return 0;
    size_t n = 0;
    for (size_t t = 0; t < mesh->triangle_count; t++)
        n += key[t] != 0 && (t == 0 || key[t] != key[t - 1]);
    free(key);
    free(order);
    return n;
}

mr_status mr_material_order(const uint32_t *materials, size_t n, uint32_t **key,
                            uint32_t **order, mr_error *err)
{
    *key = *order = NULL;
    if (n > UINT32_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "%zu triangles to order", n);
    uint32_t *k = mr_alloc_array(n + 1, sizeof *k), *o = mr_alloc_array(n + 1, sizeof *o);
    mr_status st = k && o ? MR_OK : mr_fail_nomem(err, NULL, n * 8);
    for (size_t t = 0; st == MR_OK && t < n; t++) {
        k[t] = materials[t] + 1u; /* none (UINT32_MAX) wraps to 0: first */
        o[t] = (uint32_t)t;
    }
    if (st == MR_OK)
        st = mr_radix_sort_u32(k, o, n, 32, 1, err); /* stable: each run in its order */
    if (st != MR_OK) {
        free(k);
        free(o);
        return st;
    }
    *key = k;
    *order = o;
    return MR_OK;
}
