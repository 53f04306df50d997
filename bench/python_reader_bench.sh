#!/usr/bin/env bash
# Training-read speed of `import pvcap` (docs/python.md): records a protocol session on the full-size
# simulated rig (default 2 minutes) and calibrates its pad, or takes SESSION_FOLDER; makes a compacted
# copy and a `--crop-paper` export of it; then bench/python_reader_bench.py reads crops of 480x384
# with their pressure from each, shuffled, on one core, and prints the three rates side by side.
#
#   bash bench/python_reader_bench.sh [minutes | SESSION_FOLDER] [ITEMS (300)]   (recording needs root)
# PVCAP_BENCH_COPY_SESSION=1: a SESSION_FOLDER given is copied first and left as it was (the suite's
# short form, bench.python_reader_short, reads its export fixture so).
# What it makes is removed at the end (PVCAP_BENCH_KEEP=1 keeps it).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/bench/work_dir.sh"
pvcap="$here/build/app/pvcap"
[ -f "$here/build/python/pvcap/__init__.py" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
arg=${1:-2}
items=${2:-300}
bench_work_dir python-reader-bench
if [ -d "$arg" ] && [ "${PVCAP_BENCH_COPY_SESSION:-0}" = 1 ]; then
  # A session that must stay as it is (the suite's fixture): calibrated and read as a copy.
  cp -a "$arg" "$work/session"
  session="$work/session"
  bash "$here/bench/calibrate_sim_pad.sh" "$session"
elif [ -d "$arg" ]; then
  session=$(cd "$arg" && pwd)
  bash "$here/bench/calibrate_sim_pad.sh" "$session"
else
  echo "recording $arg minutes of the protocol into $work (log: $work/pvcap.log)"
  session=$(bash "$here/bench/record_protocol_session.sh" "$work" "$arg")
fi
echo "compacting a copy for training (pvcap compact --for training) and exporting the takes (--crop-paper)"
cp -a "$session" "$work/compacted"
"$pvcap" --log-level warn compact --for training "$work/compacted" > "$work/compact.log" 2>&1 \
  || { echo "compact failed: $work/compact.log" >&2; exit 1; }
"$pvcap" --log-level warn export "$session" --layout pressurevision --crop-paper --out "$work/export" \
  > "$work/export.log" 2>&1 || { echo "export failed: $work/export.log" >&2; exit 1; }
PYTHONPATH="$here/build/python" /usr/bin/python3 "$here/bench/python_reader_bench.py" "$session" \
  "$work/compacted" "$work/export" "$items"
