#!/usr/bin/env bash
# Installs the Debian 12 packages pvcap builds and runs against, only when some are
# missing (so a machine that has them needs no network). Run as root.
#   deps.sh          what building and running pvcap needs (scripts/demo.sh)
#   deps.sh --tests  and what the tests, fuzz targets, benches and the Python module need besides
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config git
  libaravis-dev aravis-tools-cli        # GigE Vision cameras (and the fake-camera engine for the sim); arv-tool
  libusb-1.0-0-dev                      # Sensel Morph over USB
  libopencv-dev libopencv-contrib-dev   # debayer, scene rendering, ArUco, homographies, the replay window
  libjpeg62-turbo-dev libpng-dev        # the JPEG and PNG files pvcap writes (codec/image_files.h)
  libavcodec-dev libavformat-dev libavutil-dev libswscale-dev
  libsqlite3-dev zlib1g-dev             # the session index; pressure counts compressed with zlib
  libspdlog-dev libfmt-dev libcli11-dev libyaml-cpp-dev nlohmann-json3-dev
  libcpp-httplib-dev                    # the session's pages (participant display, operator console)
  libumockdev-dev umockdev              # emulated USB bus for the simulated Sensel Morph
)
# What only the tests, fuzz targets, benches and the Python module need: a first run (scripts/demo.sh)
# does without them (about 110 MB to download and 500 MB to unpack fewer; docs/testing.md).
if [ "${1:-}" = "--tests" ]; then
  packages+=(
    libgtest-dev libgmock-dev libbenchmark-dev
    clang libclang-rt-14-dev            # libFuzzer targets
    python3-dev python3-pybind11        # `import pvcap`: the reader as a Python module (docs/python.md)
    python3-opencv python3-numpy        # the store's Python example (docs/store.md) is run by a test
    python3-torch python3-venv          # pvcap.torch's tests; the install into a fresh venv
    ffmpeg sqlite3                      # the benches' reference (the ffmpeg command line); the store read by SQL
    iproute2                            # network namespaces for the simulated rig
    tmux                                # the operator's terminal console is tested in it
    chromium                            # the session's pages are tested in headless Chromium
    slurm-wlm munge                     # `pvcap dataset release --scheduler slurm` on a one-node cluster
    linuxptp                            # ptp4l and pmc: the host's PTP time, read from a real ptp4l (docs/multihost.md)
  )
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  if [ "$(id -u)" != 0 ]; then
    echo "pvcap: missing Debian packages: ${missing[*]}" >&2
    echo "pvcap: run this script as root, or: apt-get install ${missing[*]}" >&2
    exit 1
  fi
  echo "pvcap: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
