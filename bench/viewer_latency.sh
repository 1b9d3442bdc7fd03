#!/usr/bin/env bash
# evermap-viewer's figures (issue 21's closing note; docs/viewer.md, "Figures"), in the LCM
# sandbox with headless Chromium (software WebGL):
#   1. latency from MAP_GRAPH to pixels and the update rate the page achieves, for the
#      paper-scale reduced graph (~3,000 nodes: the map store of `evermap-mapper-run --config
#      config/sim-paper-scale.conf`) and a full graph (~56,000 nodes: a node per step pose of the
#      same run, tools/viewer-graph-pub), published by evermap-viewer-graph-pub at RATE Hz with
#      the publish time in `utime`; the page's timings (window.evermapStats) are read by
#      bench/viewer_latency.mjs; plus page load time (navigation to the first map drawn);
#   2. the viewer's CPU and peak RSS while it plays a log (`--log`) at 1x and 20x to one browser.
# Prints figures; asserts nothing about time.
#   bench/viewer_latency.sh [BUILD_DIR] [WORK_DIR] [LOG]
# WORK_DIR (default /tmp/evermap-viewer-bench) keeps the paper-scale run (made once, ~90 s) and
# the screenshots. LOG: an lcm-logger record of MAP_GRAPH|MAPPER_STATS|POSE (e.g. scripts/demo.sh's
# out/mapper.lcmlog); without one the replay part is skipped.
# Settings: EVERMAP_VIEWER_BENCH_S (seconds per latency case, default 60), _RATE (Hz, default 1:
# mapper-proc's --graph-period-s), _REPLAY_S (seconds per replay, default 60), _CASES (default
# "reduced full").
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; work="${2:-/tmp/evermap-viewer-bench}"; log="${3:-}"
src="$(cd "$(dirname "$0")/.." && pwd)"
[ -z "$log" ] || log="$(cd "$(dirname "$log")" && pwd)/$(basename "$log")"
if [ "${EVERMAP_LCM_SANDBOX:-}" != "1" ]; then
  exec "$src/scripts/lcm-sandbox" bash "$0" "$build" "$work" "$log"
fi
bin="$build/bin"
seconds="${EVERMAP_VIEWER_BENCH_S:-60}"
rate="${EVERMAP_VIEWER_BENCH_RATE:-1}"
replay_s="${EVERMAP_VIEWER_BENCH_REPLAY_S:-60}"
cases="${EVERMAP_VIEWER_BENCH_CASES:-reduced full}"
chromium="$(command -v chromium || command -v chromium-browser)"
port=8080  # the sandbox's own network
mkdir -p "$work"
vpid=""; ppid_=""
cleanup() { for p in "$vpid" "$ppid_"; do [ -n "$p" ] && kill -KILL "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

# The paper-scale run: its map store (reduced graph) and step poses (the full graph's nodes).
if [ ! -f "$work/paper.db" ] || [ ! -f "$work/paper/steps-reduced.csv" ]; then
  echo "viewer_latency: the paper-scale run (reduced graph, ~90 s) into $work"
  rm -f "$work"/paper.db*
  "$bin/evermap-mapper-run" --config "$src/config/sim-paper-scale.conf" --store "$work/paper.db" \
    --out "$work/paper" > "$work/paper-run.log"
fi

start_viewer() {  # ARGS...: starts evermap-viewer, waits until it serves
  "$bin/evermap-viewer" --port "$port" "$@" > "$work/viewer.log" 2>&1 &
  vpid=$!
  for _ in $(seq 200); do grep -q '^evermap-viewer: serving' "$work/viewer.log" && return; sleep 0.1; done
  echo "viewer_latency: FAIL: the viewer did not start"; cat "$work/viewer.log"; exit 1
}
# The viewer's CPU seconds (user + system) and peak RSS, MB, so far.
viewer_cpu_s() { awk -v hz="$(getconf CLK_TCK)" '{ printf "%.2f", ($14 + $15) / hz }' "/proc/$vpid/stat"; }
viewer_peak_mb() { awk '/^VmHWM/ { printf "%.0f", $2 / 1024 }' "/proc/$vpid/status"; }
stop_viewer() { kill -TERM "$vpid"; wait "$vpid" || true; vpid=""; }

# 1. Latency and update rate.
for c in $cases; do
  case "$c" in
    reduced) source_args=(--store "$work/paper.db") ;;
    full) source_args=(--steps "$work/paper/steps-reduced.csv") ;;
    *) echo "viewer_latency: unknown case $c"; exit 2 ;;
  esac
  start_viewer
  cpu0="$(viewer_cpu_s)"
  "$bin/evermap-viewer-graph-pub" "${source_args[@]}" --rate-hz "$rate" --duration-s "$seconds" \
    > "$work/pub-$c.log" 2>&1 &
  ppid_=$!
  node "$src/bench/viewer_latency.mjs" --chromium "$chromium" --url "http://127.0.0.1:$port/" \
    --duration-s "$seconds" --label "$c ${rate} Hz" --screenshot "$work/$c.png" --json "$work/$c.json" || true
  wait "$ppid_" || true; ppid_=""
  cpu1="$(viewer_cpu_s)"
  peak="$(viewer_peak_mb)"
  stop_viewer
  echo "viewer_latency $c: viewer CPU $(awk -v a="$cpu0" -v b="$cpu1" -v s="$seconds" 'BEGIN { printf "%.0f", 100 * (b - a) / s }') %" \
    "of a core over ${seconds} s, peak RSS $peak MB; $(head -1 "$work/pub-$c.log"), $(sed -n 's/^published \([0-9]*\).*/\1/p' "$work/pub-$c.log") published," \
    "$(grep -o 'MAP_GRAPH [0-9]* received' "$work/viewer.log") by the viewer, texts to the page: $(sed -n 's/^texts_sent //p' "$work/viewer.log")"
done

# 2. A log at 1x and 20x, one browser watching.
if [ -n "$log" ]; then
  for speed in 1 20; do
    start_viewer --log "$log" --speed "$speed"
    node "$src/bench/viewer_latency.mjs" --chromium "$chromium" --url "http://127.0.0.1:$port/" \
      --duration-s "$replay_s" --label "log ${speed}x" --screenshot "$work/log-${speed}x.png" > "$work/replay.txt" || true
    load="$(grep -o 'load (first map drawn) [0-9-]* ms' "$work/replay.txt" || echo 'load -')"
    echo "viewer_latency log ${speed}x: $(sed -n 's/^evermap-viewer: .*: \([0-9]* events over [0-9.]* s\) .*/\1/p' "$work/viewer.log"); " \
      "viewer CPU $(awk -v b="$(viewer_cpu_s)" -v s="$replay_s" 'BEGIN { printf "%.0f", 100 * b / s }') % of a core" \
      "over ${replay_s} s, peak RSS $(viewer_peak_mb) MB; page $load"
    stop_viewer
  done
fi
