#!/usr/bin/env bash
# `pvcap replay --out` against real time: a simulated session on the full-size rig (4 x 1080p at
# 30 Hz, raw store, the Sensel), its pad calibrated with the simulator's lenses (so every view has
# its overlay), rendered whole at the sample rate (15 Hz, four views) on this machine's cores. The
# goal is >= 3x real time (issue: performance; 2x before). The reference in the same run: the
# ffmpeg command line decoding the same four raw videos and nothing else (what the rendering cannot
# beat). Also the render's peak memory for 10 s and for the whole session.
#
#   bash bench/replay_bench.sh [seconds | SESSION_FOLDER]   (default 60; recording needs root)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/bench/work_dir.sh"
pvcap=$here/build/app/pvcap
[ -x "$pvcap" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
arg=${1:-60}
bench_work_dir replay-bench  # its renders, and a session it records (PVCAP_BENCH_KEEP=1 keeps them)
if [ -d "$arg" ]; then
  session=$(cd "$arg" && pwd)
else
  echo "recording $arg s into $work (log: $work/pvcap.log)"
  "$pvcap" session --rig "$here/rig-configs/sim.yaml" --root "$work/sessions" --duration "$arg" --no-web \
    > "$work/pvcap.log" 2>&1 || { echo "the session failed: $work/pvcap.log" >&2; exit 1; }
  session=$(ls -d "$work"/sessions/*/ | head -1)
  session=${session%/}
fi
bash "$here/bench/calibrate_sim_pad.sh" "$session" > /dev/null
# Peak memory (resident, KiB) of a 10 s stretch and of the whole: a render keeps one sample's
# pictures and a short read-ahead per camera, so the two should be alike.
peak_rss() {  # peak_rss FILE COMMAND...: runs COMMAND, writes its peak resident memory to FILE
  /usr/bin/python3 -c 'import resource, subprocess, sys
r = subprocess.run(sys.argv[2:])
open(sys.argv[1], "w").write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))
sys.exit(r.returncode)' "$@"
}
peak_rss "$work/short.rss" "$pvcap" --log-level warn replay "$session" --to 10 --out "$work/short.mp4" > /dev/null
peak_rss "$work/whole.rss" "$pvcap" --log-level warn replay "$session" --out "$work/replay.mp4" | tee "$work/replay.txt"
# The reference: decoding the first segment of each camera's video with the ffmpeg command line, the
# four side by side, as frames per second of session time (timestamps kept to the millisecond: the
# null muxer's default 1/15 s would merge two stored frames closer than that, and say so).
t0=$EPOCHREALTIME
for v in "$session"/cam?-000.mkv; do ffmpeg -hide_banner -loglevel error -threads 1 -i "$v" -vsync passthrough -enc_time_base 1:1000 -f null - & done
wait
t1=$EPOCHREALTIME
frames=$(ffprobe -v error -count_packets -select_streams v:0 -show_entries stream=nb_read_packets -of csv=p=0 "$session/cam0-000.mkv")
/usr/bin/python3 - "$work/replay.txt" "$t0" "$t1" "$frames" "$work/short.rss" "$work/whole.rss" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
short_mb, whole_mb = (int(open(p).read()) / 1024 for p in sys.argv[5:7])
m = re.search(r"showing ([\d.]+) s of the session, rendered in ([\d.]+) s \(([\d.]+) x real time\)", text)
t0, t1, frames = float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
decode = frames / 15.0 / (t1 - t0)
print(f"replay --out, 4 views at 15 Hz: {m.group(3)} x real time ({m.group(1)} s of session in {m.group(2)} s; goal >= 3)")
print(f"ffmpeg command line decoding the same four raw videos, nothing else: {decode:.2f} x real time; ratio {float(m.group(3)) / decode:.2f}")
print(f"replay --out peak memory: {short_mb:.0f} MB rendering 10 s, {whole_mb:.0f} MB rendering all {m.group(1)} s (goal < 2048 MB, not growing with length)")
PY
