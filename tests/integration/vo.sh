#!/usr/bin/env bash
# Visual odometry as a user runs it (docs/vo.md) on the real EuRoC excerpt:
#  1. evermap-vo-run over the converted log: a TUM trajectory of all 95 frames, the per-frame
#     statistics, and a log of VO_DELTA and KEYFRAME messages;
#  2. evermap-vo-proc live, inside the LCM sandbox, while lcm-logplayer replays the stereo
#     channels of the log in real time: every STEREO frame is either processed or counted as
#     dropped, the frames are tracked, and VO_DELTA arrives on LCM.
# Skips (77) without the data, except under CI.
set -euo pipefail
build="$1"; src="$2"
data="${EVERMAP_DATA:-${EVERMAP_DATA_DEFAULT:-$src/../shared/data}}"
euroc="$data/euroc-v101-micro"
if [ ! -d "$euroc" ]; then
  echo "data set euroc-v101-micro not found under $data (set EVERMAP_DATA)"
  [ "${CI:-}" = "true" ] && exit 1
  exit 77
fi
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
expect_line() {  # expect_line FILE REGEX
  grep -Eq "$2" "$1" || { cat "$1" >&2; fail "no line matching '$2'"; }
}

"$build/bin/evermap-euroc2lcm" --raw "$euroc" "$tmp/euroc.lcmlog" > /dev/null

# 1. Offline.
"$build/bin/evermap-vo-run" "$tmp/euroc.lcmlog" "$tmp/vo.tum" --body --stats "$tmp/vo.csv" \
  --output-log "$tmp/vo.lcmlog" > "$tmp/run.txt"
cat "$tmp/run.txt"
expect_line "$tmp/run.txt" '^95 frames: ok 94, no data 1,'
expect_line "$tmp/run.txt" '^95 poses'
[ "$(grep -vc '^#' "$tmp/vo.tum")" = 95 ] || fail "the trajectory does not have 95 poses"
[ "$(wc -l < "$tmp/vo.csv")" = 96 ] || fail "the statistics do not have 95 rows"
head -n 1 "$tmp/vo.csv" | grep -q '^utime,status,keyframe_changed' || fail "statistics header"
[ -s "$tmp/vo.lcmlog" ] || fail "no VO log written"
rc=0; "$build/bin/evermap-vo-run" "$tmp/missing.lcmlog" "$tmp/x.tum" 2> "$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] || fail "missing log: exit $rc, wanted 1"
expect_line "$tmp/err.txt" 'missing.lcmlog: no such log file'

# 2. Live, over LCM.
ready="$tmp/ready"
"$src/scripts/lcm-sandbox" bash -c '
  set -euo pipefail
  "$1/bin/evermap-vo-proc" --ready-file "$3" 2> "$2/proc.txt" &
  proc=$!
  lcm-logger -q -c "VO_DELTA|KEYFRAME" "$2/live.lcmlog" &
  logger=$!
  for _ in $(seq 300); do [ -f "$3" ] && break; sleep 0.1; done
  sleep 0.5
  # The stereo channels only (the pattern is matched whole). The log goes on with 140 s of
  # IMU after the last image: the player is stopped once the images are out (5.4 s).
  timeout 15 lcm-logplayer -e "STEREO|STEREO_CALIB" "$2/euroc.lcmlog" > /dev/null || true
  sleep 2
  kill -TERM "$proc"; wait "$proc"
  kill -INT "$logger"; wait "$logger" || true
' vo "$build" "$tmp" "$ready"
tail -n 3 "$tmp/proc.txt"
summary="$(grep -E '^evermap-vo-proc: [0-9]+ frames' "$tmp/proc.txt")" || fail "no summary line"
frames="$(sed -E 's/^evermap-vo-proc: ([0-9]+) frames.*/\1/' <<< "$summary")"
dropped="$(sed -E 's/.*; ([0-9]+) frames dropped.*/\1/' <<< "$summary")"
[ "$((frames + dropped))" = 95 ] || fail "$frames processed + $dropped dropped != 95 frames"
[ "$frames" -ge 10 ] || fail "only $frames frames processed"
ok="$(sed -nE 's/.* ok ([0-9]+),.*/\1/p' <<< "$summary")"
[ -n "$ok" ] && [ "$ok" -ge "$((frames - 1))" ] || fail "frames not tracked: $summary"
[ -s "$tmp/live.lcmlog" ] || fail "nothing received on VO_DELTA/KEYFRAME"
echo "vo: OK ($frames frames processed live, $dropped dropped)"
