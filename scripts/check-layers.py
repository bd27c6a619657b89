#!/usr/bin/env python3
"""The layering check: no file of src/, cli/ or python/ uses one from a layer above it.

Two checks, each against the table LAYERS (docs/architecture.md):
  - includes: every #include "..." of a file names a file of its own layer or one below;
  - calls (with --objects BUILD_DIR): from the library's object files (nm), every
    function or variable a file uses from another file is defined in its own layer or one
    below, and no two files use each other, directly or round a circle.
Prints one line per violation and exits 1 when there is any; 0 and a summary otherwise.
--self-test plants an upward include in a copy of the tree and an upward call and a circle
in a made-up symbol table, and checks that each is caught. Standard library only.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

# (path prefix, layer): the longest matching prefix decides; lower numbers are lower.
# Same number: side by side (they may use each other's files only without a circle).
LAYERS = [
    ("include/", 0),
    ("src/core/", 1),
    ("src/mesh/", 2),
    ("src/geometry/", 2),
    ("src/io/", 3),
    ("src/qem/core/", 4),
    ("src/cluster/", 4),
    ("src/metrics/", 4),
    ("src/qem/strategies/", 5),
    ("src/render/", 5),
    ("src/qem/", 6),
    ("src/ooc/", 7),
    ("cli/", 9),
    ("python/", 9),
]

INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"', re.M)
SOURCES = (".c", ".h", ".inc")


def layer_of(path):
    best = None
    for prefix, layer in LAYERS:
        if path.startswith(prefix) and (best is None or len(prefix) > len(best[0])):
            best = (prefix, layer)
    return best


def source_files(root):
    for top in ("src", "cli", "python"):
        for d, _, names in os.walk(os.path.join(root, top)):
            for n in sorted(names):
                if n.endswith(SOURCES):
                    yield os.path.relpath(os.path.join(d, n), root)


def check_includes(root):
    bad = []
    for f in sorted(source_files(root)):
        lf = layer_of(f)
        if lf is None:
            bad.append("%s: in no layer (add its folder to LAYERS)" % f)
            continue
        with open(os.path.join(root, f), encoding="utf-8", errors="replace") as fh:
            text = fh.read()
        for m in INCLUDE.finditer(text):
            name = m.group(1)
            line = text.count("\n", 0, m.start()) + 1
            here = os.path.normpath(os.path.join(os.path.dirname(f), name))
            target = None
            for cand in (here, os.path.join("include", name), os.path.join("src", name)):
                if os.path.exists(os.path.join(root, cand)):
                    target = cand
                    break
            if target is None:
                continue  # a generated or system header
            lt = layer_of(target)
            if lt is not None and lt[1] > lf[1]:
                bad.append("%s:%d: includes %s (%s, layer %d) from %s (layer %d)" %
                           (f, line, target, lt[0], lt[1], lf[0], lf[1]))
    return bad


def symbol_tables(build, root):
    """{source file: (defined symbols, used symbols)} from the library's objects."""
    base = os.path.join(build, "CMakeFiles", "mr_objects.dir")
    tables = {}
    for d, _, names in os.walk(base):
        for n in names:
            if not n.endswith(".c.o"):
                continue
            obj = os.path.join(d, n)
            src = os.path.relpath(obj, base)[: -len(".o")]
            if not os.path.exists(os.path.join(root, src)):
                continue  # left over from a file that moved
            out = subprocess.run(["nm", obj], capture_output=True, text=True, check=True).stdout
            defs, uses = set(), set()
            for ln in out.splitlines():
                p = ln.split()
                if len(p) == 3 and p[1] in "TDBRCGS":
                    defs.add(p[2])
                elif len(p) == 2 and p[0] == "U":
                    uses.add(p[1])
            tables[src] = (defs, uses)
    return tables


def check_calls(tables):
    bad = []
    owner = {}
    for f, (defs, _) in tables.items():
        for s in defs:
            owner[s] = f
    graph = {f: set() for f in tables}
    why = {}
    for f, (_, uses) in sorted(tables.items()):
        for s in sorted(uses):
            g = owner.get(s)
            if g is None or g == f:
                continue
            graph[f].add(g)
            why.setdefault((f, g), s)
            lf, lg = layer_of(f), layer_of(g)
            if lf and lg and lg[1] > lf[1]:
                bad.append("%s: calls %s in %s (%s, layer %d) from %s (layer %d)" %
                           (f, s, g, lg[0], lg[1], lf[0], lf[1]))
    # circles: strongly connected components of more than one file (Tarjan)
    index, low, stack, on, comps = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    for comp in comps:
        edges = ["%s -> %s (%s)" % (a, b, why[(a, b)]) for a in comp for b in sorted(graph[a])
                 if b in comp]
        bad.append("a circle of files: " + "; ".join(edges))
    return bad


def self_test(root):
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        for top in ("include", "src"):
            shutil.copytree(os.path.join(root, top), os.path.join(tmp, top))
        victim = os.path.join(tmp, "src", "core", "error.c")
        with open(victim, "a", encoding="utf-8") as fh:
            fh.write('\n#include "../qem/entry.h"\n')
        found = [b for b in check_includes(tmp) if b.startswith("src/core/error.c:")]
        print("planted include:", found[0] if found else "NOT CAUGHT")
        ok &= bool(found)
    fake = {
        "src/core/error.c": ({"mr_fail"}, {"mr_simplify"}),
        "src/qem/simplify.c": ({"mr_simplify"}, {"mr_fail"}),
        "src/io/obj.c": ({"mr_read_obj"}, {"mr_write_options_default"}),
        "src/io/io.c": ({"mr_write_options_default"}, {"mr_read_obj"}),
    }
    found = check_calls(fake)
    up = [b for b in found if "calls mr_simplify" in b]
    circle = [b for b in found if b.startswith("a circle") and "src/io/io.c" in b]
    print("planted call:", up[0] if up else "NOT CAUGHT")
    print("planted circle:", circle[0] if circle else "NOT CAUGHT")
    ok &= bool(up) and bool(circle)
    return ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", default=os.path.join(os.path.dirname(__file__), ".."))
    ap.add_argument("--objects", metavar="BUILD_DIR", help="also check the calls, by nm")
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    root = os.path.abspath(a.root)
    if a.self_test:
        good = self_test(root)
        print("self-test:", "passed" if good else "FAILED")
        return 0 if good else 1
    bad = check_includes(root)
    nfiles = sum(1 for _ in source_files(root))
    ncalls = 0
    if a.objects:
        tables = symbol_tables(os.path.abspath(a.objects), root)
        if not tables:
            bad.append("no object files under %s/CMakeFiles/mr_objects.dir" % a.objects)
        ncalls = len(tables)
        bad += check_calls(tables)
    for b in bad:
        print(b)
    if bad:
        print("layering: %d violation(s)" % len(bad))
        return 1
    print("layering: %d files' includes%s, every use downward, no circle" %
          (nfiles, " and %d objects' calls" % ncalls if a.objects else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
