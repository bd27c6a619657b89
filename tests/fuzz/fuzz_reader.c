/* libFuzzer target for one reader, chosen at build time by MR_FUZZ_FORMAT
 * (MR_FORMAT_OBJ, ...): the reader must reject any input cleanly, never
 * crash or read out of bounds, and produce a valid mesh when it succeeds. */
#include "meshreduce.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    mr_read_options opt;
    mr_read_options_default(&opt);
    opt.format = MR_FUZZ_FORMAT;
    opt.threads = 1 + (int)(size % 3); /* the chunked parsers at 1-3 threads */
    mr_mesh mesh;
    mr_error err;
    if (mr_mesh_read_memory(data, size, "fuzz", &opt, &mesh, &err) == MR_OK) {
        for (size_t i = 0; i < mesh.triangle_count * 3; i++)
            if (mesh.indices[i] >= mesh.vertex_count)
                abort();
        for (size_t i = 0; i < mesh.vertex_count * 3; i++)
            if (!isfinite(mesh.positions[i]))
                abort();
        mr_mesh_free(&mesh);
    } else if (err.message[0] == '\0') {
        abort(); /* every failure must say what is wrong */
    }
    return 0;
}
