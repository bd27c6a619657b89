/*
 * meshreduce._core: the Python binding of the meshreduce library, on the
 * CPython and NumPy C APIs.
 *
 * Thin, as docs/design.md asks: every function validates its arrays,
 * converts them without copying where it can (float32 (N, 3) positions and
 * uint32 (M, 3) indices, C-contiguous, are used in place; int32 indices are
 * range-checked and reinterpreted, not copied), releases the GIL around the
 * library call, maps an mr_error to an exception carrying the library's
 * message, and hands the library's malloc'd output arrays to NumPy without
 * a copy (each array owns its block through a capsule). The functions call
 * what the CLI calls (mr_mesh_simplify, mr_mesh_read, ...), with the same
 * option values, so results are the CLI's bytes.
 *
 * The small Python classes Mesh and Result (meshreduce/__init__.py) are
 * registered here at import (_register) and instantiated with keywords.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include "meshreduce.h"

#ifdef _OPENMP
#include <omp.h>
#endif

#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Classes registered by meshreduce/__init__.py. */
static PyObject *mesh_class;   /* Mesh(vertices=, triangles=, normals=, ...) */
static PyObject *result_class; /* Result(**fields) */

/* Exceptions: meshreduce.Error and one subclass per mr_status. */
static PyObject *error_base;
static PyObject *error_types[MR_ERR_CANCELLED + 1];

/* ------------------------------------------------------------------------ */
/* Errors                                                                   */
/* ------------------------------------------------------------------------ */

/* Raise the exception of a library error: its class by status, its message
 * the library's, with .status (the status name), .line and .offset (None
 * when they do not apply). Returns NULL. */
static PyObject *raise_mr_error(const mr_error *err)
{
    int s = (int)err->status;
    PyObject *type = (s >= 1 && s <= MR_ERR_CANCELLED) ? error_types[s] : error_base;
    PyObject *exc = PyObject_CallFunction(type, "s", err->message[0] ? err->message
                                                                     : mr_status_string(err->status));
    if (!exc)
        return NULL;
    PyObject *line = err->line == MR_NO_POSITION ? Py_NewRef(Py_None)
                                                 : PyLong_FromUnsignedLongLong(err->line);
    PyObject *offset = err->offset == MR_NO_POSITION ? Py_NewRef(Py_None)
                                                     : PyLong_FromUnsignedLongLong(err->offset);
    PyObject *status = PyUnicode_FromString(mr_status_string(err->status));
    if (!line || !offset || !status || PyObject_SetAttrString(exc, "status", status) < 0 ||
        PyObject_SetAttrString(exc, "line", line) < 0 ||
        PyObject_SetAttrString(exc, "offset", offset) < 0) {
        Py_XDECREF(line);
        Py_XDECREF(offset);
        Py_XDECREF(status);
        Py_DECREF(exc);
        return NULL;
    }
    Py_DECREF(line);
    Py_DECREF(offset);
    Py_DECREF(status);
    PyErr_SetObject(type, exc);
    Py_DECREF(exc);
    return NULL;
}

/* ------------------------------------------------------------------------ */
/* Input arrays                                                             */
/* ------------------------------------------------------------------------ */

static void shape_string(PyArrayObject *a, char *buf, size_t cap)
{
    size_t n = 0;
    n += (size_t)snprintf(buf + n, cap - n, "(");
    for (int d = 0; d < PyArray_NDIM(a) && n < cap; d++)
        n += (size_t)snprintf(buf + n, cap - n, d ? ", %lld" : "%lld",
                              (long long)PyArray_DIM(a, d));
    if (PyArray_NDIM(a) == 1 && n < cap)
        n += (size_t)snprintf(buf + n, cap - n, ",");
    if (n < cap)
        snprintf(buf + n, cap - n, ")");
}

/* An (N, cols) float32 C-contiguous array of obj: the same object when it
 * is one already (no copy), else a converted copy (float64 and integers
 * are accepted). rows >= 0 requires N == rows. Every value must be finite.
 * `allow_empty` admits N == 0. Returns a new reference or NULL with the
 * exception set. */
