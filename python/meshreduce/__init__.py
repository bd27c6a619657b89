"""meshreduce: simplify triangle meshes and point clouds, fast, on every core.

The functions are the C library's, through a C extension (meshreduce._core)
on the CPython and NumPy C APIs: arrays go in without a copy where they can
(float32 (N, 3) positions, uint32 or non-negative int32 (M, 3) indices,
C-contiguous), the GIL is released while the library works, and a library
error raises a meshreduce.Error subclass carrying the library's message.
Results match the command-line tool's for the same input and options.

    import meshreduce
    mesh = meshreduce.read("bunny.obj")
    r = meshreduce.simplify(mesh.vertices, mesh.triangles, ratio=0.1)
    print(len(r.triangles), r.error, r.target_reached)
    meshreduce.write("bunny-10.ply", r)
"""

import os as _os


def _load_core():
    """Import the extension with a short OpenMP spin, as the CLI runs.

    The parallel simplifier meets at a barrier a few thousand times a run;
    libgomp's threads wait there by spinning, by default for long (300,000
    turns), and on cores busy with other work a spinning thread holds the
    core its partner needs (a 1M-triangle simplification took 2-4x longer).
    libgomp reads GOMP_SPINCOUNT once, when it is loaded, which importing the
    extension does: unless the user chose (GOMP_SPINCOUNT or OMP_WAIT_POLICY
    set) or libgomp is already loaded, it is set for that moment only, to
    the CLI's value (cli/main.c), and removed again.
    """
    env = _os.environ
    short_spin = "GOMP_SPINCOUNT" not in env and "OMP_WAIT_POLICY" not in env
    if short_spin:
        try:
            with open("/proc/self/maps") as maps:
                short_spin = "libgomp" not in maps.read()
        except OSError:
            pass
    if short_spin:
        env["GOMP_SPINCOUNT"] = "10000"
    try:
        from . import _core
    finally:
        if short_spin:
            env.pop("GOMP_SPINCOUNT", None)
    return _core


_core = _load_core()
from ._core import (  # noqa: F401  (re-exported)
    CancelledError,
    EmptyMeshError,
    Error,
    InvalidArgumentError,
    MeshIOError,
    NoMemoryError,
    ParseError,
    TooLargeError,
    UnsupportedError,
    __version__,
    cluster,
    cluster_file,
    compare,
    features,
    generate,
    info,
    library_version,
    read,
    render,
    simplify,
    simplify_file,
    weld,
    write,
    write_png,
)

__all__ = [
    "Mesh", "Result", "simplify", "simplify_lods", "simplify_file", "read", "write", "compare",
    "info", "generate",
    "weld", "cluster", "cluster_file", "render", "write_png",
    "Error", "InvalidArgumentError", "MeshIOError", "ParseError", "UnsupportedError",
    "EmptyMeshError", "TooLargeError", "NoMemoryError", "CancelledError", "features", "__version__", "library_version",
]


def _shape(a):
    return "None" if a is None else "%s %s" % (tuple(getattr(a, "shape", ())), getattr(a, "dtype", ""))


class Mesh:
    """A mesh or point cloud as arrays: vertices (N, 3), triangles (M, 3)
    ((0, 3) or None for a point cloud), and optional per-vertex normals
    (N, 3), texcoords (N, 2) and colors (N, 4, RGBA in [0, 1]); and, as
    glTF files carry them, texcoords1 to texcoords3 (N, 2: texture sets 1 to
    3), tangents (N, 4: xyz and the bitangent's sign), joints (N, 4 uint16)
    with weights (N, 4), and materials (M,: each triangle's material id,
    -1 for none; an OBJ's usemtl names in order of first use).

    read() and generate() return one (float32 and uint32 arrays); write()
    accepts one, or any object with the same attributes."""

    _arrays = ("vertices", "triangles", "normals", "texcoords", "colors", "texcoords1",
               "texcoords2", "texcoords3", "tangents", "joints", "weights", "materials")
    __slots__ = _arrays

    def __init__(self, vertices, triangles=None, normals=None, texcoords=None, colors=None,
                 texcoords1=None, texcoords2=None, texcoords3=None, tangents=None, joints=None,
                 weights=None, materials=None):
        self.vertices = vertices
        self.triangles = triangles
        self.normals = normals
        self.texcoords = texcoords
        self.colors = colors
        self.texcoords1 = texcoords1
        self.texcoords2 = texcoords2
        self.texcoords3 = texcoords3
        self.tangents = tangents
        self.joints = joints
        self.weights = weights
        self.materials = materials

    def __repr__(self):
        # the first five always; the others where present
        shown = [k for k in self._arrays[:5]] + [
            k for k in self._arrays[5:] if getattr(self, k) is not None]
        return "Mesh(%s)" % ", ".join("%s=%s" % (k, _shape(getattr(self, k))) for k in shown)


