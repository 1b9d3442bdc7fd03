#!/usr/bin/env bash
# The main job, from a fresh machine: set up and build, then
#  0. the visual SLAM system from pixels: two sessions of a 3-floor building rendered as
#     stereo + IMU + wheels (evermap-sim-render; the lighting changes between them), each
#     replayed by lcm-logplayer while the deputy runs the five processes of
#     config/pipeline-log.pmd in the LCM sandbox (the second session continues the map store of
#     the first); the map against the ground truth, the same logs through evermap-slam-run,
#     and the map drawn with its floors stacked. The vocabulary is the project's own
#     (scripts/make-vocab.sh: renders of another building), so this needs no data;
#  1. the multi-process pipeline on a simulated 3-floor, multi-session run: evermap-sim-measure
#     writes the session logs; inside the LCM sandbox the deputy starts mapper-proc and the
#     registration oracle, lcm-logplayer replays the sessions and lcm-logger records what the
#     mapper publishes; then the map is evaluated against the ground truth and drawn:
#     floors stacked (Fig. 1), trajectory against ground truth (Fig. 4), nodes and update time
#     against time for the reduced and the full pose graph (Fig. 7); a summary is printed;
#     then 40 s of the image-level simulator's rendered stereo through visual odometry;
#  2. with the real data (EVERMAP_DATA), the EuRoC excerpt: converted to an LCM log, replayed
#     and checked, stereo VO over it evaluated against the ground truth;
#  3. with the real data, loop detection on the RTAB-Map samples with the project's vocabulary
#     and, beside it, one trained from real images.
# Parts 2 and 3 say in one line that they are skipped, and what to get, when the data is not
# there. Every step starts with a line that says how long it takes (on 2 cores), and nothing
# stays silent for more than 10 s: a step's own progress lines pass through, and a line
# "... N s" comes after each 9 s without one (a 2-core machine under load adds a second).
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

# Passes its input through and, after each 9 s without a line, prints "   ... LABEL: N s"
# (with the last progress line of FILE when one is given: a process's log under the deputy).
keep_alive() {  # LABEL [FILE]
  local label="$1" file="${2:-}" start=$SECONDS line="" rest="" rc p
  while :; do
    rc=0
    IFS= read -r -t 9 line || rc=$?
    if [ "$rc" -eq 0 ]; then
      printf '%s\n' "$rest$line"
      rest=""
    elif [ "$rc" -gt 128 ]; then  # timed out; a partial line is kept for the next read
      rest+="$line"
      p=""
      if [ -n "$file" ]; then
        p="$({ grep -h '^progress' "$file" 2>/dev/null || true; } | tail -n 1 | sed 's/^progress: */: /')"
      fi
      echo "   ... $label: $((SECONDS - start)) s${p}"
    else
      [ -n "$rest$line" ] && printf '%s\n' "$rest$line"
      return 0
    fi
  done
}
# Runs config/PMD's SCRIPT under evermap-deputy in an LCM sandbox (the processes' logs in
# LOG_DIR) while lcm-logger records MAP_GRAPH, MAPPER_STATS and POSE into MAPPER_LOG. The
# EVERMAP_* variables set on the call reach the deputy and its processes.
under_deputy() {  # PMD SCRIPT LOG_DIR MAPPER_LOG
  PMD="$root/config/$1" SCRIPT="$2" LOG_DIR="$3" MAPPER_LOG="$4" "$root/scripts/lcm-sandbox" bash -c '
    set -e
    lcm-logger -q -f -c "MAP_GRAPH|MAPPER_STATS|POSE" "$MAPPER_LOG" & logger=$!
    "$EVERMAP_BIN/evermap-deputy" "$PMD" --log-dir "$LOG_DIR" --script "$SCRIPT" \
        --exit-after-script --quiet
    kill -INT $logger; wait $logger || true'
}
# The tools' progress lines on stderr ("evermap-slam-run session 0: data 12.0 / 60.0 s ..."):
# the filters below let them through.
progress='^evermap-[a-z-]+[^:]*: data [0-9.]+ '

