#!/usr/bin/env bash
# The main job on the simulated rig: build, then run a whole participant session: the
# PressureVisionDB protocol (every action with one hand, then the other), performed by the
# simulated participant (--auto), with short timings (--fast, about 4 minutes).
# Extra arguments go to `pvcap session` (e.g. --duration 30 to stop early).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/build.sh"
exec "$here/build/app/pvcap" session --rig "$here/rig-configs/sim.yaml" --root "$here/sessions" \
  --protocol "$here/rig-configs/protocols/pressurevision.yaml" --auto --fast \
  --participant SIM01 --skin-tone medium --hand-order right_first --lighting LCR --overlay white_vinyl "$@"
