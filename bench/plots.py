#!/usr/bin/env python3
"""The benchmark report's plots, from the sweep's CSV (bench/sweep.c), with matplotlib.

    plots.py [CSV] [--out DIR]
    plots.py --outofcore CSV [--out DIR]

CSV defaults to bench/report/sweep.csv; DIR (default bench/report) receives
time-threads.png, speedup-threads.png, peers.png and error-MESH.png, the plots that
bench/REPORT.md embeds (bench/report.c writes the comparison sheets, rendered by the
library, and REPORT.md itself). With --outofcore, CSV is bench_outofcore's (--csv) and DIR
receives outofcore.png: time and peak memory against the input's size, a line per run
(in memory, out of core at each budget, MPI), which bench/RESULTS.md embeds. Debian's python3-matplotlib (make report installs it);
the Agg backend, so no display is needed. Exit 1 with one line on a CSV that is not the
sweep's.
"""

import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# twenty distinct colours: a sweep has more series than the default ten
plt.rcParams["axes.prop_cycle"] = plt.cycler(color=plt.cm.tab20.colors)


def read_sweep(path):
    meshes, rows, header = [], [], None
    with open(path, newline="", encoding="utf-8") as fh:
        for line in fh:
            line = line.rstrip("\r\n")
            if line.startswith("#"):
                if line.startswith("# mesh "):
                    meshes.append(line[7:].split(" ", 1)[0])
                continue
            if header is None:
                if not line.startswith("mesh,algorithm,threads,target,"):
                    raise ValueError("%s: not a sweep CSV (header '%s')" % (path, line))
                header = next(csv.reader([line]))
                continue
            if line:
                rows.append(dict(zip(header, next(csv.reader([line])))))
    if not rows:
        raise ValueError("%s has no rows" % path)

    def num(x):
        try:
            return float(x)
        except (TypeError, ValueError):
            return math.nan

    for r in rows:
        r["threads"] = int(num(r["threads"]))
        for k in ("target", "time_median", "hausdorff_rel"):
            r[k] = num(r.get(k))
    if not meshes:
        meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    return meshes, rows


def distinct(seq):
    return list(dict.fromkeys(seq))


def find(rows, mesh, alg, threads, target):
    for r in rows:
        if (r["mesh"] == mesh and r["algorithm"] == alg and r["threads"] == threads
                and abs(r["target"] - target) < 1e-9):
            return r
    return None


def finish(fig, ax, path, title, xlabel, ylabel):
    ax.set_title(title, loc="left")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="major", color="#e6e6e6")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


OUTOFCORE_COLUMNS = ("triangles", "config", "threads", "ranks", "memory", "seconds",
                     "rss_bytes")


