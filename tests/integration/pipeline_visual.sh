#!/usr/bin/env bash
# The visual SLAM system from pixels, live (docs/slam.md): a rendered 3-floor session (stereo,
# IMU, wheels, ground truth; an elevator ride, dark rooms, passers-by) is replayed at 1x by
# lcm-logplayer while evermap-deputy runs the five processes of config/pipeline-log.pmd in the
# LCM sandbox, and lcm-logger records what the mapper publishes; half-way, vo-proc is killed
# (SIGKILL) and the deputy respawns it. Checked: every other process ran start to end, vo-proc had its camera (STEREO_CALIB repeated in the log), the mapper refused
# no VO_DELTA for a missing calibration or an unknown reference, the final MAP_GRAPH against
# the log's ground truth (nodes, both floors, at least one loop closure, none false, node ATE),
# and the same log through evermap-slam-run (the same classes in one process) gives a map
# that agrees; then a short second session, the pipeline started afresh on the same stores, is
# relocalised live in the first one's map and maps on. Skips (77) without the vocabulary's
# training data, except under CI.
source "$(dirname "$0")/lib.sh" "$@"
need_data kitti07-mono-160 kitti-mono-snippet euroc-v101-micro vocab-orb-small
in_sandbox "$@"
# Seconds of the session: the elevator ride ends at 85 s, the first loop closures come
# after 200 s (slam-run: 0 closures at 200 s, 7 at 230 s).
duration="${EVERMAP_VISUAL_DURATION_S:-240}"
# Node ATE limit, metres: slam-run gives 0.17 m at 160 s, 0.19 m at 230 s and 0.20 m at 300 s
# of this session (live at 160 s: 0.14 m); 0.5 m is 2.5x that, a broken map (a floor at the
# wrong height, an aliased closure) is metres off.
max_ate="${EVERMAP_VISUAL_MAX_ATE:-0.5}"
# EVERMAP_KEEP_TMP=DIR: the stores, logs and recordings are kept there.
keep_tmp="${EVERMAP_KEEP_TMP:-}"
fail_logs=("$tmp/logs/*.log" "$tmp/logs1/*.log" "$tmp/logs*.err"); fail_tail=25

# 1. The vocabulary and the session.
"$bin/evermap-vocab-train" --out "$tmp/default.evoc" --default-data "$data" --image-step 2 > "$tmp/vocab.txt" \
  || fail "vocab-train"
"$bin/evermap-sim-render" --config "$src/config/sim-image-3floor.conf" --set render.max_duration_s="$duration" \
  --out "$tmp/s0.lcmlog" > "$tmp/render.txt" || fail "sim-render"
frames="$(awk '/^STEREO:/ { print $2 }' "$tmp/render.txt")"
echo "session: $duration s, $frames stereo pairs"

# The five processes under the deputy on LOG replayed at 1x, into the map and place stores of
# $tmp, their logs in LOG_DIR, the deputy's errors in LOG_DIR.err; lcm-logger records CHANNELS
# into RECORD. In the background: $dpid, $lpid.
start_pipeline() {  # LOG LOG_DIR RECORD CHANNELS
  lcm-logger -q -f -c "$4" "$3" &
  lpid=$!
  kill_at_exit "$lpid"
  (cd "$src" && EVERMAP_BIN="$bin" EVERMAP_LOG="$1" EVERMAP_MAP="$tmp/map.db" \
    EVERMAP_VOCAB="$tmp/default.evoc" EVERMAP_PLACES="$tmp/places.db" EVERMAP_SPEED=1 \
    exec "$bin/evermap-deputy" config/pipeline-log.pmd --log-dir "$2" --host sandbox --script go \
    --exit-after-script --quiet 2> "$2.err") &
  dpid=$!
  kill_at_exit "$dpid"
}
stop_logger() { sleep 0.5; kill -INT "$lpid"; wait "$lpid" || true; }

# 2. The five processes under the deputy, the log replayed at 1x.
start_pipeline "$tmp/s0.lcmlog" "$tmp/logs" "$tmp/mapper.lcmlog" 'MAP_GRAPH|MAPPER_STATS|POSE'
# vo-proc killed mid-run (SIGKILL: no goodbye), on the lower floor after the ride: the deputy
# respawns it, the mapper bridges the gap with wheel odometry and VO's new reference, and the
# map goes on growing.
kill_at="$(awk -v d="$duration" 'BEGIN { print int(d / 2) }')"
# Its own vo-proc only (the deputy's log names the pid), not every one on the machine.
(sleep "$kill_at"; pid="$(sed -nE 's/.* started pid ([0-9]+) .*/\1/p' "$tmp/logs/vo-proc.log" | head -n 1)"
  [ -n "$pid" ] && kill -KILL "$pid" || true) &
