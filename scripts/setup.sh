#!/usr/bin/env bash
# Installs every Debian package evermap needs, then the viewer page's npm packages (pinned in
# viewer/web/package-lock.json). Idempotent: packages already present are left alone and
# nothing is downloaded when all are installed. Needs root (or sudo) for the Debian packages.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

packages=(
  build-essential cmake ninja-build ccache pkg-config git clang-format
  liblcm-dev liblcm-bin liblcm-java libjchart2d-java default-jdk-headless
  libeigen3-dev libopencv-dev libsuitesparse-dev libsqlite3-dev sqlite3 libzstd-dev libsodium-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  iproute2 util-linux procps python3
  libwebsockets-dev chromium nodejs
)
# npm: Debian's package, unless the installed nodejs brings its own (NodeSource's does).
command -v npm > /dev/null || packages+=(npm)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
else
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "setup: need root to install: ${missing[*]}" >&2; exit 1; }
    SUDO=sudo
  fi
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The viewer page's three.js, at the version package-lock.json pins (docs/viewer.md), into
# viewer/web/node_modules (not in git). `npm ci` installs exactly the lock file, checked
# against its integrity hashes; it runs only when the installed version differs.
web="$root/viewer/web"
want="$(node -p "require('$web/package-lock.json').packages['node_modules/three'].version")"
have="$(node -p "require('$web/node_modules/three/package.json').version" 2>/dev/null || true)"
if [ "$have" = "$want" ]; then
  echo "setup: three.js $have present"
else
  echo "setup: installing three.js $want (npm ci in viewer/web)"
  (cd "$web" && npm ci --no-audit --no-fund --loglevel=error)
fi
