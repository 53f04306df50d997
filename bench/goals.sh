#!/usr/bin/env bash
# The performance issue's goals in one run, each measured beside its reference on the same machine
# in the same run, then printed as one table (docs/PERFORMANCE.md, "The goals in one run"):
#   capture   pvcap's capture path / the bare Aravis receive loop, CPU per 1080p frame   <= 1.10
#   store     real-time factor of the default store, four noisy 1080p cameras at 15 Hz    >= 1.5
#             (every frame kept under the store's own rules), and at 60 Hz, every frame    >= 1.0
#   compact   MB per noisy 1080p frame after `pvcap compact`, bit-exact                   <= 0.75
#             (printed beside it: the floor under any lossless coder, those frames' noise entropy)
#             (and on a recorded protocol session of the simulated rig's scene)
#   export    `pvcap export` / the JPEG encoder alone on the same frames                  <= 1.3
#   replay    `pvcap replay --out`, four 1080p views, x real time                          >= 3
# Each bench's own lines are kept in the work folder's logs and repeated under the table.
#
#   bash bench/goals.sh [--docs] [--short] [--session SESSION] [minutes=2]
#   (as root: the capture bench makes a network namespace; --session measures a recorded, calibrated
#   protocol session instead of recording one, and compacts it in place: give a copy; --short is the
#   suite's short form, which prints the table but measures too little to quote)
# With --docs the table, dated, with the commit and the machine, replaces docs/PERFORMANCE.md's
# current figures (between its goals:begin and goals:end markers); the dated log keeps the past.
# About 17 minutes for the default 2-minute session; everything it records is removed at the end
# (PVCAP_BENCH_KEEP=1 keeps it).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/bench/work_dir.sh"
pvcap=$here/build/app/pvcap
for b in capture_bench store_bench export_bench; do
  [ -x "$here/build/bench/$b" ] || { echo "build first: bash scripts/build.sh (no build/bench/$b)" >&2; exit 1; }
done
docs=0 short=0 given_session=""
while [ $# -gt 0 ]; do
  case $1 in
    --docs) docs=1; shift ;;
    --short) short=1; shift ;;
    --session) given_session=${2:?--session needs a recorded session folder}; shift 2 ;;
    *) break ;;
  esac
done
minutes=${1:-2}
# The short form (the suite's bench.goals_short): every step and the table in seconds, not figures to
# quote: one capture round of 1 s a path, the store bench on 15 frames, and the session given.
capture_args=(20 6 ratio) store_args=(90 2 "" raw)  # raw: the default store alone (the table's)
((short)) && capture_args=(1 1 ratio) store_args=(15 2 "" quick)
bench_work_dir goals
step() { echo "[$(date +%H:%M:%S)] $*" >&2; }
# run NAME COMMAND...: COMMAND's output into $work/NAME.txt; a failure names that file and stops.
run() {
  local name=$1
  shift
  "$@" > "$work/$name.txt" 2>&1 || { echo "goals: the $name step failed; its output: $work/$name.txt" >&2; exit 1; }
}

step "capture bench: ${capture_args[1]} rounds of ${capture_args[0]} s per path, each path first in half of them"
run capture "$here/build/bench/capture_bench" "${capture_args[@]}"
step "store bench: ${store_args[0]} noisy frames per camera, then compact"
run store "$here/build/bench/store_bench" "${store_args[@]}"
if [ -n "$given_session" ]; then
  session=$given_session  # a protocol session of the simulated rig (compact rewrites it: pass a copy)
  step "the session given: $session"
  bash "$here/bench/calibrate_sim_pad.sh" "$session"  # nothing when it has its calibration
else
  step "recording a $minutes-minute protocol session (log: $work/pvcap.log)"
  session=$(bash "$here/bench/record_protocol_session.sh" "$work" "$minutes")
fi
step "export bench on it"
run export "$here/build/bench/export_bench" "$session"
step "replay bench on it"
run replay bash "$here/bench/replay_bench.sh" "$session"
step "pvcap compact on it"
run compact "$pvcap" --log-level warn compact "$session"

/usr/bin/python3 - "$work" <<'PY' | tee "$work/table.txt"
import re, sys
work = sys.argv[1]
def text(name):
    return open(f"{work}/{name}.txt").read()
def find(name, pattern):
    m = re.search(pattern, text(name))
    if not m:
        sys.exit(f"goals: no '{pattern}' in {work}/{name}.txt")
    return m