echo "== setup: the Debian and npm packages evermap needs (seconds when present; else minutes)"
bash "$root/scripts/setup.sh" 2>&1 | keep_alive "setup"
echo "== build (cmake, ninja -j2; from scratch about 15 min on 2 cores, then seconds)"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2 | keep_alive "build"
mkdir -p "$out"
bin="$build/bin"

# ---------------------------------------------------------------------------------------------
visual_s="${EVERMAP_VISUAL_S:-240}"
visual_speed="${EVERMAP_VISUAL_SPEED:-2}"
vis="$out/visual"
vocab="$out/evermap.evoc"
echo "== 0. the visual SLAM system from pixels: 2 rendered sessions of ${visual_s} s, five processes live"
rm -rf "$vis"; mkdir -p "$vis"
echo "   the vocabulary: scripts/make-vocab.sh, trained on renders of another building (about 30 s)"
BUILD_DIR="$build" bash "$root/scripts/make-vocab.sh" "$vocab" | sed -u -n 's/^fingerprint/   fingerprint/p' |
  keep_alive "training the vocabulary"
for s in 0 1; do
  echo "   session $s: rendering ${visual_s} s of stereo, IMU, wheels and ground truth (evermap-sim-render, about $((visual_s / 4)) s)"
  "$bin/evermap-sim-render" --config "$root/config/sim-image-3floor.conf" --set render.session=$s \
    --set render.max_duration_s="$visual_s" --out "$vis/s$s.lcmlog" 2>&1 |
    sed -u -n -E -e 's/^session/   session/p' -e "/$progress/s/^/   /p" | keep_alive "rendering session $s"
done
for s in 0 1; do
  echo "   session $s: replayed at ${visual_speed}x (about $((visual_s / visual_speed + 15)) s); vo-proc, imu-proc, elevator-proc, loopclose-proc, mapper-proc under evermap-deputy"
  EVERMAP_BIN="$bin" EVERMAP_CONFIG="$root/config" EVERMAP_LOG="$vis/s$s.lcmlog" EVERMAP_MAP="$vis/map.db" EVERMAP_VOCAB="$vocab" \
  EVERMAP_PLACES="$vis/places.db" EVERMAP_SPEED="$visual_speed" \
    under_deputy pipeline-log.pmd go "$vis/deputy-logs-s$s" "$vis/mapper-s$s.lcmlog" |
    keep_alive "replaying session $s, mapper-proc" "$vis/deputy-logs-s$s/mapper-proc.log"
  { grep -hE "^(nodes|loop_closures|relocalizations|vo_before_calibration) " "$vis/deputy-logs-s$s/mapper-proc.log" || true; } |
    tr '\n' ' ' | sed 's/^/   mapper: /'; echo
done
echo "== the live map (last MAP_GRAPH) against the ground truth of the logs (seconds)"
"$bin/evermap-pipeline-eval" --truth-log "$vis/s0.lcmlog" --truth-log "$vis/s1.lcmlog" --log "$vis/mapper-s1.lcmlog" \
  | tee "$vis/map_eval.txt" | grep -E "^(nodes|edges|floors|nodes_on_consistent_floor|loop_edges_false|sessions|node_ate)" | sed 's/^/   /'
echo "== the same two logs offline through evermap-slam-run, the five processes' classes in one process (about $((visual_s * 4 / 7)) s)"
"$bin/evermap-slam-run" --vocab "$vocab" --out "$vis/offline" "$vis/s0.lcmlog" "$vis/s1.lcmlog" 2>&1 |
  sed -u -n -E -e '/^(session\.|nodes |accepted_closures|false_closures|relocalizations|node_ate_rmse|realtime|ms_per_frame|peak)/s/^/   /p' \
    -e "/$progress/s/^/   /p" | keep_alive "evermap-slam-run"
cat "$vis"/s0.gt.tum "$vis"/s1.gt.tum | grep -v '^#' > "$vis/ground_truth.tum"
"$bin/evermap-map-render" --store "$vis/map.db" --gt "$vis/ground_truth.tum" \
  --title "visual SLAM from pixels, live: 2 sessions, floors stacked (cf. paper Fig. 1)" --out "$vis/fig1_visual_map.png"
