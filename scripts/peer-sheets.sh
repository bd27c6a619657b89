#!/usr/bin/env bash
# Our outputs beside the peers' (issue 18): for each mesh named, one PNG
# whose rows are the targets (25, 10, 1 % of the vertices) and whose
# columns are meshreduce (default), meshreduce --quality best, CGAL's
# Lindstrom-Turk edge collapse and meshopt_simplify, each panel coloured by
# its distance to the input (render --error-to, one colour scale a sheet)
# and captioned with its Hausdorff and RMS distance.
#
#   scripts/peer-sheets.sh SAVED OUTDIR MESH...
#
# SAVED is the folder bench_simplify --others --save wrote (its files are
# MESH-PCT-ALGORITHM.ply); MESH names a mesh of ../shared/data as the
# benchmark names it (bunny, armadillo, nefertiti, homer, ...). A missing
# output (a peer that was not built) leaves its panel out. CLI defaults to
# build/meshreduce (set CLI to change it); VIEW=front|side|top picks the
# camera (default iso).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cli=${CLI:-$here/build/meshreduce}
data=${MR_SHARED_DATA:-$here/../shared/data}
saved=$1
out=$2
shift 2
mkdir -p "$out"
declare -A file=([bunny]=stanford-bunny.obj [armadillo]=armadillo.obj [nefertiti]=nefertiti.obj
    [ogre]=ogre.obj [fandisk]=fandisk.obj [homer]=homer.obj [igea]=igea.ply [beast]=beast.obj
    [spot]=spot.obj)
for mesh in "$@"; do
    ref=$data/${file[$mesh]:?unknown mesh $mesh}
    panels=()
    columns=0
    for pct in 25 10 1; do
        n=0
        for alg in meshreduce-full meshreduce-best cgal-lt meshopt; do
            f=$saved/$mesh-$pct-$alg.ply
            if [ -f "$f" ]; then
                panels+=("$f")
                n=$((n + 1))
            fi
        done
        [ "$n" -gt "$columns" ] && columns=$n
    done
    [ "${#panels[@]}" -gt 0 ] || { echo "peer-sheets: no outputs of $mesh in $saved" >&2; exit 1; }
    "$cli" render "${panels[@]}" -o "$out/$mesh-peers.png" --error-to "$ref" \
        --columns "$columns" --size 420x340 ${VIEW:+--view "$VIEW"} \
        --title "$mesh: meshreduce | meshreduce --quality best | CGAL Lindstrom-Turk | meshopt_simplify at 25, 10, 1 %"
done
