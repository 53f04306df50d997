#!/usr/bin/env bash
# Build, then run every test (unit, integration on the simulated rig, bounded fuzz runs).
#   --quick   a developer's loop: the unit tests and one short 4-camera session (under 2 minutes
#             after the build); every other argument goes to ctest.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
quick=0
args=()
for a in "$@"; do
  if [[ $a == --quick ]]; then quick=1; else args+=("$a"); fi
done
bash "$here/scripts/deps.sh" --tests
PVCAP_ALL=ON bash "$here/scripts/build.sh"
cd "$here/build"
# A fresh build orders the tests by the timings of a full run here (docs/testing.md, "How the suite
# is scheduled"): the longest chains start first; ctest keeps its own timings from then on.
if [[ ! -f Testing/Temporary/CTestCostData.txt ]]; then
  mkdir -p Testing/Temporary
  cp "$here/tests/ctest-cost-data.txt" Testing/Temporary/CTestCostData.txt
fi
if ((quick)); then
  status=0
  ctest --output-on-failure -j 2 -L unit "${args[@]}" || status=$?
  ctest --output-on-failure -R '^SimSession\.FourCamerasTenSecondsEveryFrameAccountedAndTimecodesMatch$' \
    "${args[@]}" || status=$?
  exit "$status"
fi
ctest --output-on-failure -j 2 "${args[@]}"  # lanes: docs/testing.md