static PyArrayObject *float_rows(PyObject *obj, int cols, npy_intp rows, const char *name,
                                 int allow_empty)
{
    PyArrayObject *a0 = (PyArrayObject *)PyArray_FROMANY(obj, NPY_NOTYPE, 0, 0, 0);
    if (!a0) {
        if (PyErr_ExceptionMatches(PyExc_ValueError) || PyErr_ExceptionMatches(PyExc_TypeError)) {
            PyErr_Clear();
            PyErr_Format(PyExc_TypeError, "%s: not an array of numbers (%.80s)", name,
                         Py_TYPE(obj)->tp_name);
        }
        return NULL;
    }
    char shape[96];
    if (PyArray_NDIM(a0) != 2 || PyArray_DIM(a0, 1) != cols ||
        (rows >= 0 && PyArray_DIM(a0, 0) != rows)) {
        shape_string(a0, shape, sizeof shape);
        if (rows >= 0)
            PyErr_Format(PyExc_ValueError, "%s must have shape (%lld, %d) (one row per vertex), "
                                           "got %s",
                         name, (long long)rows, cols, shape);
        else
            PyErr_Format(PyExc_ValueError, "%s must have shape (N, %d), got %s", name, cols,
                         shape);
        Py_DECREF(a0);
        return NULL;
    }
    if (PyArray_DIM(a0, 0) == 0 && !allow_empty) {
        PyErr_Format(PyExc_ValueError, "%s is empty (shape (0, %d))", name, cols);
        Py_DECREF(a0);
        return NULL;
    }
    const char kind = PyArray_DESCR(a0)->kind;
    if (kind != 'f' && kind != 'i' && kind != 'u' && PyArray_SIZE(a0) > 0) {
        PyErr_Format(PyExc_TypeError, "%s must hold real numbers (float32 or float64), got "
                                      "dtype %c%d",
                     name, kind, (int)PyArray_ITEMSIZE(a0));
        Py_DECREF(a0);
        return NULL;
    }
    PyArrayObject *a = (PyArrayObject *)PyArray_FromArray(
        a0, PyArray_DescrFromType(NPY_FLOAT32), NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    Py_DECREF(a0);
    if (!a)
        return NULL;
    const float *v = PyArray_DATA(a);
    const npy_intp n = PyArray_SIZE(a);
    for (npy_intp i = 0; i < n; i++) {
        if (!isfinite(v[i])) {
            PyErr_Format(PyExc_ValueError, "%s[%lld, %d] is %s%s", name, (long long)(i / cols),
                         (int)(i % cols), isnan(v[i]) ? "NaN" : "infinite",
                         isnan(v[i]) ? "" : " (or beyond float32's range)");
            Py_DECREF(a);
            return NULL;
        }
    }
    return a;
}

/* An (M, 3) array of vertex indices as uint32, C-contiguous: uint32 input
 * is used in place, int32 input (all values non-negative) reinterpreted
 * without a copy, any other integer type copied. Every index must lie in
 * [0, vertex_count). allow_empty admits M == 0. */
static PyArrayObject *index_rows(PyObject *obj, size_t vertex_count, const char *name,
                                 int allow_empty)
{
    PyArrayObject *a0 = (PyArrayObject *)PyArray_FROMANY(obj, NPY_NOTYPE, 0, 0, 0);
    if (!a0) {
        if (PyErr_ExceptionMatches(PyExc_ValueError) || PyErr_ExceptionMatches(PyExc_TypeError)) {
            PyErr_Clear();
            PyErr_Format(PyExc_TypeError, "%s: not an array of integers (%.80s)", name,
                         Py_TYPE(obj)->tp_name);
        }
        return NULL;
    }
    char shape[96];
    if (PyArray_NDIM(a0) != 2 || PyArray_DIM(a0, 1) != 3) {
        shape_string(a0, shape, sizeof shape);
        PyErr_Format(PyExc_ValueError, "%s must have shape (M, 3) (three vertex indices per "
                                       "triangle), got %s",
                     name, shape);
        Py_DECREF(a0);
        return NULL;
    }
    if (PyArray_DIM(a0, 0) == 0 && !allow_empty) {
        PyErr_Format(PyExc_ValueError, "%s is empty (shape (0, 3))", name);
        Py_DECREF(a0);
        return NULL;
    }
    const int type = PyArray_TYPE(a0);
    const char kind = PyArray_DESCR(a0)->kind;
    if (kind != 'i' && kind != 'u' && PyArray_SIZE(a0) > 0) {
        PyErr_Format(PyExc_TypeError, "%s must hold integers (int32, int64 or uint32), got "
                                      "dtype %c%d",
                     name, kind, (int)PyArray_ITEMSIZE(a0));
        Py_DECREF(a0);
        return NULL;
    }
    const int in_place = PyArray_ISCARRAY_RO(a0) && PyArray_ISNOTSWAPPED(a0) &&
                         (type == NPY_UINT32 || type == NPY_INT32 ||
                          (PyArray_ITEMSIZE(a0) == 4 && (kind == 'i' || kind == 'u')));
    const npy_intp n = PyArray_SIZE(a0);
    if (in_place) {
        /* 4-byte integers read as uint32: a negative int32 reads as a huge
         * index and fails the range test; say which it was. */
        const uint32_t *u = PyArray_DATA(a0);
        for (npy_intp i = 0; i < n; i++) {
            if (u[i] >= vertex_count) {
                if (kind == 'i' && (int32_t)u[i] < 0)
                    PyErr_Format(PyExc_ValueError, "%s[%lld, %d] = %d is negative", name,
                                 (long long)(i / 3), (int)(i % 3), (int)(int32_t)u[i]);
                else
                    PyErr_Format(PyExc_ValueError,
                                 "%s[%lld, %d] = %lu is out of range (%zu vertices: 0 to %zu)",
                                 name, (long long)(i / 3), (int)(i % 3), (unsigned long)u[i],
                                 vertex_count, vertex_count ? vertex_count - 1 : 0);
                Py_DECREF(a0);
                return NULL;
            }
        }
        if (type == NPY_UINT32)
            return a0;
        PyArrayObject *view = (PyArrayObject *)PyArray_View(a0, PyArray_DescrFromType(NPY_UINT32),
                                                           NULL);
        Py_DECREF(a0);
        return view;
    }
    /* Other integer types: through int64 (uint64 beyond its range reads
     * negative and is refused), copied into a new uint32 array. */
    PyArrayObject *w = (PyArrayObject *)PyArray_FromArray(
        a0, PyArray_DescrFromType(NPY_INT64), NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    Py_DECREF(a0);
    if (!w)
        return NULL;
    npy_intp dims[2] = {n / 3, 3};
    PyArrayObject *out = (PyArrayObject *)PyArray_SimpleNew(2, dims, NPY_UINT32);
    if (!out) {
        Py_DECREF(w);
        return NULL;
    }
    const int64_t *s = PyArray_DATA(w);
    uint32_t *d = PyArray_DATA(out);
    for (npy_intp i = 0; i < n; i++) {
        if (s[i] < 0 || (uint64_t)s[i] >= vertex_count) {
            if (s[i] < 0)
                PyErr_Format(PyExc_ValueError, "%s[%lld, %d] = %lld is negative", name,
                             (long long)(i / 3), (int)(i % 3), (long long)s[i]);
            else
                PyErr_Format(PyExc_ValueError,
                             "%s[%lld, %d] = %lld is out of range (%zu vertices: 0 to %zu)", name,
                             (long long)(i / 3), (int)(i % 3), (long long)s[i], vertex_count,
                             vertex_count ? vertex_count - 1 : 0);
            Py_DECREF(w);
            Py_DECREF(out);
            return NULL;
        }
        d[i] = (uint32_t)s[i];
    }
    Py_DECREF(w);
    return out;
}

/* The arrays of one input mesh, held while the library reads them. */
typedef struct py_mesh {
    PyArrayObject *v, *t, *n, *uv, *c;
    PyArrayObject *more[MR_MORE_TEXCOORDS], *tan, *jo, *we, *mat; /* py_mesh_more's */
    mr_mesh m; /* points into the arrays: never freed by mr_mesh_free */
} py_mesh;

static void py_mesh_release(py_mesh *p)
{
    Py_XDECREF(p->v);
    Py_XDECREF(p->t);
    Py_XDECREF(p->n);
    Py_XDECREF(p->uv);
    Py_XDECREF(p->c);
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        Py_XDECREF(p->more[k]);
    Py_XDECREF(p->tan);
    Py_XDECREF(p->jo);
    Py_XDECREF(p->we);
    Py_XDECREF(p->mat);
    memset(p, 0, sizeof *p);
}

/* The names of the arrays besides the weighed attributes, in the order
 * py_mesh_more takes them: texcoords1-3, tangents, joints, weights,
 * materials. */
#define PY_MORE 7
static const char *const more_names[PY_MORE] = {"texcoords1", "texcoords2", "texcoords3",
                                                "tangents",   "joints",     "weights",
                                                "materials"};

/* An array of integers of `rows` x cols (cols 0: 1-D, `rows` long) with
 * every value in [lo, hi], copied into a new array of `type` (uint16 or
 * uint32); -1 becomes UINT32_MAX for uint32 (a material's "none"). */
static PyArrayObject *int_rows(PyObject *obj, int cols, npy_intp rows, long long lo,
                               long long hi, int type, const char *name)
{
    PyArrayObject *a0 = (PyArrayObject *)PyArray_FROMANY(obj, NPY_NOTYPE, 0, 0, 0);
    if (!a0) {
        if (PyErr_ExceptionMatches(PyExc_ValueError) || PyErr_ExceptionMatches(PyExc_TypeError)) {
            PyErr_Clear();
            PyErr_Format(PyExc_TypeError, "%s: not an array of integers (%.80s)", name,
                         Py_TYPE(obj)->tp_name);
        }
        return NULL;
    }
    const char kind = PyArray_DESCR(a0)->kind;
    const int nd = cols ? 2 : 1;
    if (PyArray_NDIM(a0) != nd || PyArray_DIM(a0, 0) != rows ||
        (cols && PyArray_DIM(a0, 1) != cols) ||
        (kind != 'i' && kind != 'u' && PyArray_SIZE(a0) > 0)) {
        char shape[96];
        shape_string(a0, shape, sizeof shape);
        if (cols)
            PyErr_Format(PyExc_ValueError, "%s must be integers of shape (%lld, %d), got %s %c%d",
                         name, (long long)rows, cols, shape, kind, (int)PyArray_ITEMSIZE(a0));
        else
            PyErr_Format(PyExc_ValueError, "%s must be integers of shape (%lld,), got %s %c%d",
                         name, (long long)rows, shape, kind, (int)PyArray_ITEMSIZE(a0));
        Py_DECREF(a0);
        return NULL;
    }
    PyArrayObject *w = (PyArrayObject *)PyArray_FromArray(
        a0, PyArray_DescrFromType(NPY_INT64), NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    Py_DECREF(a0);
    if (!w)
        return NULL;
    npy_intp dims[2] = {rows, cols};
    PyArrayObject *out = (PyArrayObject *)PyArray_SimpleNew(nd, dims, type);
    if (!out) {
        Py_DECREF(w);
        return NULL;
    }
    const int64_t *x = PyArray_DATA(w);
    const npy_intp n = PyArray_SIZE(w);
    for (npy_intp i = 0; i < n; i++) {
        if (x[i] < lo || x[i] > hi) {
            PyErr_Format(PyExc_ValueError, "%s: value %lld at %lld is not in [%lld, %lld]", name,
                         (long long)x[i], (long long)i, lo, hi);
            Py_DECREF(w);
            Py_DECREF(out);
            return NULL;
        }
        if (type == NPY_UINT16)
            ((uint16_t *)PyArray_DATA(out))[i] = (uint16_t)x[i];
        else
            ((uint32_t *)PyArray_DATA(out))[i] = x[i] < 0 ? UINT32_MAX : (uint32_t)x[i];
    }
    Py_DECREF(w);
    return out;
}

/* The arrays besides the weighed attributes (more_names' order; each may
 * be NULL or None) into p, which py_mesh_from filled. Returns 0, or -1
 * with the exception set (p released). */
static int py_mesh_more(py_mesh *p, PyObject *const *x)
{
    const npy_intp nv = (npy_intp)p->m.vertex_count, nt = (npy_intp)p->m.triangle_count;
#define GIVEN(i) (x[i] && x[i] != Py_None)
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        if (GIVEN(k) && !(p->more[k] = float_rows(x[k], 2, nv, more_names[k], 1)))
            goto fail;
    if (GIVEN(3) && !(p->tan = float_rows(x[3], 4, nv, "tangents", 1)))
        goto fail;
    if (GIVEN(4) != GIVEN(5)) {
        PyErr_SetString(PyExc_ValueError, "joints and weights go together: give both or neither");
        goto fail;
    }
    if (GIVEN(4) && (!(p->jo = int_rows(x[4], 4, nv, 0, 65535, NPY_UINT16, "joints")) ||
                     !(p->we = float_rows(x[5], 4, nv, "weights", 1))))
        goto fail;
    if (GIVEN(6) && !(p->mat = int_rows(x[6], 0, nt, -1, (long long)UINT32_MAX - 1, NPY_UINT32,
                                        "materials")))
        goto fail;
#undef GIVEN
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        p->m.more_texcoords[k] = p->more[k] ? PyArray_DATA(p->more[k]) : NULL;
    p->m.tangents = p->tan ? PyArray_DATA(p->tan) : NULL;
    p->m.joints = p->jo ? PyArray_DATA(p->jo) : NULL;
    p->m.weights = p->we ? PyArray_DATA(p->we) : NULL;
    p->m.materials = p->mat ? PyArray_DATA(p->mat) : NULL;
    return 0;
fail:
    py_mesh_release(p);
    return -1;
}

/* Fill p from Python objects (triangles, normals, texcoords, colors may be
 * None). need_triangles: a triangle mesh is required (no None, no empty).
 * Returns 0, or -1 with the exception set (p released). */
static int py_mesh_from(py_mesh *p, PyObject *vertices, PyObject *triangles, PyObject *normals,
                        PyObject *texcoords, PyObject *colors, int need_triangles,
                        const char *vname, const char *tname)
{
    memset(p, 0, sizeof *p);
    if (!(p->v = float_rows(vertices, 3, -1, vname, 0)))
        goto fail;
    const npy_intp nv = PyArray_DIM(p->v, 0);
    if ((uint64_t)nv > (uint64_t)UINT32_MAX - 1) {
        PyErr_Format(PyExc_ValueError, "%s: %lld vertices exceed the 32-bit index limit", vname,
                     (long long)nv);
        goto fail;
    }
    if (triangles == NULL || triangles == Py_None) {
        if (need_triangles) {
            PyErr_Format(PyExc_ValueError, "%s: a triangle mesh is needed (got None)", tname);
            goto fail;
        }
    } else if (!(p->t = index_rows(triangles, (size_t)nv, tname, !need_triangles))) {
        goto fail;
    }
    if (normals && normals != Py_None && !(p->n = float_rows(normals, 3, nv, "normals", 0)))
        goto fail;
    if (texcoords && texcoords != Py_None &&
        !(p->uv = float_rows(texcoords, 2, nv, "texcoords", 0)))
        goto fail;
    if (colors && colors != Py_None && !(p->c = float_rows(colors, 4, nv, "colors", 0)))
        goto fail;
    p->m.vertex_count = (size_t)nv;
    p->m.positions = PyArray_DATA(p->v);
    p->m.triangle_count = p->t ? (size_t)PyArray_DIM(p->t, 0) : 0;
    p->m.indices = p->t ? PyArray_DATA(p->t) : NULL;
    p->m.normals = p->n ? PyArray_DATA(p->n) : NULL;
    p->m.texcoords = p->uv ? PyArray_DATA(p->uv) : NULL;
    p->m.colors = p->c ? PyArray_DATA(p->c) : NULL;
    return 0;
fail:
    py_mesh_release(p);
    return -1;
}

/* Fill p from a mesh object: anything with .vertices and .triangles
 * (and optionally .normals, .texcoords, .colors), such as Mesh and Result. */
static int py_mesh_from_object(py_mesh *p, PyObject *mesh, int need_triangles)
{
    static const char *const names[] = {"vertices", "triangles", "normals", "texcoords",
                                        "colors"};
    PyObject *f[5] = {NULL, NULL, NULL, NULL, NULL};
    for (int i = 0; i < 5; i++) {
        f[i] = PyObject_GetAttrString(mesh, names[i]);
        if (!f[i]) {
            if (!PyErr_ExceptionMatches(PyExc_AttributeError))
                goto fail;
            PyErr_Clear();
        }
    }
    if (!f[0]) {
        PyErr_Format(PyExc_TypeError, "mesh: expected an object with .vertices and "
                                      ".triangles (meshreduce.Mesh), got %.80s",
                     Py_TYPE(mesh)->tp_name);
        goto fail;
    }
    int rc = py_mesh_from(p, f[0], f[1], f[2], f[3], f[4], need_triangles, "mesh.vertices",
                          "mesh.triangles");
    for (int i = 0; i < 5; i++)
        Py_XDECREF(f[i]);
    if (rc < 0)
        return rc;
    /* the arrays besides, where the object has them */
    PyObject *x[PY_MORE] = {NULL};
    for (int i = 0; i < PY_MORE && rc == 0; i++) {
        x[i] = PyObject_GetAttrString(mesh, more_names[i]);
        if (!x[i]) {
            if (PyErr_ExceptionMatches(PyExc_AttributeError))
                PyErr_Clear();
            else
                rc = -1;
        }
    }
    if (rc < 0)
        py_mesh_release(p);
    else
        rc = py_mesh_more(p, x);
    for (int i = 0; i < PY_MORE; i++)
        Py_XDECREF(x[i]);
    return rc;
fail:
    for (int i = 0; i < 5; i++)
        Py_XDECREF(f[i]);
    return -1;
}

/* ------------------------------------------------------------------------ */
/* Output arrays                                                            */
/* ------------------------------------------------------------------------ */

static void free_capsule_block(PyObject *cap)
{
    free(PyCapsule_GetPointer(cap, NULL));
}

/* An (rows, cols) array (cols 0: 1-D) over a malloc'd block, which the
 * array then owns: a capsule, its base, frees it. On failure the block is
 * freed. */
static PyObject *take_array(void *data, size_t rows, int cols, int typenum)
{
    npy_intp dims[2] = {(npy_intp)rows, cols};
    const int nd = cols ? 2 : 1;
    if (!data || rows == 0) {
        free(data);
        return PyArray_ZEROS(nd, dims, typenum, 0);
    }
    PyObject *cap = PyCapsule_New(data, NULL, free_capsule_block);
    if (!cap) {
        free(data);
        return NULL;
    }
    PyObject *a = PyArray_SimpleNewFromData(nd, dims, typenum, data);
    if (!a) {
        Py_DECREF(cap); /* frees data */
        return NULL;
    }
    if (PyArray_SetBaseObject((PyArrayObject *)a, cap) < 0) { /* steals cap, even failing */
        Py_DECREF(a);
        return NULL;
    }
    return a;
}

/* Set d[key] = value, stealing value; -1 on failure (value released). */
static int set_item(PyObject *d, const char *key, PyObject *value)
{
    if (!value)
        return -1;
    int rc = PyDict_SetItemString(d, key, value);
    Py_DECREF(value);
    return rc;
}

/* Move the arrays of an owned mr_mesh into dict d as vertices, triangles,
 * normals, texcoords, colors (None when absent); the mesh is left empty. */
static int move_mesh_arrays(PyObject *d, mr_mesh *m)
{
    mr_mesh x = *m;
    mr_mesh_init(m);
    int rc = 0;
    rc |= set_item(d, "vertices", take_array(x.positions, x.vertex_count, 3, NPY_FLOAT32));
    rc |= set_item(d, "triangles", take_array(x.indices, x.triangle_count, 3, NPY_UINT32));
    /* the per-vertex arrays: None where absent */
    const struct {
        const char *name;
        void *data;
        int cols, type;
    } per_vertex[] = {{"normals", x.normals, 3, NPY_FLOAT32},
                      {"texcoords", x.texcoords, 2, NPY_FLOAT32},
                      {"colors", x.colors, 4, NPY_FLOAT32},
                      {more_names[0], x.more_texcoords[0], 2, NPY_FLOAT32},
                      {more_names[1], x.more_texcoords[1], 2, NPY_FLOAT32},
                      {more_names[2], x.more_texcoords[2], 2, NPY_FLOAT32},
                      {"tangents", x.tangents, 4, NPY_FLOAT32},
                      {"joints", x.joints, 4, NPY_UINT16},
                      {"weights", x.weights, 4, NPY_FLOAT32}};
    for (size_t i = 0; i < sizeof per_vertex / sizeof *per_vertex; i++)
        rc |= set_item(d, per_vertex[i].name,
                       per_vertex[i].data ? take_array(per_vertex[i].data, x.vertex_count,
                                                       per_vertex[i].cols, per_vertex[i].type)
                                          : Py_NewRef(Py_None));
    /* materials as int64, -1 for none */
    PyObject *mat = Py_NewRef(Py_None);
    if (x.materials) {
        npy_intp dims[1] = {(npy_intp)x.triangle_count};
        Py_DECREF(mat);
        mat = PyArray_SimpleNew(1, dims, NPY_INT64);
        for (size_t t = 0; mat && t < x.triangle_count; t++)
            ((int64_t *)PyArray_DATA((PyArrayObject *)mat))[t] =
                x.materials[t] == UINT32_MAX ? -1 : (int64_t)x.materials[t];
        free(x.materials);
    }
    rc |= set_item(d, "materials", mat);
    return rc ? -1 : 0;
}

/* cls(**kwargs); kwargs released. */
static PyObject *make(PyObject *cls, PyObject *kwargs)
{
    if (!kwargs)
        return NULL;
    if (!cls) {
        Py_DECREF(kwargs);
        PyErr_SetString(PyExc_RuntimeError, "meshreduce._core: classes not registered (import "
                                            "meshreduce, not meshreduce._core)");
        return NULL;
    }
    PyObject *empty = PyTuple_New(0);
    PyObject *r = empty ? PyObject_Call(cls, empty, kwargs) : NULL;
    Py_XDECREF(empty);
    Py_DECREF(kwargs);
    return r;
}

/* ------------------------------------------------------------------------ */
/* Progress                                                                 */
/* ------------------------------------------------------------------------ */

/* The library calls progress from the calling thread with the GIL
 * released (about every 1 % of the collapses): take it, call the Python
 * callable, and check for Ctrl-C. The first exception (from the callable,
 * or KeyboardInterrupt) is kept, the library is asked to stop (it returns
 * MR_ERR_CANCELLED), and the exception is raised in its place. */
typedef struct py_progress {
    PyObject *callable; /* or NULL: only signals are checked */
    PyObject *exc_type, *exc_value, *exc_tb;
} py_progress;

static int on_progress(double fraction, void *user)
{
    py_progress *p = user;
    PyGILState_STATE g = PyGILState_Ensure();
    if (!p->exc_type) {
        if (p->callable) {
            PyObject *r = PyObject_CallFunction(p->callable, "d", fraction);
            Py_XDECREF(r);
        }
        if (!PyErr_Occurred())
            PyErr_CheckSignals();
        if (PyErr_Occurred())
            PyErr_Fetch(&p->exc_type, &p->exc_value, &p->exc_tb);
    }
    const int stop = p->exc_type != NULL;
    PyGILState_Release(g);
    return stop; /* nonzero: the library stops (MR_ERR_CANCELLED) */
}

/* After the call: raise the kept exception (returns -1), else 0. */
static int progress_finish(py_progress *p)
{
    if (!p->exc_type)
        return 0;
    PyErr_Restore(p->exc_type, p->exc_value, p->exc_tb);
    p->exc_type = p->exc_value = p->exc_tb = NULL;
    return -1;
}

/* ------------------------------------------------------------------------ */
/* Threads and fork                                                         */
/* ------------------------------------------------------------------------ */

/*
 * GCC's OpenMP runtime (libgomp) does not survive fork(): a child whose
 * parent has run a parallel region waits forever for the parent's worker
 * threads, which the child does not have, at its first parallel region with
 * more than one thread. multiprocessing forks by default on Linux. So in a
 * child forked after the module was imported, every call runs on one thread
 * (the same results: the library is deterministic at any thread count).
 */
static volatile int forked_child;

static void on_fork_child(void)
{
    forked_child = 1;
#ifdef _OPENMP
    omp_set_num_threads(1);
#endif
}

/* Check a threads argument (0 = all cores) and give the count to use. */
static int check_threads(int *threads)
{
    if (*threads < 0) {
        PyErr_Format(PyExc_ValueError, "threads must be >= 0 (0 = all cores), got %d", *threads);
        return -1;
    }
    if (forked_child)
        *threads = 1;
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Option helpers                                                           */
/* ------------------------------------------------------------------------ */

/* The name among names[] (NULL-terminated) that s equals: its index; else
 * -1 with a ValueError listing them. */
static int choose(const char *what, const char *s, const char *const *names)
{
    for (int i = 0; names[i]; i++)
        if (!strcmp(s, names[i]))
            return i;
    char list[256] = "";
    size_t n = 0;
    for (int i = 0; names[i] && n < sizeof list; i++)
        n += (size_t)snprintf(list + n, sizeof list - n, "%s'%s'", i ? ", " : "", names[i]);
    PyErr_Format(PyExc_ValueError, "%s must be one of %s, got '%s'", what, list, s);
    return -1;
}

/* A size_t from a non-negative integer object. */
static int to_size(PyObject *o, const char *name, size_t *out)
{
    if (!PyLong_Check(o) && !PyIndex_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be an integer, got %.80s", name,
                     Py_TYPE(o)->tp_name);
        return -1;
    }
    PyObject *i = PyNumber_Index(o);
    if (!i)
        return -1;
    int overflow = 0;
    if (PyLong_AsLongLongAndOverflow(i, &overflow) < 0 || overflow < 0) {
        Py_DECREF(i);
        if (!PyErr_Occurred())
            PyErr_Format(PyExc_ValueError, "%s must be >= 0", name);
        return -1;
    }
    size_t v = PyLong_AsSize_t(i);
    Py_DECREF(i);
    if (v == (size_t)-1 && PyErr_Occurred())
        return -1;
    *out = v;
    return 0;
}

/* A double from a real number object, which must be finite. */
static int to_double(PyObject *o, const char *name, double *out)
{
    double v = PyFloat_AsDouble(o);
    if (v == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s must be a number, got %.80s", name, Py_TYPE(o)->tp_name);
        return -1;
    }
    if (!isfinite(v)) {
        PyErr_Format(PyExc_ValueError, "%s must be finite, got %R", name, o);
        return -1;
    }
    *out = v;
    return 0;
}

/* ------------------------------------------------------------------------ */
/* simplify                                                                 */
/* ------------------------------------------------------------------------ */

static const char *const collapse_names[] = {"full", "half", NULL};
static const char *const quality_names[] = {"default", "best", NULL};
static const char *const strategy_names[] = {
    "greedy", "batched", "ppq", "rppq", "fppq", "multiqueue", "partitioned", "partitioned-boundary",
    NULL};
static const char *const stop_names[] = {"target", "max_error", "locked", "refused"};

/* locked: a boolean mask of the vertices, or their indices. Fills a
 * malloc'd one-byte-per-vertex array. */
static uint8_t *lock_array(PyObject *locked, size_t vertex_count)
{
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(locked, NPY_NOTYPE, 0, 0, 0);
    if (!a)
        return NULL;
    uint8_t *lock = calloc(vertex_count ? vertex_count : 1, 1);
    if (!lock) {
        Py_DECREF(a);
        PyErr_NoMemory();
        return NULL;
    }
    const char kind = PyArray_DESCR(a)->kind;
    if (PyArray_NDIM(a) != 1) {
        PyErr_SetString(PyExc_ValueError, "locked must be one-dimensional: a boolean mask "
                                          "of the vertices or vertex indices");
        goto fail;
    }
    if (kind == 'b') {
        if ((size_t)PyArray_DIM(a, 0) != vertex_count) {
            PyErr_Format(PyExc_ValueError, "locked: a boolean mask needs one entry per vertex "
                                           "(%zu), got %lld",
                         vertex_count, (long long)PyArray_DIM(a, 0));
            goto fail;
        }
        PyArrayObject *b = (PyArrayObject *)PyArray_FromArray(
            a, PyArray_DescrFromType(NPY_BOOL), NPY_ARRAY_IN_ARRAY);
        if (!b)
            goto fail;
        const npy_bool *m = PyArray_DATA(b);
        for (size_t i = 0; i < vertex_count; i++)
            lock[i] = m[i] ? 1 : 0;
        Py_DECREF(b);
    } else if (kind == 'i' || kind == 'u' || PyArray_SIZE(a) == 0) {
        PyArrayObject *b = (PyArrayObject *)PyArray_FromArray(
            a, PyArray_DescrFromType(NPY_INT64), NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
        if (!b)
            goto fail;
        const int64_t *v = PyArray_DATA(b);
        for (npy_intp i = 0; i < PyArray_SIZE(b); i++) {
            if (v[i] < 0 || (uint64_t)v[i] >= vertex_count) {
                PyErr_Format(PyExc_ValueError,
                             "locked[%lld] = %lld is no vertex (%zu vertices: 0 to %zu)",
                             (long long)i, (long long)v[i], vertex_count,
                             vertex_count ? vertex_count - 1 : 0);
                Py_DECREF(b);
                goto fail;
            }
            lock[v[i]] = 1;
        }
        Py_DECREF(b);
    } else {
        PyErr_SetString(PyExc_TypeError, "locked must be a boolean mask of the vertices or "
                                         "integer vertex indices");
        goto fail;
    }
    Py_DECREF(a);
    return lock;
fail:
    Py_DECREF(a);
    free(lock);
    return NULL;
}

/* PyErr_Format for a function that returns -1. */
#define format_error(...) (PyErr_Format(__VA_ARGS__), -1)

/* options.seams from its name; -1 with the exception set. */
static int seam_mode_from(mr_simplify_options *o, const char *seams)
{
    if (!strcmp(seams, "auto"))
        o->seams = MR_SEAMS_AUTO;
    else if (!strcmp(seams, "free"))
        o->seams = MR_SEAMS_FREE;
    else if (!strcmp(seams, "keep"))
        o->seams = MR_SEAMS_KEEP;
    else
        return format_error(PyExc_ValueError, "seams must be 'auto', 'free' or 'keep', got '%.40s'",
                            seams);
    return 0;
}

/* The options of simplify() and simplify_file() from their arguments;
 * -1 with the exception set. */
static int simplify_options_from(mr_simplify_options *o, PyObject *ratio, PyObject *vcount,
                                 PyObject *tcount, PyObject *max_error, int absolute,
                                 const char *collapse, const char *strategy, int lock_border,
                                 double boundary_weight, double max_normal_turn, int prune,
                                 int threads, unsigned filter_levels,
                                 unsigned multiqueue_factor, const char *quality,
                                 unsigned partitions, PyObject *progress, PyObject *weights)
{
    mr_simplify_options_default(o);
    if (weights != Py_None) {
        /* {"normal": W, "uv": W, "color": W}: the names given, the others
         * keep their defaults */
        if (!PyDict_Check(weights))
            return format_error(PyExc_TypeError,
                                "attribute_weights must be a dict such as {'normal': 0.5}, "
                                "got %.80s",
                                Py_TYPE(weights)->tp_name);
        PyObject *key, *value;
        Py_ssize_t pos = 0;
        while (PyDict_Next(weights, &pos, &key, &value)) {
            static const char *const names[3] = {"normal", "uv", "color"};
            double *dst[3] = {&o->normal_weight, &o->uv_weight, &o->color_weight};
            const char *name = PyUnicode_Check(key) ? PyUnicode_AsUTF8(key) : NULL;
            int k = 0;
            while (name && k < 3 && strcmp(name, names[k]) != 0)
                k++;
            if (!name || k == 3)
                return format_error(PyExc_ValueError,
                                    "attribute_weights: unknown attribute %R (normal, uv, color)",
                                    key);
            if (to_double(value, name, dst[k]) < 0)
                return -1;
            if (!(*dst[k] >= 0) || !isfinite(*dst[k]))
                return format_error(PyExc_ValueError,
                                    "attribute_weights: %s must be a finite number >= 0", name);
        }
    }
    if (ratio != Py_None) {
        if (to_double(ratio, "ratio", &o->target_ratio) < 0)
            return -1;
        if (!(o->target_ratio > 0.0 && o->target_ratio <= 1.0))
            return format_error(PyExc_ValueError, "ratio must be in (0, 1], got %R", ratio);
    }
    if (vcount != Py_None) {
        if (to_size(vcount, "vertex_count", &o->target_vertices) < 0)
            return -1;
        if (o->target_vertices == 0)
            return format_error(PyExc_ValueError, "vertex_count must be positive");
    }
    if (tcount != Py_None) {
        if (to_size(tcount, "triangle_count", &o->target_triangles) < 0)
            return -1;
        o->until_error = o->target_triangles == 0; /* as the CLI's --triangles 0 */
    }
    if (max_error != Py_None) {
        if (to_double(max_error, "max_error", &o->max_error) < 0)
            return -1;
        if (!(o->max_error > 0))
            return format_error(PyExc_ValueError, "max_error must be positive, got %R",
                                max_error);
    }
    if (o->target_ratio == 0 && o->target_vertices == 0 && o->target_triangles == 0 &&
        o->max_error == 0 && !o->until_error)
        return format_error(PyExc_ValueError, "simplify: no target given (ratio, vertex_count, "
                                              "triangle_count or max_error)");
    o->error_absolute = absolute;
    int k = choose("collapse", collapse, collapse_names);
    if (k < 0)
        return -1;
    o->collapse = k == 0 ? MR_COLLAPSE_FULL : MR_COLLAPSE_HALF;
    if ((k = choose("quality", quality, quality_names)) < 0)
        return -1;
    o->quality = k == 0 ? MR_QUALITY_DEFAULT : MR_QUALITY_BEST;
    if (partitions > MR_PARTITIONS_MAX)
        return format_error(PyExc_ValueError, "partitions must be in 0..%d, got %u",
                            MR_PARTITIONS_MAX, partitions);
    o->partitions = partitions;
    if (strategy) {
        if ((k = choose("strategy", strategy, strategy_names)) < 0)
            return -1;
        static const mr_strategy strategies[] = {MR_STRATEGY_GREEDY, MR_STRATEGY_BATCHED,
                                                 MR_STRATEGY_PPQ,    MR_STRATEGY_RPPQ,
                                                 MR_STRATEGY_FPPQ,   MR_STRATEGY_MULTIQUEUE,
                                                 MR_STRATEGY_PARTITIONED,
                                                 MR_STRATEGY_PARTITIONED_BOUNDARY};
        o->strategy = strategies[k];
    }
    if (!(boundary_weight >= 0) || !isfinite(boundary_weight))
        return format_error(PyExc_ValueError, "boundary_weight must be a finite number >= 0");
    o->boundary_weight = boundary_weight;
    if (!(max_normal_turn > 0 && max_normal_turn <= 180))
        return format_error(PyExc_ValueError, "max_normal_turn must be degrees in (0, 180]");
    if (max_normal_turn != 60.0) /* the default stays the library's own value */
        o->max_normal_turn = max_normal_turn * 3.14159265358979323846 / 180.0;
    o->lock_border = lock_border;
    o->prune = prune;
    if (check_threads(&threads) < 0)
        return -1;
    o->threads = threads;
    if (filter_levels > 12)
        return format_error(PyExc_ValueError, "filter_levels must be in 1..12 (0 = default)");
    o->filter_levels = filter_levels;
    if (multiqueue_factor > 1024)
        return format_error(PyExc_ValueError, "multiqueue_factor must be in 1..1024 (0 = 2)");
    o->multiqueue_factor = multiqueue_factor;
    if (progress != Py_None && !PyCallable_Check(progress))
        return format_error(PyExc_TypeError, "progress must be callable, got %.80s",
                            Py_TYPE(progress)->tp_name);
    return 0;
}

PyDoc_STRVAR(simplify_doc,
"simplify($module, /, vertices, triangles, *, ratio=None, vertex_count=None, triangle_count=None,\n"
"         max_error=None, absolute=False, collapse='full', strategy=None,\n"
"         lock_border=False, boundary_weight=1.0, max_normal_turn=60.0, locked=None,\n"
"         prune=False, normals=None, texcoords=None, colors=None, threads=0,\n"
"         progress=None, filter_levels=0, multiqueue_factor=0, quality='default',\n"
"         partitions=0, attribute_weights=None, seams='auto', texcoords1=None,\n"
"         texcoords2=None, texcoords3=None, tangents=None, joints=None, weights=None,\n"
"         materials=None)\n"
"--\n"
"\n"
"Reduce a triangle mesh by quadric-error edge collapse, as `meshreduce simplify`\n"
"does (the same library call, mr_mesh_simplify, and the same option values: the\n"
"same output for the same input and options).\n"
"\n"
"vertices: (N, 3) float32 or float64 positions (float32 C-contiguous arrays are\n"
"used without a copy). triangles: (M, 3) int32, int64 or uint32 vertex indices\n"
"(uint32 and non-negative int32 C-contiguous arrays without a copy).\n"
"normals (N, 3), texcoords (N, 2), colors (N, 4): per-vertex attributes carried\n"
"through; attribute seams (vertices split at one position) are kept.\n"
"texcoords1-3 (N, 2), joints (N, 4) with weights (N, 4): carried as the\n"
"surviving vertex had them (no blend); materials (M,): each triangle's material\n"
"id (-1: none), kept (a vertex two materials share is a seam; the output's\n"
"triangles are grouped by material); tangents (N, 4) are left out (None).\n"
"attribute_weights: their part in the collapse cost, a dict such as\n"
"{'normal': 0.5, 'uv': 0.25, 'color': 1.0} (those are the defaults; a name not\n"
"given keeps its default, 0 leaves an attribute out: it is interpolated), as\n"
"`meshreduce simplify --attribute-weights`. seams: 'auto', 'free' or 'keep', as\n"
"`--seams` (keep: seam vertices slide only along their seams; free: they may\n"
"leave them from the start, priced by that cost; auto: held, freed when the\n"
"target needs it, and from the start where they lock a tenth of the surface).\n"
"\n"
"Targets (the first reached stops; at least one is needed): ratio, the fraction\n"
"of vertices to keep in (0, 1]; vertex_count; triangle_count (0: as far as\n"
"max_error, or the rules, allow); max_error, the largest collapse error, relative\n"
"to the bounding-box diagonal unless absolute=True. Vertex counts count surface\n"
"points (copies of a vertex split by attributes count once).\n"
"\n"
"collapse: 'full' (both ends move to the optimal position) or 'half'.\n"
"strategy: 'batched' (default), 'greedy', 'partitioned' (slabs along the longest\n"
"axis, partitions of them: 0 = 16; the output depends on that count, not on the\n"
"threads), 'partitioned-boundary' (the same slabs, collapses taken in batches\n"
"under claims and rebalanced by counts), or the concurrent 'ppq', 'rppq',\n"
"'fppq', 'multiqueue' (half-edge collapse only; output may vary with threads).\n"
"lock_border: never move boundary vertices. locked: vertices that never move, a\n"
"boolean mask of length N or an array of vertex indices. boundary_weight: weight\n"
"of the quadrics holding boundaries and seams. max_normal_turn: degrees in\n"
"(0, 180]. prune: drop small disconnected pieces. threads: 0 = all cores.\n"
"filter_levels (fppq, rppq; 1..12, 0 = from the thread count) and\n"
"multiqueue_factor (multiqueue: heaps per thread, 0 = 2) tune the queues.\n"
"quality: 'default', or 'best' (full collapse only): volume-preserving placement\n"
"and a final fit of the output to the input's surface, lower RMS distance at a\n"
"few times the time, as `meshreduce simplify --quality best`.\n"
"progress: a callable taking the fraction done (0..1), called from this thread\n"
"about every 1 % of the work; an exception it raises, or Ctrl-C (checked at the\n"
"same moments, with or without progress), stops the simplification there and is\n"
"raised.\n"
"\n"
"Returns a Result with vertices (float32), triangles (uint32), normals,\n"
"texcoords, colors, texcoords1-3, tangents, joints, weights, materials (or None), origin (uint32: for each output vertex, the input\n"
"vertex it descends from), error (the largest collapse error, as a distance),\n"
"target_reached, stop_reason ('target', 'max_error', 'locked', 'refused'), stop\n"
"(a sentence), and the figures of `meshreduce simplify --json` as attributes and\n"
"in .stats. A missed target is a result (target_reached False), not an error.\n"
"Raises ValueError for bad arrays or options and meshreduce.Error subclasses for\n"
"the library's errors.");

static PyObject *py_simplify(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"vertices",  "triangles",     "ratio",           "vertex_count",
                             "triangle_count", "max_error", "absolute",       "collapse",
                             "strategy",  "lock_border",   "boundary_weight", "max_normal_turn",
                             "locked",    "prune",         "normals",         "texcoords",
                             "colors",    "threads",       "progress",        "filter_levels",
                             "multiqueue_factor", "quality", "partitions", "attribute_weights",
                             "seams", "texcoords1", "texcoords2", "texcoords3", "tangents",
                             "joints", "weights", "materials", NULL};
    PyObject *vertices, *triangles, *ratio = Py_None, *vcount = Py_None, *tcount = Py_None,
                                    *max_error = Py_None, *locked = Py_None, *normals = Py_None,
                                    *texcoords = Py_None, *colors = Py_None, *progress = Py_None,
                                    *weights = Py_None;
    PyObject *more[PY_MORE] = {Py_None, Py_None, Py_None, Py_None, Py_None, Py_None, Py_None};
    int absolute = 0, lock_border = 0, prune = 0, threads = 0;
    const char *collapse = "full", *strategy = NULL, *quality = "default", *seams = "auto";
    double boundary_weight = 1.0, max_normal_turn = 60.0;
    unsigned int filter_levels = 0, multiqueue_factor = 0, partitions = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OO|$OOOOpszpddOpOOOiOIIsIOsOOOOOOO", kwlist,
                                     &vertices, &triangles, &ratio, &vcount, &tcount, &max_error,
                                     &absolute, &collapse, &strategy, &lock_border,
                                     &boundary_weight, &max_normal_turn, &locked, &prune,
                                     &normals, &texcoords, &colors, &threads, &progress,
                                     &filter_levels, &multiqueue_factor, &quality, &partitions,
                                     &weights, &seams, &more[0], &more[1], &more[2], &more[3],
                                     &more[4], &more[5], &more[6]))
        return NULL;

    mr_simplify_options o;
    if (simplify_options_from(&o, ratio, vcount, tcount, max_error, absolute, collapse, strategy,
                              lock_border, boundary_weight, max_normal_turn, prune, threads,
                              filter_levels, multiqueue_factor, quality, partitions, progress,
                              weights) < 0 ||
        seam_mode_from(&o, seams) < 0)
        return NULL;

    py_mesh in;
    if (py_mesh_from(&in, vertices, triangles, normals, texcoords, colors, 1, "vertices",
                     "triangles") < 0 ||
        py_mesh_more(&in, more) < 0)
        return NULL;
    uint8_t *lock = NULL;
    if (locked != Py_None) {
        if (!(lock = lock_array(locked, in.m.vertex_count))) {
            py_mesh_release(&in);
            return NULL;
        }
        o.vertex_lock = lock;
    }
    py_progress prog = {progress != Py_None ? progress : NULL, NULL, NULL, NULL};
    o.progress = on_progress;
    o.progress_user = &prog;

    mr_mesh out;
    mr_mesh_init(&out);
    uint32_t *origin = NULL;
    mr_simplify_stats s;
    memset(&s, 0, sizeof s);
    mr_error err;
    mr_status st;
    Py_BEGIN_ALLOW_THREADS
    st = mr_mesh_simplify(&in.m, &o, &out, &origin, &s, &err);
    Py_END_ALLOW_THREADS
    free(lock);
    py_mesh_release(&in);
    if (progress_finish(&prog) < 0) {
        mr_mesh_free(&out);
        free(origin);
        return NULL;
    }
    if (st != MR_OK)
        return raise_mr_error(&err);

    PyObject *d = PyDict_New();
    if (!d) {
        mr_mesh_free(&out);
        free(origin);
        return NULL;
    }
    const size_t nv = out.vertex_count;
    int rc = move_mesh_arrays(d, &out);
    rc |= set_item(d, "origin", take_array(origin, nv, 0, NPY_UINT32));
    PyObject *stats = Py_BuildValue(
        "{s:O,s:s,s:s,s:n,s:n,s:n,s:n,s:n,s:n,s:d,s:n,s:n,s:{s:d,s:d,s:d}}", "target_reached",
        s.target_reached ? Py_True : Py_False, "stop_reason", stop_names[s.stop], "stop",
        mr_simplify_stop_string(s.stop), "input_vertices", (Py_ssize_t)s.input_vertices,
        "output_points", (Py_ssize_t)s.output_points, "input_triangles",
        (Py_ssize_t)s.input_triangles, "output_vertices", (Py_ssize_t)s.output_vertices,
        "output_triangles", (Py_ssize_t)s.output_triangles, "collapses",
        (Py_ssize_t)s.collapses, "max_error", s.max_error, "locked_vertices",
        (Py_ssize_t)s.locked_vertices, "pruned_parts", (Py_ssize_t)s.pruned_parts, "seconds",
        "setup", s.seconds_setup, "collapse", s.seconds_collapse, "output", s.seconds_output);
    if (stats && s.queue_pops) /* the concurrent-queue strategies' profile */
        rc |= set_item(stats, "profile",
                       Py_BuildValue("{s:n,s:n,s:n,s:n,s:n,s:n,s:n}", "pops",
                                     (Py_ssize_t)s.queue_pops, "lock_acquisitions",
                                     (Py_ssize_t)s.lock_acquisitions, "lock_failures",
                                     (Py_ssize_t)s.lock_failures, "topology_checks",
                                     (Py_ssize_t)s.topology_checks, "collapses",
                                     (Py_ssize_t)s.collapses, "priority_updates",
                                     (Py_ssize_t)s.priority_updates, "compactions",
                                     (Py_ssize_t)s.compactions));
    if (stats && s.partition_passes) /* the partitioned strategy's profile */
        rc |= set_item(stats, "partitioned",
                       Py_BuildValue("{s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:{s:n,s:n,s:n,s:n}}",
                                     "passes", (Py_ssize_t)s.partition_passes,
                                     "interior_collapses", (Py_ssize_t)s.interior_collapses,
                                     "boundary_collapses", (Py_ssize_t)s.boundary_collapses,
                                     "boundary_sequential", (Py_ssize_t)s.boundary_sequential,
                                     "tail_collapses", (Py_ssize_t)s.tail_collapses,
                                     "rebalances", (Py_ssize_t)s.rebalances, "claim_conflicts",
                                     (Py_ssize_t)s.claim_conflicts, "rebalance_triggers",
                                     "count", (Py_ssize_t)s.rebalance_count, "imbalance",
                                     (Py_ssize_t)s.rebalance_imbalance, "boundary",
                                     (Py_ssize_t)s.rebalance_boundary, "acceptance",
                                     (Py_ssize_t)s.rebalance_acceptance));
    if (!stats || rc || PyDict_Update(d, stats) < 0 ||
        set_item(d, "error", PyFloat_FromDouble(s.max_error)) < 0) {
        Py_XDECREF(stats);
        Py_DECREF(d);
        return NULL;
    }
    if (set_item(d, "stats", stats) < 0) { /* stats released */
        Py_DECREF(d);
        return NULL;
    }
    return make(result_class, d);
}

static int path_arg(PyObject *o, PyObject **bytes);

/* The out-of-core options of simplify_file() and cluster_file(): memory,
 * temp_dir (its bytes object into *dir, which the caller releases) and
 * temp_budget, each None for the default. */
static int ooc_options_from(mr_out_of_core_options *c, PyObject *memory, PyObject *temp_dir,
                            PyObject *temp_budget, PyObject **dir)
{
    mr_out_of_core_options_default(c);
    size_t n;
    if (memory != Py_None) {
        if (to_size(memory, "memory", &n) < 0)
            return -1;
        if (n == 0) {
            PyErr_SetString(PyExc_ValueError, "memory must be positive (bytes)");
            return -1;
        }
        c->memory = n;
    }
    if (temp_budget != Py_None) {
        if (to_size(temp_budget, "temp_budget", &n) < 0)
            return -1;
        c->temp_budget = n;
    }
    if (temp_dir != Py_None) {
        if (!path_arg(temp_dir, dir))
            return -1;
        c->temp_dir = PyBytes_AS_STRING(*dir);
    }
    return 0;
}

PyDoc_STRVAR(simplify_file_doc,
"simplify_file($module, /, input, output, *, ratio=None, vertex_count=None,\n"
"              triangle_count=None, max_error=None, absolute=False, collapse='full',\n"
"              strategy=None, lock_border=False, boundary_weight=1.0,\n"
"              max_normal_turn=60.0, locked=None, prune=False, threads=0,\n"
"              progress=None, quality='default', partitions=0, memory=None,\n"
"              temp_dir=None, temp_budget=None, attribute_weights=None,\n"
"              seams='auto')\n"
"--\n"
"\n"
"Simplify a mesh file into a file, as `meshreduce simplify IN -o OUT --memory M`\n"
"(mr_simplify_file): an input whose simplification fits the memory budget\n"
"(memory, bytes: default 4 GiB; about 160 bytes a triangle) is read whole and\n"
"simplified as simplify() does (the same bytes); a larger binary PLY is\n"
"simplified out of core, in chunks that fit, merged up a tree to the target\n"
"(its normals, texture coordinates and colors carried). temp_dir: where the temporary files go (they have no name);\n"
"temp_budget: bytes of them at most. The targets and options as simplify()'s;\n"
"locked: a boolean mask of the input's vertices or their indices. Returns the\n"
"statistics: those of simplify(), and out_of_core, chunks, chunk_capacity,\n"
"top_chunks (an output larger than a chunk, written as PLY: the pieces the tree\n"
"ends at, 0 otherwise), levels (each with its chunks, triangles and seconds),\n"
"passes, temp_bytes_peak, memory and seconds.");

static PyObject *py_simplify_file(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"input",     "output",        "ratio",           "vertex_count",
                             "triangle_count", "max_error", "absolute",       "collapse",
                             "strategy",  "lock_border",   "boundary_weight", "max_normal_turn",
                             "locked",    "prune",         "threads",         "progress",
                             "quality",   "partitions",    "memory",          "temp_dir",
                             "temp_budget", "attribute_weights", "seams", NULL};
    PyObject *input = NULL, *output = NULL, *ratio = Py_None, *vcount = Py_None,
             *tcount = Py_None, *max_error = Py_None, *locked = Py_None, *progress = Py_None,
             *memory = Py_None, *temp_dir = Py_None, *temp_budget = Py_None, *weights = Py_None;
    int absolute = 0, lock_border = 0, prune = 0, threads = 0;
    const char *collapse = "full", *strategy = NULL, *quality = "default", *seams = "auto";
    double boundary_weight = 1.0, max_normal_turn = 60.0;
    unsigned int partitions = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O&O&|$OOOOpszpddOpiOsIOOOOs", kwlist, path_arg,
                                     &input, path_arg, &output, &ratio, &vcount, &tcount,
                                     &max_error, &absolute, &collapse, &strategy, &lock_border,
                                     &boundary_weight, &max_normal_turn, &locked, &prune,
                                     &threads, &progress, &quality, &partitions, &memory,
                                     &temp_dir, &temp_budget, &weights, &seams))
        return NULL;
    PyObject *result = NULL, *dir = NULL;
    uint8_t *lock = NULL;
    mr_simplify_options o;
    mr_out_of_core_options c;
    mr_out_of_core_options_default(&c);
    if (simplify_options_from(&o, ratio, vcount, tcount, max_error, absolute, collapse, strategy,
                              lock_border, boundary_weight, max_normal_turn, prune, threads, 0,
                              0, quality, partitions, progress, weights) < 0 ||
        seam_mode_from(&o, seams) < 0)
        goto done;
    if (ooc_options_from(&c, memory, temp_dir, temp_budget, &dir) < 0)
        goto done;
    const char *in_path = PyBytes_AS_STRING(input), *out_path = PyBytes_AS_STRING(output);
    mr_error err;
    mr_status st;
    if (locked != Py_None) {
        size_t nv;
        if (mr_file_counts(in_path, &nv, NULL, &err) != MR_OK) {
            raise_mr_error(&err);
            goto done;
        }
        if (!(lock = lock_array(locked, nv)))
            goto done;
        o.vertex_lock = lock;
    }
    py_progress prog = {progress != Py_None ? progress : NULL, NULL, NULL, NULL};
    o.progress = on_progress;
    o.progress_user = &prog;
    mr_simplify_file_stats fs;
    memset(&fs, 0, sizeof fs);
    Py_BEGIN_ALLOW_THREADS
    st = mr_simplify_file(in_path, out_path, &o, &c, NULL, &fs, &err);
    Py_END_ALLOW_THREADS
    if (progress_finish(&prog) < 0)
        goto done;
    if (st != MR_OK) {
        raise_mr_error(&err);
        goto done;
    }
    const mr_simplify_stats *s = &fs.simplify;
    PyObject *levels = PyList_New(0);
    for (unsigned l = 0; levels && l < fs.levels && l < MR_LEVELS_MAX; l++) {
        PyObject *e = Py_BuildValue("{s:n,s:n,s:d}", "chunks", (Py_ssize_t)fs.level_chunks[l],
                                    "triangles", (Py_ssize_t)fs.level_triangles[l], "seconds",
                                    fs.level_seconds[l]);
        if (!e || PyList_Append(levels, e) < 0) {
            Py_XDECREF(e);
            Py_CLEAR(levels);
            break;
        }
        Py_DECREF(e);
    }
    if (!levels)
        goto done;
    result = Py_BuildValue(
        "{s:O,s:s,s:s,s:n,s:n,s:n,s:n,s:n,s:n,s:d,s:n,s:n,s:O,s:K,s:n,s:n,s:n,s:n,s:I,s:K,"
        "s:N,s:{s:d,s:d,s:d,s:d}}",
        "target_reached", s->target_reached ? Py_True : Py_False, "stop_reason",
        stop_names[s->stop], "stop", mr_simplify_stop_string(s->stop), "input_vertices",
        (Py_ssize_t)s->input_vertices, "output_points", (Py_ssize_t)s->output_points,
        "input_triangles", (Py_ssize_t)s->input_triangles, "output_vertices",
        (Py_ssize_t)s->output_vertices, "output_triangles", (Py_ssize_t)s->output_triangles,
        "collapses", (Py_ssize_t)s->collapses, "max_error", s->max_error, "locked_vertices",
        (Py_ssize_t)s->locked_vertices, "pruned_parts", (Py_ssize_t)s->pruned_parts,
        "out_of_core", fs.out_of_core ? Py_True : Py_False, "memory",
        (unsigned long long)fs.memory, "chunks", (Py_ssize_t)fs.chunks, "chunk_capacity",
        (Py_ssize_t)fs.chunk_capacity, "oversized_chunks", (Py_ssize_t)fs.oversized_chunks,
        "top_chunks", (Py_ssize_t)fs.top_chunks, "passes", fs.passes, "temp_bytes_peak",
        (unsigned long long)fs.temp_bytes_peak, "levels", levels, "seconds", "read", fs.seconds_read, "simplify", fs.seconds_simplify,
        "write", fs.seconds_write, "total", fs.seconds_total);
