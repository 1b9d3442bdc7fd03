#!/usr/bin/env bash
# Every process shows what it runs with (issue 44, deliverable 5; issue 45, deliverable 2):
# --help lists each option with its default, unit and range, --print-config prints the values
# in effect as a config file that --config reads back to the same values, a bad value is
# refused naming the option and its range, and the shipped configs still load. Opens no LCM.
source "$(dirname "$0")/lib.sh" "$@"

# program, one of its keys, a value outside that key's range, the range as --help shows it
while read -r program key bad range; do
  exe="$bin/$program"
  if [ ! -x "$exe" ]; then echo "skip $program (not built)"; continue; fi
  "$exe" --help > "$tmp/help.txt" || fail "$program --help exits non-zero"
  grep -q -- "--print-config" "$tmp/help.txt" || fail "$program --help lists no --print-config"
  grep -Eq "^  $key +[^ ]" "$tmp/help.txt" || fail "$program --help does not list $key"
  grep -F "$key" "$tmp/help.txt" | grep -qF -- "$range" ||
    fail "$program --help does not show $key's range $range"
  "$exe" --print-config > "$tmp/a.conf" || fail "$program --print-config exits non-zero"
  [ -s "$tmp/a.conf" ] || fail "$program --print-config printed nothing"
  "$exe" --config "$tmp/a.conf" --print-config > "$tmp/b.conf" ||
    fail "$program --config of its own --print-config is refused"
  cmp -s "$tmp/a.conf" "$tmp/b.conf" || fail "$program --print-config does not read back"
  rc=0
  "$exe" --set "$key=$bad" --print-config > /dev/null 2> "$tmp/err.txt" || rc=$?
  [ "$rc" = 2 ] || fail "$program --set $key=$bad: exit $rc, wanted 2"
  head -n 1 "$tmp/err.txt" | grep -qF "option $key: $bad is outside $range" ||
    { cat "$tmp/err.txt" >&2; fail "$program --set $key=$bad does not name the option and range"; }
  echo "ok $program"
done <<'LIST'
evermap-vo-proc odometry.keyframe_inlier_fraction 1 [0, 1)
evermap-imu-proc publish_rate_hz 0 > 0
evermap-elevator-proc max_ride_s -1 > 0
evermap-mapper-proc mapper.overlap_radius_cells 4 [0, 3]
evermap-loopclose-proc max_places 0 >= 1
evermap-viewer viewer.port 70000 [0, 65535]
LIST

# The settings the deputy's pipelines start each process with (config/pipeline-*.pmd).
for p in vo-proc imu-proc elevator-proc mapper-proc loopclose-proc; do
  "$bin/evermap-$p" --config "$src/config/$p.cfg" --print-config > /dev/null ||
    fail "config/$p.cfg no longer loads"
done
echo "process options: ok"
