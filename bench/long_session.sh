#!/usr/bin/env bash
# A long session on the simulated rig at reduced resolution (4 cameras 640x480 at 30 Hz, the Sensel):
# the recorder's memory (RSS) at 1, 10 and 20 minutes, the write-ahead log's peak size, the index's
# size, and how long the end-of-session re-mapping takes. Memory must not grow with time.
#
#   bash bench/long_session.sh [minutes]      (default 20; needs root: the simulated rig's namespace)
#   bash bench/long_session.sh --seconds N    (the suite's short form: the same lines, none of the marks)
# The session is removed at the end (PVCAP_BENCH_KEEP=1 keeps it).
set -euo pipefail
if [ "${1:-}" = "--seconds" ]; then
  seconds=${2:?--seconds needs a number}
  minutes=0
else
  minutes=${1:-20}
  seconds=$((minutes * 60))
fi
here=$(cd "$(dirname "$0")/.." && pwd)
pvcap=$here/build/app/pvcap
[ -x "$pvcap" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
source "$here/bench/work_dir.sh"
bench_work_dir long-session
sed 's/width: 1920/width: 640/; s/height: 1080/height: 480/' "$here/rig-configs/sim.yaml" > "$work/rig.yaml"
"$pvcap" session --rig "$work/rig.yaml" --root "$work/sessions" --duration "$seconds" --no-web \
  > "$work/pvcap.log" 2>&1 &
pid=$!
start=$(date +%s)
wal_peak=0
declare -A rss_at
marks=(1 10 20 "$minutes")
while kill -0 "$pid" 2>/dev/null; do
  sleep 1
  elapsed=$(( $(date +%s) - start ))
  rss=$(awk '/VmRSS/ {print $2}' "/proc/$pid/status" 2>/dev/null || echo 0)
  for m in "${marks[@]}"; do
    if [ -z "${rss_at[$m]:-}" ] && [ "$elapsed" -ge $((m * 60 - 2)) ] && [ "$m" -le "$minutes" ]; then
      rss_at[$m]=$rss
      echo "$(printf '%5d' "$elapsed") s: recorder RSS $((rss / 1024)) MB"
    fi
  done
  wal=$(stat -c %s "$work"/sessions/*/session.db-wal 2>/dev/null | head -1 || true)
  [ -n "$wal" ] && [ "$wal" -gt "$wal_peak" ] && wal_peak=$wal
done
wait "$pid" || { echo "the session failed: $work/pvcap.log" >&2; exit 1; }
session=$(ls -d "$work"/sessions/*/ | head -1)
echo "seconds recorded:          $seconds"
for m in 1 10 20; do
  [ -n "${rss_at[$m]:-}" ] && echo "recorder RSS at $(printf '%2d' "$m") min:    $((rss_at[$m] / 1024)) MB"
done
echo "WAL peak:                  $((wal_peak / 1024 / 1024)) MB"
echo "index (session.db):        $(( $(stat -c %s "$session/session.db") / 1024 / 1024 )) MB"
echo "videos:                    $(du -sm --exclude=session.db* "$session" | cut -f1) MB"
grep -o "re-paired with the final clock fits in [0-9.]* s" "$work/pvcap.log" | sed 's/^/re-mapping: /'
grep -A6 "camera    received" "$work/pvcap.log" || true
