#!/usr/bin/env bash
# meshreduce-mpi against meshreduce: the out-of-core simplification on
# 1, 2, 3 and 4 ranks gives the single process's bytes (binary PLY and OBJ
# inputs, full and half-edge collapse, an output larger than a chunk, a
# PLY with texture coordinates and colors), and
# so does the streaming cluster (PLY, OBJ, STL); an error is said once and leaves
# no output; a rank killed mid-run ends the job with a non-zero status,
# no output file and no temporary file.
# usage: mpi_check.sh MESHREDUCE MESHREDUCE_MPI MPIEXEC WORKDIR
set -u
MR=$1 MPI=$2 MPIEXEC=$3 W=$4
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
run() { "$MPIEXEC" --oversubscribe --bind-to none -np "$@"; }
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$W" && mkdir -p "$W/tmp" || exit 1
"$MR" generate scan --triangles 300k -o "$W/scan.ply" -q || fail "generate"
"$MR" convert "$W/scan.ply" "$W/scan.obj" -q || fail "convert"
# meshreduce-mpi's COMMAND (simplify or cluster) of $W/INPUT on 1-4 ranks (1
# or 2 threads) gives the single process's bytes;
# usage: same_at_ranks WHAT COMMAND INPUT ARGS...
same_at_ranks() {
  local what=$1 command=$2 input=$3
  shift 3
  "$MR" --threads 2 "$command" "$W/$input" -o "$W/one.ply" "$@" -q || fail "single $what"
  for np in 1 2 3 4; do
    t=$(( np % 2 + 1 ))
    run "$np" "$MPI" --threads "$t" "$command" "$W/$input" -o "$W/np$np.ply" "$@" -q \
      || fail "$np ranks, $what"
    cmp -s "$W/one.ply" "$W/np$np.ply" || fail "$np ranks ($t threads), $what: other bytes"
  done
  echo "ok: $what at 1-4 ranks: the single process's bytes"
}
for input in scan.ply scan.obj; do
  for mode in full half; do
    same_at_ranks "$input $mode" simplify "$input" --ratio 2% --memory 6M --collapse "$mode" \
      --temp-dir "$W/tmp"
  done
done
# an output larger than a chunk (the forest)
same_at_ranks "the forest" simplify scan.ply --ratio 60% --memory 6M
# texture coordinates and colors carried through the chunks (seams across
# the cuts)
/usr/bin/python3 "$(dirname "$0")/make_seamed.py" "$W/scan.ply" "$W/seamed.ply" || fail "seamed input"
same_at_ranks "attributes" simplify seamed.ply --ratio 2% --memory 8M --temp-dir "$W/tmp"
"$MR" convert "$W/seamed.ply" "$W/seamed.obj" -q || fail "convert seamed"
same_at_ranks "an OBJ's attributes" simplify seamed.obj --ratio 2% --memory 8M --temp-dir "$W/tmp"
# ... and an output larger than a chunk with them (the forest's bands find
# a seam's wedges by position)
same_at_ranks "the forest with attributes" simplify seamed.ply --ratio 30% --memory 8M
# an unwelded PLY (the seamed vertices without attributes): the position
# pass finds the repeats, and they go as wedges
/usr/bin/python3 "$(dirname "$0")/make_seamed.py" --bare "$W/scan.ply" "$W/unwelded.ply" \
  || fail "unwelded input"
same_at_ranks "an unwelded PLY" simplify unwelded.ply --ratio 2% --memory 8M
# cluster: the passes shared out over 1-4 ranks give the single process's
# bytes (binary PLY in place; OBJ and binary STL through temporary files
# under a small budget; a cell and a target count)
"$MR" convert "$W/scan.ply" "$W/scan.stl" -q || fail "convert stl"
for input in scan.ply scan.obj scan.stl; do
  for size in "--cell-rel 0.004" "--target-vertices 3000"; do
    same_at_ranks "cluster of $input, $size" cluster "$input" $size --memory 1M \
      --temp-dir "$W/tmp"
  done
done
# --json on rank 0 only: one object
out=$(run 3 "$MPI" simplify "$W/scan.ply" -o "$W/j.ply" --ratio 2% --memory 6M --json -q) \
  || fail "json run"
[ "$(printf '%s\n' "$out" | grep -c '"out_of_core": true')" = 1 ] || fail "json: $out"
# an error (a budget too small) said once, no output
rm -f "$W/bad.ply"
err=$(run 2 "$MPI" simplify "$W/scan.ply" -o "$W/bad.ply" --ratio 2% --memory 64k 2>&1 >/dev/null)
[ $? -ne 0 ] || fail "a budget too small went through"
[ "$(printf '%s\n' "$err" | grep -c 'too small')" = 1 ] || fail "the error, once: $err"
[ ! -e "$W/bad.ply" ] || fail "an output after an error"
# a rank killed mid-run: the victim is a rank (a child of mpirun) that holds
# a temporary file of the job open, so the job is past its start; a job that
# ends before the kill is retried on a larger input
killed_run() {
  "$MR" generate scan --triangles "$1" -o "$W/big.ply" -q || fail "generate $1"
  rm -f "$W/killed.ply"
  "$MPIEXEC" --oversubscribe --bind-to none -np 2 "$MPI" --threads 1 simplify "$W/big.ply" \
    -o "$W/killed.ply" --ratio 1% --memory 24M --temp-dir "$W/tmp" -q >/dev/null 2>&1 &
  job=$!
  victim=""
  while kill -0 "$job" 2>/dev/null; do
    for p in $(pgrep -P "$job"); do
      if ls -l "/proc/$p/fd" 2>/dev/null | grep -q -- "$W/tmp/"; then victim=$p; break; fi
    done
    [ -n "$victim" ] && break
    sleep 0.01
  done
  killed=0
  [ -n "$victim" ] && kill -KILL "$victim" 2>/dev/null && killed=1
  wait "$job"
  rc=$?
}
for size in 2M 8M 24M; do
  killed_run "$size"
  [ "$killed" = 1 ] && break
  echo "note: the $size job ended before a rank could be killed; a larger one"
done
[ "$killed" = 1 ] || fail "no rank could be killed mid-run"
[ $rc -ne 0 ] || fail "the job with a killed rank exited 0"
[ ! -e "$W/killed.ply" ] || fail "an output after a rank was killed"
left=$(ls -A "$W/tmp" | wc -l)
[ "$left" = 0 ] || fail "$left temporary files left: $(ls -A "$W/tmp")"
echo "ok: a killed rank ends the job (status $rc), no output, no temporary file"
echo "PASS"
