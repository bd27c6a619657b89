/*
 * Exact welding's map, below both its users: mr_mesh_weld_exact and
 * mr_mesh_weld_seams (cleanup.c) and the surface points (surface.c). Two
 * vertices are one when the bit patterns of the words of their layout are
 * equal, -0 read as +0; the first vertex of each class is its
 * representative. Sorted by a hash (radix sort), so O(n) in the vertices
 * and the same on any number of threads.
 */
#include "weld_map.h"
#include "adjacency.h"

#define PARALLEL_MIN 65536

static inline uint32_t float_word(float f)
{
    uint32_t w;
    memcpy(&w, &f, sizeof w);
    return w == UINT32_C(0x80000000) ? 0 : w;
}

static bool same_vertex(const mr_weld_layout *l, uint32_t a, uint32_t b)
{
    for (unsigned k = 0; k < l->count; k++) {
        const float *p = l->arrays[k] + (size_t)a * l->widths[k];
        const float *q = l->arrays[k] + (size_t)b * l->widths[k];
        for (unsigned j = 0; j < l->widths[k]; j++)
            if (float_word(p[j]) != float_word(q[j]))
                return false;
    }
    return true;
}

static uint64_t hash_vertex(const mr_weld_layout *l, uint32_t v)
{
    uint64_t h = UINT64_C(0x9e3779b97f4a7c15);
    for (unsigned k = 0; k < l->count; k++) {
        const float *p = l->arrays[k] + (size_t)v * l->widths[k];
        for (unsigned j = 0; j < l->widths[k]; j++)
            h = mr_mix64(h ^ float_word(p[j]));
    }
    return h;
}

/* mr_weld_run: a run normally holds copies of one vertex, so the list of
 * distinct representatives stays at one or two entries; only hash
 * collisions make it longer. */
void mr_weld_run(const mr_weld_layout *l, const uint32_t *ids, size_t k, uint32_t *target,
                 uint8_t *keep, uint32_t *reps, size_t *merged)
{
    size_t nreps = 0;
    for (size_t i = 0; i < k; i++) {
        uint32_t v = ids[i];
        size_t r = 0;
        while (r < nreps && !same_vertex(l, reps[r], v))
            r++;
        if (r == nreps) {
            reps[nreps++] = v;
            target[v] = v;
            keep[v] = 1;
        } else {
            target[v] = reps[r];
            (*merged)++;
        }
    }
}

mr_status mr_weld_map(const mr_weld_layout *l, size_t vc, uint32_t *target, uint8_t *keep,
                      size_t *merged, mr_error *err)
{
    mr_status st = MR_OK;
    uint64_t *keys = mr_alloc_array(vc, sizeof *keys);
    uint32_t *ids = mr_alloc_array(vc, sizeof *ids);
    uint32_t *reps = mr_alloc_array(vc, sizeof *reps);
    uint8_t *own_keep = keep ? NULL : mr_calloc_array(vc, 1);
    if (!keys || !ids || !reps || (!keep && !own_keep)) {
        st = mr_fail_nomem(err, NULL, vc * 17);
        goto done;
    }
    /* Sort by a hash truncated to ~11 bits more than the vertex ids need:
     * distinct vertices then rarely share a key, with fewer radix passes
     * than a full 64-bit key. Equal vertices always share it. */
    unsigned bits = mr_index_bits(vc) + 11;
    if (bits > 64)
        bits = 64;
#pragma omp parallel for schedule(static) if (vc > PARALLEL_MIN)
    for (size_t v = 0; v < vc; v++) {
        keys[v] = hash_vertex(l, (uint32_t)v) >> (64 - bits);
        ids[v] = (uint32_t)v;
    }
    if ((st = mr_radix_sort_u64(keys, ids, vc, bits, 0, err)) != MR_OK)
        goto done;

    *merged = 0;
    for (size_t i = 0; i < vc;) {
        size_t j = i + 1;
        while (j < vc && keys[j] == keys[i])
            j++;
        mr_weld_run(l, ids + i, j - i, target, keep ? keep : own_keep, reps, merged);
        i = j;
    }
done:
    free(keys);
    free(ids);
    free(reps);
    free(own_keep);
    return st;
}

mr_status mr_weld_positions(const float *positions, size_t vertex_count, uint32_t *target,
                            mr_error *err)
{
    const mr_weld_layout l = {{positions}, {3}, 1};
    size_t merged;
    return mr_weld_map(&l, vertex_count, target, NULL, &merged, err);
}

