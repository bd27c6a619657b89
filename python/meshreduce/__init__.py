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
    "Mesh", "Result", "simplify", "simplify_file", "read", "write", "compare", "info", "generate",
    "weld", "cluster", "cluster_file", "render", "write_png",
    "Error", "InvalidArgumentError", "MeshIOError", "ParseError", "UnsupportedError",
    "EmptyMeshError", "TooLargeError", "NoMemoryError", "CancelledError", "features", "__version__", "library_version",
]


def _shape(a):
    return "None" if a is None else "%s %s" % (tuple(getattr(a, "shape", ())), getattr(a, "dtype", ""))


class Mesh:
    """A mesh or point cloud as arrays: vertices (N, 3), triangles (M, 3)
    ((0, 3) or None for a point cloud), and optional per-vertex normals
    (N, 3), texcoords (N, 2) and colors (N, 4, RGBA in [0, 1]).

    read() and generate() return one (float32 and uint32 arrays); write()
    accepts one, or any object with the same attributes."""

    __slots__ = ("vertices", "triangles", "normals", "texcoords", "colors")

    def __init__(self, vertices, triangles=None, normals=None, texcoords=None, colors=None):
        self.vertices = vertices
        self.triangles = triangles
        self.normals = normals
        self.texcoords = texcoords
        self.colors = colors

    def __repr__(self):
        return "Mesh(vertices=%s, triangles=%s, normals=%s, texcoords=%s, colors=%s)" % (
            _shape(self.vertices), _shape(self.triangles), _shape(self.normals),
            _shape(self.texcoords), _shape(self.colors))


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
