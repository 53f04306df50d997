#!/usr/bin/env bash
# `pvcap replay --out` against real time: a simulated session on the full-size rig (4 x 1080p at
# 30 Hz, raw store, the Sensel), its pad calibrated with the simulator's lenses (so every view has
# its overlay), rendered whole at the sample rate (15 Hz, four views) on this machine's cores, from
# the view videos recorded beside the lossless ones (the default) and from the lossless videos
# (--from-raw). The goal is >= 3x real time (issue: performance; 2x before). The references in the
# same run: the ffmpeg command line decoding the same four videos and nothing else (what each
# rendering cannot beat). Also the render's peak memory for 10 s and for the whole session.
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
"$pvcap" --log-level warn replay "$session" --from-raw --out "$work/replay-raw.mp4" | tee "$work/replay-raw.txt"
# The references: decoding the first segment of each camera's video (lossless, then its view video)
# with the ffmpeg command line, the four side by side, as seconds of session per second (timestamps
# kept to the millisecond: the null muxer's default 1/15 s would merge two stored frames closer than
# that, and say so).
decode_four() {  # decode_four VIDEO...: prints the wall seconds the four decodes took together
  local t0=$EPOCHREALTIME
  for v in "$@"; do ffmpeg -hide_banner -loglevel error -threads 1 -i "$v" -vsync passthrough -enc_time_base 1:1000 -f null - & done
  wait
  /usr/bin/python3 -c "import sys; print(float(sys.argv[2]) - float(sys.argv[1]))" "$t0" "$EPOCHREALTIME"
}
raw_s=$(decode_four "$session"/cam?-000.mkv)
views_s=$(decode_four "$session"/views/cam?-000.mkv)
frames=$(ffprobe -v error -count_packets -select_streams v:0 -show_entries stream=nb_read_packets -of csv=p=0 "$session/cam0-000.mkv")
view_frames=$(ffprobe -v error -count_packets -select_streams v:0 -show_entries stream=nb_read_packets -of csv=p=0 "$session/views/cam0-000.mkv")
/usr/bin/python3 - "$work/replay.txt" "$work/replay-raw.txt" "$raw_s" "$views_s" "$frames" "$view_frames" "$work/short.rss" "$work/whole.rss" <<'PY'
import re, sys
def rendered(path):
    m = re.search(r"showing ([\d.]+) s of the session, rendered in ([\d.]+) s \(([\d.]+) x real time\)", open(path).read())
    return float(m.group(1)), float(m.group(2)), float(m.group(3))
(session_s, taken, views_x), (_, raw_taken, raw_x) = rendered(sys.argv[1]), rendered(sys.argv[2])
raw_s, views_s, frames, view_frames = float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
short_mb, whole_mb = (int(open(p).read()) / 1024 for p in sys.argv[7:9])
raw_decode, views_decode = frames / 15.0 / raw_s, frames / 15.0 / views_s
print(f"replay --out, 4 views at 15 Hz: {views_x:.2f} x real time ({session_s} s of session in {taken} s; goal >= 3), "
      f"from the view videos ({view_frames} of {frames} frames of camera 0's first segment in its view video)")
print(f"ffmpeg command line decoding the same four view videos, nothing else: {views_decode:.2f} x real time; ratio {views_x / views_decode:.2f}")
print(f"replay --out --from-raw, from the lossless videos: {raw_x:.2f} x real time ({session_s} s of session in {raw_taken} s)")
print(f"ffmpeg command line decoding the same four raw videos, nothing else: {raw_decode:.2f} x real time; ratio {raw_x / raw_decode:.2f}")
print(f"replay --out peak memory: {short_mb:.0f} MB rendering 10 s, {whole_mb:.0f} MB rendering all {session_s} s (goal < 2048 MB, not growing with length)")
PY
