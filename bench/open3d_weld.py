#!/usr/bin/env python3
"""Open3D's TriangleMesh.merge_close_vertices for meshreduce's weld tests and
benchmark.

  open3d_weld.py check IN.bin EPS OUT.bin
      IN.bin: int64 vertex count, int64 triangle count, float32 xyz per
      vertex, uint32 triangle indices. Welds (positions widened to double, as
      Open3D stores them) and writes OUT.bin: int64 vertex count, int64
      triangle count, float64 xyz, int32 triangle indices.
  open3d_weld.py time MESH RUNS EPS...
      Prints 'EPS SECONDS VERTICES' per radius: the median of RUNS calls on a
      fresh copy of the mesh (the copy is not timed).
"""
import statistics
import sys
import time

import numpy as np
import open3d as o3d


def check(src, eps, dst):
    with open(src, "rb") as f:
        nv, nt = np.frombuffer(f.read(16), dtype="<i8")
        pos = np.frombuffer(f.read(int(nv) * 12), dtype="<f4").reshape(-1, 3)
        tri = np.frombuffer(f.read(int(nt) * 12), dtype="<u4").reshape(-1, 3)
    mesh = o3d.geometry.TriangleMesh()
    mesh.vertices = o3d.utility.Vector3dVector(pos.astype(np.float64))
    mesh.triangles = o3d.utility.Vector3iVector(tri.astype(np.int32))
    mesh.merge_close_vertices(eps)
    v = np.asarray(mesh.vertices, dtype="<f8")
    t = np.asarray(mesh.triangles, dtype="<i4")
    with open(dst, "wb") as f:
        f.write(np.array([len(v), len(t)], dtype="<i8").tobytes())
        f.write(v.tobytes())
        f.write(t.tobytes())


def timing(path, runs, radii):
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    mesh = o3d.io.read_triangle_mesh(path)
    if len(mesh.vertices) == 0:
        sys.exit("open3d read no vertices from " + path)
    for eps in radii:
        times = []
        out = 0
        for _ in range(runs):
            m = o3d.geometry.TriangleMesh(mesh)
            t0 = time.perf_counter()
            m.merge_close_vertices(eps)
            times.append(time.perf_counter() - t0)
            out = len(m.vertices)
        print(repr(eps), statistics.median(times), out, flush=True)


def main():
    a = sys.argv[1:]
    if len(a) == 4 and a[0] == "check":
        check(a[1], float(a[2]), a[3])
    elif len(a) >= 4 and a[0] == "time":
        timing(a[1], int(a[2]), [float(x) for x in a[3:]])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
