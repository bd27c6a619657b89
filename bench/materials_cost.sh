#!/usr/bin/env bash
# What an OBJ's usemtl groups cost `simplify`: the generated scan as OBJ
# with K material groups (slabs along x; faces in the generator's order, so
# the usemtl lines interleave) against the same OBJ without them, RUNS
# alternating runs of `simplify --ratio RATIO --json`, medians of the read
# time and the library's simplify time (setup + collapse + output), and
# the output's vertices (the material borders are kept as seams).
#
#   bench/materials_cost.sh [TRIANGLES] [K] [RATIO] [RUNS]
#
# Defaults: 1000000 triangles, 8 groups, 0.1, 5 runs. Needs the Python
# module (build/python, Debian's /usr/bin/python3 with python3-numpy) to
# write the two OBJs; meshreduce is build/meshreduce (MR_CLI to change it).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
tris=${1:-1000000}
groups=${2:-8}
ratio=${3:-0.1}
runs=${4:-5}
mr=${MR_CLI:-$here/build/meshreduce}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
PYTHONPATH=$here/build/python /usr/bin/python3 - "$work" "$tris" "$groups" <<'PY'
import sys, numpy as np, meshreduce
work, tris, k = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
m = meshreduce.generate("scan", tris)
c = m.vertices[m.triangles].mean(axis=1)[:, 0]
m.materials = np.minimum(((c - c.min()) / (c.max() - c.min()) * k).astype(np.int64), k - 1)
meshreduce.write(work + "/mat.obj", m, material_names=["m%d" % i for i in range(k)])
m.materials = None
meshreduce.write(work + "/plain.obj", m)
PY
echo "meshreduce $("$mr" --version | head -1 | awk '{print $NF}'), $(nproc) cores; scan of $tris triangles, $groups groups, ratio $ratio, $runs runs"
for i in $(seq "$runs"); do
    for kind in plain mat; do
        "$mr" simplify "$work/$kind.obj" -o "$work/out.obj" --ratio "$ratio" --json -q |
            /usr/bin/python3 -c "import json,sys; d=json.load(sys.stdin); s=d['seconds']; print('$kind', s['read'], s['setup']+s['collapse']+s['output'], d['output_vertices'])"
    done
done | /usr/bin/python3 -c "
import sys, statistics as st
rows = {}
for line in sys.stdin:
    k, r, w, v = line.split()
    rows.setdefault(k, []).append((float(r), float(w), int(v)))
print('%-6s %9s %11s %9s' % ('', 'read s', 'simplify s', 'vertices'))
for k in ('plain', 'mat'):
    r = rows[k]
    print('%-6s %9.3f %11.3f %9d' % (k, st.median(x[0] for x in r), st.median(x[1] for x in r), r[0][2]))
print('simplify with groups / without: %.2fx' % (st.median(x[1] for x in rows['mat']) / st.median(x[1] for x in rows['plain'])))
"
