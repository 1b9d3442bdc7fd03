#!/usr/bin/env bash
# evermap-viewer in a real browser (issue 21), in the LCM sandbox: a short simulated run
# (3 floors, 2 sessions) is replayed at 20x through mapper-proc and the registration oracle
# under the deputy (config/pipeline-oracle.pmd) while evermap-viewer listens. Headless
# Chromium (Debian's package) loads the page during the replay (viewer_browser.mjs drives it
# over the DevTools protocol); once the run is over, the page must show the node count of the
# mapper's last MAP_GRAPH, have drawn that map in 3-D, and have had no script error. The
# screenshot is kept (EVERMAP_VIEWER_SCREENSHOT, default BUILD/viewer-browser.png). Then
# hostile messages on every channel the viewer reads (evermap-lcm-fuzz): it must stay up,
# count them, and stop cleanly on SIGTERM. Last, what the mapper published (recorded by
# lcm-logger) is played by `evermap-viewer --log` at 10x: the page must reach the same count,
# and after its time slider is moved to 30 % show fewer nodes (a seek back).
# Without chromium, node or three.js (scripts/setup.sh installs them) the test is skipped
# (exit 77), and fails when CI=true.
set -euo pipefail
build="$1"; src="$2"
if [ "${EVERMAP_LCM_SANDBOX:-}" != "1" ]; then
  exec "$src/scripts/lcm-sandbox" bash "$0" "$@"
fi
bin="$build/bin"
skip() {
  if [ "${CI:-}" = true ]; then echo "viewer_browser: FAIL (CI=true): $*"; exit 1; fi
  echo "viewer_browser: SKIP: $*"
  exit 77
}
[ -x "$bin/evermap-viewer" ] || skip "evermap-viewer is not built (libwebsockets-dev missing: run scripts/setup.sh)"
chromium="$(command -v chromium || command -v chromium-browser || true)"
[ -n "$chromium" ] || skip "chromium is not installed (run scripts/setup.sh)"
command -v node > /dev/null || skip "node is not installed (run scripts/setup.sh)"
[ -f "$src/viewer/web/node_modules/three/build/three.module.js" ] || skip "three.js is not installed (run scripts/setup.sh)"
screenshot="${EVERMAP_VIEWER_SCREENSHOT:-$build/viewer-browser.png}"
speed="${EVERMAP_VIEWER_SPEED:-20}"
port=8080  # the sandbox's own network: nothing else listens here
tmp="$(mktemp -d)"
vpid=""; dpid=""; bpid=""; lpid=""
cleanup() {
  for p in "$bpid" "$dpid" "$vpid" "$lpid"; do [ -n "$p" ] && kill -KILL "$p" 2>/dev/null || true; done
  rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
  echo "viewer_browser: FAIL: $*"
  for f in "$tmp/viewer.log" "$tmp/browser.log" "$tmp/logs/mapper-proc.log" "$tmp/deputy.err"; do
    [ -f "$f" ] && { echo "--- $f"; tail -20 "$f"; }
  done
  exit 1
}

# 1. A short run: about 15 simulated minutes, 45 s at 20x.
"$bin/evermap-sim-measure" --config "$src/config/sim-small.conf" --set patrol.total_hours=0.06 \
  --out "$tmp/run" > "$tmp/sim.txt" || fail "simulator"

# 2. The viewer, then the pipeline under the deputy.
"$bin/evermap-viewer" --port "$port" > "$tmp/viewer.log" 2>&1 &
vpid=$!
for _ in $(seq 100); do grep -q '^evermap-viewer: serving' "$tmp/viewer.log" && break; sleep 0.1; done
grep -q '^evermap-viewer: serving' "$tmp/viewer.log" || fail "the viewer did not start"
lcm-logger -q -f -c 'MAP_GRAPH|MAPPER_STATS|POSE|FLOOR|REGISTER_RESULT|DEPUTY_STATUS' "$tmp/mapper.lcmlog" > /dev/null 2>&1 &
lpid=$!
(cd "$src" && EVERMAP_BIN="$bin" EVERMAP_RUN="$tmp/run" EVERMAP_MAP="$tmp/map.db" EVERMAP_SPEED="$speed" \
  exec "$bin/evermap-deputy" config/pipeline-oracle.pmd --log-dir "$tmp/logs" --host sandbox \
  --script replay --exit-after-script --quiet 2> "$tmp/deputy.err") &
dpid=$!