done:
    free(lock);
    Py_XDECREF(dir);
    Py_XDECREF(input);
    Py_XDECREF(output);
    return result;
}

/* ------------------------------------------------------------------------ */
/* read / write / generate / info                                           */
/* ------------------------------------------------------------------------ */

static const char *const format_names[] = {"auto", "obj", "ply", "stl", "xyz", "gltf", NULL};

static int path_arg(PyObject *o, PyObject **bytes)
{
    return PyUnicode_FSConverter(o, bytes);
}

PyDoc_STRVAR(read_doc,
"read($module, /, path, *, format=None, threads=0)\n"
"--\n"
"\n"
"Read a mesh or point cloud (OBJ, PLY, STL, XYZ, glTF (.gltf, .glb: its scene's\n"
"triangles in world space); by extension, PLY, STL and .glb also by\n"
"content; format='obj'|'ply'|'stl'|'xyz'|'gltf' forces one). Returns a Mesh with vertices\n"
"(N, 3) float32, triangles (M, 3) uint32 ((0, 3) for a point cloud), and normals,\n"
"texcoords, colors (or None). Raises meshreduce.MeshIOError when the file cannot\n"
"be read and meshreduce.ParseError (with .line / .offset) when it is malformed.");

static PyObject *py_read(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"path", "format", "threads", NULL};
    PyObject *path = NULL;
    const char *format = NULL;
    int threads = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O&|$zi", kwlist, path_arg, &path, &format,
                                     &threads))
        return NULL;
    mr_read_options ro;
    mr_read_options_default(&ro);
    if (format) {
        int k = choose("format", format, format_names);
        if (k < 0) {
            Py_DECREF(path);
            return NULL;
        }
        ro.format = (mr_format)k;
    }
    if (check_threads(&threads) < 0) {
        Py_DECREF(path);
        return NULL;
    }
    ro.threads = threads;
    mr_mesh m;
    mr_mesh_init(&m);
    mr_error err;
    mr_status st;
    const char *p = PyBytes_AS_STRING(path);
    Py_BEGIN_ALLOW_THREADS
    st = mr_mesh_read(p, &ro, &m, &err);
    Py_END_ALLOW_THREADS
    Py_DECREF(path);
    if (st != MR_OK)
        return raise_mr_error(&err);
    PyObject *d = PyDict_New();
    if (!d || move_mesh_arrays(d, &m) < 0) {
        mr_mesh_free(&m);
        Py_XDECREF(d);
        return NULL;
    }
    return make(mesh_class, d);
}

