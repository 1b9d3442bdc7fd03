#!/usr/bin/env bash
# The data-set converter programs as a user runs them: evermap-euroc2lcm on the real EuRoC
# excerpt, evermap-kitti2lcm on a stereo folder made from real KITTI frames and on the real
# monocular folder (refused), and their usage errors. Skips (77) without the data, except
# under CI.
source "$(dirname "$0")/lib.sh" "$@"
euroc="$data/euroc-v101-micro"; kitti="$data/kitti07-mono-160"
need_data "$euroc" "$kitti"
euroc="$(cd "$euroc" && pwd)"; kitti="$(cd "$kitti" && pwd)"  # the symlinks below need absolute targets

# EuRoC, options after the positional arguments as in docs/datasets.md.
"$build/bin/evermap-euroc2lcm" "$euroc" "$tmp/euroc.lcmlog" \
  --gt "$euroc/groundtruth_openvins/V1_01_easy.csv" > "$tmp/euroc.txt"
cat "$tmp/euroc.txt"
expect_line "$tmp/euroc.txt" '^  STEREO +95 messages'
# Calibration is state: at the start, then once a second of the 4.7 s (docs/contracts.md).
expect_line "$tmp/euroc.txt" '^  STEREO_CALIB +5 messages'
expect_line "$tmp/euroc.txt" '^  IMU +29120 messages'
expect_line "$tmp/euroc.txt" '^  GROUND_TRUTH +2895 messages'
expect_line "$tmp/euroc.txt" '^skipped: 4 image rows'
[ -s "$tmp/euroc.lcmlog" ] || fail "no log written"
ls "$tmp" | grep -q '\.tmp\.' && fail "temporary file left behind"

# KITTI: a stereo folder from 20 real frames (image_1 = image_0), then the real mono folder.
seq="$tmp/07"; mkdir -p "$seq/image_0" "$seq/image_1"
cp "$kitti/calib.txt" "$seq/"
head -n 20 "$kitti/times.txt" > "$seq/times.txt"
head -n 20 "$kitti/poses.txt" > "$seq/poses.txt"
for i in $(seq -f %06g 0 19); do
  ln -s "$kitti/image_0/$i.png" "$seq/image_0/$i.png"
  ln -s "$kitti/image_0/$i.png" "$seq/image_1/$i.png"
done
"$build/bin/evermap-kitti2lcm" --raw "$seq" "$tmp/kitti.lcmlog" > "$tmp/kitti.txt"
cat "$tmp/kitti.txt"
expect_line "$tmp/kitti.txt" '^wrote .*kitti.lcmlog \(images: gray8\)'
expect_line "$tmp/kitti.txt" '^  STEREO +20 messages'
expect_line "$tmp/kitti.txt" '^  GROUND_TRUTH +20 messages'

# The default encoding, and evermap-log-recode: raw -> zstd -> raw gives the same log byte for
# byte (lossless, every other event copied), and a cut log is refused naming it.
"$build/bin/evermap-kitti2lcm" "$seq" "$tmp/kitti-zstd.lcmlog" > "$tmp/kitti-zstd.txt"
expect_line "$tmp/kitti-zstd.txt" '^wrote .*kitti-zstd.lcmlog \(images: zstd\)'
"$build/bin/evermap-log-recode" "$tmp/kitti.lcmlog" "$tmp/recoded.lcmlog" > "$tmp/recode.txt"
expect_line "$tmp/recode.txt" '^frames 20 encoding zstd bytes_per_frame_in [0-9]+ bytes_per_frame_out [0-9]+ kept 0$'
cmp -s "$tmp/recoded.lcmlog" "$tmp/kitti-zstd.lcmlog" || fail "recoded raw log differs from the converter's zstd log"
"$build/bin/evermap-log-recode" "$tmp/recoded.lcmlog" "$tmp/back.lcmlog" --encoding gray8 > /dev/null
cmp -s "$tmp/back.lcmlog" "$tmp/kitti.lcmlog" || fail "raw -> zstd -> raw is not the same log"
head -c 300000 "$tmp/recoded.lcmlog" > "$tmp/cut.lcmlog"
rc=0; "$build/bin/evermap-log-recode" "$tmp/cut.lcmlog" "$tmp/cut-out.lcmlog" 2> "$tmp/cut.err" > /dev/null || rc=$?
[ "$rc" = 1 ] || fail "cut log: exit $rc, wanted 1"
expect_line "$tmp/cut.err" '^evermap-log-recode: .*cut.lcmlog'
[ -e "$tmp/cut-out.lcmlog" ] && fail "a log was written for a cut input"

rc=0; "$build/bin/evermap-kitti2lcm" "$kitti" "$tmp/mono.lcmlog" 2> "$tmp/mono.err" || rc=$?
[ "$rc" = 1 ] || fail "monocular folder: exit $rc, wanted 1"
expect_line "$tmp/mono.err" 'image_1: no right images'
[ "$(wc -l < "$tmp/mono.err")" = 1 ] || fail "the error is not one line"
[ -e "$tmp/mono.lcmlog" ] && fail "a log was written for a refused input"

rc=0; "$build/bin/evermap-euroc2lcm" "$euroc" 2> /dev/null || rc=$?
[ "$rc" = 2 ] || fail "missing argument: exit $rc, wanted 2"
rc=0; "$build/bin/evermap-kitti2lcm" --bogus "$seq" x 2> /dev/null || rc=$?
[ "$rc" = 2 ] || fail "unknown option: exit $rc, wanted 2"
echo "dataset tools: OK"
