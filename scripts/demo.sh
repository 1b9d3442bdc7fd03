#!/usr/bin/env bash
# The main job, from a fresh machine: set up and build, then
#  0. the visual SLAM system from pixels: two sessions of a 3-floor building rendered as
#     stereo + IMU + wheels (evermap-sim-render; the lighting changes between them), each
#     replayed by lcm-logplayer while the deputy runs the five processes of
#     config/pipeline-log.pmd in the LCM sandbox (the second session continues the map store of
#     the first); the map against the ground truth, the same logs through evermap-slam-run,
#     and the map drawn with its floors stacked;
#  1. the multi-process pipeline on a simulated 3-floor, multi-session run: evermap-sim-measure
#     writes the session logs; inside the LCM sandbox the deputy starts mapper-proc and the
#     registration oracle, lcm-logplayer replays the sessions and lcm-logger records what the
#     mapper publishes; then the map is evaluated against the ground truth and drawn:
#     floors stacked (Fig. 1), trajectory against ground truth (Fig. 4), nodes and update time
#     against time for the reduced and the full pose graph (Fig. 7); a summary is printed;
#     then 40 s of the image-level simulator's rendered stereo through visual odometry;
#  2. the real EuRoC excerpt: converted to an LCM log, replayed and checked, stereo VO over it
#     evaluated against the ground truth, and loop detection on the RTAB-Map samples.
#
#   scripts/demo.sh [RUN_DIR]   RUN_DIR: a run written by `evermap-sim-measure --out`
#                               (default: one made from config/sim-small.conf)
# Environment: BUILD_DIR (build), OUT_DIR (out), EVERMAP_DATA (../shared/data),
#   EVERMAP_SIM_CONFIG (config/sim-small.conf), EVERMAP_SPEED (replay speed, 20),
#   EVERMAP_VISUAL_S (seconds of each rendered session, 240),
#   EVERMAP_VISUAL_SPEED (their replay speed, 2).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
out="${OUT_DIR:-$root/out}"
data="${EVERMAP_DATA:-$root/../shared/data}"
sim_config="${EVERMAP_SIM_CONFIG:-$root/config/sim-small.conf}"
speed="${EVERMAP_SPEED:-20}"
run="${1:-}"

bash "$root/scripts/setup.sh"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2
mkdir -p "$out"
bin="$build/bin"

# ---------------------------------------------------------------------------------------------
visual_s="${EVERMAP_VISUAL_S:-240}"
visual_speed="${EVERMAP_VISUAL_SPEED:-2}"
vis="$out/visual"
if [ -d "$data/kitti07-mono-160" ]; then
  echo "== 0. the visual SLAM system from pixels: 2 rendered sessions of ${visual_s} s, five processes live"
  rm -rf "$vis"; mkdir -p "$vis"
  "$bin/evermap-vocab-train" --out "$vis/default.evoc" --default-data "$data" | tail -n 1
  for s in 0 1; do
    "$bin/evermap-sim-render" --config "$root/config/sim-image-3floor.conf" --set render.session=$s \
      --set render.max_duration_s="$visual_s" --out "$vis/s$s.lcmlog" | sed -n 's/^session/   session/p'
  done
  for s in 0 1; do
    echo "   session $s: replayed at ${visual_speed}x; vo-proc, imu-proc, elevator-proc, loopclose-proc, mapper-proc under evermap-deputy"
    EVERMAP_BIN="$bin" EVERMAP_LOG="$vis/s$s.lcmlog" EVERMAP_MAP="$vis/map.db" EVERMAP_VOCAB="$vis/default.evoc" \
    EVERMAP_PLACES="$vis/places.db" EVERMAP_SPEED="$visual_speed" OUT="$vis" S="$s" \
      "$root/scripts/lcm-sandbox" bash -c '
        set -e
        lcm-logger -q -f -c "MAP_GRAPH|MAPPER_STATS|POSE" "$OUT/mapper-s$S.lcmlog" & logger=$!
        "$EVERMAP_BIN/evermap-deputy" "'"$root"'/config/pipeline-log.pmd" --log-dir "$OUT/deputy-logs-s$S" \
            --script go --exit-after-script --quiet
        kill -INT $logger; wait $logger || true'
    { grep -hE "^(nodes|loop_closures|relocalizations|vo_before_calibration) " "$vis/deputy-logs-s$s/mapper-proc.log" || true; } |
      tr '\n' ' ' | sed 's/^/   mapper: /'; echo
  done
  echo "== the live map (last MAP_GRAPH) against the ground truth of the logs"
  "$bin/evermap-pipeline-eval" --truth-log "$vis/s0.lcmlog" --truth-log "$vis/s1.lcmlog" --log "$vis/mapper-s1.lcmlog" \
    | tee "$vis/map_eval.txt" | grep -E "^(nodes|edges|floors|nodes_on_consistent_floor|loop_edges_false|sessions|node_ate)" | sed 's/^/   /'
  echo "== the same two logs offline through evermap-slam-run (the five processes' classes in one process)"
  "$bin/evermap-slam-run" --vocab "$vis/default.evoc" --out "$vis/offline" "$vis/s0.lcmlog" "$vis/s1.lcmlog" 2>/dev/null |
    grep -E "^(session\.|nodes |accepted_closures|false_closures|relocalizations|node_ate_rmse|realtime|ms_per_frame|peak)" | sed 's/^/   /'
  cat "$vis"/s0.gt.tum "$vis"/s1.gt.tum | grep -v '^#' > "$vis/ground_truth.tum"
  "$bin/evermap-map-render" --store "$vis/map.db" --gt "$vis/ground_truth.tum" \
    --title "visual SLAM from pixels, live: 2 sessions, floors stacked (cf. paper Fig. 1)" --out "$vis/fig1_visual_map.png"
  rm -f "$vis"/s0.lcmlog "$vis"/s1.lcmlog  # 2-3 GB of PNG frames; made again in 2 minutes