PyDoc_STRVAR(write_doc,
"write($module, /, path, mesh, *, format=None, encoding=None, normals=True, texcoords=True,\n"
"      colors=True, material_names=None, materials_from=None)\n"
"--\n"
"\n"
"Write a mesh: any object with .vertices and .triangles (and optionally\n"
".normals, .texcoords, .colors), such as Mesh or Result. The format comes from\n"
"the extension unless format='obj'|'ply'|'stl'|'xyz' is given; encoding is\n"
"'binary' (default for PLY/STL), 'ascii' or 'big-endian' (PLY). normals,\n"
"texcoords, colors=False drop those arrays. The mesh's other arrays\n"
"(texcoords1-3, tangents, materials) go where the format holds them: glTF\n"
"writes every one (a primitive per material; joints and weights need a skin\n"
"and are left out), OBJ its materials as usemtl groups. material_names: the\n"
"materials' names, by id (OBJ usemtl lines; glTF materials' names).\n"
"materials_from: the file the materials come from, as `meshreduce convert` uses\n"
"its input: a glTF's into an OBJ (OUT.mtl and the textures written beside it),\n"
"an OBJ's mtllib colours and textures into a glTF (with material_names). The file\n"
"appears complete or not at all (temporary file, then rename), as with the CLI.");

