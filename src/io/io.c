/* The format dispatcher: which format a path or its bytes are, reading a
 * file through a memory map into the format's reader, and writing a mesh
 * through the format's writer into an all-or-nothing output file
 * (output.c). */
#define _DEFAULT_SOURCE /* madvise under strict C11 */
#include "io_internal.h"
#include "gltf.h"
#include "mapped.h"
#include "text.h"

#include <ctype.h>
#include <strings.h>
#include <errno.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

static bool ends_with_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    if (m > n)
        return false;
    for (size_t i = 0; i < m; i++)
        if (tolower((unsigned char)s[n - m + i]) != suffix[i])
            return false;
    return true;
}

mr_format mr_format_from_path(const char *path)
{
    if (!path)
        return MR_FORMAT_AUTO;
    if (ends_with_ci(path, ".obj"))
        return MR_FORMAT_OBJ;
    if (ends_with_ci(path, ".ply"))
        return MR_FORMAT_PLY;
    if (ends_with_ci(path, ".stl"))
        return MR_FORMAT_STL;
    if (ends_with_ci(path, ".xyz"))
        return MR_FORMAT_XYZ;
    if (ends_with_ci(path, ".gltf") || ends_with_ci(path, ".glb"))
        return MR_FORMAT_GLTF;
    return MR_FORMAT_AUTO;
}

static uint32_t read_le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

mr_format mr_format_sniff(const void *data, size_t size)
{
    const unsigned char *d = data;
    if (size >= 4 && memcmp(d, "ply", 3) == 0 && (d[3] == '\n' || d[3] == '\r'))
        return MR_FORMAT_PLY;
    if (size >= 12 && memcmp(d, "glTF", 4) == 0)
        return MR_FORMAT_GLTF; /* .glb */
    /* Binary STL: 80-byte header, triangle count, 50 bytes per triangle.
     * Checked before ascii because binary headers often start "solid". */
    if (size >= 84 && (size - 84) % 50 == 0 && read_le32(d + 80) == (size - 84) / 50)
        return MR_FORMAT_STL;
    if (size >= 6) {
        size_t i = 0;
        while (i < size && isspace(d[i]))
            i++;
        if (size - i >= 6 && strncasecmp((const char *)d + i, "solid", 5) == 0 &&
            isspace(d[i + 5])) {
            /* ascii STL: a "facet" keyword follows within the first bytes */
            size_t lim = size < 4096 ? size : 4096;
            for (size_t j = i + 5; j + 5 <= lim; j++)
                if (strncasecmp((const char *)d + j, "facet", 5) == 0)
                    return MR_FORMAT_STL;
            if (lim == size) /* "solid name\nendsolid": an empty ascii STL */
                return MR_FORMAT_STL;
        }
    }
    return MR_FORMAT_AUTO;
}

mr_status mr_validate_mesh(const mr_mesh *mesh, const char *name, mr_error *err)
{
    for (size_t i = 0; i < mesh->vertex_count * 3; i++)
        if (!isfinite(mesh->positions[i]))
            return mr_fail_plain(err, MR_ERR_PARSE, name,
                                 "vertex %zu has a non-finite coordinate (%g)", i / 3,
                                 (double)mesh->positions[i]);
    for (size_t i = 0; i < mesh->triangle_count * 3; i++)
        if (mesh->indices[i] >= mesh->vertex_count)
            return mr_fail_plain(err, MR_ERR_PARSE, name,
                                 "triangle %zu uses vertex %u, but there are %zu vertices",
                                 i / 3, mesh->indices[i], mesh->vertex_count);
    return MR_OK;
}

/* A glTF document's scene as one mesh (base_dir NULL: from memory, no
 * external file read). */
static mr_status read_gltf(const void *data, size_t size, const char *name, const char *base_dir,
                           mr_mesh *mesh, mr_error *err)
{
    mr_gltf *g;
    mr_status st = mr_gltf_load(data, size, name, base_dir, &g, err);
    if (st == MR_OK)
        st = mr_gltf_scene_mesh(g, mesh, err);
    mr_gltf_free(g);
    return st;
}

