#!/usr/bin/env bash
# The sanitizer run (issue 17): ASan + UBSan build in build-asan, then every unit test and
# every integration test under it. Long (a second full build and the suite at ASan speed):
# on demand, not in CI.
#   nice -n 15 scripts/sanitize.sh [ctest args...]     (BUILD_DIR=build-asan, JOBS=2)
# Result and what was found: docs/reliability.md, "The sanitizer run".
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build-asan}"
jobs="${JOBS:-2}"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DEVERMAP_SANITIZE=ON -DEVERMAP_BUILD_BENCH=OFF -DEVERMAP_BUILD_JAVA=ON
cmake --build "$build" -j"$jobs"
# Every finding fails its test: ASan aborts on the first error; UBSan is built with
# -fno-sanitize-recover. Leaks are reported at exit (LeakSanitizer, part of ASan) and fail
# the program; the suppressions name only uninstrumented third-party libraries.
supp="$root/scripts/sanitize-lsan.supp"
export ASAN_OPTIONS="abort_on_error=0:halt_on_error=1:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
export LSAN_OPTIONS="suppressions=$supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
ctest --test-dir "$build" --output-on-failure -j"$jobs" --timeout 3600 "$@"