static PyObject *py_write(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"path", "mesh", "format", "encoding", "normals", "texcoords",
                             "colors", "material_names", "materials_from", NULL};
    static const char *const encodings[] = {"default", "ascii", "binary", "big-endian", NULL};
    PyObject *path = NULL, *mesh, *names = Py_None, *seq = NULL, *from = Py_None,
             *from_path = NULL;
    const char *format = NULL, *encoding = NULL;
    const char **name_list = NULL;
    mr_write_options wo;
    mr_write_options_default(&wo);
    int normals = 1, texcoords = 1, colors = 1;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O&O|$zzpppOO", kwlist, path_arg, &path, &mesh,
                                     &format, &encoding, &normals, &texcoords, &colors, &names,
                                     &from))
        return NULL;
    if (from != Py_None) {
        if (!path_arg(from, &from_path))
            goto fail;
        wo.materials_from = PyBytes_AS_STRING(from_path);
    }
    if (names != Py_None) {
        /* the materials' names: usemtl lines (OBJ), glTF materials' names */
        if (!(seq = PySequence_Fast(names, "material_names must be a sequence of str")))
            goto fail;
        const Py_ssize_t nn = PySequence_Fast_GET_SIZE(seq);
        name_list = calloc((size_t)nn + 1, sizeof *name_list);
        if (!name_list) {
            PyErr_NoMemory();
            goto fail;
        }
        for (Py_ssize_t i = 0; i < nn; i++) {
            PyObject *x = PySequence_Fast_GET_ITEM(seq, i);
            if (!PyUnicode_Check(x) || !(name_list[i] = PyUnicode_AsUTF8(x))) {
                if (!PyErr_Occurred())
                    PyErr_Format(PyExc_TypeError, "material_names[%zd] is not a str", i);
                goto fail;
            }
        }
        wo.material_names = name_list;
        wo.material_count = (size_t)nn;
    }
    int k;
    if (format) {
        if ((k = choose("format", format, format_names)) < 0)
            goto fail;
        wo.format = (mr_format)k;
    }
    if (encoding) {
        if ((k = choose("encoding", encoding, encodings)) < 0)
            goto fail;
        wo.encoding = (mr_encoding)k;
    }
    wo.write_normals = normals;
    wo.write_texcoords = texcoords;
    wo.write_colors = colors;
    py_mesh in;
    if (py_mesh_from_object(&in, mesh, 0) < 0)
        goto fail;
    mr_error err;
    mr_status st;
    const char *p = PyBytes_AS_STRING(path);
    Py_BEGIN_ALLOW_THREADS
    st = mr_mesh_write(p, &in.m, &wo, &err);
    Py_END_ALLOW_THREADS
    py_mesh_release(&in);
    Py_DECREF(path);
    Py_XDECREF(seq);
    Py_XDECREF(from_path);
    free(name_list);
    if (st != MR_OK)
        return raise_mr_error(&err);
    Py_RETURN_NONE;
fail:
    Py_DECREF(path);
    Py_XDECREF(seq);
    Py_XDECREF(from_path);
    free(name_list);
    return NULL;
}

PyDoc_STRVAR(generate_doc,
"generate($module, /, kind='scan', triangles=1000000, *, seed=1)\n"
"--\n"
"\n"
"A procedural mesh, as `meshreduce generate`: kind 'sphere' (closed geodesic\n"
"sphere), 'torus' (open, with holes placed from the seed) or 'scan' (closed noisy\n"
"scan-like surface, the CLI's default input), with about `triangles` triangles.\n"
"Deterministic for a kind, count and seed.");

static PyObject *py_generate(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"kind", "triangles", "seed", NULL};
    const char *kind = "scan";
    PyObject *tri = NULL, *seed_obj = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "|sO$O", kwlist, &kind, &tri, &seed_obj))
        return NULL;
    mr_generator g;
    if (mr_generator_from_name(kind, &g) != 0)
        return PyErr_Format(PyExc_ValueError, "kind must be 'sphere', 'torus' or 'scan', got "
                                              "'%s'",
                            kind);
    size_t triangles = 1000000, seed = 1;
    if (tri && to_size(tri, "triangles", &triangles) < 0)
        return NULL;
    if (triangles == 0)
        return PyErr_Format(PyExc_ValueError, "triangles must be positive");
    if (seed_obj && to_size(seed_obj, "seed", &seed) < 0)
        return NULL;
    mr_mesh m;
    mr_mesh_init(&m);
    mr_error err;
    mr_status st;
    Py_BEGIN_ALLOW_THREADS
    st = mr_generate(g, triangles, (uint64_t)seed, &m, &err);
    Py_END_ALLOW_THREADS
    if (st != MR_OK)
        return raise_mr_error(&err);
    PyObject *d = PyDict_New();
    if (!d || move_mesh_arrays(d, &m) < 0) {
        mr_mesh_free(&m);
        Py_XDECREF(d);
        return NULL;
    }
    return make(mesh_class, d);
}

/* Accept (mesh) or (vertices, triangles=None). */
static int mesh_or_arrays(py_mesh *p, PyObject *a, PyObject *b, int need_triangles)
{
    if (PyObject_HasAttrString(a, "vertices")) {
        if (b && b != Py_None) {
            PyErr_SetString(PyExc_TypeError, "give a mesh object or (vertices, triangles), "
                                             "not both");
            return -1;
        }
        return py_mesh_from_object(p, a, need_triangles);
    }
    return py_mesh_from(p, a, b, NULL, NULL, NULL, need_triangles, "vertices", "triangles");
}

PyDoc_STRVAR(info_doc,
"info($module, /, vertices, triangles=None)\n"
"--\n"
"\n"
"Counts, bounds and topology of a mesh -- `vertices` may also be a file path or a\n"
"Mesh -- as `meshreduce info --json` reports them (without\n"
"the file fields): vertices, referenced/unreferenced/surface/split vertices,\n"
"triangles, degenerate and duplicate triangles, edges, boundary edges and\n"
"loops, non-manifold edges and vertices, misoriented edges, components,\n"
"euler_characteristic, genus (None unless a manifold surface), closed, manifold,\n"
"oriented, bbox_min, bbox_max, bbox_diagonal, surface_area. Accepts a file path\n"
"(read as read() does), a Mesh (or any object with .vertices and .triangles) or\n"
"the arrays.");

static PyObject *py_read(PyObject *self, PyObject *args, PyObject *kw);

static PyObject *py_info(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"vertices", "triangles", NULL};
    PyObject *a, *b = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|O", kwlist, &a, &b))
        return NULL;
    py_mesh in;
    int rc;
    if (PyUnicode_Check(a) || PyBytes_Check(a) || PyObject_HasAttrString(a, "__fspath__")) {
        /* a file: read it, as `meshreduce info FILE` */
        PyObject *read_args = PyTuple_Pack(1, a);
        PyObject *mesh = read_args ? py_read(self, read_args, NULL) : NULL;
        Py_XDECREF(read_args);
        if (!mesh)
            return NULL;
        rc = mesh_or_arrays(&in, mesh, b, 0);
        Py_DECREF(mesh);
    } else {
        rc = mesh_or_arrays(&in, a, b, 0);
    }
    if (rc < 0)
        return NULL;
    mr_stats s;
    mr_error err;
    mr_status st;
    Py_BEGIN_ALLOW_THREADS
    st = mr_stats_compute(in.m.positions, 0, in.m.vertex_count, in.m.indices,
                          in.m.triangle_count, &s, &err);
    Py_END_ALLOW_THREADS
    const int has_n = in.n != NULL, has_uv = in.uv != NULL, has_c = in.c != NULL;
    int sets = has_uv;
    for (int k = 0; k < MR_MORE_TEXCOORDS; k++)
        sets += in.more[k] != NULL;
    const int has_t = in.tan != NULL, has_s = in.jo != NULL;
    const size_t materials = mr_mesh_material_count(&in.m);
    py_mesh_release(&in);
    if (st != MR_OK)
        return raise_mr_error(&err);
    long long genus = -1; /* as cmd_info.c's genus_of */
    if (s.manifold && s.triangle_count) {
        long long twice = 2 * (long long)s.components - s.euler_characteristic -
                          (long long)s.boundary_loops;
        genus = twice >= 0 && twice % 2 == 0 ? twice / 2 : -1;
    }
    PyObject *g = genus >= 0 ? PyLong_FromLongLong(genus) : Py_NewRef(Py_None);
    if (!g)
        return NULL;
    return Py_BuildValue(
        "{s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:O,s:O,s:O,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:L,s:N,"
        "s:O,s:O,s:O,s:(ddd),s:(ddd),s:d,s:d,s:i,s:O,s:O,s:n}",
        "vertices", (Py_ssize_t)s.vertex_count, "referenced_vertices",
        (Py_ssize_t)s.referenced_vertices, "unreferenced_vertices",
        (Py_ssize_t)s.unreferenced_vertices, "surface_vertices", (Py_ssize_t)s.surface_vertices,
        "split_vertices", (Py_ssize_t)s.split_vertices, "triangles",
        (Py_ssize_t)s.triangle_count, "degenerate_triangles", (Py_ssize_t)s.degenerate_triangles,
        "duplicate_triangles", (Py_ssize_t)s.duplicate_triangles, "normals",
        has_n ? Py_True : Py_False, "texcoords", has_uv ? Py_True : Py_False, "colors",
        has_c ? Py_True : Py_False, "edges", (Py_ssize_t)s.edge_count, "boundary_edges",
        (Py_ssize_t)s.boundary_edges, "boundary_loops", (Py_ssize_t)s.boundary_loops,
        "nonmanifold_edges", (Py_ssize_t)s.nonmanifold_edges, "nonmanifold_vertices",
        (Py_ssize_t)s.nonmanifold_vertices, "misoriented_edges",
        (Py_ssize_t)s.misoriented_edges, "components", (Py_ssize_t)s.components,
        "euler_characteristic", s.euler_characteristic, "genus", g, "closed",
        s.closed ? Py_True : Py_False, "manifold", s.manifold ? Py_True : Py_False, "oriented",
        s.oriented ? Py_True : Py_False, "bbox_min", s.bbox_min[0], s.bbox_min[1],
        s.bbox_min[2], "bbox_max", s.bbox_max[0], s.bbox_max[1], s.bbox_max[2],
        "bbox_diagonal", s.bbox_diagonal, "surface_area", s.surface_area, "texcoord_sets", sets,
        "tangents", has_t ? Py_True : Py_False, "skin", has_s ? Py_True : Py_False, "materials",
        (Py_ssize_t)materials);
}

/* ------------------------------------------------------------------------ */
/* compare                                                                  */
/* ------------------------------------------------------------------------ */

PyDoc_STRVAR(compare_doc,
"compare($module, /, a_vertices, a_triangles, b_vertices, b_triangles, *, samples=1000000,\n"
"        seed=1, threads=0)\n"
"--\n"
"\n"
"Surface distances between a reference mesh (a) and a test mesh (b), as\n"
"`meshreduce compare --json` reports them (same defaults: 1,000,000 samples per\n"
"mesh, seed 1): hausdorff, rms, mean, reference_to_test_max,\n"
"test_to_reference_max, reference_to_test_rms, test_to_reference_rms,\n"
"modified_hausdorff, their *_rel values (relative to the reference's bounding-box\n"
"diagonal), diagonal, reference_points, test_points, samples, seed.");