mr_status mr_mesh_read_memory(const void *data, size_t size, const char *name,
                              const mr_read_options *options, mr_mesh *mesh,
                              mr_error *err)
{
    mr_error_clear(err);
    if (!mesh || (!data && size))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, name, "no mesh or no data given");
    mr_mesh_init(mesh);
    mr_read_options defaults;
    if (!options) {
        mr_read_options_default(&defaults);
        options = &defaults;
    }
    if (size == 0)
        return mr_fail_plain(err, MR_ERR_EMPTY, name, "file is empty");

    mr_format fmt = options->format;
    mr_format sniffed = mr_format_sniff(data, size);
    if (fmt == MR_FORMAT_AUTO)
        fmt = mr_format_from_path(name);
    /* Content wins over a misleading extension for the formats that can
     * be recognised by their content. */
    if (sniffed != MR_FORMAT_AUTO && options->format == MR_FORMAT_AUTO)
        fmt = sniffed;
    if (fmt == MR_FORMAT_AUTO)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, name,
                             "unknown file format (expected .obj, .ply, .stl, .xyz, .gltf or "
                             ".glb)");

    int threads = mr_thread_count(options->threads);
    mr_status st;
    switch (fmt) {
    case MR_FORMAT_OBJ: st = mr_read_obj(data, size, name, threads, mesh, err); break;
    case MR_FORMAT_PLY: st = mr_read_ply(data, size, name, threads, mesh, err); break;
    case MR_FORMAT_STL: st = mr_read_stl(data, size, name, threads, mesh, err); break;
    case MR_FORMAT_XYZ: st = mr_read_xyz(data, size, name, threads, mesh, err); break;
    case MR_FORMAT_GLTF: st = read_gltf(data, size, name, NULL, mesh, err); break;
    default:
        st = mr_fail_plain(err, MR_ERR_UNSUPPORTED, name, "unknown file format");
    }
    if (st != MR_OK) {
        mr_mesh_free(mesh);
        return st;
    }
    return MR_OK;
}

mr_status mr_mesh_read(const char *path, const mr_read_options *options, mr_mesh *mesh,
                       mr_error *err)
{
    mr_error_clear(err);
    if (!path || !mesh)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no path or mesh given");
    mr_mesh_init(mesh);

    mr_mapped_file f;
    mr_status st = mr_map_file(path, &f, err);
    if (st != MR_OK)
        return st;
    madvise((void *)f.data, f.size, MADV_SEQUENTIAL | MADV_WILLNEED);
    const mr_format fmt = options && options->format != MR_FORMAT_AUTO
                              ? options->format
                              : mr_format_sniff(f.data, f.size) != MR_FORMAT_AUTO
                                    ? mr_format_sniff(f.data, f.size)
                                    : mr_format_from_path(path);
    if (fmt == MR_FORMAT_GLTF && f.size) {
        /* its external buffers beside it */
        char dir[4200];
        const char *slash = strrchr(path, '/');
        snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path + (slash == path)) : 1,
                 slash ? path : ".");
        mr_error_clear(err);
        st = read_gltf(f.data, f.size, path, dir, mesh, err);
        if (st != MR_OK)
            mr_mesh_free(mesh);
    } else {
        st = mr_mesh_read_memory(f.data, f.size, path, options, mesh, err);
    }
    mr_unmap_file(&f);
    return st;
}

/* ------------------------------------------------------------------------ */
/* Writing a mesh                                                           */
/* ------------------------------------------------------------------------ */

/* One per-vertex array a writer will write: `used` of every `stride` floats. */
typedef struct written_array {
    const float *data;
    int stride, used;
    const char *what;
} written_array;

/* The arrays the writer of `fmt` writes, into a[]; returns their count.
 * Keep in step with the writers: OBJ writes rgb of the colors, PLY rgba
 * (as bytes), STL positions only (its facet normals are computed), XYZ
 * positions and normals. */
static int written_arrays(mr_format fmt, const mr_mesh *m, const mr_write_options *o,
                          written_array a[4])
{
    bool attributes = fmt == MR_FORMAT_OBJ || fmt == MR_FORMAT_PLY || fmt == MR_FORMAT_GLTF;
    int n = 0;
    a[n++] = (written_array){m->positions, 3, 3, "position"};
    if (m->normals && o->write_normals && (attributes || fmt == MR_FORMAT_XYZ))
        a[n++] = (written_array){m->normals, 3, 3, "normal"};
    if (m->texcoords && o->write_texcoords && attributes)
        a[n++] = (written_array){m->texcoords, 2, 2, "texture coordinate"};
    if (m->colors && o->write_colors && attributes)
        a[n++] = (written_array){m->colors, 4, fmt == MR_FORMAT_OBJ ? 3 : 4, "color"};
    return n;
}

/* No format can hold NaN or infinity (or not portably), and a reader of
 * ours would refuse the file: refuse the mesh before a file is created. */
static mr_status check_finite(mr_format fmt, const mr_mesh *m, const mr_write_options *o,
                              const char *path, mr_error *err)
{
    written_array a[4];
    int n = written_arrays(fmt, m, o, a);
    for (size_t v = 0; v < m->vertex_count; v++)
        for (int k = 0; k < n; k++)
            for (int c = 0; c < a[k].used; c++) {
                float x = a[k].data[(size_t)a[k].stride * v + (size_t)c];
                if (!isfinite(x))
                    return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path,
                                         "vertex %zu has a non-finite %s (%g); "
                                         "nothing was written",
                                         v, a[k].what, (double)x);
            }
    return MR_OK;
}

