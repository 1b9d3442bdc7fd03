#!/usr/bin/env bash
# Localization against a stored map with nothing outside the repository (as
# map_export_rendered.sh), offline and live: the first 60 s of sessions 0 and 1 of the rendered
# 3-floor building are rendered as logs; evermap-slam-run maps session 0 with --places; then
# session 1 (other lighting) is localized against that map twice: offline by evermap-slam-run
# --localize, and live by the processes of config/pipeline-localize.pmd under evermap-deputy in
# the LCM sandbox, lcm-logplayer replaying it at 1x and lcm-logger recording LOCALIZATION with
# the replayed GROUND_TRUTH for evermap-pipeline-eval --localization-log. Checked each time:
# both stores byte-identical after the run (sha256), the session localized, its pose error
# while localized under a bound, no false localization. About two minutes.
source "$(dirname "$0")/lib.sh" "$@"
in_sandbox "$@"
duration="${EVERMAP_LOCALIZE_DURATION_S:-60}"
conf="$src/config/sim-image-3floor.conf"
fail_logs=("$tmp/logs/*.log" "$tmp/logs.err"); fail_tail=20
keep_tmp="${EVERMAP_KEEP_TMP:-}"  # a folder the stores, logs and recordings are copied to

without_data_folder
for s in 0 1; do
  "$bin/evermap-sim-render" --config "$conf" --set "render.session=$s" \
    --set "render.max_duration_s=$duration" --out "$tmp/s$s.lcmlog" > "$tmp/render$s.txt" \
    || fail "sim-render session $s"
done
"$bin/evermap-slam-run" --vocab "$tmp/sim.evoc" --out "$tmp/map" --places "$tmp/s0.lcmlog" \
  > "$tmp/slam.txt" 2>&1 || { tail -20 "$tmp/slam.txt"; fail "evermap-slam-run (mapping)"; }
before="$(sha256sum "$tmp/map/map.db" "$tmp/map/places.db")"

# check WHAT SUMMARY: the localization figures of SUMMARY (localize-summary.txt's lines, or
# evermap-pipeline-eval's) within their bounds, and the stores unchanged.
check() {
  local what="$1" summary="$2" localized frames rmse false_frames node_false
  sha256sum "$tmp/map/map.db" "$tmp/map/places.db" > "$tmp/after.sha"
  [ "$(cat "$tmp/after.sha")" = "$before" ] \
    || fail "$what: localization changed a store: $(diff <(echo "$before") "$tmp/after.sha" | tr "\n" " ")"
  word() { awk -v k="$1" '{ for (i = 1; i < NF; ++i) if ($i == k) { print $(i + 1); exit } }' "$summary"; }
  localized="$(word localized_frames)"
  frames="$(word frames)"
  rmse="$(word ate_rmse_m)"
  false_frames="$(word false_frames)"
  awk -v l="$localized" -v n="$frames" 'BEGIN { exit !(n > 0 && l >= 0.3 * n) }' \
    || fail "$what: localized in $localized of $frames frames (under 30 %)"
  awk -v r="$rmse" 'BEGIN { exit !(r != "" && r >= 0 && r < 0.3) }' \
    || fail "$what: pose error while localized: rmse $rmse m (bound 0.3 m)"
  [ "$false_frames" = "0" ] || fail "$what: $false_frames frames localized more than 0.5 m or 5 deg off"
  # The same against the node tracked (the map's own error left out), over the same frames:
  # every node of the rendered map has truth.
  node_word() { awk -v k="$1" '$1 == "truth_against_node" { for (i = 2; i < NF; ++i) if ($i == k) print $(i + 1) }' "$summary"; }
  node_false="$(node_word false_frames)"
  [ "$node_false" = "0" ] \
    || fail "$what: against the node tracked, false frames: ${node_false:-no truth_against_node line}"
  [ "$(node_word frames)" = "$(word frames_localized)" ] \
    || fail "$what: against the node tracked, $(node_word frames) frames of $(word frames_localized) localized with truth"
  echo "OK $what: localized $localized of $frames frames, rmse $rmse m, stores unchanged"
}

# Offline, in one process.
"$bin/evermap-slam-run" --vocab "$tmp/sim.evoc" --localize "$tmp/map" --out "$tmp/loc" \
  "$tmp/s1.lcmlog" > "$tmp/loc.txt" 2>&1 || { tail -20 "$tmp/loc.txt"; fail "evermap-slam-run --localize"; }
cat "$tmp/loc.txt"
[ -s "$tmp/loc/localization.csv" ] || fail "no localization.csv"
check offline "$tmp/loc/localize-summary.txt"

# Live: the five processes under the deputy, the log replayed at 1x.
lcm-logger -q -f -c "LOCALIZATION|GROUND_TRUTH" "$tmp/live.lcmlog" &
logger=$!
kill_at_exit "$logger"
(cd "$src" && EVERMAP_BIN="$bin" EVERMAP_LOG="$tmp/s1.lcmlog" EVERMAP_MAP="$tmp/map/map.db" \
  EVERMAP_PLACES="$tmp/map/places.db" EVERMAP_VOCAB="$tmp/sim.evoc" EVERMAP_SPEED=1 \
  exec "$bin/evermap-deputy" config/pipeline-localize.pmd --log-dir "$tmp/logs" --host sandbox \
  --script go --exit-after-script --quiet 2> "$tmp/logs.err") || fail "the deputy failed"
sleep 0.5
kill -INT "$logger"
wait "$logger" || true
for p in vo-proc imu-proc elevator-proc mapper-proc loopclose-proc; do
  [ "$(grep -c 'started pid' "$tmp/logs/$p.log")" -eq 1 ] || fail "$p was restarted"
done
"$bin/evermap-pipeline-eval" --store "$tmp/map/map.db" --truth-log "$tmp/s0.lcmlog" \
  --localization-log "$tmp/live.lcmlog" > "$tmp/live.txt" 2>&1 \
  || { cat "$tmp/live.txt"; fail "evermap-pipeline-eval --localization-log"; }
grep -E "^(localization|truth|truth_against_node) " "$tmp/live.txt"
check live "$tmp/live.txt"
