#!/usr/bin/env bash
# Comparison sheets of the partitioned strategies (issue 16): for each mesh,
# one PNG whose rows are the targets (25, 10, 1, 0.5 % of the vertices) and
# whose columns are the default strategy, the partitioned one and its
# boundary-aware variant, each panel coloured by its distance to the input
# (render --error-to, one colour scale for the whole sheet), so that a seam
# along the slab planes would show as a band of warmer faces.
#
#   scripts/partition-sheets.sh [CLI] [OUTDIR]
#
# CLI defaults to build/meshreduce, OUTDIR to bench/report/sheets. The
# meshes: the generated 1M scan (a side view, along the slab axis), and the
# bunny and the armadillo from ../shared/data when present.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cli=${1:-$here/build/meshreduce}
out=${2:-$here/bench/report/sheets}
data=${MR_SHARED_DATA:-$here/../shared/data}
threads=${THREADS:-0}
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

meshes=()
"$cli" generate scan --triangles 1M -o "$tmp/scan-1M.ply" -q
meshes+=("scan-1M:$tmp/scan-1M.ply:front")
[ -f "$data/stanford-bunny.obj" ] && meshes+=("bunny:$data/stanford-bunny.obj:front")
[ -f "$data/armadillo.obj" ] && meshes+=("armadillo:$data/armadillo.obj:front")

for entry in "${meshes[@]}"; do
    IFS=: read -r name file view <<<"$entry"
    panels=()
    for target in 25% 10% 1% 0.5%; do
        for strategy in batched partitioned partitioned-boundary; do
            label=${strategy/batched/default}
            o="$tmp/$name-${target%\%}pct-$label.ply"
            "$cli" simplify "$file" -o "$o" --ratio "$target" --strategy "$strategy" \
                --threads "$threads" -q
            panels+=("$o")
        done
    done
    "$cli" render "${panels[@]}" -o "$out/$name-partitioned.png" --error-to "$file" \
        --columns 3 --view "$view" --size 360x300 \
        --title "$name: default | partitioned | partitioned-boundary at 25, 10, 1, 0.5 % (16 slabs)"
done
