#!/usr/bin/env bash
# Installs every Debian package evermap needs. Idempotent: packages already present are
# left alone and nothing is downloaded when all are installed. Needs root (or sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config git
  liblcm-dev liblcm-bin liblcm-java libjchart2d-java default-jdk-headless
  libeigen3-dev libopencv-dev libsuitesparse-dev libsqlite3-dev sqlite3
  libgtest-dev libgmock-dev libbenchmark-dev
  iproute2 util-linux procps python3
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root to install: ${missing[*]}" >&2; exit 1; }
  SUDO=sudo
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
