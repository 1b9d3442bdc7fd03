#!/usr/bin/env bash
# Converts the real EuRoC excerpt to an LCM log, replays it with lcm-logplayer inside the LCM
# sandbox (private network namespace) and checks that a subscriber receives every message
# intact. Skips (77) without the data, except under CI.
set -euo pipefail
build="$1"; src="$2"
data="${EVERMAP_DATA:-${EVERMAP_DATA_DEFAULT:-$src/../shared/data}}"
euroc="$data/euroc-v101-micro"
if [ ! -d "$euroc" ]; then
  echo "data set euroc-v101-micro not found under $data (set EVERMAP_DATA)"
  [ "${CI:-}" = "true" ] && exit 1
  exit 77
fi
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
"$build/bin/evermap-euroc2lcm" "$euroc" "$tmp/euroc.lcmlog" \
  --gt "$euroc/groundtruth_openvins/V1_01_easy.csv"
# 145 s of IMU; replayed at 4x speed.
BUILD_DIR="$build" "$src/scripts/replay-check.sh" "$tmp/euroc.lcmlog" 4