else
  echo "== 0. skipped: no vocabulary training data at $data (set EVERMAP_DATA)"
fi

# ---------------------------------------------------------------------------------------------
echo "== 1. the pipeline on a simulated multi-floor, multi-session run"
if [ -z "$run" ]; then
  run="$out/sim-run"
  rm -rf "$run"
  "$bin/evermap-sim-measure" --config "$sim_config" --out "$run" | tail -n 3
fi
[ -f "$run/run.sim.txt" ] || { echo "demo: $run/run.sim.txt not found (a run of evermap-sim-measure --out)" >&2; exit 2; }

rm -f "$out/map.db" "$out/map.db-wal" "$out/map.db-shm" "$out/mapper.lcmlog"
rm -rf "$out/deputy-logs"
echo "   replaying $(ls "$run"/session-*.lcmlog | wc -l) session log(s) at ${speed}x; mapper-proc and the oracle under evermap-deputy"
start_s=$(date +%s.%N)
EVERMAP_BIN="$bin" EVERMAP_RUN="$run" EVERMAP_MAP="$out/map.db" EVERMAP_SPEED="$speed" \
EVERMAP_MAPPER_FLAGS="--progress-s 5" OUT="$out" \
  "$root/scripts/lcm-sandbox" bash -c '
    set -e
    lcm-logger -q -f -c "MAP_GRAPH|MAPPER_STATS|POSE" "$OUT/mapper.lcmlog" & logger=$!
    # Progress: the mapper prints a line every 5 s into its deputy log.
    ( while sleep 5; do
        tail -n 1 "$OUT/deputy-logs/mapper-proc.log" 2>/dev/null | grep "^progress" | sed "s/^/   /" || true
      done ) & watcher=$!
    "$EVERMAP_BIN/evermap-deputy" "'"$root"'/config/pipeline-oracle.pmd" --log-dir "$OUT/deputy-logs" \
        --script replay --exit-after-script --quiet
    kill $watcher 2>/dev/null || true
    kill -INT $logger; wait $logger || true'
end_s=$(date +%s.%N)

echo "== the map against the ground truth"
"$bin/evermap-pipeline-eval" --run "$run" --log "$out/mapper.lcmlog" --json "$out/map_eval.json" \
  --poses-tum "$out/live_poses.tum" | tee "$out/map_eval.txt"
cat "$run"/session-*.tum | grep -v '^#' > "$out/ground_truth.tum"

echo "== figures"
"$bin/evermap-map-render" --store "$out/map.db" --gt "$out/ground_truth.tum" \
  --title "reduced pose graph, floors stacked (cf. paper Fig. 1)" --out "$out/fig1_map_floors.png"
"$bin/evermap-eval" --gt "$out/ground_truth.tum" --est "$out/live_poses.tum" --max-dt 0.06 \
  --plot "$out/fig4_trajectory.png" --json "$out/fig4_trajectory.json" | grep -A1 "^ATE" || true
# Fig. 7 needs the full pose graph beside the reduced one: the offline runner maps the same run
# both ways in one process and draws nodes and update time against time.
mkdir -p "$out/fig7"
"$bin/evermap-mapper-run" --config "$run/run.sim.txt" --mode both --out "$out/fig7" > "$out/fig7/run.txt" 2>&1 ||
  { cat "$out/fig7/run.txt"; exit 1; }
