/*
 * What mr_mesh_simplify carries besides the attributes it weighs: each
 * triangle's material, texture sets 1-3, joints and weights.
 *
 * Materials: a vertex that triangles of two materials share is split into
 * one vertex per material (the same values) before the run, so the border
 * between materials is a seam that the seam rules keep in place; each
 * output triangle takes its first corner's material (every corner has
 * it), and the output's triangles are grouped by material (none first,
 * then by id; each run in its order). The rest is the surviving input
 * vertex's: a vertex whose values differ from its neighbour's at one
 * position is a seam already.
 */
#include "carried.h"

#include <stdlib.h>
#include <string.h>

void mr_carried_free(mr_carried *c)
{
    mr_mesh_free(&c->split);
    free(c->src);
    free(c->vmat);
    free(c->lock);
    memset(c, 0, sizeof *c);
}

mr_status mr_carried_split(const mr_mesh *in, const uint8_t *lock, mr_carried *c, mr_error *err)
{
    memset(c, 0, sizeof *c);
    mr_mesh_init(&c->split);
    const size_t nv = in->vertex_count, nc = 3 * in->triangle_count;
    uint32_t *head = mr_alloc_array(nv + 1, sizeof *head);
    uint32_t *next = mr_alloc_array(nc + 1, sizeof *next);
    uint32_t *vs = mr_alloc_array(nc + 1, sizeof *vs), *vm = mr_alloc_array(nc + 1, sizeof *vm);
    uint32_t *idx = mr_alloc_array(nc + 1, sizeof *idx);
    mr_status st = MR_OK;
    if (!head || !next || !vs || !vm || !idx)
        st = mr_fail_nomem(err, NULL, nv * 4 + nc * 16);
    size_t made = 0;
    for (size_t v = 0; st == MR_OK && v < nv; v++)
        head[v] = UINT32_MAX;
    for (size_t k = 0; st == MR_OK && k < nc; k++) {
        const uint32_t v = in->indices[k], g = in->materials[k / 3];
        uint32_t x = head[v];
        while (x != UINT32_MAX && vm[x] != g)
            x = next[x];
        if (x == UINT32_MAX) {
            x = (uint32_t)made++;
            vs[x] = v;
            vm[x] = g;
            next[x] = head[v];
            head[v] = x;
        }
        idx[k] = x;
    }
    if (st == MR_OK && made > (size_t)UINT32_MAX - 1)
        st = mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL,
                           "%zu vertices after splitting them by material exceed the 32-bit "
                           "index limit",
                           made);
    if (st == MR_OK)
        st = mr_mesh_alloc(&c->split, made, in->triangle_count,
                           mr_mesh_attributes(in) & MR_ATTR_BASIC, err);
    if (st == MR_OK && lock && !(c->lock = mr_alloc_array(made + 1, 1)))
        st = mr_fail_nomem(err, NULL, made);
    for (size_t x = 0; st == MR_OK && x < made; x++) {
        const size_t v = vs[x];
        memcpy(c->split.positions + 3 * x, in->positions + 3 * v, 12);
        if (in->normals)
            memcpy(c->split.normals + 3 * x, in->normals + 3 * v, 12);
        if (in->texcoords)
            memcpy(c->split.texcoords + 2 * x, in->texcoords + 2 * v, 8);
        if (in->colors)
            memcpy(c->split.colors + 4 * x, in->colors + 4 * v, 16);
        if (lock)
            c->lock[x] = lock[v];
    }
    if (st == MR_OK)
        memcpy(c->split.indices, idx, nc * sizeof *idx);
    free(head);
    free(next);
    free(idx);
    c->src = vs;
    c->vmat = vm;
    if (st != MR_OK)
        mr_carried_free(c);
    return st;
}

mr_status mr_carried_finish(const mr_mesh *in, const mr_carried *c, mr_mesh *out,
                            uint32_t *origin, mr_error *err)
{
    const size_t nv = out->vertex_count, nt = out->triangle_count;
    const unsigned more = mr_mesh_attributes(in) &
                          (MR_ATTR_TEXCOORDS1 | MR_ATTR_TEXCOORDS2 | MR_ATTR_TEXCOORDS3 |
                           MR_ATTR_SKIN);
    mr_mesh extra;
    mr_mesh_init(&extra);
    mr_status st = mr_mesh_alloc(&extra, nv, in->materials ? nt : 0,
                                 more | (in->materials ? MR_ATTR_MATERIALS : 0), err);
    if (st != MR_OK)
        return st;
    if (in->materials) {
        /* each triangle's material by its first corner's split vertex
         * (origin is still the split mesh's); the triangles grouped */
        uint32_t *fm = mr_alloc_array(nt + 1, sizeof *fm), *key = NULL, *order = NULL;
        uint32_t *idx = mr_alloc_array(3 * nt + 1, sizeof *idx);
        st = fm && idx ? MR_OK : mr_fail_nomem(err, NULL, nt * 16);
        for (size_t t = 0; st == MR_OK && t < nt; t++)
            fm[t] = c->vmat[origin[out->indices[3 * t]]];
        if (st == MR_OK)
            st = mr_material_order(fm, nt, &key, &order, err);
        for (size_t i = 0; st == MR_OK && i < nt; i++) {
            memcpy(idx + 3 * i, out->indices + 3 * (size_t)order[i], 3 * sizeof *idx);
            extra.materials[i] = key[i] - 1u;
        }
        if (st == MR_OK)
            memcpy(out->indices, idx, 3 * nt * sizeof *idx);
        free(fm);
        free(key);
        free(order);
        free(idx);
        if (st != MR_OK) {
            mr_mesh_free(&extra);
            return st;
        }
    }
    /* origin: into the input's vertices */
    if (c->src)
        for (size_t v = 0; v < nv; v++)
            origin[v] = c->src[origin[v]];
    for (size_t v = 0; v < nv; v++)
        mr_mesh_copy_more(&extra, v, in, origin[v], 1);
    /* the arrays handed over */
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        out->more_texcoords[k] = extra.more_texcoords[k];
    out->joints = extra.joints;
    out->weights = extra.weights;
    out->materials = extra.materials;
    free(extra.positions);
    free(extra.indices);
    return MR_OK;
}
