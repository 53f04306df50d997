#!/usr/bin/env bash
# The main job on the simulated rig: build, calibrate the rig (once), then run a whole participant
# session: the PressureVisionDB protocol (every action with one hand, then the other), performed by
# the simulated participant (--auto), with short timings (--fast, about 4 minutes), ending in its
# report (with the rig's calibration and the sync self-check).
# Extra arguments go to `pvcap session` (e.g. --duration 30 to stop early).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/build.sh" pvcap  # what the demo runs; scripts/test.sh builds the rest
pvcap="$here/build/app/pvcap"
rig="$here/rig-configs/sim.yaml"
calibration="$here/rig-configs/sim.calibration.yaml"
newest() { ls -1d "$1"/*/ 2>/dev/null | sort | tail -n 1; }

# The rig's calibration, as a lab makes it once (docs/calibration.md): a board session for each
# camera's lens, then a short session for where the pad lies in each camera. Kept beside the rig
# file; every later session on the rig records it.
# A step that fails says what failed and how to redo it, and the demo goes on to its session: the
# report then shows which cameras have no calibration (docs/calibration.md).
calibration_step() {  # WHAT REDO COMMAND...
  local what=$1 redo=$2
  shift 2
  if ! "$@"; then
    echo
    echo "== the demo's calibration failed at: $what (its message is above) =="
    echo "   The session runs on; its report marks each camera without a pad calibration (no overlay)."
    echo "   To redo this step:   $redo"
    echo "   To calibrate anew:   rm $calibration && bash scripts/demo.sh"
    echo
    return 1
  fi
}
if ! grep -q "cells_to_ideal_px" "$calibration" 2>/dev/null; then
  echo "== calibrating the simulated rig (once; about 2 minutes) =="
  rm -rf "$here/sessions/calibration"
  if calibration_step "recording the board session" "rm $calibration && bash scripts/demo.sh" \
      "$pvcap" session --rig "$rig" --board --duration 26 --root "$here/sessions/calibration" --no-web; then
    board=$(newest "$here/sessions/calibration")
    calibration_step "each camera's lens (pvcap calibrate intrinsics)" \
      "build/app/pvcap calibrate intrinsics $board --rig $rig --ground-truth $board/sim-truth" \
      "$pvcap" calibrate intrinsics "$board" --rig "$rig" --ground-truth "$board/sim-truth" \
      --save-views "$board/board-views" || true
    if calibration_step "recording the pad session" "rm $calibration && bash scripts/demo.sh" \
        "$pvcap" session --rig "$rig" --duration 6 --root "$here/sessions/calibration/pad" --no-web; then
      pad=$(newest "$here/sessions/calibration/pad")
      calibration_step "the pad in each camera (pvcap calibrate pad)" \
        "build/app/pvcap calibrate pad $pad --rig $rig --ground-truth $pad/sim-truth" \
        "$pvcap" calibrate pad "$pad" --rig "$rig" --ground-truth "$pad/sim-truth" || true
    fi
  fi
fi

exec "$pvcap" session --rig "$rig" --root "$here/sessions" \
  --protocol "$here/rig-configs/protocols/pressurevision.yaml" --auto --fast \
  --participant SIM01 --skin-tone medium --hand-order right_first --lighting LCR --overlay white_vinyl "$@"