capture = find("capture", r"ratio pvcap/bare ([\d.]+)")
store = find("store", r"real-time factor ([\d.]+) for 4 x 1080p at 15 Hz")
full_rate = find("store", r"full rate: real-time factor ([\d.]+) for 4 x 1080p at 60 Hz")
compact = find("store", r"compact \(.*?\): ([\d.]+) -> ([\d.]+) MB per 1080p frame.*?read back: (bit-exact|[^\n]*)")
export = find("export", r"ratio export / encoder alone: ([\d.]+)")
replay = find("replay", r"4 views at 15 Hz: ([\d.]+) x real time")
session = find("compact", r"compacted \d+ segments, (\d+) frames in [\d.]+ s \([\d.]+ frames/s\): ([\d.]+) -> ([\d.]+) MB")
frames, before, after = int(session.group(1)), float(session.group(2)), float(session.group(3))
rows = [
    ("capture path / bare Aravis loop", "<= 1.10", float(capture.group(1)), lambda v: v <= 1.10, "{:.2f}"),
    ("store real-time factor, 4 noisy cameras", ">= 1.5", float(store.group(1)), lambda v: v >= 1.5, "{:.2f}"),
    ("store at 60 Hz, every frame, 4 cameras", ">= 1.0", float(full_rate.group(1)), lambda v: v >= 1.0, "{:.2f}"),
    ("compact, MB per noisy 1080p frame", "<= 0.75", float(compact.group(2)), lambda v: v <= 0.75, "{:.2f}"),
    ("compact, MB per frame, recorded session", "<= 0.75", after / frames if frames else float("nan"),
     lambda v: v <= 0.75, "{:.3f}"),
    ("export / JPEG encoder alone", "<= 1.3", float(export.group(1)), lambda v: v <= 1.3, "{:.2f}"),
    ("replay, x real time (four 1080p views)", ">= 3", float(replay.group(1)), lambda v: v >= 3, "{:.2f}"),
]
print(f"{'goal':42} {'target':>8} {'measured':>9}  status")
for name, target, value, ok, form in rows:
    print(f"{name:42} {target:>8} {form.format(value):>9}  {'met' if ok(value) else 'NOT MET'}")
print(f"compact read back: {compact.group(3)} (store bench); recorded session {before:.1f} -> {after:.1f} MB for {frames} frames")
floor = find("store", r"compact's floor: .*?([\d.]+) MB per 1080p frame")
print(f"the noisy frames' floor: {float(floor.group(1)):.3f} MB per frame, their noise's own entropy "
      f"(no lossless coder averages less){': the compact goal is below it' if float(floor.group(1)) > 0.75 else ''}")
print("as printed by the benches:")
for name, pattern in [("capture", r"cpu per 1080p frame.*"), ("store", r"pipeline, 4 cameras.*"),
                      ("store", r"full rate: .*"),
                      ("store", r"compact \(.*"), ("store", r"compact's floor.*"),
                      ("compact", r"compacted \d+ segments.*"),
                      ("export", r"export: .*"), ("export", r"JPEG encoder alone.*"),
                      ("replay", r"replay --out, 4 views.*"), ("replay", r"ffmpeg command line.*view videos.*"),
                      ("replay", r"replay --out --from-raw.*"), ("replay", r"ffmpeg command line.*raw videos.*")]:
    print("  " + re.search(pattern, text(name)).group(0))
PY

if [ "$docs" = 1 ]; then
  /usr/bin/python3 - "$here/docs/PERFORMANCE.md" "$work/table.txt" \
    "$(date -u +%Y-%m-%d) at $(git -C "$here" rev-parse --short HEAD) on $(nproc) cores" <<'PY'
import sys
doc, table, when = sys.argv[1], open(sys.argv[2]).read().rstrip("\n"), sys.argv[3]
text = open(doc).read()
begin, end = "<!-- goals:begin -->", "<!-- goals:end -->"
if begin not in text or end not in text:
    sys.exit(f"goals: {doc} has no {begin} ... {end} section to replace")
block = f"{begin}\nPrinted by `bash bench/goals.sh --docs` on {when}:\n```\n{table}\n```\n{end}"
head, rest = text.split(begin, 1)
open(doc, "w").write(head + block + rest.split(end, 1)[1])
print(f"goals: the table is now docs/PERFORMANCE.md's current figures")
PY
fi
