#!/usr/bin/env bash
# Installs missing packages, then configures and builds pvcap into build/.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/deps.sh"
# PVCAP_WERROR=ON (what .ci/run sets): warnings in pvcap's own code fail the build.
cmake -S "$here" -B "$here/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  ${PVCAP_WERROR:+-DPVCAP_WERROR=$PVCAP_WERROR} >/dev/null
cmake --build "$here/build" -j "$(nproc)"