def read_outofcore(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or any(c not in rows[0] for c in OUTOFCORE_COLUMNS):
        raise ValueError("%s: not a bench_outofcore CSV (columns %s)"
                         % (path, ", ".join(OUTOFCORE_COLUMNS)))
    for r in rows:
        try:
            for k in ("triangles", "threads", "ranks"):
                r[k] = int(r[k])
            for k in ("seconds", "rss_bytes"):
                r[k] = float(r[k])
        except ValueError:
            raise ValueError("%s: not a bench_outofcore CSV (a row's numbers: %s)"
                             % (path, ",".join(str(v) for v in r.values())))
    return rows


def outofcore_plot(path, out):
    rows = read_outofcore(path)
    fig, (at, am) = plt.subplots(1, 2, figsize=(12, 5))
    # a line per run across the sizes; where one size has several budgets
    # for a run, a line per budget; each point labelled with its budget
    plural = lambda n: "s" if n > 1 else ""  # noqa: E731
    budgets = {}
    for r in rows:
        budgets.setdefault((r["config"], r["threads"], r["ranks"], r["triangles"]),
                           set()).add(r["memory"])
    series = {}
    for r in rows:
        split = len(budgets[(r["config"], r["threads"], r["ranks"], r["triangles"])]) > 1
        if r["config"] == "mpi":
            label = "MPI, %d rank%s" % (r["ranks"], plural(r["ranks"]))
        elif r["config"] == "in memory":
            label = "in memory, %d thread%s" % (r["threads"], plural(r["threads"]))
        else:
            label = "out of core, %d thread%s" % (r["threads"], plural(r["threads"]))
        if split:
            label += ", --memory " + r["memory"]
        series.setdefault(label, []).append(r)
    for label, rs in series.items():
        rs.sort(key=lambda r: r["triangles"])
        xs = [r["triangles"] for r in rs]
        line, = at.plot(xs, [r["seconds"] for r in rs], marker="o", label=label)
        if any(r["rss_bytes"] > 0 for r in rs):
            am.plot(xs, [r["rss_bytes"] / 1e9 for r in rs], marker="o", label=label,
                    color=line.get_color())
            for r in rs:
                if r["config"] != "in memory":
                    am.annotate(r["memory"], (r["triangles"], r["rss_bytes"] / 1e9),
                                textcoords="offset points", xytext=(4, -10), fontsize=7,
                                color=line.get_color())
    for ax in (at, am):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="major", color="#e6e6e6")
        ax.set_xlabel("input triangles")
    at.set_title("Time (whole process, median)", loc="left")
    at.set_ylabel("seconds")
    am.set_title("Peak resident memory (per process)", loc="left")
    am.set_ylabel("GB")
    am.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    os.makedirs(out, exist_ok=True)
    fig.savefig(os.path.join(out, "outofcore.png"), dpi=100, bbox_inches="tight")
    plt.close(fig)
    print("plots: outofcore.png in %s" % out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", nargs="?", default="bench/report/sweep.csv")
    ap.add_argument("--out", default="bench/report")
    ap.add_argument("--outofcore", metavar="CSV", help="bench_outofcore's CSV")
    a = ap.parse_args()
    if a.outofcore:
        try:
            outofcore_plot(a.outofcore, a.out)
        except (OSError, ValueError) as e:
            print("plots: %s" % e, file=sys.stderr)
            return 1
        return 0
    try:
        meshes, rows = read_sweep(a.csv)
    except (OSError, ValueError) as e:
        print("plots: %s" % e, file=sys.stderr)
        return 1
    os.makedirs(a.out, exist_ok=True)
    targets = sorted(distinct(r["target"] for r in rows), reverse=True)
    mid = min(targets, key=lambda t: abs(math.log(t / 0.1)))  # the target nearest 10 %
    algs = distinct(r["algorithm"] for r in rows)
    threaded = [x for x in algs if any(r["algorithm"] == x and r["threads"] > 1 for r in rows)]
    written = []

    # time and speedup against threads: every threaded algorithm on every mesh
    ft, at = plt.subplots(figsize=(8, 5))
    fs, as_ = plt.subplots(figsize=(8, 5))
    top = 1
    for m in meshes:
        for alg in threaded:
            pts = sorted((r["threads"], r["time_median"]) for r in rows
                         if r["mesh"] == m and r["algorithm"] == alg
                         and abs(r["target"] - mid) < 1e-9)
            if not pts:
                continue
            one = find(rows, m, alg, 1, mid)
            xs = [p[0] for p in pts]
            at.plot(xs, [p[1] for p in pts], marker="o", label="%s %s" % (m, alg))
            if one:
                as_.plot(xs, [one["time_median"] / p[1] for p in pts], marker="o",
                         label="%s %s" % (m, alg))
            top = max(top, max(xs))
    at.set_yscale("log")
    for ax in (at, as_):
        ax.set_xticks(sorted(distinct(r["threads"] for r in rows)))
    as_.plot([1, top], [1, top], linestyle="--", color="#909090", label="ideal")
    for fig, ax, name, ylabel in ((ft, at, "time-threads.png", "seconds (median)"),
                                  (fs, as_, "speedup-threads.png", "speedup over 1 thread")):
        what = "Time" if name.startswith("time") else "Speedup"
        finish(fig, ax, os.path.join(a.out, name),
               "%s vs threads (to %g%% of the vertices)" % (what, 100 * mid), "threads", ylabel)
        written.append(name)

    # error against reduction, per mesh: every algorithm at 1 thread
    for m in meshes:
        fig, ax = plt.subplots(figsize=(8, 5))
        for alg in distinct(r["algorithm"] for r in rows if r["mesh"] == m):
            pts = sorted((r["target"], 100 * r["hausdorff_rel"]) for r in rows
                         if r["mesh"] == m and r["algorithm"] == alg and r["threads"] == 1
                         and math.isfinite(r["hausdorff_rel"]))
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=alg)
        ax.set_xscale("log")
        ax.set_yscale("log")
        name = "error-%s.png" % m
        finish(fig, ax, os.path.join(a.out, name), "%s: error vs reduction (1 thread)" % m,
               "vertices kept (fraction of the input)",
               "Hausdorff distance, % of the bbox diagonal")
        written.append(name)

    # ours against the peers: time at the middle target, 1 thread
    fig, ax = plt.subplots(figsize=(8, 5))
    width = 0.8 / max(1, len(algs))
    for k, alg in enumerate(algs):
        ys = []
        for m in meshes:
            r = find(rows, m, alg, 1, mid)
            ys.append(r["time_median"] if r else math.nan)
        ax.bar([i + (k - (len(algs) - 1) / 2) * width for i in range(len(meshes))], ys, width,
               label=alg)
    ax.set_xticks(range(len(meshes)))
    ax.set_xticklabels(meshes)
    ax.set_yscale("log")
    finish(fig, ax, os.path.join(a.out, "peers.png"),
           "Ours vs peers: time to %g%% (1 thread)" % (100 * mid), "",
           "seconds (median, log scale)")
    written.append("peers.png")
    print("plots: %s in %s" % (", ".join(written), a.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
