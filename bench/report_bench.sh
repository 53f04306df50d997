#!/usr/bin/env bash
# The HTML report of a simulated session: its size and how long it takes to build on one core
# (taskset -c 0), with and without the sync self-check. The session is recorded on the full-size
# simulated rig (4 x 1080p at 30 Hz, the Sensel), its pad calibrated with the simulator's lenses
# (so the self-check and the overlay thumbnails have a calibration to work through).
#
#   bash bench/report_bench.sh [minutes | SESSION_FOLDER]   (default 10; recording needs root)
# A session it records is removed at the end (PVCAP_BENCH_KEEP=1 keeps it).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/bench/work_dir.sh"
pvcap=$here/build/app/pvcap
[ -x "$pvcap" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
arg=${1:-10}
if [ -d "$arg" ]; then
  session=$(cd "$arg" && pwd)
else
  bench_work_dir report-bench
  echo "recording $arg minutes into $work (log: $work/pvcap.log)"
  "$pvcap" session --rig "$here/rig-configs/sim.yaml" --root "$work/sessions" --duration $((arg * 60)) --no-web \
    > "$work/pvcap.log" 2>&1 || { echo "the session failed: $work/pvcap.log" >&2; exit 1; }
  session=$(ls -d "$work"/sessions/*/ | head -1)
  session=${session%/}
fi
bash "$here/bench/calibrate_sim_pad.sh" "$session"
span=$(/usr/bin/python3 -c "import sqlite3, sys; db = sqlite3.connect(f'file:{sys.argv[1]}/session.db?mode=ro', uri=True)
print('%.1f' % ((lambda r: (r[1] - r[0]) / 1e9 if r[1] else float('nan'))(db.execute('SELECT started_host_ns, ended_host_ns FROM session').fetchone())))" "$session")
t0=$EPOCHREALTIME
taskset -c 0 "$pvcap" --log-level warn report "$session" --no-self-check > /dev/null
t1=$EPOCHREALTIME
taskset -c 0 "$pvcap" --log-level warn report "$session" > /dev/null
t2=$EPOCHREALTIME
"$pvcap" --log-level warn report "$session" --json > "$session/report.json"
echo "session:                    $session ($span s)"
echo "report.html:                $(( $(stat -c %s "$session/report.html") / 1024 )) kB"
/usr/bin/python3 -c "import sys; a, b, c = map(float, sys.argv[1:]); print(f'build, one core:            {b - a:.1f} s without the self-check, {c - b:.1f} s with it')" "$t0" "$t1" "$t2"
/usr/bin/python3 - "$session/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
sc = r["self_check"]
print(f"self-check:                 {sc['presses_used']} presses used of {sc['presses_found']} found")
for c in sc["cameras"]:
    if c["offset_ms"] is None:
        print(f"  {c['name']}: no offset ({c['verdict']})")
    else:
        print(f"  {c['name']}: offset {c['offset_ms']:+.2f} ms +- {c['uncertainty_ms']:.2f} ms, "
              f"{c['presses']} presses ({c.get('presses_rejected', 0)} set aside)")
PY
