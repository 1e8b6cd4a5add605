#!/usr/bin/env bash
# Install isowrench's build and test dependencies from Debian packages (Debian 12 "bookworm").
# Only installs what is missing; needs root (uses sudo when not root).
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config clang clang-format libclang-rt-14-dev libfuzzer-14-dev
  liborocos-kdl-dev liburdfdom-dev libeigen3-dev libtinyxml2-dev
  libcli11-dev nlohmann-json3-dev libceres-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3 python3-numpy valgrind librsvg2-bin
  python3-dev pybind11-dev python3-pytest python3-pykdl python3-matplotlib
  librandom123-dev python3-distributed
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "isowrench: all ${#PACKAGES[@]} Debian packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "isowrench: need root to install: ${missing[*]}" >&2; exit 1
  fi
fi
echo "isowrench: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
