#!/bin/sh
# The serial build (cmake -DMR_OPENMP=OFF) gives the OpenMP build's bytes:
# `meshreduce generate` and `meshreduce simplify` outputs of both command-line
# tools, compared with cmp, the OpenMP one at --threads 1 and 2.
#
#   scripts/check-serial.sh OPENMP_CLI SERIAL_CLI [DATA_DIR]
#
# DATA_DIR (default ../shared/data beside the checkout) holds the shared
# test meshes; those that are absent are skipped. Binary PLY outputs, so
# every float is compared bit for bit.
set -eu
omp=$1
serial=$2
data=${3:-$(dirname "$0")/../../shared/data}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/meshreduce-serial.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM
compared=0

# same FILE_A FILE_B WHAT
same() {
    if ! cmp -s "$1" "$2"; then
        echo "check-serial: $3: the serial build's output differs from the OpenMP build's" >&2
        cmp "$1" "$2" >&2 || true
        exit 1
    fi
    compared=$((compared + 1))
}

# simplify_one NAME INPUT ARGS...: the serial output (and the serial one at
# --threads 2: the option must change nothing), then the OpenMP one at one
# thread -- the concurrent-queue strategies are relaxed above one thread.
simplify_one() {
    name=$1
    in=$2
    shift 2
    "$serial" simplify "$in" -o "$tmp/$name.serial.ply" -q "$@"
    "$serial" --threads 2 simplify "$in" -o "$tmp/$name.serial2.ply" -q "$@"
    same "$tmp/$name.serial.ply" "$tmp/$name.serial2.ply" "$name (serial, --threads 2)"
    "$omp" --threads 1 simplify "$in" -o "$tmp/$name.omp1.ply" -q "$@"
    same "$tmp/$name.serial.ply" "$tmp/$name.omp1.ply" "$name (--threads 1)"
}

# simplify NAME INPUT ARGS...: simplify_one, and the OpenMP output at 2
# threads too.
simplify() {
    simplify_one "$@"
    name=$1
    in=$2
    shift 2
    "$omp" --threads 2 simplify "$in" -o "$tmp/$name.omp2.ply" -q "$@"
    same "$tmp/$name.serial.ply" "$tmp/$name.omp2.ply" "$name (--threads 2)"
}

# Generated meshes, above the sizes where the parallel loops start: each
# build writes its own, and they must agree too.
for g in "scan 300000" "torus 150000"; do
    set -- $g
    "$serial" generate "$1" --triangles "$2" --seed 5 -o "$tmp/$1.serial.ply" -q
    "$omp" --threads 2 generate "$1" --triangles "$2" --seed 5 -o "$tmp/$1.ply" -q
    same "$tmp/$1.serial.ply" "$tmp/$1.ply" "generate $1"
done
simplify scan-batched-full "$tmp/scan.ply" --ratio 0.1
simplify scan-batched-half "$tmp/scan.ply" --ratio 0.25 --collapse half
simplify scan-greedy-full "$tmp/scan.ply" --ratio 0.01 --strategy greedy
simplify torus-lock-border "$tmp/torus.ply" --ratio 0.1 --lock-border
simplify scan-quality-best "$tmp/scan.ply" --ratio 0.05 --quality best
simplify scan-partitioned-full "$tmp/scan.ply" --ratio 0.1 --strategy partitioned
simplify torus-partitioned-half "$tmp/torus.ply" --ratio 0.05 --strategy partitioned \
    --partitions 5 --collapse half
for st in ppq rppq fppq multiqueue; do
    simplify_one "scan-$st" "$tmp/scan.ply" --ratio 0.05 --collapse half --strategy "$st"
done
# PPQ on one thread is greedy's half-edge run.
"$omp" --threads 1 simplify "$tmp/scan.ply" -o "$tmp/scan-greedy-half.ply" -q --ratio 0.05 \
    --collapse half --strategy greedy
same "$tmp/scan-greedy-half.ply" "$tmp/scan-ppq.serial.ply" "scan ppq (serial) = greedy half"

# Shared data: holes and unreferenced vertices, UV seams, triangle strips.
for f in stanford-bunny.obj spot.obj igea.ply; do
    if [ -f "$data/$f" ]; then
        simplify "${f%.*}" "$data/$f" --ratio 0.1
    else
        echo "check-serial: $data/$f absent: skipped"
    fi
done
echo "check-serial: $compared outputs of the serial build are the OpenMP build's bytes"