class Result:
    """What an operation returned: arrays (vertices, triangles, normals,
    texcoords, colors, origin, ...) and figures (error, target_reached,
    collapses, ...) as attributes; `stats` holds the figures as a dict, as the
    CLI's --json prints them. A Result is a mesh for write()."""

    def __init__(self, **fields):
        self.__dict__.update(fields)

    def __repr__(self):
        parts = []
        for k, v in self.__dict__.items():
            if k == "stats":
                continue
            parts.append("%s=%s" % (k, _shape(v) if hasattr(v, "shape") else repr(v)))
        return "Result(%s)" % ", ".join(parts)


_core._register(Mesh, Result)


_CARRIED = ("texcoords1", "texcoords2", "texcoords3", "tangents", "joints", "weights",
            "materials")


def simplify_lods(vertices, triangles, levels, *, normals=None, texcoords=None, colors=None,
                  samples=0, **options):
    """Levels of detail, as `meshreduce simplify --lods` builds them
    (mr_mesh_lods): level k keeps levels[k] of the input's triangles
    (fractions in (0, 1), decreasing), simplified from level k - 1 with the
    options of simplify() (no ratio, vertex_count or triangle_count: the
    levels are the targets), and is measured against the input.

    Returns a list of Results, one per level, each simplify()'s with
    origin composed to the input's vertices, and hausdorff_rel, rms_rel
    (its distances to the input relative to the input's bounding-box
    diagonal, compare()'s with `samples` samples: 0 = its default) and
    error_rel: the largest hausdorff_rel up to this level, never smaller
    than the level before's."""
    for k in ("ratio", "vertex_count", "triangle_count"):
        if options.get(k) is not None:
            raise ValueError("simplify_lods: the levels are the targets (no %s)" % k)
    levels = [float(f) for f in levels]
    if not levels:
        raise ValueError("simplify_lods: no levels given")
    for i, f in enumerate(levels):
        if not (0 < f < 1) or (i and not f < levels[i - 1]):
            raise ValueError("simplify_lods: level %d's fraction %g is not in (0, 1) below the "
                             "level before's" % (i + 1, f))
    import numpy as np
    tri = np.asarray(triangles)
    total = len(tri)
    if total == 0:
        raise EmptyMeshError("simplify_lods: the mesh has no triangles")
    cmp = {"threads": options.get("threads", 0)}
    if samples:
        cmp["samples"] = samples
    out, worst = [], 0.0
    cur = (vertices, triangles, normals, texcoords, colors)
    # texture sets 1-3, skin and materials go from level to level
    carried = {k: options.pop(k) for k in _CARRIED if k in options}
    origin = None
    for f in levels:
        target = max(1, int(np.floor(f * total + 0.5)))  # llround
        target = min(target, len(cur[1]))
        r = simplify(cur[0], cur[1], normals=cur[2], texcoords=cur[3], colors=cur[4],
                     triangle_count=target, **carried, **options)
        carried = {k: getattr(r, k) for k in _CARRIED if getattr(r, k) is not None}
        if origin is not None:
            r.origin = origin[r.origin]
        origin = r.origin
        d = compare(vertices, triangles, r.vertices, r.triangles, **cmp)
        worst = max(worst, d["hausdorff_rel"])
        r.target_triangles = target
        r.hausdorff_rel, r.rms_rel, r.error_rel = d["hausdorff_rel"], d["rms_rel"], worst
        out.append(r)
        cur = (r.vertices, r.triangles, r.normals, r.texcoords, r.colors)
    return out
