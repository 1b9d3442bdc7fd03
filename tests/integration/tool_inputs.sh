#!/usr/bin/env bash
# Offline tools on bad input (issue 17, deliverable 6): a log cut mid-event or damaged, a
# config file with an unknown key or a non-finite value, a number out of range. Each must be
# refused with one line naming the input on stderr and a non-zero exit, and leave no output
# file (nor a temporary one) behind. Needs no data set: the log is the IMU of a synthetic
# elevator run (evermap-imu-elevator-run --synthetic).
source "$(dirname "$0")/lib.sh" "$@"
checks=0

# refused WANT_RC REGEX OUTPUT... -- COMMAND...: COMMAND exits WANT_RC, the first line of its
# stderr matches REGEX (and with WANT_RC 1, stderr is that one line), and none of OUTPUT (nor
# anything else new in $tmp/out) exists afterwards.
refused() {
  local want="$1" regex="$2"; shift 2
  local outputs=()
  while [ "$1" != "--" ]; do outputs+=("$1"); shift; done
  shift
  rm -rf "$tmp/out"; mkdir -p "$tmp/out"
  local rc=0
  "$@" > "$tmp/stdout.txt" 2> "$tmp/stderr.txt" || rc=$?
  [ "$rc" = "$want" ] || { cat "$tmp/stderr.txt" >&2; fail "exit $rc, wanted $want: $*"; }
  head -n 1 "$tmp/stderr.txt" | grep -Eq -- "$regex" ||
    { cat "$tmp/stderr.txt" >&2; fail "no '$regex' on the first line of stderr: $*"; }
  if [ "$want" = 1 ]; then
    [ "$(wc -l < "$tmp/stderr.txt")" = 1 ] || { cat "$tmp/stderr.txt" >&2; fail "more than one line: $*"; }
  fi
  for o in "${outputs[@]}"; do [ ! -e "$o" ] || fail "$o left behind by: $*"; done
  [ -z "$(ls -A "$tmp/out")" ] || { ls -la "$tmp/out" >&2; fail "files left in the output folder by: $*"; }
  echo "ok: $(head -n 1 "$tmp/stderr.txt")"
  checks=$((checks + 1))
}

# A valid log: 60 s of 100 Hz IMU with two elevator rides (~6000 events).
"$bin/evermap-imu-elevator-run" --synthetic 2 --write-lcm-log "$tmp/imu.lcmlog" > /dev/null
size=$(stat -c %s "$tmp/imu.lcmlog")
[ "$size" -gt 100000 ] || fail "the synthetic log has only $size bytes"
# Cut in the middle of an event (a logger killed mid-write), and one with a damaged byte in
# the middle (the sync word of some event overwritten).
head -c $((size - 17)) "$tmp/imu.lcmlog" > "$tmp/cut.lcmlog"
cp "$tmp/imu.lcmlog" "$tmp/corrupt.lcmlog"
# Event boundaries are not known from the shell: overwrite 64 bytes in the middle, which
# always hits a header or a length/sync check of some event.
printf '%*s' 64 '' | tr ' ' 'X' | dd of="$tmp/corrupt.lcmlog" bs=1 seek=$((size / 2)) conv=notrunc status=none

mkdir -p "$tmp/out"
"$bin/evermap-imu-elevator-run" --lcm-log "$tmp/imu.lcmlog" --dump-attitude "$tmp/out/ok.txt" > /dev/null
[ -s "$tmp/out/ok.txt" ] || fail "the intact log gave no attitude"

# 1. Truncated and corrupt logs.
for log in cut corrupt; do
  what='(truncated|corrupt) at byte [0-9]+ \(event [0-9]+, after [0-9]+ complete events\)'
  refused 1 "^evermap-imu-elevator-run: .*$log.lcmlog: $what" -- \
    "$bin/evermap-imu-elevator-run" --lcm-log "$tmp/$log.lcmlog" --dump-attitude "$tmp/out/att.txt" \
    --write-lcm-log "$tmp/out/imu.lcmlog"
  refused 1 "^evermap-vo-run: .*$log.lcmlog: $what" -- \
    "$bin/evermap-vo-run" "$tmp/$log.lcmlog" "$tmp/out/vo.tum" --output-log "$tmp/out/vo.lcmlog" \
    --stats "$tmp/out/vo.csv"
  refused 1 "^evermap-slam-run: .*$log.lcmlog: $what" "$tmp/out/slam" -- \
    "$bin/evermap-slam-run" --vocab "$tmp/no.evoc" --out "$tmp/out/slam" "$tmp/$log.lcmlog"
  refused 1 "^evermap-pipeline-eval: .*$log.lcmlog: $what" -- \
    "$bin/evermap-pipeline-eval" --truth-log "$tmp/$log.lcmlog" --store "$tmp/none.db" --json "$tmp/out/e.json"
  refused 2 "^evermap-lcm-check: .*$log.lcmlog: $what" -- \
    "$bin/evermap-lcm-check" --log "$tmp/$log.lcmlog"
  refused 1 "^evermap-imu-elevator-run: .*$log.lcmlog: $what" -- \
    "$bin/evermap-imu-elevator-run" --print-floor-log "$tmp/$log.lcmlog"