rm -f "$vis"/s0.lcmlog "$vis"/s1.lcmlog  # 2-3 GB of frames; made again in 2 minutes

# ---------------------------------------------------------------------------------------------
echo "== 1. the pipeline on a simulated multi-floor, multi-session run"
if [ -z "$run" ]; then
  run="$out/sim-run"
  rm -rf "$run"
  echo "   simulating the run: evermap-sim-measure --config $sim_config (about 30 s)"
  "$bin/evermap-sim-measure" --config "$sim_config" --out "$run" 2>&1 > "$out/sim-measure.txt" |
    sed -u -n -E "/$progress/s/^/   /p" | keep_alive "evermap-sim-measure"
  tail -n 3 "$out/sim-measure.txt"
fi
[ -f "$run/run.sim.txt" ] || { echo "demo: $run/run.sim.txt not found (a run of evermap-sim-measure --out)" >&2; exit 2; }

rm -f "$out/map.db" "$out/map.db-wal" "$out/map.db-shm" "$out/mapper.lcmlog"
rm -rf "$out/deputy-logs"
echo "   replaying $(ls "$run"/session-*.lcmlog | wc -l) session log(s) at ${speed}x; mapper-proc and the oracle under evermap-deputy (about 80 s)"
start_s=$(date +%s.%N)
EVERMAP_BIN="$bin" EVERMAP_CONFIG="$root/config" EVERMAP_RUN="$run" EVERMAP_MAP="$out/map.db" EVERMAP_SPEED="$speed" \
EVERMAP_MAPPER_FLAGS="--progress-s 5" \
  under_deputy pipeline-oracle.pmd replay "$out/deputy-logs" "$out/mapper.lcmlog" |
  keep_alive "replaying, mapper-proc" "$out/deputy-logs/mapper-proc.log"
end_s=$(date +%s.%N)

echo "== the map against the ground truth (seconds)"
"$bin/evermap-pipeline-eval" --run "$run" --log "$out/mapper.lcmlog" --json "$out/map_eval.json" \
  --poses-tum "$out/live_poses.tum" | tee "$out/map_eval.txt"
cat "$run"/session-*.tum | grep -v '^#' > "$out/ground_truth.tum"

echo "== figures (about 30 s: Fig. 7 maps the run again offline, reduced and full graph)"
"$bin/evermap-map-render" --store "$out/map.db" --gt "$out/ground_truth.tum" \
  --title "reduced pose graph, floors stacked (cf. paper Fig. 1)" --out "$out/fig1_map_floors.png"
"$bin/evermap-eval" --gt "$out/ground_truth.tum" --est "$out/live_poses.tum" --max-dt 0.06 \
  --plot "$out/fig4_trajectory.png" --json "$out/fig4_trajectory.json" | grep -A1 "^ATE" || true
# Fig. 7 needs the full pose graph beside the reduced one: the offline runner maps the same run
# both ways in one process and draws nodes and update time against time.
mkdir -p "$out/fig7"
{ "$bin/evermap-mapper-run" --config "$run/run.sim.txt" --mode both --out "$out/fig7" > "$out/fig7/run.txt" 2>&1 ||
  { cat "$out/fig7/run.txt"; exit 1; }; } | keep_alive "evermap-mapper-run"
for mode in reduced full; do
  awk -v m="$mode" '/^(nodes|ate_rmse_m|update_median_ms|update_p99_ms) / {v[$1] = $2}
    END {printf "   offline, %-8s graph: %5d nodes, ATE %.3f m, solver update median %.2f ms, p99 %.2f ms\n",
         m, v["nodes"], v["ate_rmse_m"], v["update_median_ms"], v["update_p99_ms"]}' "$out/fig7/summary-$mode.txt"
done

# ---------------------------------------------------------------------------------------------
echo "== image level: 40 s of rendered stereo (evermap-sim-render), stereo VO over it, evaluated (about 40 s)"
"$bin/evermap-sim-render" --config "$root/config/sim-image-vo200.conf" --set render.max_duration_s=40 \
  --out "$out/sim-image.lcmlog" 2>&1 > "$out/sim-image.txt" | sed -u -n -E "/$progress/s/^/   /p" |
  keep_alive "evermap-sim-render"
