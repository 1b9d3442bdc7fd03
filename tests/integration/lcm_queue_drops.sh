#!/usr/bin/env bash
# LCM 1.3.1's own queue drops are counted (core/messages/lcm_receive_guard.h): the GoogleTest
# LcmQueueDrops.* over udpm:// inside the LCM sandbox (outside it the test skips itself).
set -euo pipefail
build="$1"; src="$2"
out="$("$src/scripts/lcm-sandbox" "$build/bin/messages_lcm_receive_guard_test" \
  --gtest_filter='LcmQueueDrops.*' 2>&1)" || { echo "$out"; exit 1; }
echo "$out" | tail -n 4
grep -q '^\[  PASSED  \] 1 test' <<< "$out" || { echo "FAIL: the test did not run (skipped?)"; exit 1; }
grep -q 'SKIPPED' <<< "$out" && { echo "FAIL: skipped inside the sandbox"; exit 1; }
echo "OK: LCM's queue drops counted over udpm"
