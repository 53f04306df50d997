#!/usr/bin/env bash
# What a pvcap command and a simulated rig cost before any work: `pvcap --version` (loading the
# libraries), beside a program that links nothing (the reference: starting a process at all);
# `pvcap sim` until it serves the rig and from SIGTERM to its exit; and a whole 1-s session.
#   bash bench/start_bench.sh [RUNS] [BUILD_DIR]   (defaults: 15 runs, build/)
# Medians, as printed; run it as root (the simulated rig's network namespace). It removes what it records.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
runs=${1:-15}
build=${2:-$here/build}
# The simulator's and the session's starts are slower: 5 and 3 of them (fewer when RUNS is smaller).
sim_runs=$((runs < 5 ? runs : 5)) session_runs=$((runs < 3 ? runs : 3))
pvcap=$build/app/pvcap
source "$here/bench/work_dir.sh"
bench_work_dir start-bench

median() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
ms() { echo $((($(date +%s%N) - $1) / 1000000)); }

echo 'int main() { return 0; }' > "$work/nothing.c"
cc -O2 -o "$work/nothing" "$work/nothing.c"
for i in $(seq "$runs"); do
  t=$(date +%s%N); "$work/nothing"; ms "$t" >> "$work/nothing.ms"
  t=$(date +%s%N); "$pvcap" --version > /dev/null; ms "$t" >> "$work/version.ms"
done
libs=$(ldd "$pvcap" | wc -l)
n=$(median < "$work/nothing.ms") v=$(median < "$work/version.ms")
echo "pvcap --version: ${v} ms (median of $runs; $libs libraries loaded); a program that links nothing: ${n} ms"

mkdir -p "$work/truth"
for i in $(seq "$sim_runs"); do
  t=$(date +%s%N)
  "$pvcap" --log-level warn sim --rig "$here/rig-configs/sim.yaml" --truth "$work/truth" 2> "$work/sim.err" &
  pid=$!
  until grep -q "serving" "$work/sim.err" 2> /dev/null; do
    kill -0 "$pid" 2> /dev/null || { echo "pvcap sim ended without serving:" >&2; cat "$work/sim.err" >&2; exit 1; }
    sleep 0.01
  done
  ms "$t" >> "$work/serving.ms"
  sleep 1
  t=$(date +%s%N); kill -TERM "$pid"; wait "$pid" || true; ms "$t" >> "$work/exit.ms"
  rm -rf "$work/truth"/*
done
echo "pvcap sim (4 x 1080p): serving after $(median < "$work/serving.ms") ms, ended $(median < "$work/exit.ms") ms after SIGTERM (median of $sim_runs; PVCAP_SIM_CACHE=${PVCAP_SIM_CACHE:-default})"

for i in $(seq "$session_runs"); do
  rm -rf "$work/sessions"
  t=$(date +%s%N)
  "$pvcap" --log-level warn session --rig "$here/rig-configs/sim.yaml" --root "$work/sessions" --duration 1 --no-web \
    > "$work/session.log" 2>&1
  ms "$t" >> "$work/session.ms"
done
echo "pvcap session --duration 1 on the simulated rig, start to exit: $(median < "$work/session.ms") ms (median of $session_runs)"
