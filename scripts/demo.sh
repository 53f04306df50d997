#!/usr/bin/env bash
# The main job on the simulated rig: build, then record a session end to end.
# Extra arguments go to `pvcap session` (e.g. --duration 30).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/build.sh"
exec "$here/build/app/pvcap" session --rig "$here/rig-configs/sim.yaml" \
  --root "$here/sessions" --duration 10 \
  --participant SIM01 --skin-tone medium --hand-order right_first --lighting LCR --overlay white_vinyl "$@"