static PyObject *py_compare(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"a_vertices", "a_triangles", "b_vertices", "b_triangles",
                             "samples",    "seed",        "threads",    NULL};
    PyObject *av, *at, *bv, *bt, *samples_obj = NULL, *seed_obj = NULL;
    int threads = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOOO|$OOi", kwlist, &av, &at, &bv, &bt,
                                     &samples_obj, &seed_obj, &threads))
        return NULL;
    mr_compare_options co;
    mr_compare_options_default(&co);
    co.samples = 1000000;
    co.seed = 1; /* the CLI's defaults */
    size_t v;
    if (samples_obj) {
        if (to_size(samples_obj, "samples", &v) < 0)
            return NULL;
        co.samples = v;
    }
    if (seed_obj) {
        if (to_size(seed_obj, "seed", &v) < 0)
            return NULL;
        co.seed = v;
    }
    if (check_threads(&threads) < 0)
        return NULL;
    co.threads = threads;
    py_mesh a, b;
    if (py_mesh_from(&a, av, at, NULL, NULL, NULL, 1, "a_vertices", "a_triangles") < 0)
        return NULL;
    if (py_mesh_from(&b, bv, bt, NULL, NULL, NULL, 1, "b_vertices", "b_triangles") < 0) {
        py_mesh_release(&a);
        return NULL;
    }
    mr_compare_result r;
    mr_error err;
    mr_status st;
    Py_BEGIN_ALLOW_THREADS
    st = mr_compare(a.m.positions, a.m.vertex_count, a.m.indices, a.m.triangle_count,
                    b.m.positions, b.m.vertex_count, b.m.indices, b.m.triangle_count, &co, &r,
                    &err);
    Py_END_ALLOW_THREADS
    py_mesh_release(&a);
    py_mesh_release(&b);
    if (st != MR_OK)
        return raise_mr_error(&err);
    return Py_BuildValue("{s:K,s:K,s:n,s:n,s:d,s:d,s:d,s:d,s:d,s:d,s:d,s:d,s:d,s:d,s:d,s:d,s:d}",
                         "samples", (unsigned long long)co.samples, "seed",
                         (unsigned long long)co.seed, "reference_points",
                         (Py_ssize_t)r.ref_points, "test_points", (Py_ssize_t)r.test_points,
                         "diagonal", r.diagonal, "hausdorff", r.hausdorff, "rms", r.rms, "mean",
                         r.mean, "reference_to_test_max", r.ref_to_test_max,
                         "test_to_reference_max", r.test_to_ref_max, "reference_to_test_rms",
                         r.ref_to_test_rms, "test_to_reference_rms", r.test_to_ref_rms,
                         "modified_hausdorff", r.modified_hausdorff, "hausdorff_rel",
                         r.hausdorff_rel, "rms_rel", r.rms_rel, "mean_rel", r.mean_rel,
                         "modified_hausdorff_rel", r.modified_hausdorff_rel);
}

/* ------------------------------------------------------------------------ */
/* weld / cluster                                                           */
/* ------------------------------------------------------------------------ */

/* The bounding-box diagonal of all the vertices, as the CLI's --eps-rel and
 * --cell-rel take it (cli_bbox_diagonal). */
static int bbox_diagonal(const mr_mesh *m, double *diagonal)
{
    mr_stats st;
    mr_error err;
    mr_status rc;
    Py_BEGIN_ALLOW_THREADS
    rc = mr_stats_compute(m->positions, 0, m->vertex_count, NULL, 0, &st, &err);
    Py_END_ALLOW_THREADS
    if (rc != MR_OK) {
        raise_mr_error(&err);
        return -1;
    }
    *diagonal = st.bbox_diagonal;
    return 0;
}

static const char *const weld_algorithm_names[] = {"auto", "serial", "pweld", "pweld-async",
                                                   NULL};

PyDoc_STRVAR(weld_doc,
"weld($module, /, points, triangles=None, *, eps=None, eps_rel=None, reduce=None, strict=False,\n"
"     algorithm='auto', order='index', drop_degenerate=False, normals=None,\n"
"     texcoords=None, colors=None, threads=0)\n"
"--\n"
"\n"
"Exact epsilon welding, as `meshreduce weld` (mr_mesh_weld): vertices are visited\n"
"in order (order='index', or 'grade': by visual importance); an unclustered one\n"
"starts a cluster with its unclustered neighbours within eps (strict=True: < eps,\n"
"as Open3D's merge_close_vertices), represented by their mean (attributes\n"
"averaged too); triangles are remapped. The same output for every algorithm\n"
"('auto', 'serial', 'pweld', 'pweld-async') and thread count.\n"
"\n"
"The radius, exactly one of: eps (absolute), eps_rel (a fraction of the\n"
"bounding-box diagonal), reduce (remove at least this fraction of the vertices,\n"
"in [0, 1): the smallest such eps is searched for). points: (N, 3); triangles:\n"
"(M, 3) or None for a point cloud. drop_degenerate removes collapsed triangles.\n"
"\n"
"Returns a Result with vertices, triangles, normals, texcoords, colors, remap\n"
"(uint32 (N,): the output vertex of each input vertex), eps, algorithm,\n"
"threads, input/output vertex and triangle counts, graph_edges, rounds, seconds\n"
"and stats (a dict of those figures).");

static PyObject *py_weld(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"points",  "triangles", "eps",       "eps_rel",   "reduce",
                             "strict",  "algorithm", "order",     "drop_degenerate",
                             "normals", "texcoords", "colors",    "threads",   NULL};
    static const char *const orders[] = {"index", "grade", NULL};
    PyObject *points, *triangles = Py_None, *eps = Py_None, *eps_rel = Py_None,
                      *reduce = Py_None, *normals = Py_None, *texcoords = Py_None,
                      *colors = Py_None;
    int strict = 0, drop = 0, threads = 0;
    const char *algorithm = "auto", *order = "index";
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|O$OOOpsspOOOi", kwlist, &points, &triangles,
                                     &eps, &eps_rel, &reduce, &strict, &algorithm, &order, &drop,
                                     &normals, &texcoords, &colors, &threads))
        return NULL;
    mr_weld_options o;
    mr_weld_options_default(&o);
    const int given = (eps != Py_None) + (eps_rel != Py_None) + (reduce != Py_None);
    if (given != 1)
        return PyErr_Format(PyExc_ValueError, "weld: give exactly one radius: eps, eps_rel or "
                                              "reduce (got %d)",
                            given);
    double radius;
    PyObject *r_obj = eps != Py_None ? eps : eps_rel != Py_None ? eps_rel : reduce;
    const char *r_name = eps != Py_None ? "eps" : eps_rel != Py_None ? "eps_rel" : "reduce";
    if (to_double(r_obj, r_name, &radius) < 0)
        return NULL;
    if (reduce != Py_None ? !(radius >= 0 && radius < 1) : !(radius >= 0))
        return PyErr_Format(PyExc_ValueError, "%s must be %s, got %R", r_name,
                            reduce != Py_None ? "a fraction in [0, 1)" : ">= 0", r_obj);
    int k;
    if ((k = choose("algorithm", algorithm, weld_algorithm_names)) < 0)
        return NULL;
    o.algorithm = (mr_weld_algorithm)k;
    if ((k = choose("order", order, orders)) < 0)
        return NULL;
    o.order = (mr_weld_order)k;
    o.strict = strict;
    o.drop_degenerate = drop;
    if (check_threads(&threads) < 0)
        return NULL;
    o.threads = threads;
    py_mesh in;
    if (py_mesh_from(&in, points, triangles, normals, texcoords, colors, 0, "points",
                     "triangles") < 0)
        return NULL;
    mr_error err;
    mr_status st = MR_OK;
    if (eps != Py_None) {
        o.eps = radius;
    } else if (eps_rel != Py_None) {
        double diagonal;
        if (bbox_diagonal(&in.m, &diagonal) < 0) {
            py_mesh_release(&in);
            return NULL;
        }
        o.eps = radius * diagonal;
    } else {
        Py_BEGIN_ALLOW_THREADS
        st = mr_weld_find_eps(in.m.positions, 0, in.m.vertex_count, radius, &o, &o.eps, NULL,
                              &err);
        Py_END_ALLOW_THREADS
    }
    mr_mesh out;
    mr_mesh_init(&out);
    uint32_t *remap = NULL;
    mr_weld_stats ws;
    memset(&ws, 0, sizeof ws);
    if (st == MR_OK) {
        Py_BEGIN_ALLOW_THREADS
        st = mr_mesh_weld(&in.m, &o, &out, &remap, &ws, &err);
        Py_END_ALLOW_THREADS
    }
    const size_t nin = in.m.vertex_count;
    py_mesh_release(&in);
    if (st != MR_OK)
        return raise_mr_error(&err);
    PyObject *d = PyDict_New();
    if (!d) {
        mr_mesh_free(&out);
        free(remap);
        return NULL;
    }
    static const char *const algorithm_names[] = {"auto", "serial", "pweld", "pweld-async"};
    int rc = move_mesh_arrays(d, &out);
    rc |= set_item(d, "remap", take_array(remap, nin, 0, NPY_UINT32));
    PyObject *stats = Py_BuildValue(
        "{s:s,s:i,s:d,s:n,s:n,s:n,s:n,s:n,s:I,s:n,s:{s:d,s:d,s:d,s:d,s:d,s:d}}", "algorithm",
        algorithm_names[ws.algorithm <= MR_WELD_PWELD_ASYNC ? ws.algorithm : 0], "threads",
        ws.threads, "eps", ws.eps, "input_vertices", (Py_ssize_t)ws.input_vertices,
        "input_triangles", (Py_ssize_t)ws.input_triangles, "output_vertices",
        (Py_ssize_t)ws.output_vertices, "output_triangles", (Py_ssize_t)ws.output_triangles,
        "graph_edges", (Py_ssize_t)ws.graph_edges, "rounds", ws.rounds, "peak_bytes",
        (Py_ssize_t)ws.peak_bytes, "seconds", "order", ws.seconds_order, "graph",
        ws.seconds_graph, "mapping", ws.seconds_mapping, "reduction", ws.seconds_reduction,
        "retriangulation", ws.seconds_retriangulation, "total", ws.seconds_total);
    if (!stats || rc || PyDict_Update(d, stats) < 0) {
        Py_XDECREF(stats);
        Py_DECREF(d);
        return NULL;
    }
    if (set_item(d, "stats", stats) < 0) { /* stats released */
        Py_DECREF(d);
        return NULL;
    }
    return make(result_class, d);
}

PyDoc_STRVAR(cluster_doc,
"cluster($module, /, vertices, triangles=None, *, cell=None, cell_rel=None, vertex_count=None,\n"
"        normals=None, texcoords=None, colors=None, threads=0)\n"
"--\n"
"\n"
"Grid vertex clustering, as `meshreduce cluster` (mr_mesh_cluster): each occupied\n"
"cubic cell becomes one vertex at its quadric-optimal point (kept in the cell),\n"
"collapsed and duplicate triangles are removed. The cell size, exactly one of:\n"
"cell (absolute), cell_rel (a fraction of the bounding-box diagonal), or\n"
"vertex_count (the cell size whose grid has about this many occupied cells).\n"
"Returns a Result with vertices, triangles, attributes, cell, cells, counts,\n"
"seconds and stats.");

static PyObject *py_cluster(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"vertices", "triangles", "cell",   "cell_rel", "vertex_count",
                             "normals",  "texcoords", "colors", "threads",  NULL};
    PyObject *vertices, *triangles = Py_None, *cell = Py_None, *cell_rel = Py_None,
                        *vcount = Py_None, *normals = Py_None, *texcoords = Py_None,
                        *colors = Py_None;
    int threads = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|O$OOOOOOi", kwlist, &vertices, &triangles,
                                     &cell, &cell_rel, &vcount, &normals, &texcoords, &colors,
                                     &threads))
        return NULL;
    mr_cluster_options o;
    mr_cluster_options_default(&o);
    const int given = (cell != Py_None) + (cell_rel != Py_None) + (vcount != Py_None);
    if (given != 1)
        return PyErr_Format(PyExc_ValueError, "cluster: give exactly one of cell, cell_rel or "
                                              "vertex_count (got %d)",
                            given);
    double x = 0;
    if (cell != Py_None || cell_rel != Py_None) {
        const char *name = cell != Py_None ? "cell" : "cell_rel";
        if (to_double(cell != Py_None ? cell : cell_rel, name, &x) < 0)
            return NULL;
        if (!(x > 0))
            return PyErr_Format(PyExc_ValueError, "%s must be positive", name);
    } else {
        if (to_size(vcount, "vertex_count", &o.target_vertices) < 0)
            return NULL;
        if (o.target_vertices == 0)
            return PyErr_Format(PyExc_ValueError, "vertex_count must be positive");
    }
    if (check_threads(&threads) < 0)
        return NULL;
    o.threads = threads;
    py_mesh in;
    if (py_mesh_from(&in, vertices, triangles, normals, texcoords, colors, 0, "vertices",
                     "triangles") < 0)
        return NULL;
    if (cell != Py_None) {
        o.cell = x;
    } else if (cell_rel != Py_None) {
        double diagonal;
        if (bbox_diagonal(&in.m, &diagonal) < 0) {
            py_mesh_release(&in);
            return NULL;
        }
        o.cell = x * diagonal;
        if (!(o.cell > 0) || isinf(o.cell)) {
            py_mesh_release(&in);
            return PyErr_Format(PyExc_ValueError, "cell_rel %g of the bounding-box diagonal %g "
                                                  "is no usable cell size",
                                x, diagonal);
        }
    }
    mr_mesh out;
    mr_mesh_init(&out);
    mr_cluster_stats cs;
    memset(&cs, 0, sizeof cs);
    mr_error err;
    mr_status st;
    Py_BEGIN_ALLOW_THREADS
    st = mr_mesh_cluster(&in.m, &o, &out, &cs, &err);
    Py_END_ALLOW_THREADS
    py_mesh_release(&in);
    if (st != MR_OK)
        return raise_mr_error(&err);
    PyObject *d = PyDict_New();
    if (!d) {
        mr_mesh_free(&out);
        return NULL;
    }
    int rc = move_mesh_arrays(d, &out);
    PyObject *stats = Py_BuildValue(
        "{s:d,s:n,s:n,s:n,s:n,s:n,s:{s:d,s:d,s:d,s:d}}", "cell", cs.cell, "cells",
        (Py_ssize_t)cs.cells, "input_vertices", (Py_ssize_t)cs.input_vertices, "input_triangles",
        (Py_ssize_t)cs.input_triangles, "output_vertices", (Py_ssize_t)cs.output_vertices,
        "output_triangles", (Py_ssize_t)cs.output_triangles, "seconds", "cells",
        cs.seconds_cells, "representatives", cs.seconds_representatives, "triangles",
        cs.seconds_triangles, "total", cs.seconds_total);
    if (!stats || rc || PyDict_Update(d, stats) < 0) {
        Py_XDECREF(stats);
        Py_DECREF(d);
        return NULL;
    }
    if (set_item(d, "stats", stats) < 0) { /* stats released */
        Py_DECREF(d);
        return NULL;
    }
    return make(result_class, d);
}

