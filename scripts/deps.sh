#!/usr/bin/env bash
# Installs the Debian 12 packages pvcap builds and runs against, only when some are
# missing (so a machine that has them needs no network). Run as root.
#   deps.sh          what building and running pvcap needs
#   deps.sh --tests  and what the tests need besides (a browser for the pages, tmux for the console)
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config git
  libaravis-dev aravis-tools            # GigE Vision cameras (and the fake-camera engine for the sim)
  libusb-1.0-0-dev                      # Sensel Morph over USB
  libopencv-dev libopencv-contrib-dev   # debayer, scene rendering, ArUco, homographies
  libjpeg62-turbo-dev libpng-dev        # the JPEG and PNG files pvcap writes (codec/image_files.h)
  libavcodec-dev libavformat-dev libavutil-dev libswscale-dev ffmpeg
  libsqlite3-dev sqlite3 zlib1g-dev     # the session index; pressure counts compressed with zlib
  libspdlog-dev libfmt-dev libcli11-dev libyaml-cpp-dev nlohmann-json3-dev
  libcpp-httplib-dev                    # the session's pages (participant display, operator console)
  libgtest-dev libgmock-dev libbenchmark-dev
  libumockdev-dev umockdev              # emulated USB device for the Sensel tests
  iproute2 util-linux                   # network namespaces for the simulated rig
  python3-opencv python3-numpy          # the store's Python example (docs/store.md) is run by a test
  python3-dev python3-pybind11          # `import pvcap`: the reader as a Python module (docs/python.md)
  clang libclang-rt-14-dev              # libFuzzer targets
)
if [ "${1:-}" = "--tests" ]; then
  packages+=(
    tmux                                # the operator's terminal console is tested in it
    chromium                            # the session's pages are tested in headless Chromium
    slurm-wlm munge                     # `pvcap dataset release --scheduler slurm` on a one-node cluster
    python3-torch python3-venv          # pvcap.torch's tests; the install into a fresh venv
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
