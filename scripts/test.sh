#!/usr/bin/env bash
# Build, then run every test (unit, integration on the simulated rig, bounded fuzz runs).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/deps.sh" --tests
bash "$here/scripts/build.sh"
cd "$here/build"
ctest --output-on-failure -j 2 "$@"
