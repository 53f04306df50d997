#!/usr/bin/env bash
# Export speed for a simulated protocol session: records one (default 10 minutes on the full-size
# simulated rig, the paper's protocol performed by the simulated hand), calibrates its pad with the
# simulator's lenses, then runs build/bench/export_bench on it: export time beside the JPEG encoder
# alone on the same frames.
#
#   bash bench/export_bench.sh [minutes | SESSION_FOLDER]   (recording needs root)
# A session it records is removed at the end (PVCAP_BENCH_KEEP=1 keeps it).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/bench/work_dir.sh"
[ -x "$here/build/bench/export_bench" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
arg=${1:-10}
if [ -d "$arg" ]; then
  session=$(cd "$arg" && pwd)
else
  bench_work_dir export-bench
  echo "recording $arg minutes of the protocol into $work (log: $work/pvcap.log)"
  session=$(bash "$here/bench/record_protocol_session.sh" "$work" "$arg")
fi
bash "$here/bench/calibrate_sim_pad.sh" "$session"  # a session given: calibrated once
"$here/build/bench/export_bench" "$session"