tail -n 1 "$out/sim-image.txt"
"$bin/evermap-vo-run" --body "$out/sim-image.lcmlog" "$out/sim_image_vo.tum" | tail -n 2 | keep_alive "evermap-vo-run"
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
# Real data: what each folder is and where it comes from is in its SOURCE.txt.
euroc="$data/euroc-v101-micro"
if [ -d "$euroc/mav0" ]; then
  echo "== 2. the real EuRoC excerpt (about 30 s)"
  gt=()
  [ -f "$euroc/groundtruth_openvins/V1_01_easy.csv" ] && gt=(--gt "$euroc/groundtruth_openvins/V1_01_easy.csv")
  "$bin/evermap-euroc2lcm" "$euroc" "$out/euroc.lcmlog" "${gt[@]}"
  echo "   replaying $out/euroc.lcmlog with lcm-logplayer (4x) in the LCM sandbox"
  BUILD_DIR="$build" "$root/scripts/replay-check.sh" "$out/euroc.lcmlog" 4 | tail -n 3 | keep_alive "replay check"
  echo "   stereo VO over the log (evermap-vo-run), evaluated against the ground truth"
  "$bin/evermap-vo-run" "$out/euroc.lcmlog" "$out/euroc_vo.tum" --body --stats "$out/euroc_vo.csv"
  if [ ${#gt[@]} -gt 0 ]; then
    # The vehicle barely moves in the excerpt: align on the first pose, not by Umeyama.
    "$bin/evermap-eval" --gt "${gt[1]}" --est "$out/euroc_vo.tum" --align first \
      --plot "$out/euroc_vo.png" --json "$out/euroc_vo.json"
  fi
else
  echo "== 2. skipped (no real data): EuRoC V1_01_easy is not at $euroc; put its mav0/ there (ASL layout; the excerpt used is Kimera-VIO's tests/data/MicroEurocDataset, ground truth from OpenVINS' ov_data/euroc_mav as groundtruth_openvins/) and set EVERMAP_DATA"
fi
samples="$data/rtabmap-lcd-samples"
if [ -f "$samples/samples_GT.bmp" ]; then
  echo "== 3. place recognition on RTAB-Map's loop-closure samples: the project's vocabulary, then one trained from real images (about 40 s)"
  "$bin/evermap-place-eval" --vocab "$vocab" --images "$samples/samples" --gt "$samples/samples_GT.bmp" |
    sed -u -n 's/^  \(raw score\|score + epipolar\)/   project vocabulary, \1/p' | keep_alive "evermap-place-eval"
  # Beside it, evermap-vocab-train's default training images (KITTI 07 and 01, EuRoC V1_01
  # cam0, slambook2's TUM frames; not the samples, the test set).
  if { "$bin/evermap-vocab-train" --out "$out/real-images.evoc" --default-data "$data" > "$out/real-images.txt" 2>&1; } |
    keep_alive "training the real-image vocabulary"; then
    "$bin/evermap-place-eval" --vocab "$out/real-images.evoc" --images "$samples/samples" --gt "$samples/samples_GT.bmp" |
      sed -u -n 's/^  \(raw score\|score + epipolar\)/   real-image vocabulary, \1/p' | keep_alive "evermap-place-eval"
  else
    echo "   no real-image vocabulary beside it: $(head -n 1 "$out/real-images.txt")"
  fi
else
  echo "== 3. skipped (no real data): RTAB-Map's loop-closure samples are not at $samples; put samples/*.jpg and samples_GT.bmp from github.com/introlab/rtabmap (data/samples, data/samples_GT.bmp) there and set EVERMAP_DATA"
fi
echo "== done: outputs in $out"
if [ -x "$bin/evermap-viewer" ]; then
  # The replays above ran in the LCM sandbox, out of a browser's reach: the viewer shows the
  # stored map afterwards (live: run it beside the pipeline, docs/viewer.md).
  echo "   to see the map in a browser: $bin/evermap-viewer --store $out/map.db, then open http://127.0.0.1:8080/"
fi
