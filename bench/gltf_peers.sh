#!/usr/bin/env bash
# meshreduce against gltfpack (meshoptimizer's glTF tool, the npm package's
# WebAssembly build) on glTF files, at gltfpack's own triangle count:
# whole-process time (median of RUNS alternating runs), and each output's
# distance and attribute deviation from its input (meshreduce compare
# --json: RMS and Hausdorff % of the diagonal, normal RMS in degrees, the
# texture deviation's RMS % of the diagonal).
#
#   bench/gltf_peers.sh NODE_MODULES [RATIO] [RUNS] [FILE...]
#
# NODE_MODULES: where `npm install gltfpack@1.3` put it (and, for a third
# row, `npm install meshoptimizer@1.3`: its simplifyWithAttributes through
# bench/meshopt_attributes.mjs on the model as OBJ, normals 0.5 and UVs 1,
# at the same count; its time includes reading the OBJ text in JavaScript
# and is not comparable). gltfpack runs with
# -noq (no quantisation), -kn -km -ke (nodes, materials and extras kept),
# -si RATIO and -se 1 (no error limit: the ratio is the target, as for
# meshreduce). FILE...: default, the .glb sample models of
# ../shared/data/gltf that use no compression. meshreduce is build/meshreduce
# (MR_CLI to change it), at its default threads. With MR_SHEETS=DIR, each
# model's render sheet (input, gltfpack's, meshreduce's; textured, from one
# camera, each captioned with its distance to the input) goes to
# DIR/MODEL.png. MR_ARGS adds options to meshreduce's runs (e.g.
# MR_ARGS=--free-seams).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
modules=${1:?usage: gltf_peers.sh NODE_MODULES [RATIO] [RUNS] [FILE...]}
ratio=${2:-0.1}
runs=${3:-3}
shift $(( $# < 3 ? $# : 3 ))
mr=${MR_CLI:-$here/build/meshreduce}
gp="$modules/gltfpack/cli.js"
[ -f "$gp" ] || { echo "gltfpack not found in $modules (npm install gltfpack@1.3)"; exit 1; }
files=("$@")
if [ ${#files[@]} -eq 0 ]; then
    for f in "$here"/../shared/data/gltf/*/glTF-Binary/*.glb; do
        grep -qa -e KHR_draco_mesh_compression -e EXT_meshopt_compression "$f" || files+=("$f")
    done
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
now() { date +%s.%N; }
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR + 1) / 2)]}'; }
py=/usr/bin/python3  # Debian's; the standard library only
pct() { $py -c "import sys; print(float(sys.argv[1]) * 100)" "$1"; }
field() { $py -c "import json,sys; d=json.load(open(sys.argv[1])); print(d.get(sys.argv[2], float('nan')))" "$1" "$2"; }

echo "meshreduce $("$mr" --version 2>&1 | head -1 | awk '{print $NF}') against gltfpack 1.3 (npm, wasm; node $(node --version))"
echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores; ratio $ratio; median of $runs alternating runs"
printf '%-22s %-10s %9s %8s %9s %9s %9s %10s\n' model tool triangles "time s" "RMS %" "Haus %" "normal °" "texture %"
for f in "${files[@]}"; do
    name=$(basename "$f" .glb)
    node "$gp" -i "$f" -o "$work/gp.glb" -noq -kn -km -ke -si "$ratio" -se 1 >/dev/null 2>&1 || {
        printf '%-22s gltfpack failed\n' "$name"; continue; }
    tris=$("$mr" info "$work/gp.glb" --json 2>/dev/null | $py -c "import json,sys; print(json.load(sys.stdin)['triangles'])" 2>/dev/null) || {
        printf '%-22s gltfpack left no triangles\n' "$name"; continue; }
    tg=(); tm=()
    for r in $(seq "$runs"); do
        for tool in gp mr; do
            [ $((r % 2)) -eq 0 ] && tool=$([ $tool = gp ] && echo mr || echo gp)
            t0=$(now)
            if [ $tool = gp ]; then
                node "$gp" -i "$f" -o "$work/gp.glb" -noq -kn -km -ke -si "$ratio" -se 1 >/dev/null 2>&1
                tg+=("$(echo "$(now) - $t0" | bc)")
            else
                "$mr" simplify "$f" -o "$work/mr.glb" --triangles "$tris" ${MR_ARGS:-} -q 2>/dev/null
                tm+=("$(echo "$(now) - $t0" | bc)")
            fi
        done
    done
    for tool in gp mr; do
        "$mr" compare "$f" "$work/$tool.glb" --json > "$work/$tool.json"
        mine=$("$mr" info "$work/$tool.glb" --json | $py -c "import json,sys; print(json.load(sys.stdin)['triangles'])")
        if [ $tool = gp ]; then t=$(printf '%s\n' "${tg[@]}" | median); label=gltfpack; else t=$(printf '%s\n' "${tm[@]}" | median); label=meshreduce; fi
        printf '%-22s %-10s %9s %8.3f %9.4f %9.4f %9.3f %10.4f\n' "$name" "$label" "$mine" "$t" \
            "$(pct "$(field "$work/$tool.json" rms_rel)")" \
            "$(pct "$(field "$work/$tool.json" hausdorff_rel)")" \
            "$(field "$work/$tool.json" normal_rms_degrees)" \
            "$(pct "$(field "$work/$tool.json" texture_rms_rel)")"
    done
    if [ -f "$modules/meshoptimizer/index.js" ] && "$mr" convert "$f" "$work/in.obj" -q 2>/dev/null &&
        grep -q '^vn ' "$work/in.obj" && grep -q '^vt ' "$work/in.obj"; then
        t0=$(now)
        if node "$here/bench/meshopt_attributes.mjs" "$modules" "$work/in.obj" "$tris" \
            "$work/mo.obj" >/dev/null 2>&1; then
            t=$(echo "$(now) - $t0" | bc)
            "$mr" compare "$f" "$work/mo.obj" --json > "$work/mo.json"
            mine=$("$mr" info "$work/mo.obj" --json | $py -c "import json,sys; print(json.load(sys.stdin)['triangles'])")
            printf '%-22s %-10s %9s %8.3f %9.4f %9.4f %9.3f %10.4f\n' "$name" meshopt "$mine" "$t" \
                "$(pct "$(field "$work/mo.json" rms_rel)")" \
                "$(pct "$(field "$work/mo.json" hausdorff_rel)")" \
                "$(field "$work/mo.json" normal_rms_degrees)" \
                "$(pct "$(field "$work/mo.json" texture_rms_rel)")"
        fi
    fi
    if [ -n "${MR_SHEETS:-}" ]; then
        mkdir -p "$MR_SHEETS"
        cp "$work/gp.glb" "$work/gltfpack.glb"
        cp "$work/mr.glb" "$work/meshreduce.glb"
        "$mr" render "$f" "$work/gltfpack.glb" "$work/meshreduce.glb" -o "$MR_SHEETS/$name.png" \
            --size 400x400 --title "$name at gltfpack's triangle count ($ratio)" -q
    fi
done
