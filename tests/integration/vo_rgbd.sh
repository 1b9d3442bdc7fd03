#!/usr/bin/env bash
# RGB-D visual odometry as a user runs it (docs/rgbd.md) on the real TUM fr1_rpy excerpt:
#  1. evermap-tum2lcm, then evermap-vo-run over the log: a TUM trajectory, evermap-eval on it;
#  2. evermap-slam-run over it: the whole system (VO, loop closure, mapper with the camera's
#     mounting from RGBD_CALIB) maps it without an input error;
#  3. evermap-vo-proc live, inside the LCM sandbox, while lcm-logplayer replays RGBD in real
#     time: every frame processed or counted as dropped, VO_DELTA and KEYFRAME on LCM.
# Skips (77) without the data, except under CI.
source "$(dirname "$0")/lib.sh" "$@"
need_data tum-rgbd-fr1-rpy
tum="$data/tum-rgbd-fr1-rpy"

"$build/bin/evermap-tum2lcm" "$tum" "$tmp/tum.lcmlog" > "$tmp/convert.txt"
expect_line "$tmp/convert.txt" '^camera: TUM freiburg1'
expect_line "$tmp/convert.txt" 'RGBD +150 messages'
expect_line "$tmp/convert.txt" 'RGBD_CALIB +[0-9]+ messages'

# 1. Offline.
"$build/bin/evermap-vo-run" "$tmp/tum.lcmlog" "$tmp/vo.tum" --stats "$tmp/vo.csv" > "$tmp/run.txt"
cat "$tmp/run.txt"
expect_line "$tmp/run.txt" '^150 frames: ok 1[4-5][0-9],'
"$build/bin/evermap-eval" --gt "$tum/groundtruth.txt" --est "$tmp/vo.tum" --rpe-frames 30 > "$tmp/eval.txt"
cat "$tmp/eval.txt"
expect_line "$tmp/eval.txt" '^RPE over 30 frames'

# 2. The whole system, offline.
vocab="$data/vocab-orb-small/slambook2_vocabulary.yml.gz"
if [ -f "$vocab" ]; then
  "$build/bin/evermap-slam-run" --vocab "$vocab" --out "$tmp/slam" "$tmp/tum.lcmlog" > "$tmp/slam.txt" 2>&1 \
    || { cat "$tmp/slam.txt"; fail "evermap-slam-run"; }
  grep -E '^(nodes|pose_ate_rmse_m|node_ate_rmse_m|input_errors) ' "$tmp/slam.txt"
  expect_line "$tmp/slam.txt" '^input_errors 0$'
  expect_line "$tmp/slam.txt" '^nodes [1-9][0-9]* '
  expect_line "$tmp/slam.txt" '^pose_ate_rmse_m 0\.0'  # below 0.1 m (measured 0.058 m)
else
  echo "vocabulary $vocab not found: evermap-slam-run step skipped"
fi

# 3. Live, over LCM.
vo_proc_live vo "$tmp/tum.lcmlog" "RGBD" 150
if grep -q "bad input" <<< "$vo_summary"; then fail "bad input frames: $vo_summary"; fi
echo "vo_rgbd: OK ($vo_frames frames processed live, $vo_dropped dropped)"
