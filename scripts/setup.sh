#!/usr/bin/env bash
# Installs planecell's Debian 12 build and runtime dependencies when any is missing.
# Idempotent and non-interactive: does nothing (and needs no network) when all are present.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev libopencv-dev libopencv-contrib-dev liboctomap-dev libceres-dev
  libspdlog-dev libcli11-dev liblcm-dev liblcm-bin libreaderwriterqueue-dev
  libgtest-dev libgmock-dev libbenchmark-dev libyaml-cpp-dev libsqlite3-dev sqlite3 libboost-dev
  nlohmann-json3-dev zlib1g-dev iproute2
  clang-14 libclang-rt-14-dev   # libFuzzer + sanitizer runtimes for scripts/fuzz.sh
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "[setup] all ${#PACKAGES[@]} Debian packages present"
  exit 0
fi

echo "[setup] installing ${#missing[@]} missing Debian packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "[setup] error: not root and no sudo; install as root: apt-get install ${missing[*]}" >&2
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "[setup] done"