done
# Not an LCM log at all.
head -c 5000 /dev/urandom > "$tmp/random.lcmlog"
refused 1 "^evermap-vo-run: .*random.lcmlog: corrupt at byte 0 " -- \
  "$bin/evermap-vo-run" "$tmp/random.lcmlog" "$tmp/out/vo.tum"

# 2. Config files refuse what --set refuses.
printf 'publish_rate_hz = 50\nno_such_key = 1\n' > "$tmp/unknown.cfg"
printf 'publish_rate_hz = inf\n' > "$tmp/inf.cfg"
printf 'max_ride_s = nan\n' > "$tmp/nan.cfg"
refused 2 "^evermap-imu-proc: .*unknown.cfg:2: unknown option \"no_such_key\"" -- \
  "$bin/evermap-imu-proc" --config "$tmp/unknown.cfg" --print-options
refused 2 "^evermap-imu-proc: .*inf.cfg:1: option publish_rate_hz: \"inf\" is not a finite number" -- \
  "$bin/evermap-imu-proc" --config "$tmp/inf.cfg" --print-options
refused 2 "^evermap-imu-proc: bad --set: unknown option \"no_such_key\"" -- \
  "$bin/evermap-imu-proc" --set no_such_key=1 --print-options
refused 2 "^evermap-imu-proc: bad --set: option publish_rate_hz: \"inf\" is not a finite number" -- \
  "$bin/evermap-imu-proc" --set publish_rate_hz=inf --print-options
refused 2 "^evermap-elevator-proc: .*unknown.cfg:1: unknown option \"publish_rate_hz\"" -- \
  "$bin/evermap-elevator-proc" --config "$tmp/unknown.cfg" --print-options
refused 2 "^evermap-elevator-proc: .*nan.cfg:1: option max_ride_s: \"nan\" is not a finite number" -- \
  "$bin/evermap-elevator-proc" --config "$tmp/nan.cfg" --print-options
refused 2 "^evermap-imu-elevator-run: .*nan.cfg:1: option max_ride_s: \"nan\" is not a finite number" -- \
  "$bin/evermap-imu-elevator-run" --config "$tmp/nan.cfg" --synthetic 1
refused 2 "^evermap-imu-elevator-run: .*unknown.cfg:1: unknown option \"publish_rate_hz\"" -- \
  "$bin/evermap-imu-elevator-run" --config "$tmp/unknown.cfg" --synthetic 1
# 3. Numbers out of range.
refused 2 "^evermap-vo-run: bad --max-frames: -5 is outside >= 1" -- \
  "$bin/evermap-vo-run" --max-frames -5 "$tmp/imu.lcmlog" "$tmp/out/vo.tum"
refused 2 "^evermap-mapper-proc: bad --queue: -5 is outside \[1, 1000000\]" -- \
  "$bin/evermap-mapper-proc" --queue -5
refused 2 "^evermap-map-render: bad --width: 0 is outside \[16, 20000\]" -- \
  "$bin/evermap-map-render" --store "$tmp/none.db" --out "$tmp/out/m.png" --width 0
refused 2 "^evermap-eval: bad --max-dt: 0 is outside > 0" -- \
  "$bin/evermap-eval" --gt "$tmp/a.tum" --est "$tmp/b.tum" --max-dt 0
refused 2 "^evermap-imu-elevator-run: bad --rate: \"inf\" is not a finite number" -- \
  "$bin/evermap-imu-elevator-run" --synthetic 1 --rate inf
refused 2 '^evermap-solver: bad --wildfire: "nan" is not a finite number' -- \
  "$bin/evermap-solver" --wildfire nan "$tmp/none.g2o"

echo "OK: $checks bad inputs refused with one line, a non-zero exit and no output left behind"