PyDoc_STRVAR(cluster_file_doc,
"cluster_file($module, /, input, output, *, cell=None, cell_rel=None, vertex_count=None,\n"
"             threads=0, memory=None, temp_dir=None, temp_budget=None)\n"
"--\n"
"\n"
"Grid clustering from a file into a file, as `meshreduce cluster IN -o OUT`\n"
"(mr_cluster_file): the input is read in passes, in memory that grows with the\n"
"output (4 bytes a vertex beside it), the same bytes as cluster() on the mesh\n"
"read whole: a binary PLY file in place, a binary STL or OBJ file through\n"
"temporary files in temp_dir (at most temp_budget bytes) when its clustering in\n"
"memory would not fit `memory` bytes (default 4 GiB; else it is read whole, as\n"
"ascii files are). The cell size as in cluster(). Returns the statistics (cell,\n"
"cells, counts, streamed: whether it was read in passes, temp_bytes_peak,\n"
"seconds).");

static PyObject *py_cluster_file(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"input",  "output", "cell",     "cell_rel",    "vertex_count",
                             "threads", "memory", "temp_dir", "temp_budget", NULL};
    PyObject *input = NULL, *output = NULL, *cell = Py_None, *cell_rel = Py_None,
             *vcount = Py_None, *memory = Py_None, *temp_dir = Py_None,
             *temp_budget = Py_None;
    int threads = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O&O&|$OOOiOOO", kwlist, path_arg, &input,
                                     path_arg, &output, &cell, &cell_rel, &vcount, &threads,
                                     &memory, &temp_dir, &temp_budget))
        return NULL;
    PyObject *result = NULL, *dir = NULL;
    mr_out_of_core_options c;
    if (ooc_options_from(&c, memory, temp_dir, temp_budget, &dir) < 0)
        goto done;
    mr_cluster_options o;
    mr_cluster_options_default(&o);
    const int given = (cell != Py_None) + (cell_rel != Py_None) + (vcount != Py_None);
    if (given != 1) {
        PyErr_Format(PyExc_ValueError, "cluster_file: give exactly one of cell, cell_rel or "
                                       "vertex_count (got %d)",
                     given);
        goto done;
    }
    if (cell != Py_None || cell_rel != Py_None) {
        const char *name = cell != Py_None ? "cell" : "cell_rel";
        double x;
        if (to_double(cell != Py_None ? cell : cell_rel, name, &x) < 0)
            goto done;
        if (!(x > 0)) {
            PyErr_Format(PyExc_ValueError, "%s must be positive", name);
            goto done;
        }
        if (cell != Py_None)
            o.cell = x;
        else
            o.cell_rel = x;
    } else {
        if (to_size(vcount, "vertex_count", &o.target_vertices) < 0)
            goto done;
        if (o.target_vertices == 0) {
            PyErr_Format(PyExc_ValueError, "vertex_count must be positive");
            goto done;
        }
    }
    if (check_threads(&threads) < 0)
        goto done;
    o.threads = threads;
    mr_cluster_stats cs;
    memset(&cs, 0, sizeof cs);
    mr_error err;
    mr_status st;
    const char *in_path = PyBytes_AS_STRING(input), *out_path = PyBytes_AS_STRING(output);
    Py_BEGIN_ALLOW_THREADS
    st = mr_cluster_file(in_path, out_path, &o, &c, NULL, &cs, &err);
    Py_END_ALLOW_THREADS
    if (st != MR_OK) {
        raise_mr_error(&err);
        goto done;
    }
    result = Py_BuildValue(
        "{s:d,s:n,s:n,s:n,s:n,s:n,s:O,s:K,s:{s:d,s:d,s:d,s:d}}", "cell", cs.cell, "cells",
        (Py_ssize_t)cs.cells, "input_vertices", (Py_ssize_t)cs.input_vertices, "input_triangles",
        (Py_ssize_t)cs.input_triangles, "output_vertices", (Py_ssize_t)cs.output_vertices,
        "output_triangles", (Py_ssize_t)cs.output_triangles, "streamed",
        cs.streamed ? Py_True : Py_False, "temp_bytes_peak", (unsigned long long)cs.temp_bytes_peak,
        "seconds", "cells",
        cs.seconds_cells, "representatives", cs.seconds_representatives, "triangles",
        cs.seconds_triangles, "total", cs.seconds_total);
done:
    Py_XDECREF(input);
    Py_XDECREF(output);
    Py_XDECREF(dir);
    return result;
}

/* ------------------------------------------------------------------------ */
/* render / write_png                                                       */
/* ------------------------------------------------------------------------ */

/* A 0xRRGGBB colour from an int or an (r, g, b) sequence of 0..255. */
static int to_rgb(PyObject *o, const char *name, uint32_t *out)
{
    if (PyLong_Check(o)) {
        long v = PyLong_AsLong(o);
        if (v == -1 && PyErr_Occurred())
            return -1;
        if (v < 0 || v > 0xFFFFFF) {
            PyErr_Format(PyExc_ValueError, "%s must be 0xRRGGBB or (r, g, b)", name);
            return -1;
        }
        *out = (uint32_t)v;
        return 0;
    }
    int r, g, b;
    if (!PyArg_ParseTuple(o, "iii", &r, &g, &b) || r < 0 || r > 255 || g < 0 || g > 255 ||
        b < 0 || b > 255) {
        PyErr_Clear();
        PyErr_Format(PyExc_ValueError, "%s must be 0xRRGGBB or (r, g, b) with 0..255", name);
        return -1;
    }
    *out = (uint32_t)r << 16 | (uint32_t)g << 8 | (uint32_t)b;
    return 0;
}

/* A 1-D float32 array of n finite values. */
static PyArrayObject *scalar_array(PyObject *o, npy_intp n, const char *name, const char *per)
{
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(o, NPY_FLOAT32, 1, 1,
                                                        NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    if (!a)
        return NULL;
    if (PyArray_DIM(a, 0) != n) {
        PyErr_Format(PyExc_ValueError, "%s needs one value per %s (%lld), got %lld", name, per,
                     (long long)n, (long long)PyArray_DIM(a, 0));
        Py_DECREF(a);
        return NULL;
    }
    return a;
}

/* A surface's look for render(): a file's (mr_look_read), or arrays'
 * (texcoords, colors, face_materials and looks); held while the library
 * draws. */
typedef struct py_look {
    mr_look file;
    int from_file;
    PyArrayObject *uv, *col, *fm;
    mr_render_material *mats;
    mr_image *imgs;
    PyArrayObject **pix; /* each material's texture pixels, or NULL */
    size_t nmat;
} py_look;

static void py_look_release(py_look *l)
{
    if (l->from_file)
        mr_look_free(&l->file);
    Py_XDECREF(l->uv);
    Py_XDECREF(l->col);
    Py_XDECREF(l->fm);
    for (size_t i = 0; l->pix && i < l->nmat; i++)
        Py_XDECREF(l->pix[i]);
    free(l->pix);
    free(l->mats);
    free(l->imgs);
    memset(l, 0, sizeof *l);
}

/* looks[i] (a dict: "color" (r, g, b[, a]) in 0..1 or 0xRRGGBB, "texture"
 * an (H, W, 3 or 4) uint8 image, "wrap" 'repeat', 'clamp' or 'mirror',
 * "v_up" True by default) into l->mats[i]. */
static int look_from(py_look *l, size_t i, PyObject *d)
{
    mr_render_material *m = &l->mats[i];
    m->color[0] = m->color[1] = m->color[2] = m->color[3] = 1;
    m->wrap_s = m->wrap_t = MR_WRAP_REPEAT;
    m->v_up = 1;
    if (!PyDict_Check(d)) {
        PyErr_Format(PyExc_TypeError, "looks[%zu] must be a dict (color, texture, wrap, v_up)", i);
        return -1;
    }
    PyObject *c = PyDict_GetItemString(d, "color"), *t = PyDict_GetItemString(d, "texture"),
             *w = PyDict_GetItemString(d, "wrap"), *v = PyDict_GetItemString(d, "v_up");
    if (c && PyLong_Check(c)) {
        uint32_t rgb;
        if (to_rgb(c, "looks[].color", &rgb) < 0)
            return -1;
        for (int k = 0; k < 3; k++)
            m->color[k] = (float)((rgb >> (16 - 8 * k)) & 0xFF) / 255.0f;
    } else if (c && c != Py_None) {
        PyObject *seq = PySequence_Fast(c, "looks[].color must be 0xRRGGBB or (r, g, b[, a])");
        if (!seq)
            return -1;
        const Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
        for (Py_ssize_t k = 0; k < n && k < 4; k++)
            m->color[k] = (float)PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, k));
        Py_DECREF(seq);
        if (PyErr_Occurred())
            return -1;
        if (n < 3 || n > 4) {
            PyErr_Format(PyExc_ValueError, "looks[%zu].color needs 3 or 4 values in 0..1", i);
            return -1;
        }
    }
    if (w && w != Py_None) {
        static const char *const wraps[] = {"repeat", "clamp", "mirror", NULL};
        const char *ws = PyUnicode_Check(w) ? PyUnicode_AsUTF8(w) : NULL;
        const int k = ws ? choose("wrap", ws, wraps) : -1;
        if (k < 0) {
            if (!PyErr_Occurred())
                PyErr_SetString(PyExc_ValueError, "wrap must be 'repeat', 'clamp' or 'mirror'");
            return -1;
        }
        m->wrap_s = m->wrap_t = (mr_wrap)k;
    }
    if (v && v != Py_None && (m->v_up = PyObject_IsTrue(v)) < 0)
        return -1;
    if (t && t != Py_None) {
        PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(t, NPY_UINT8, 3, 3,
                                                            NPY_ARRAY_IN_ARRAY);
        if (!a)
            return -1;
        const npy_intp h = PyArray_DIM(a, 0), wd = PyArray_DIM(a, 1), ch = PyArray_DIM(a, 2);
        if ((ch != 3 && ch != 4) || h < 1 || wd < 1 || h > 32768 || wd > 32768) {
            Py_DECREF(a);
            PyErr_Format(PyExc_ValueError, "looks[%zu].texture must be (H, W, 3 or 4) uint8", i);
            return -1;
        }
        if (ch == 3) { /* to RGBA */
            npy_intp dims[3] = {h, wd, 4};
            PyArrayObject *r = (PyArrayObject *)PyArray_SimpleNew(3, dims, NPY_UINT8);
            if (!r) {
                Py_DECREF(a);
                return -1;
            }
            const uint8_t *src = PyArray_DATA(a);
            uint8_t *dst = PyArray_DATA(r);
            for (npy_intp px = 0; px < h * wd; px++) {
                dst[4 * px] = src[3 * px];
                dst[4 * px + 1] = src[3 * px + 1];
                dst[4 * px + 2] = src[3 * px + 2];
                dst[4 * px + 3] = 255;
            }
            Py_DECREF(a);
            a = r;
        }
        l->pix[i] = a;
        l->imgs[i] = (mr_image){(int)wd, (int)h, PyArray_DATA(a)};
        m->texture = &l->imgs[i];
    }
    return 0;
}

/* The arrays' look into l and o (nv vertices, nt triangles). */
static int look_from_arrays(py_look *l, mr_render_options *o, size_t nv, size_t nt,
                            PyObject *texcoords, PyObject *colors, PyObject *face_materials,
                            PyObject *looks)
{
    if (looks != Py_None) {
        PyObject *seq = PySequence_Fast(looks, "looks must be a sequence of dicts");
        if (!seq)
            return -1;
        l->nmat = (size_t)PySequence_Fast_GET_SIZE(seq);
        l->mats = calloc(l->nmat + 1, sizeof *l->mats);
        l->imgs = calloc(l->nmat + 1, sizeof *l->imgs);
        l->pix = calloc(l->nmat + 1, sizeof *l->pix);
        int rc = l->mats && l->imgs && l->pix ? 0 : (PyErr_NoMemory(), -1);
        for (size_t i = 0; rc == 0 && i < l->nmat; i++)
            rc = look_from(l, i, PySequence_Fast_GET_ITEM(seq, (Py_ssize_t)i));
        Py_DECREF(seq);
        if (rc < 0)
            return -1;
        o->materials = l->mats;
        o->material_count = l->nmat;
    }
    if (texcoords != Py_None) {
        if (!(l->uv = float_rows(texcoords, 2, (npy_intp)nv, "texcoords", 1)))
            return -1;
        o->texcoords = PyArray_DATA(l->uv);
    }
    if (colors != Py_None) {
        if (!(l->col = float_rows(colors, 4, (npy_intp)nv, "colors", 1)))
            return -1;
        o->vertex_colors = PyArray_DATA(l->col);
    }
    if (face_materials != Py_None) {
        if (!l->nmat) {
            PyErr_SetString(PyExc_ValueError, "face_materials index looks: give looks too");
            return -1;
        }
        if (!(l->fm = int_rows(face_materials, 0, (npy_intp)nt, -1, (long long)l->nmat - 1,
                               NPY_UINT32, "face_materials")))
            return -1;
        o->face_material = PyArray_DATA(l->fm);
    }
    return 0;
}

PyDoc_STRVAR(render_doc,
"render($module, /, vertices, triangles=None, *, width=1024, height=768, view='iso', yaw=None,\n"
"       pitch=None, supersample=3, wire=False, background=0xFFFFFF, color=None,\n"
"       wire_color=None, point_radius=0.0, margin=0.04, face_scalar=None,\n"
"       vertex_scalar=None, scalar_min=None, scalar_max=None, threads=0,\n"
"       texcoords=None, colors=None, face_materials=None, looks=None, plain=False)\n"
"--\n"
"\n"
"Render a mesh (flat-shaded, z-buffered, headlight) or a point cloud\n"
"(triangles None or empty: splats) with the library's software rasterizer, as\n"
"`meshreduce render` draws one panel. Returns an (height, width, 4) uint8 RGBA\n"
"image (alpha 255). view: 'iso', 'front', 'side', 'top', or yaw and pitch in\n"
"degrees. Colours: 0xRRGGBB or (r, g, b). face_scalar (one value per triangle)\n"
"or vertex_scalar (per vertex) colour the surface by a heat map over\n"
"[scalar_min, scalar_max] (default: the values' range). The same image at any\n"
"thread count. write_png(path, image) saves it.\n"
"\n"
"vertices may be a file path: the file is drawn as `meshreduce render` draws\n"
"it -- its glTF materials or OBJ mtllib/usemtl materials with their base-colour\n"
"textures (PNG, JPEG), and vertex colours -- unless plain=True. For arrays, the\n"
"look is given: texcoords (N, 2; v up), colors (N, 4: display values 0..1,\n"
"multiplying), looks (a list of dicts, one per material: 'color' (r, g, b[, a])\n"
"in 0..1 or 0xRRGGBB, 'texture' an (H, W, 3 or 4) uint8 image, 'wrap' 'repeat',\n"
"'clamp' or 'mirror', 'v_up' False for glTF's v) and face_materials (M,: an\n"
"index into looks per triangle, -1 for the plain color; without it every\n"
"triangle takes looks[0]).");

