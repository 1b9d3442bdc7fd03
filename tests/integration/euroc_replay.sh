#!/usr/bin/env bash
# Converts the real EuRoC excerpt to an LCM log, replays it with lcm-logplayer inside the LCM
# sandbox (private network namespace) and checks that a subscriber receives every message
# intact. Skips (77) without the data, except under CI.
source "$(dirname "$0")/lib.sh" "$@"
need_data euroc-v101-micro
euroc="$data/euroc-v101-micro"
"$build/bin/evermap-euroc2lcm" "$euroc" "$tmp/euroc.lcmlog" \
  --gt "$euroc/groundtruth_openvins/V1_01_easy.csv"
# 145 s of IMU; replayed at 4x speed.
BUILD_DIR="$build" "$src/scripts/replay-check.sh" "$tmp/euroc.lcmlog" 4
