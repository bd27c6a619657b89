#!/usr/bin/env python3
"""Time Open3D's mesh reader on the files given; print 'PATH SECONDS' per file
(median of --runs runs), for bench_io to compare with in the same run."""
import statistics
import sys
import time

import open3d as o3d


def main():
    args = sys.argv[1:]
    runs = 3
    if args and args[0].startswith("--runs="):
        runs = int(args[0].split("=", 1)[1])
        args = args[1:]
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    for path in args:
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            mesh = o3d.io.read_triangle_mesh(path)
            times.append(time.perf_counter() - t0)
            if len(mesh.triangles) == 0:
                sys.exit("open3d read no triangles from " + path)
        print(path, statistics.median(times), len(mesh.vertices), len(mesh.triangles))


if __name__ == "__main__":
    main()
