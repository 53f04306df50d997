#!/usr/bin/env bash
# The power-cut test with many more cut points than the suite's eight: one 30-s protocol session
# recorded with its writes, syncs and name changes traced, then cut at POINTS moments drawn at
# random (each rebuilt as a power cut would leave it, recovered, verified and read; see
# tests/integration/test_power_cut.cpp). Prints one line per cut and the summary docs/performance-log.md
# quotes (cut points tried, lost at most, median); exits as the test did.
#
#   bash bench/power_cut.sh [POINTS] [SEED]    (default 60 points, a fresh seed, printed)
#
# Needs root (the simulated rig's network namespace) and a build (bash scripts/build.sh).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
tests=$here/build/tests/pvcap_integration_tests
[ -x "$tests" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
export PVCAP_POWER_CUT_POINTS=${1:-60}
[ -n "${2:-}" ] && export PVCAP_POWER_CUT_SEED=$2
log=$(mktemp /tmp/pvcap-power-cut-XXXXXX.log)
"$tests" --gtest_filter='PowerCut.*' > "$log" 2>&1
status=$?
if [ $status -eq 0 ]; then
  grep -E '^(power cut|trace|cut [0-9]+ at)' "$log"
else
  cat "$log"
fi
rm -f "$log"
exit $status
