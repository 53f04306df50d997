#!/usr/bin/env bash
# Records a protocol session on the full-size simulated rig for the benches (the paper's protocol at
# its real timings, performed by the simulated hand), gives it a pad calibration
# (bench/calibrate_sim_pad.sh), and prints its folder. The caller removes DIR.
#
#   bash bench/record_protocol_session.sh DIR MINUTES   (as root; the log is DIR/pvcap.log)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dir=$1
minutes=$2
"$here/build/app/pvcap" session --rig "$here/rig-configs/sim.yaml" --root "$dir/sessions" \
  --duration $((minutes * 60)) --no-web --protocol "$here/rig-configs/protocols/pressurevision.yaml" --auto \
  --participant BENCH01 --skin-tone light --hand-order right_first --lighting LCR --overlay white_vinyl \
  > "$dir/pvcap.log" 2>&1 || { echo "the session failed: $dir/pvcap.log" >&2; exit 1; }
session=$(find "$dir/sessions" -mindepth 1 -maxdepth 1 -type d | sort | head -1)
bash "$here/bench/calibrate_sim_pad.sh" "$session" >&2  # stdout is the folder alone
echo "$session"
