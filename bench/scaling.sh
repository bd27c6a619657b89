#!/usr/bin/env bash
# The scaling run for a machine with many cores (the lent 16-core one):
# 1/2/4/8/16 threads for the default (batched), partitioned,
# partitioned-boundary, FPPQ and MultiQueue on the generated 4M scan, plus
# weld and cluster, 3 alternating rounds; the library's phase times from
# --json (reading and writing excluded) into $OUT/scale.csv; the outputs of
# the deterministic ones compared across thread counts
# ($OUT/determinism.txt). Stops taking new rounds past GUARD seconds, so
# that it fits a lease.
#
#   bench/scaling.sh [MESHREDUCE]      (default build/meshreduce)
#
# To carry it to a machine without the build's libraries: copy the binary,
# libgomp.so.1, libpng16.so.16 and libz.so.1 into one folder and set
# LD_LIBRARY_PATH to it.
set -u
MR=${1:-build/meshreduce}
OUT=${OUT:-out/scaling}
mkdir -p "$OUT"
W=/tmp/scale; mkdir -p $W
LOG=$OUT/scale.csv
t0=$(date +%s)
GUARD=${GUARD:-430}
nproc > $OUT/machine.txt; lscpu >> $OUT/machine.txt 2>&1; free -g >> $OUT/machine.txt 2>&1
$MR generate scan --triangles 4M -o $W/s4.ply -q || exit 1
echo "run,case,threads,setup,collapse,output,total_lib,rss_kb" > $LOG
one() { # run case threads args...
  local run=$1 c=$2 t=$3; shift 3
  local j
  j=$( { /usr/bin/time -f "RSS %M" $MR --threads $t "$@" --json -q; } 2>$W/err ) || { echo "FAIL $c $t" >> $OUT/fail.txt; cat $W/err >> $OUT/fail.txt; return; }
  local rss=$(grep -o 'RSS [0-9]*' $W/err | cut -d' ' -f2)
  python3 - "$run" "$c" "$t" "$rss" "$j" >> $LOG <<'EOF'
import json, sys
run, c, t, rss, j = sys.argv[1:]
s = json.loads(j)["seconds"]
keys = [k for k in ("setup", "collapse", "output") if k in s]
if keys:
    tot = sum(s[k] for k in keys); print(f"{run},{c},{t},{s['setup']:.4f},{s['collapse']:.4f},{s['output']:.4f},{tot:.4f},{rss}")
else:
    print(f"{run},{c},{t},,,,{s['total']:.4f},{rss}")
EOF
}
for run in 1 2 3; do
  for t in 1 16 2 8 4; do
    [ $(( $(date +%s) - t0 )) -gt $GUARD ] && { echo "guard at run $run t $t" >> $OUT/fail.txt; break 2; }
    one $run default10 $t simplify $W/s4.ply -o $W/d10_$t.ply --ratio 10%
    one $run default1 $t simplify $W/s4.ply -o $W/d1_$t.ply --ratio 1%
    one $run partitioned10 $t simplify $W/s4.ply -o $W/p10_$t.ply --ratio 10% --strategy partitioned
    one $run pboundary10 $t simplify $W/s4.ply -o $W/b10_$t.ply --ratio 10% --strategy partitioned-boundary
    one $run fppq10 $t simplify $W/s4.ply -o $W/f10_$t.ply --ratio 10% --strategy fppq --collapse half
    one $run multiqueue10 $t simplify $W/s4.ply -o $W/m10_$t.ply --ratio 10% --strategy multiqueue --collapse half
    one $run weld $t weld $W/s4.ply -o $W/w_$t.ply --eps-rel 2e-3
    one $run cluster $t cluster $W/s4.ply -o $W/c_$t.ply --cell-rel 2e-3
    [ $run = 1 ] && [ $t = 1 ] && one $run greedyhalf10 1 simplify $W/s4.ply -o $W/g10.ply --ratio 10% --strategy greedy --collapse half
  done
  if [ $run = 1 ]; then
    for p in d10 d1 p10 b10 w c; do for t in 2 4 8 16; do
      cmp -s $W/${p}_1.ply $W/${p}_$t.ply && echo "$p $t same" || echo "$p $t DIFFERENT"
    done; done > $OUT/determinism.txt
  fi
done
echo "elapsed $(( $(date +%s) - t0 )) s" >> $OUT/machine.txt