static PyObject *py_render(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"vertices",   "triangles",    "width",         "height",
                             "view",       "yaw",          "pitch",         "supersample",
                             "wire",       "background",   "color",         "wire_color",
                             "point_radius", "margin",     "face_scalar",   "vertex_scalar",
                             "scalar_min", "scalar_max",   "threads",       "texcoords",
                             "colors",     "face_materials", "looks",       "plain",
                             NULL};
    PyObject *vertices, *triangles = Py_None, *yaw = Py_None, *pitch = Py_None,
                        *background = Py_None, *color = Py_None, *wire_color = Py_None,
                        *face_scalar = Py_None, *vertex_scalar = Py_None, *smin = Py_None,
                        *smax = Py_None, *texcoords = Py_None, *colors = Py_None,
                        *face_materials = Py_None, *looks = Py_None;
    mr_render_options o;
    mr_render_options_default(&o);
    const char *view = "iso";
    int wire = 0, plain = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|O$iisOOipOOOddOOOOiOOOOp", kwlist, &vertices,
                                     &triangles, &o.width, &o.height, &view, &yaw, &pitch,
                                     &o.supersample, &wire, &background, &color, &wire_color,
                                     &o.point_radius, &o.margin, &face_scalar, &vertex_scalar,
                                     &smin, &smax, &o.threads, &texcoords, &colors,
                                     &face_materials, &looks, &plain))
        return NULL;
    o.wire = wire;
    if (o.width < 1 || o.width > 16384 || o.height < 1 || o.height > 16384)
        return PyErr_Format(PyExc_ValueError, "width and height must be in 1..16384");
    if (o.supersample < 1 || o.supersample > 8)
        return PyErr_Format(PyExc_ValueError, "supersample must be in 1..8");
    if (yaw != Py_None || pitch != Py_None) {
        if (strcmp(view, "iso") != 0)
            return PyErr_Format(PyExc_ValueError, "one camera: view, or yaw and pitch");
        o.view = MR_VIEW_CUSTOM;
        o.yaw = o.pitch = 0;
        if (yaw != Py_None && to_double(yaw, "yaw", &o.yaw) < 0)
            return NULL;
        if (pitch != Py_None && to_double(pitch, "pitch", &o.pitch) < 0)
            return NULL;
    } else if (mr_view_from_name(view, &o.view) != 0) {
        return PyErr_Format(PyExc_ValueError, "view must be one of 'iso', 'front', 'side', "
                                              "'top', got '%s'",
                            view);
    }
    if ((background != Py_None && to_rgb(background, "background", &o.background) < 0) ||
        (color != Py_None && to_rgb(color, "color", &o.color) < 0) ||
        (wire_color != Py_None && to_rgb(wire_color, "wire_color", &o.wire_color) < 0))
        return NULL;
    if (!(o.point_radius >= 0) || !(o.margin >= 0 && o.margin < 0.5))
        return PyErr_Format(PyExc_ValueError, "point_radius must be >= 0 and margin in [0, 0.5)");
    if (check_threads(&o.threads) < 0)
        return NULL;
    if (face_scalar != Py_None && vertex_scalar != Py_None)
        return PyErr_Format(PyExc_ValueError, "give face_scalar or vertex_scalar, not both");
    py_mesh in;
    py_look look;
    memset(&look, 0, sizeof look);
    memset(&in, 0, sizeof in);
    if (PyUnicode_Check(vertices) || PyBytes_Check(vertices) ||
        PyObject_HasAttrString(vertices, "__fspath__")) {
        /* a file, drawn as its file shows it */
        PyObject *path = NULL;
        if (triangles != Py_None || texcoords != Py_None || colors != Py_None ||
            face_materials != Py_None || looks != Py_None)
            return PyErr_Format(PyExc_TypeError, "a file path brings its own triangles and "
                                                 "look (no triangles, texcoords, colors, "
                                                 "face_materials or looks)");
        if (!path_arg(vertices, &path))
            return NULL;
        mr_error err;
        mr_status st;
        const char *p = PyBytes_AS_STRING(path);
        Py_BEGIN_ALLOW_THREADS
        st = mr_look_read(p, &look.file, &err);
        Py_END_ALLOW_THREADS
        Py_DECREF(path);
        if (st != MR_OK)
            return raise_mr_error(&err);
        look.from_file = 1;
        in.m = look.file.mesh;
        if (!plain) {
            o.texcoords = look.file.mesh.texcoords;
            o.vertex_colors = look.file.mesh.colors;
            o.face_material = look.file.face_material;
            o.materials = look.file.materials;
            o.material_count = look.file.material_count;
        }
    } else {
        if (py_mesh_from(&in, vertices, triangles, NULL, NULL, NULL, 0, "vertices", "triangles") <
            0)
            return NULL;
        if (!plain && look_from_arrays(&look, &o, in.m.vertex_count, in.m.triangle_count,
                                       texcoords, colors, face_materials, looks) < 0) {
            py_look_release(&look);
            py_mesh_release(&in);
            return NULL;
        }
    }
    PyArrayObject *sc = NULL;
    if (face_scalar != Py_None || vertex_scalar != Py_None) {
        const int face = face_scalar != Py_None;
        if (face && in.m.triangle_count == 0) {
            py_mesh_release(&in);
            py_look_release(&look);
            return PyErr_Format(PyExc_ValueError, "face_scalar needs triangles");
        }
        sc = scalar_array(face ? face_scalar : vertex_scalar,
                          (npy_intp)(face ? in.m.triangle_count : in.m.vertex_count),
                          face ? "face_scalar" : "vertex_scalar", face ? "triangle" : "vertex");
        if (!sc) {
            py_mesh_release(&in);
            py_look_release(&look);
            return NULL;
        }
        const float *v = PyArray_DATA(sc);
        double lo = INFINITY, hi = -INFINITY;
        for (npy_intp i = 0; i < PyArray_DIM(sc, 0); i++) {
            if (v[i] < lo)
                lo = v[i];
            if (v[i] > hi)
                hi = v[i];
        }
        o.scalar_min = lo;
        o.scalar_max = hi > lo ? hi : lo + 1;
        if ((smin != Py_None && to_double(smin, "scalar_min", &o.scalar_min) < 0) ||
            (smax != Py_None && to_double(smax, "scalar_max", &o.scalar_max) < 0)) {
            Py_DECREF(sc);
            py_mesh_release(&in);
            py_look_release(&look);
            return NULL;
        }
        if (face)
            o.face_scalar = v;
        else
            o.vertex_scalar = v;
    }
    npy_intp dims[3] = {o.height, o.width, 4};
    PyArrayObject *img = (PyArrayObject *)PyArray_SimpleNew(3, dims, NPY_UINT8);
    if (!img) {
        Py_XDECREF(sc);
        py_mesh_release(&in);
        py_look_release(&look);
        return NULL;
    }
    mr_error err;
    mr_status st;
    uint8_t *px = PyArray_DATA(img);
    Py_BEGIN_ALLOW_THREADS
    st = mr_render(in.m.positions, in.m.vertex_count, in.m.indices, in.m.triangle_count, &o, px,
                   0, &err);
    Py_END_ALLOW_THREADS
    Py_XDECREF(sc);
    if (look.from_file)
        memset(&in, 0, sizeof in); /* the look's mesh: freed with it */
    py_mesh_release(&in);
    py_look_release(&look);
    if (st != MR_OK) {
        Py_DECREF(img);
        return raise_mr_error(&err);
    }
    return (PyObject *)img;
}

PyDoc_STRVAR(write_png_doc,
"write_png($module, /, path, image)\n"
"--\n"
"\n"
"Write an (H, W, 4) uint8 RGBA image (render's output) as an RGB PNG (alpha\n"
"dropped), completely or not at all. Raises meshreduce.UnsupportedError when the\n"
"library was built without libpng.");

static PyObject *py_write_png(PyObject *self, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"path", "image", NULL};
    PyObject *path = NULL, *image;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O&O", kwlist, path_arg, &path, &image))
        return NULL;
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(image, NPY_UINT8, 3, 3,
                                                        NPY_ARRAY_IN_ARRAY);
    if (!a) {
        Py_DECREF(path);
        return NULL;
    }
    if (PyArray_DIM(a, 2) != 4 || PyArray_DIM(a, 0) < 1 || PyArray_DIM(a, 1) < 1 ||
        PyArray_DIM(a, 0) > (1 << 20) || PyArray_DIM(a, 1) > (1 << 20)) {
        Py_DECREF(a);
        Py_DECREF(path);
        return PyErr_Format(PyExc_ValueError, "image must have shape (H, W, 4) (RGBA)");
    }
    mr_error err;
    mr_status st;
    const char *p = PyBytes_AS_STRING(path);
    const uint8_t *px = PyArray_DATA(a);
    const int h = (int)PyArray_DIM(a, 0), w = (int)PyArray_DIM(a, 1);
    Py_BEGIN_ALLOW_THREADS
    st = mr_png_write(p, px, w, h, &err);
    Py_END_ALLOW_THREADS
    Py_DECREF(a);
    Py_DECREF(path);
    if (st != MR_OK)
        return raise_mr_error(&err);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------------ */
/* Module                                                                   */
/* ------------------------------------------------------------------------ */

static PyObject *py_register(PyObject *self, PyObject *args)
{
    PyObject *m, *r;
    if (!PyArg_ParseTuple(args, "OO", &m, &r))
        return NULL;
    Py_XSETREF(mesh_class, Py_NewRef(m));
    Py_XSETREF(result_class, Py_NewRef(r));
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"simplify", (PyCFunction)(void (*)(void))py_simplify, METH_VARARGS | METH_KEYWORDS,
     simplify_doc},
    {"simplify_file", (PyCFunction)(void (*)(void))py_simplify_file,
     METH_VARARGS | METH_KEYWORDS, simplify_file_doc},
    {"read", (PyCFunction)(void (*)(void))py_read, METH_VARARGS | METH_KEYWORDS, read_doc},
    {"write", (PyCFunction)(void (*)(void))py_write, METH_VARARGS | METH_KEYWORDS, write_doc},
    {"generate", (PyCFunction)(void (*)(void))py_generate, METH_VARARGS | METH_KEYWORDS,
     generate_doc},
    {"info", (PyCFunction)(void (*)(void))py_info, METH_VARARGS | METH_KEYWORDS, info_doc},
    {"compare", (PyCFunction)(void (*)(void))py_compare, METH_VARARGS | METH_KEYWORDS,
     compare_doc},
    {"weld", (PyCFunction)(void (*)(void))py_weld, METH_VARARGS | METH_KEYWORDS, weld_doc},
    {"cluster", (PyCFunction)(void (*)(void))py_cluster, METH_VARARGS | METH_KEYWORDS,
     cluster_doc},
    {"cluster_file", (PyCFunction)(void (*)(void))py_cluster_file,
     METH_VARARGS | METH_KEYWORDS, cluster_file_doc},
    {"render", (PyCFunction)(void (*)(void))py_render, METH_VARARGS | METH_KEYWORDS, render_doc},
    {"write_png", (PyCFunction)(void (*)(void))py_write_png, METH_VARARGS | METH_KEYWORDS,
     write_png_doc},
    {"_register", py_register, METH_VARARGS,
     "_register(Mesh, Result): the classes the functions return (meshreduce/__init__.py)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "meshreduce._core",
    "The C extension of meshreduce: import meshreduce, which re-exports these functions.", -1,
    methods, NULL, NULL, NULL, NULL};

static int add_error(PyObject *m, const char *name, mr_status status, PyObject *extra_base,
                     const char *doc)
{
    PyObject *bases = extra_base ? PyTuple_Pack(2, error_base, extra_base)
                                 : PyTuple_Pack(1, error_base);
    if (!bases)
        return -1;
    char qual[96];
    snprintf(qual, sizeof qual, "meshreduce.%s", name);
    PyObject *t = PyErr_NewExceptionWithDoc(qual, doc, bases, NULL);
    Py_DECREF(bases);
    if (!t)
        return -1;
    error_types[status] = t;
    return PyModule_AddObjectRef(m, name, t);
}

/* meshreduce.features: what this build has: "openmp" (parallel; else the
 * serial build, threads=0 meaning one thread) and "png" (write_png). */
static int add_features(PyObject *m)
{
#ifdef _OPENMP
    PyObject *openmp = Py_True;
#else
    PyObject *openmp = Py_False;
#endif
#ifdef MR_HAVE_PNG
    PyObject *png = Py_True;
#else
    PyObject *png = Py_False;
#endif
    PyObject *f = Py_BuildValue("{s:O,s:O}", "openmp", openmp, "png", png);
    if (!f)
        return -1;
    int rc = PyModule_AddObjectRef(m, "features", f);
    Py_DECREF(f);
    return rc;
}

PyMODINIT_FUNC PyInit__core(void)
{
    import_array();
    static int atfork_done;
    if (!atfork_done) {
        if (pthread_atfork(NULL, NULL, on_fork_child) != 0) {
            PyErr_SetString(PyExc_ImportError, "meshreduce: pthread_atfork failed");
            return NULL;
        }
        atfork_done = 1;
    }
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    error_base = PyErr_NewExceptionWithDoc(
        "meshreduce.Error",
        "An error reported by the meshreduce library: the message is the library's; "
        ".status names the mr_status, .line and .offset locate a file error (or None).",
        NULL, NULL);
    if (!error_base || PyModule_AddObjectRef(m, "Error", error_base) < 0 ||
        add_error(m, "InvalidArgumentError", MR_ERR_INVALID_ARGUMENT, PyExc_ValueError,
                  "A bad option or argument (MR_ERR_INVALID_ARGUMENT).") < 0 ||
        add_error(m, "MeshIOError", MR_ERR_IO, PyExc_OSError,
                  "A file could not be opened, read or written (MR_ERR_IO).") < 0 ||
        add_error(m, "ParseError", MR_ERR_PARSE, PyExc_ValueError,
                  "A file's content is malformed (MR_ERR_PARSE).") < 0 ||
        add_error(m, "UnsupportedError", MR_ERR_UNSUPPORTED, NULL,
                  "Well-formed but not supported (MR_ERR_UNSUPPORTED).") < 0 ||
        add_error(m, "EmptyMeshError", MR_ERR_EMPTY, PyExc_ValueError,
                  "The input holds nothing to work on (MR_ERR_EMPTY).") < 0 ||
        add_error(m, "TooLargeError", MR_ERR_TOO_LARGE, PyExc_ValueError,
                  "Counts beyond what 32-bit indices address (MR_ERR_TOO_LARGE).") < 0 ||
        add_error(m, "NoMemoryError", MR_ERR_NO_MEMORY, PyExc_MemoryError,
                  "An allocation failed (MR_ERR_NO_MEMORY).") < 0 ||
        add_error(m, "CancelledError", MR_ERR_CANCELLED, NULL,
                  "The work was cancelled (MR_ERR_CANCELLED); simplify raises the exception "
                  "that cancelled it instead.") < 0 ||
        add_features(m) < 0 ||
        PyModule_AddStringConstant(m, "__version__", MR_VERSION_STRING) < 0 ||
        PyModule_AddStringConstant(m, "library_version", mr_version()) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
