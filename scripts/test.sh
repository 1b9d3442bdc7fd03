#!/usr/bin/env bash
# The test command: set-up, configure, build and run every test, from a fresh machine.
#   scripts/test.sh            (BUILD_DIR=build by default)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
bash "$root/scripts/setup.sh"
bash "$root/scripts/format.sh" --check
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j2
ctest --test-dir "$build" --output-on-failure -j2 "$@"
