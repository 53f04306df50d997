#!/usr/bin/env bash
# Installs missing packages, then configures and builds pvcap into build/: every target, or only
# those named (`bash scripts/build.sh pvcap`: the command alone, what the demo runs).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/deps.sh"
# PVCAP_ALL=ON (what scripts/test.sh sets): a missing test, fuzz, bench or Python package is an error.
# PVCAP_WERROR=ON (what .ci/run sets): warnings in pvcap's own code fail the build.
# PVCAP_DEBUG_INFO=ON: with -g, for a debugger. Off by default (a first run builds faster: a heavy
# file 37 s -> 26 s); GCC's code is the same with or without it (-g never changes what is generated).
flags="-O2 -DNDEBUG"  # stated (CMake's RelWithDebInfo would add -g) so one choice never sticks in the cache
if [[ ${PVCAP_DEBUG_INFO:-OFF} == ON ]]; then flags="-O2 -g -DNDEBUG"; fi
# PVCAP_UNITY=OFF: one compiler run per source file, for a developer's incremental builds. The default
# (ON) compiles each folder's sources in batches of 8, which parses the shared headers (OpenCV, fmt,
# nlohmann/json, spdlog) once per batch: with the fuzz targets' objects built once, a clean build on 2 cores
# went from 878 s to about 440 s (docs/testing.md).
unity=ON
if [[ ${PVCAP_UNITY:-ON} == OFF ]]; then unity=OFF; fi
cmake -S "$here" -B "$here/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$flags" \
  -DCMAKE_UNITY_BUILD=$unity -DCMAKE_UNITY_BUILD_BATCH_SIZE=8 ${PVCAP_WERROR:+-DPVCAP_WERROR=$PVCAP_WERROR} \
  -DPVCAP_ALL=${PVCAP_ALL:-OFF} >/dev/null
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$here/build" -j "$(nproc)" "${targets[@]}"
