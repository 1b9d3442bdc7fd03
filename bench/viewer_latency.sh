#!/usr/bin/env bash
# evermap-viewer's figures (issue 21's closing note; docs/viewer.md, "Figures"), in the LCM
# sandbox with headless Chromium (software WebGL):
#   1. latency from MAP_GRAPH to pixels and the update rate the page achieves, for the
#      paper-scale reduced graph (~3,000 nodes: the map store of `evermap-mapper-run --config
#      config/sim-paper-scale.conf`) and a full graph (~56,000 nodes: a node per step pose of the
#      same run, tools/viewer-graph-pub), published by evermap-viewer-graph-pub at RATE Hz with
#      the publish time in `utime`; the page's timings (window.evermapStats) are read by
#      bench/viewer_latency.mjs; plus page load time (navigation to the first map drawn);
#   2. the viewer's CPU and peak RSS, one browser watching, while a session is replayed live
#      through the pipeline (as integration.viewer_browser: the 3-floor, 2-session simulated
#      run of 917 s, mapper-proc and the registration oracle under the deputy) at 1x (the first
#      REPLAY_S seconds) and 20x (the whole run), and while the viewer plays LOG itself (`--log`)
#      at 1x and 20x.
# Prints figures; asserts nothing about time.
#   bench/viewer_latency.sh [BUILD_DIR] [WORK_DIR] [LOG]
# WORK_DIR (default /tmp/evermap-viewer-bench) keeps the paper-scale run (made once, ~90 s), the
# simulated session and the screenshots. LOG: an lcm-logger record of MAP_GRAPH|MAPPER_STATS|POSE
# (e.g. scripts/demo.sh's out/mapper.lcmlog); without one that part is skipped.
# Settings: EVERMAP_VIEWER_BENCH_S (seconds per latency case, default 60), _CASES (default
# "reduced@1 full@1 reduced@10 full@3": graph@rate in Hz; 1 Hz is mapper-proc's
# --graph-period-s), _REPLAY_S (seconds of the 1x replay, default 120), _PARTS (default
# "latency live log").
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; work="${2:-/tmp/evermap-viewer-bench}"; log="${3:-}"
src="$(cd "$(dirname "$0")/.." && pwd)"
[ -z "$log" ] || log="$(cd "$(dirname "$log")" && pwd)/$(basename "$log")"
if [ "${EVERMAP_LCM_SANDBOX:-}" != "1" ]; then
  exec "$src/scripts/lcm-sandbox" bash "$0" "$build" "$work" "$log"
fi
bin="$build/bin"
seconds="${EVERMAP_VIEWER_BENCH_S:-60}"
replay_s="${EVERMAP_VIEWER_BENCH_REPLAY_S:-120}"
cases="${EVERMAP_VIEWER_BENCH_CASES:-reduced@1 full@1 reduced@10 full@3}"
parts="${EVERMAP_VIEWER_BENCH_PARTS:-latency live log}"
chromium="$(command -v chromium || command -v chromium-browser)"
port=8080  # the sandbox's own network
mkdir -p "$work"
vpid=""; ppid_=""; dpid=""
cleanup() { for p in "$dpid" "$vpid" "$ppid_"; do [ -n "$p" ] && kill -KILL "$p" 2>/dev/null || true; done; }
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
[[ " $parts " == *" latency "* ]] || cases=""
for graph_rate in $cases; do
  c="${graph_rate%@*}"; rate="${graph_rate#*@}"
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
    --duration-s "$seconds" --label "$c ${rate} Hz" --screenshot "$work/$c.png" --json "$work/$c-$rate.json" || true
  wait "$ppid_" || true; ppid_=""
  cpu1="$(viewer_cpu_s)"
  peak="$(viewer_peak_mb)"
  stop_viewer
  echo "viewer_latency $c ${rate} Hz: viewer CPU $(awk -v a="$cpu0" -v b="$cpu1" -v s="$seconds" 'BEGIN { printf "%.0f", 100 * (b - a) / s }') %" \
    "of a core over ${seconds} s, peak RSS $peak MB; $(head -1 "$work/pub-$c.log"), $(sed -n 's/^published \([0-9]*\).*/\1/p' "$work/pub-$c.log") published," \
    "$(grep -o 'MAP_GRAPH [0-9]* received' "$work/viewer.log") by the viewer, texts to the page: $(sed -n 's/^texts_sent //p' "$work/viewer.log")"