killer=$!
rc=0
wait "$dpid" || rc=$?
wait "$killer" || true
[ "$rc" -eq 0 ] || fail "deputy exited with $rc"
stop_logger

# 3. Every process ran once, start to end; the contracts held.
logs="$tmp/logs"
for p in imu-proc elevator-proc mapper-proc loopclose-proc; do
  [ "$(grep -c 'started pid' "$logs/$p.log")" -eq 1 ] || fail "$p was restarted"
  grep -q "ended: exit code 0 after" "$logs/$p.log" || fail "$p did not stop cleanly on SIGTERM"
done
[ "$(grep -c 'started pid' "$logs/vo-proc.log")" -eq 2 ] || fail "vo-proc was not killed once and respawned once"
grep -q "ended: exit code 0 after" "$logs/vo-proc.log" || fail "the respawned vo-proc did not stop cleanly on SIGTERM"
# The respawned vo-proc took the repeated calibration (the killed one printed nothing).
grep -q "calibrations 1 (refused 0)" "$logs/vo-proc.log" || fail "the respawned vo-proc did not take the calibration"
# The map grew after the kill: nodes in the mapper's progress lines (every 10 s of wall time)
# from 5 s after the kill to the end. (Whether the silence lasted the tracker's 0.5 s
# vo_timeout_s depends on how fast the respawned vo-proc answers; either way it is bridged.)
read -r nodes_after_kill nodes_at_end < <(awk -v t="$kill_at" '/^progress:/ {
  w = $3 + 0; n = $0; sub(/.*nodes /, "", n); n = n + 0
  if (w >= t + 5 && first == "") first = n
  last = n } END { print first + 0, last + 0 }' "$logs/mapper-proc.log")
echo "mapper: $nodes_after_kill nodes 5 s after vo-proc was killed, $nodes_at_end at the end; vo_timeouts $(value vo_timeouts "$logs/mapper-proc.log")"
[ "$nodes_at_end" -gt "$nodes_after_kill" ] || fail "the map did not grow after vo-proc was killed"
# A vo-proc waits for the next STEREO_CALIB (every second): the respawned one refuses at most
# a second of frames (20 at 20 Hz; 25 for the replay's jitter), the first one none.
uncalibrated="$(grep -c "no calibration received yet" "$logs/vo-proc.log" || true)"
[ "$uncalibrated" -le 25 ] || fail "vo-proc refused $uncalibrated frames for want of a calibration"
received="$(value received_VO_DELTA "$logs/mapper-proc.log")"
echo "mapper: VO_DELTA received ${received:-0} of $frames"
[ "$(value vo_before_calibration "$logs/mapper-proc.log")" = 0 ] || fail "the mapper refused VO_DELTA before STEREO_CALIB"
grep -q "unknown reference keyframe" "$logs/mapper-proc.log" && fail "the mapper refused VO_DELTA (unknown reference)"
grep -q '^undecodable 0$' "$logs/mapper-proc.log" || fail "undecodable messages reached the mapper"
sed -n 's/^\(steps\|nodes\|loop_closures\|registrations_ok\|rejected_map_gate\|gate_recoveries\|recoveries_too_far\|timeouts\|vo_timeouts\|dropped\) /mapper \1 /p' \
  "$logs/mapper-proc.log"
grep -h "loopclose-proc: keyframes" "$logs/loopclose-proc.log" | tail -1

# 4. The live map against the ground truth.
"$bin/evermap-pipeline-eval" --truth-log "$tmp/s0.lcmlog" --log "$tmp/mapper.lcmlog" --max-ate "$max_ate" \
  > "$tmp/eval.txt" || { cat "$tmp/eval.txt"; fail "evaluation (node ATE over $max_ate m?)"; }
sed 's/^/live: /' "$tmp/eval.txt"
nodes="$(value nodes "$tmp/eval.txt")"
[ "$nodes" -ge 25 ] || fail "only $nodes nodes"
grep -q '^floors 2 ' "$tmp/eval.txt" || fail "the map does not hold the 2 floors of the session"
[ "$(value nodes_on_consistent_floor "$tmp/eval.txt")" = "$nodes" ] || fail "nodes on the wrong floor"
loops="$(awk '$1 == "edges" { gsub(/\(/, "", $3); print $3 }' "$tmp/eval.txt")"
[ "${loops:-0}" -ge 1 ] || fail "no loop closure in the map"
[ "$(value loop_edges_false "$tmp/eval.txt")" = 0 ] || fail "a false loop closure in the map"