# 3. The browser, during the replay.
sleep 3
kill -0 "$dpid" 2>/dev/null || fail "the pipeline ended before the browser started"
node "$src/tests/integration/viewer_browser.mjs" --chromium "$chromium" --url "http://127.0.0.1:$port/" \
  --expect-file "$tmp/expected" --screenshot "$screenshot" --timeout-s 240 > "$tmp/browser.log" 2>&1 &
bpid=$!

# 4. The end of the run: the mapper's last MAP_GRAPH holds as many nodes as it reports.
rc=0; wait "$dpid" || rc=$?; dpid=""
[ "$rc" -eq 0 ] || fail "deputy exited with $rc"
nodes="$(awk '$1 == "nodes" { n = $2 } END { print n }' "$tmp/logs/mapper-proc.log")"
[ -n "$nodes" ] && [ "$nodes" -gt 0 ] || fail "the mapper reported no nodes"
echo "$nodes" > "$tmp/expected"
rc=0; wait "$bpid" || rc=$?; bpid=""
sleep 0.5
kill -INT "$lpid"; wait "$lpid" || true; lpid=""
cat "$tmp/browser.log"
[ "$rc" -eq 0 ] || fail "the browser check failed"
kill -0 "$vpid" 2>/dev/null || fail "the viewer died during the replay"

# The viewer's cost over the replay (measured, not asserted): CPU seconds and peak RSS.
read -r vut vst < <(awk '{ print $14, $15 }' "/proc/$vpid/stat")
viewer_cost="CPU $(awk -v u="$vut" -v s="$vst" -v hz="$(getconf CLK_TCK)" 'BEGIN { printf "%.1f", (u + s) / hz }') s, peak RSS $(awk '/^VmHWM/ { printf "%.0f", $2 / 1024 }' "/proc/$vpid/status") MB over the ${speed}x replay"

# 5. Hostile input on every channel the viewer reads.
channels="MAP_GRAPH,POSE,FLOOR,MAPPER_STATS,REGISTER_RESULT,DEPUTY_STATUS,VO_DELTA,KEYFRAME,STEREO"
"$bin/evermap-lcm-fuzz" --channels "$channels" --fragment-attack > /dev/null || fail "fragment attack"
"$bin/evermap-lcm-fuzz" --channels "$channels" --count "${EVERMAP_FUZZ_COUNT:-200}" --seed 21 > "$tmp/fuzz.txt" \
  || fail "fuzz sender"
sleep 2
kill -0 "$vpid" 2>/dev/null || fail "the viewer died of hostile messages"
kill -TERM "$vpid"
rc=0; wait "$vpid" || rc=$?; vpid=""
[ "$rc" -eq 0 ] || fail "the viewer exited with $rc after SIGTERM"
malformed="$(grep -o '[0-9]* malformed' "$tmp/viewer.log" | awk '{ s += $1 } END { print s + 0 }')"
[ "$malformed" -gt 0 ] || fail "the viewer counted no malformed message"
echo "viewer: $viewer_cost"
echo "viewer: mapper nodes $nodes shown; fuzz: $(cat "$tmp/fuzz.txt"); $malformed malformed messages counted, viewer alive"
grep -E '^(graphs|last_graph_nodes|images_sent|connections|texts_sent|versions_skipped) ' "$tmp/viewer.log" | tr '\n' ' '
echo

# 6. The recorded log with the time slider.
"$bin/evermap-viewer" --log "$tmp/mapper.lcmlog" --speed 10 --port "$port" > "$tmp/viewer-log.log" 2>&1 &
vpid=$!
for _ in $(seq 100); do grep -q '^evermap-viewer: serving' "$tmp/viewer-log.log" && break; sleep 0.1; done
grep -q '^evermap-viewer: serving' "$tmp/viewer-log.log" || fail "the viewer did not start on the log"
node "$src/tests/integration/viewer_browser.mjs" --chromium "$chromium" --url "http://127.0.0.1:$port/" \
  --expect-file "$tmp/expected" --screenshot "$tmp/log.png" --timeout-s 240 --seek 0.3 > "$tmp/browser.log" 2>&1 \
  || { cat "$tmp/browser.log"; fail "the browser check of --log failed"; }
sed 's/^viewer_browser: /viewer_browser --log: /' "$tmp/browser.log"
kill -TERM "$vpid"
rc=0; wait "$vpid" || rc=$?; vpid=""
[ "$rc" -eq 0 ] || fail "the viewer (--log) exited with $rc after SIGTERM"