mr_status mr_mesh_write(const char *path, const mr_mesh *mesh,
                        const mr_write_options *options, mr_error *err)
{
    mr_error_clear(err);
    if (!path || !mesh)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no path or mesh given");
    mr_write_options defaults;
    if (!options) {
        mr_write_options_default(&defaults);
        options = &defaults;
    }
    mr_format fmt = options->format != MR_FORMAT_AUTO ? options->format
                                                      : mr_format_from_path(path);
    if (fmt == MR_FORMAT_AUTO)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, path,
                             "cannot tell the output format from the extension "
                             "(use .obj, .ply, .stl, .xyz, .gltf or .glb)");
    if (fmt == MR_FORMAT_STL && mesh->triangle_count == 0 && mesh->vertex_count > 0)
        return mr_fail_plain(err, MR_ERR_UNSUPPORTED, path,
                             "STL holds triangles only; a point cloud cannot be written "
                             "as STL (use .ply, .obj or .xyz)");
    if (mesh->vertex_count && !mesh->positions)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path, "mesh has no positions");
    for (size_t i = 0; i < mesh->triangle_count * 3; i++)
        if (mesh->indices[i] >= mesh->vertex_count)
            return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path,
                                 "triangle %zu uses vertex %u, but there are %zu vertices",
                                 i / 3, mesh->indices[i], mesh->vertex_count);
    mr_status st = check_finite(fmt, mesh, options, path, err);
    if (st != MR_OK)
        return st;
    if (fmt == MR_FORMAT_GLTF)
        return mr_gltf_write_mesh(mesh, path, options, err); /* its own files */
    /* an OBJ of a glTF's materials: their library and textures beside it */
    mr_gltf_mtl lib;
    memset(&lib, 0, sizeof lib);
    mr_write_options with_lib;
    if (fmt == MR_FORMAT_OBJ && mesh->materials && options->materials_from &&
        !options->material_names &&
        mr_format_from_path(options->materials_from) == MR_FORMAT_GLTF) {
        if ((st = mr_gltf_mtl_export(options->materials_from, path, &lib, err)) != MR_OK)
            return st;
        with_lib = *options;
        with_lib.mtllib = lib.mtllib;
        with_lib.material_names = (const char *const *)lib.names;
        with_lib.material_count = lib.count;
        options = &with_lib;
    }

    mr_output_file out;
    st = mr_output_open(&out, path, err);
    if (st != MR_OK) {
        mr_gltf_mtl_free(&lib);
        return st;
    }
    FILE *f = out.f;
    static const size_t bufsize = 1 << 20;
    char *buf = malloc(bufsize);
    if (buf)
        setvbuf(f, buf, _IOFBF, bufsize);

    switch (fmt) {
    case MR_FORMAT_OBJ: st = mr_write_obj(f, mesh, options, path, err); break;
    case MR_FORMAT_PLY: st = mr_write_ply(f, mesh, options, path, err); break;
    case MR_FORMAT_STL: st = mr_write_stl(f, mesh, options, path, err); break;
    case MR_FORMAT_XYZ: st = mr_write_xyz(f, mesh, options, path, err); break;
    default: st = mr_fail_plain(err, MR_ERR_UNSUPPORTED, path, "unknown output format");
    }
    /* all the files or none: the library and its textures go into place
     * before the OBJ, which names them */
    if (lib.nfiles) {
        st = mr_output_finish(&out, path, st, err);
        if (st == MR_OK)
            st = mr_gltf_mtl_commit(&lib, err);
        if (st == MR_OK)
            st = mr_output_commit(&out, path, err);
        else
            mr_output_abandon(&out);
    } else {
        st = mr_output_close(&out, path, st, err);
    }
    free(buf);
    mr_gltf_mtl_free(&lib);
    return st;
}

mr_status mr_file_counts(const char *path, size_t *vertex_count, size_t *triangle_count,
                         mr_error *err)
{
    mr_error_clear(err);
    if (!path)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no path given");
    mr_ply_source *s;
    mr_status st = mr_ply_source_open(path, 1, &s, err);
    if (st != MR_OK)
        return st;
    if (vertex_count)
        *vertex_count = mr_ply_source_vertex_count(s);
    if (triangle_count)
        *triangle_count = mr_ply_source_triangle_count(s);
    mr_ply_source_close(s);
    return MR_OK;
}
