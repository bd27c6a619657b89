#!/usr/bin/env python3
"""What a Python call costs on top of the library: meshreduce.simplify on the
generated 1M-triangle scan against the library's own time for the same call
(the C API's phases, as the result's stats report them) and against the CLI
(`meshreduce simplify --json`, whose seconds are the same phases, and its
wall time with reading and writing the file).

  PYTHONPATH=build/python /usr/bin/python3 bench/bench_python.py \\
      [--cli build/meshreduce] [--triangles 1000000] [--ratio 0.1] [--runs 5] [--threads 0]

Debian's Python (/usr/bin/python3, with python3-numpy). For each input kind
-- float32 positions with uint32 indices (used in place), float64 with int64
(converted) -- the median of the runs of: the call's wall time, the
library's time inside it, and the difference (the binding's overhead: argument
checks, conversions, result arrays and dict). Runs alternate between the kinds
and the CLI.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import meshreduce


def library_seconds(stats):
    s = stats["seconds"]
    return s["setup"] + s["collapse"] + s["output"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", default=os.path.join("build", "meshreduce"))
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--ratio", type=float, default=0.1)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", type=int, default=0)
    a = ap.parse_args()

    mesh = meshreduce.generate("scan", a.triangles)
    kinds = {
        "float32/uint32": (np.ascontiguousarray(mesh.vertices, np.float32),
                           np.ascontiguousarray(mesh.triangles, np.uint32)),
        "float64/int64": (mesh.vertices.astype(np.float64), mesh.triangles.astype(np.int64)),
    }
    print(f"python {sys.version.split()[0]} ({sys.executable}), numpy {np.__version__}, "
          f"meshreduce module from {os.path.dirname(meshreduce.__file__)}")
    print(f"input: generated scan, {len(mesh.vertices)} vertices, {len(mesh.triangles)} "
          f"triangles; target ratio {a.ratio}; threads {a.threads or 'all'}; "
          f"median of {a.runs} alternating runs")
    have_cli = os.access(a.cli, os.X_OK)
    tmp = tempfile.mkdtemp(prefix="bench-python-")
    src, dst = os.path.join(tmp, "in.ply"), os.path.join(tmp, "out.ply")
    if have_cli:
        meshreduce.write(src, mesh)

    wall = {k: [] for k in kinds}
    lib = {k: [] for k in kinds}
    cli_wall, cli_lib = [], []
    meshreduce.simplify(*kinds["float32/uint32"], ratio=a.ratio, threads=a.threads)  # warm-up
    for _ in range(a.runs):
        for k, (v, t) in kinds.items():
            t0 = time.perf_counter()
            r = meshreduce.simplify(v, t, ratio=a.ratio, threads=a.threads)
            wall[k].append(time.perf_counter() - t0)
            lib[k].append(library_seconds(r.stats))
        if have_cli:
            t0 = time.perf_counter()
            p = subprocess.run([a.cli, "simplify", src, "-o", dst, "--ratio", str(a.ratio),
                                "--threads", str(a.threads), "--json"],
                               capture_output=True, text=True, check=True)
            cli_wall.append(time.perf_counter() - t0)
            cli_lib.append(library_seconds(json.loads(p.stdout)))

    med = statistics.median
    print(f"\n{'call':34} {'wall s':>9} {'library s':>10} {'overhead ms':>12}")
    for k in kinds:
        over = med([w - l for w, l in zip(wall[k], lib[k])]) * 1e3
        print(f"{'meshreduce.simplify, ' + k:34} {med(wall[k]):9.4f} {med(lib[k]):10.4f} "
              f"{over:12.2f}")
    if have_cli:
        print(f"{'CLI simplify (read + write too)':34} {med(cli_wall):9.4f} {med(cli_lib):10.4f} "
              f"{'':>12}")
    else:
        print(f"(no CLI at {a.cli}: its row left out)")
    for f in (src, dst):
        if os.path.exists(f):
            os.unlink(f)
    os.rmdir(tmp)


if __name__ == "__main__":
    main()
