#!/usr/bin/env bash
# The power-cut campaign (issue 58; docs/store.md, "What a power cut can lose"): one 30-s protocol
# session on four cameras at the simulated rig's 30 Hz, through a segment rollover, encoders held up
# (their frames in the spill) and the index held up (its rows in the journal), recorded with every
# write, sync and name change traced; then cut at POINTS moments (a fifth drawn over the whole
# session, the rest inside a rollover, a spill in use, the index behind or the stop), each rebuilt as a power
# cut would leave it, recovered, verified and checked (tests/integration/test_power_cut.cpp). Prints
# one line per cut (what it met, what it lost) and the summary docs/store.md quotes; exits as the test did.
#
#   bash bench/power_cut.sh [POINTS] [SEED] [RIG]    (default: 100 points, a fresh seed, RIG 1080p;
#                                                      RIG 320x240 is the suite's small session)
#
# Needs root (the simulated rig's network namespace), a build (bash scripts/build.sh) and ~8 GB of
# free space in /tmp at 1080p (the session, its trace and one cut's image at a time); removes them.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
tests=$here/build/tests/pvcap_integration_tests
[ -x "$tests" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
export PVCAP_POWER_CUT_POINTS=${1:-100}
[ -n "${2:-}" ] && export PVCAP_POWER_CUT_SEED=$2
export PVCAP_POWER_CUT_RIG=${3:-1080p}
log=$(mktemp /tmp/pvcap-power-cut-XXXXXX.log)
start=$(date +%s)
"$tests" --gtest_filter='PowerCut.*' > "$log" 2>&1
status=$?
if [ $status -eq 0 ]; then
  grep -E '^(power cut|trace|cut [0-9]+ at)' "$log"
else
  cat "$log"
fi
echo "power cut campaign: $(( $(date +%s) - start )) s, exit $status"
rm -f "$log"
exit $status