# 5. The same log offline: the same classes in one process.
"$bin/evermap-slam-run" --vocab "$tmp/default.evoc" --out "$tmp/offline" "$tmp/s0.lcmlog" > "$tmp/offline.txt" 2>&1 \
  || { tail "$tmp/offline.txt"; fail "slam-run"; }
off_nodes="$(value nodes "$tmp/offline/summary.txt")"
off_ate="$(value node_ate_rmse_m "$tmp/offline/summary.txt")"
live_ate="$(value node_ate_rmse_m "$tmp/eval.txt")"
echo "offline: nodes $off_nodes, node ATE rmse $off_ate m, $(value realtime_factor "$tmp/offline/summary.txt")x real time"
# They may differ: live, registrations are answered at most at 2 Hz and later than offline,
# where each is answered at once, so steps close differently and nodes land on other
# keyframes. The node counts agree within 30 %, and both maps are within the ATE limit.
awk -v a="$nodes" -v b="$off_nodes" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= 0.3 * b) }' \
  || fail "live $nodes nodes, offline $off_nodes: more than 30 % apart"
awk -v a="$off_ate" -v m="$max_ate" 'BEGIN { exit !(a <= m) }' || fail "offline node ATE $off_ate m over $max_ate m"
[ "$(value false_closures "$tmp/offline/summary.txt")" = 0 ] || fail "a false closure offline"
echo "session 0: the five processes mapped $duration s of rendered stereo live: $nodes nodes, 2 floors, $loops loop edges, node ATE $live_ate m (offline $off_ate m)"

# 6. A second session (other lighting) into the same map and place stores, the pipeline started
# afresh: it begins at session 0's first node and must be placed in session 0's map live (until
# loopclose-proc took its clock from VO_DELTA, its first answer came 3-4 s of data late and the
# live second session never relocalised, docs/slam.md).
duration1="${EVERMAP_VISUAL_SESSION1_S:-45}"
"$bin/evermap-sim-render" --config "$src/config/sim-image-3floor.conf" --set render.session=1 \
  --set render.max_duration_s="$duration1" --out "$tmp/s1.lcmlog" > "$tmp/render1.txt" || fail "sim-render session 1"
start_pipeline "$tmp/s1.lcmlog" "$tmp/logs1" "$tmp/mapper1.lcmlog" 'MAP_GRAPH|MAPPER_STATS|POSE|REGISTER_.*'
rc=0
wait "$dpid" || rc=$?
[ "$rc" -eq 0 ] || fail "deputy exited with $rc (session 1)"
stop_logger
relocalised="$(value relocalizations "$tmp/logs1/mapper-proc.log")"
[ "${relocalised:-0}" -ge 1 ] || { tail -30 "$tmp/logs1/mapper-proc.log"; fail "session 1 was not relocalised live in session 0's map"; }
"$bin/evermap-pipeline-eval" --truth-log "$tmp/s0.lcmlog" --truth-log "$tmp/s1.lcmlog" --log "$tmp/mapper1.lcmlog" \
  --max-ate "$max_ate" > "$tmp/eval1.txt" || { cat "$tmp/eval1.txt"; fail "evaluation after session 1 (node ATE over $max_ate m?)"; }
sed 's/^/live, after session 1: /' "$tmp/eval1.txt"
nodes1="$(value nodes "$tmp/eval1.txt")"
[ "$nodes1" -gt "$nodes" ] || fail "session 1 added no node ($nodes1 after, $nodes before)"
[ "$(value sessions "$tmp/eval1.txt")" = 2 ] || fail "the map does not hold 2 sessions"
[ "$(value nodes_on_consistent_floor "$tmp/eval1.txt")" = "$nodes1" ] || fail "nodes on the wrong floor after session 1"
[ "$(value loop_edges_false "$tmp/eval1.txt")" = 0 ] || fail "a false loop closure after session 1"
echo "OK: live, session 0 $nodes nodes (node ATE $live_ate m, offline $off_ate m); session 1 relocalised and mapped on: $nodes1 nodes, node ATE $(value node_ate_rmse_m "$tmp/eval1.txt") m"
