#!/usr/bin/env bash
# Gives a simulated session a pad calibration for the benches: the simulator's lenses (its truth,
# as a board session would measure them) written as SESSION/calibration.yaml, then the pad
# calibrated from the session itself, as a lab would. Nothing is done when the file exists.
#
#   bash bench/calibrate_sim_pad.sh SESSION
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
session=$1
[ -f "$session/calibration.yaml" ] && exit 0
/usr/bin/python3 - "$session" <<'PY'
import json, sys
s = sys.argv[1]
t = json.load(open(f"{s}/sim-truth/rig.json"))
cams = [{"name": c["name"], "model": c["model"], "intrinsics": {"method": "truth", "rms_px": 0.0}} for c in t["cameras"]]
json.dump({"pvcap_calibration": 1, "rig": "sim-rig", "pad_layout": t["pad"], "cameras": cams},
          open(f"{s}/calibration.yaml", "w"))
PY
"$here/build/app/pvcap" --log-level warn calibrate pad "$session" > /dev/null