for mode in reduced full; do
  awk -v m="$mode" '/^(nodes|ate_rmse_m|update_median_ms|update_p99_ms) / {v[$1] = $2}
    END {printf "   offline, %-8s graph: %5d nodes, ATE %.3f m, solver update median %.2f ms, p99 %.2f ms\n",
         m, v["nodes"], v["ate_rmse_m"], v["update_median_ms"], v["update_p99_ms"]}' "$out/fig7/summary-$mode.txt"
done

# ---------------------------------------------------------------------------------------------
echo "== image level: 40 s of rendered stereo (evermap-sim-render), stereo VO over it, evaluated"
"$bin/evermap-sim-render" --config "$root/config/sim-image-vo200.conf" --set render.max_duration_s=40 \
  --out "$out/sim-image.lcmlog" | tail -n 1
"$bin/evermap-vo-run" --body "$out/sim-image.lcmlog" "$out/sim_image_vo.tum" | tail -n 2
"$bin/evermap-eval" --gt "$out/sim-image.gt.tum" --est "$out/sim_image_vo.tum" \
  --plot "$out/sim_image_vo.png" --json "$out/sim_image_vo.json" | grep -A2 "^ATE"
rm -f "$out/sim-image.lcmlog"  # 300 MB of PNG frames; made again in 20 s

# ---------------------------------------------------------------------------------------------
sim_s=$(awk '/^#/ {next} {t=$1; if (n++ == 0 || t - last > 3600) {if (n > 1) total += last - first; first = t} last = t} END {total += last - first; printf "%.0f", total}' "$out/ground_truth.tum")
wall_s=$(awk -v a="$start_s" -v b="$end_s" 'BEGIN {printf "%.1f", b - a}')
echo "== summary (simulated run $run)"
grep -E '^(nodes|edges|floors|sessions|node_ate_rmse_m|node_ate_median_m|pose_ate_median_m|stats_rejected|stats_dropped_messages) ' "$out/map_eval.txt" |
  awk '{k = $1; $1 = ""; printf "   %-24s%s\n", k, $0}'
echo "   simulated time           ${sim_s} s"
echo "   pipeline wall time       ${wall_s} s (replay at ${speed}x, with start-up and shut-down)"
awk -v s="$sim_s" -v w="$wall_s" 'BEGIN {printf "   real-time factor         %.1fx\n", s / w}'
echo "   figures                  $out/fig1_map_floors.png $out/fig4_trajectory.png"
echo "                            $out/fig7/fig7-nodes.svg $out/fig7/fig7-update.svg $out/fig7/fig7-components.svg"

# ---------------------------------------------------------------------------------------------
euroc="$data/euroc-v101-micro"
if [ -d "$euroc/mav0" ]; then
  echo "== 2. the real EuRoC excerpt"
  gt=()
  [ -f "$euroc/groundtruth_openvins/V1_01_easy.csv" ] && gt=(--gt "$euroc/groundtruth_openvins/V1_01_easy.csv")
  "$bin/evermap-euroc2lcm" "$euroc" "$out/euroc.lcmlog" "${gt[@]}"
  echo "   replaying $out/euroc.lcmlog with lcm-logplayer (4x) in the LCM sandbox"
  BUILD_DIR="$build" "$root/scripts/replay-check.sh" "$out/euroc.lcmlog" 4 | tail -n 3
  echo "   stereo VO over the log (evermap-vo-run), evaluated against the ground truth"
  "$bin/evermap-vo-run" "$out/euroc.lcmlog" "$out/euroc_vo.tum" --body --stats "$out/euroc_vo.csv"
  if [ ${#gt[@]} -gt 0 ]; then
    # The vehicle barely moves in the excerpt: align on the first pose, not by Umeyama.
    "$bin/evermap-eval" --gt "${gt[1]}" --est "$out/euroc_vo.tum" --align first \
      --plot "$out/euroc_vo.png" --json "$out/euroc_vo.json"
  fi
  if [ -d "$data/rtabmap-lcd-samples" ]; then
    echo "   place recognition: vocabulary from real images, loop detection on the RTAB-Map samples"
    "$bin/evermap-vocab-train" --out "$out/default.evoc" --default-data "$data" | tail -n 1
    "$bin/evermap-place-eval" --vocab "$out/default.evoc" \
      --images "$data/rtabmap-lcd-samples/samples" --gt "$data/rtabmap-lcd-samples/samples_GT.bmp"
  fi
else
  echo "== 2. skipped: no EuRoC excerpt at $euroc (set EVERMAP_DATA)"
fi
echo "== done: outputs in $out"
if [ -x "$bin/evermap-viewer" ]; then
  # The replays above ran in the LCM sandbox, out of a browser's reach: the viewer shows the
  # stored map afterwards (live: run it beside the pipeline, docs/viewer.md).
  echo "   to see the map in a browser: $bin/evermap-viewer --store $out/map.db, then open http://127.0.0.1:8080/"
fi