done

# 2. A session replayed live through the pipeline, one browser watching.
if [[ " $parts " == *" live "* ]]; then
  if [ ! -f "$work/run/run.sim.txt" ]; then
    "$bin/evermap-sim-measure" --config "$src/config/sim-small.conf" --set patrol.total_hours=0.06 \
      --out "$work/run" > "$work/sim.txt"
  fi
  for speed in 1 20; do
    rm -rf "$work/map.db"* "$work/logs"
    start_viewer
    (cd "$src" && EVERMAP_BIN="$bin" EVERMAP_RUN="$work/run" EVERMAP_MAP="$work/map.db" EVERMAP_SPEED="$speed" \
      exec "$bin/evermap-deputy" config/pipeline-oracle.pmd --log-dir "$work/logs" --host sandbox \
      --script replay --exit-after-script --quiet 2> "$work/deputy.err") &
    dpid=$!
    t0="$(date +%s.%N)"
    # The browser until the run ends (20x) or for REPLAY_S seconds (1x).
    window="$replay_s"; [ "$speed" = 1 ] || window=$((917 / speed + 10))
    node "$src/bench/viewer_latency.mjs" --chromium "$chromium" --url "http://127.0.0.1:$port/" \
      --duration-s "$window" --label "live ${speed}x" --screenshot "$work/live-${speed}x.png" > "$work/live.txt" || true
    cpu="$(viewer_cpu_s)"; peak="$(viewer_peak_mb)"
    wall="$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.0f", b - a }')"
    kill -TERM "$dpid" 2>/dev/null || true; wait "$dpid" 2>/dev/null || true; dpid=""
    stop_viewer
    echo "viewer_latency live ${speed}x: viewer CPU ${cpu} s over ${wall} s ($(awk -v c="$cpu" -v w="$wall" 'BEGIN { printf "%.0f", 100 * c / w }') % of a core)," \
      "peak RSS $peak MB; $(grep -o 'MAP_GRAPH [0-9]* received' "$work/viewer.log"), $(grep -o 'POSE [0-9]* received' "$work/viewer.log");" \
      "page: $(grep -o 'load (first map drawn) [0-9-]* ms' "$work/live.txt"), $(grep -o 'maps received [0-9]*, drawn [0-9]*' "$work/live.txt")"
  done
fi

# 3. A log played by the viewer itself (--log) at 1x and 20x, one browser watching.
if [[ " $parts " == *" log "* ]] && [ -n "$log" ]; then
  for speed in 1 20; do
    start_viewer --log "$log" --speed "$speed"
    for _ in $(seq 300); do grep -q ' events over ' "$work/viewer.log" && break; sleep 0.1; done
    span="$(sed -n 's/^evermap-viewer: .* events over \([0-9]*\)[0-9.]* s .*/\1/p' "$work/viewer.log")"
    window=$(( ${span:-60} / speed + 5 )); [ "$window" -ge 30 ] || window=30  # the page loads first
    node "$src/bench/viewer_latency.mjs" --chromium "$chromium" --url "http://127.0.0.1:$port/" \
      --duration-s "$window" --label "log ${speed}x" --screenshot "$work/log-${speed}x.png" > "$work/replay.txt" || true
    echo "viewer_latency --log ${speed}x: $(sed -n 's/^evermap-viewer: .*: \([0-9]* events over [0-9.]* s\) .*/\1/p' "$work/viewer.log");" \
      "viewer CPU $(viewer_cpu_s) s over ${window} s, peak RSS $(viewer_peak_mb) MB;" \
      "page $(grep -o 'load (first map drawn) [0-9-]* ms' "$work/replay.txt" || echo 'load -')"
    stop_viewer
  done
fi
