#!/usr/bin/env bash
# Every program under tools/ shows what it runs with (issues 44 and 45): --help lists its
# options with default, unit and range; --print-config prints the values in effect as a config
# that --config reads back to the same text; a bad value is refused (exit 2) with one line
# naming the option and the allowed range, through --set and through the program's own flag.
# Needs no data set.
source "$(dirname "$0")/lib.sh" "$@"
checks=0

# refused REGEX COMMAND...: exit 2 and REGEX on the first line of stderr.
refused() {
  local regex="$1"; shift
  local rc=0
  "$@" > /dev/null 2> "$tmp/err.txt" || rc=$?
  [ "$rc" = 2 ] || { cat "$tmp/err.txt" >&2; fail "exit $rc, wanted 2: $*"; }
  head -n 1 "$tmp/err.txt" | grep -Eq -- "$regex" ||
    { cat "$tmp/err.txt" >&2; fail "no '$regex' on the first line of stderr: $*"; }
  checks=$((checks + 1))
}

# reads_back PROGRAM ARGS...: PROGRAM ARGS --print-config, read back with --config, prints the
# same text (and a program with its own --config: ARGS holds it and the text is read back the
# same way).
reads_back() {
  local prog="$1"; shift
  "$bin/$prog" "$@" --print-config > "$tmp/a.conf" || fail "$prog $* --print-config"
  [ -s "$tmp/a.conf" ] || fail "$prog --print-config printed nothing"
  "$bin/$prog" --config "$tmp/a.conf" --print-config > "$tmp/b.conf" ||
    fail "$prog --config (its own --print-config) failed"
  cmp -s "$tmp/a.conf" "$tmp/b.conf" || { diff "$tmp/a.conf" "$tmp/b.conf" >&2; fail "$prog: printed config does not read back"; }
  checks=$((checks + 1))
}

# program | a numeric option | its flag | a value outside its range | the range as printed
while IFS='|' read -r prog key flag bad range; do
  [ -n "$prog" ] || continue
  "$bin/$prog" --help > "$tmp/help.txt" || fail "$prog --help: exit $?"
  grep -q "^options (--set KEY=VALUE" "$tmp/help.txt" || fail "$prog --help: no options table"
  grep -Eq "^  $key +[^ ]" "$tmp/help.txt" || fail "$prog --help: $key not listed"
  reads_back "$prog"
  [ "$bad" = - ] || refused "^evermap-[a-z0-9-]+: bad --set: option $key: $bad is outside $range" \
    "$bin/$prog" --set "$key=$bad" --print-config
  [ "$flag" = - ] || refused "^evermap-[a-z0-9-]+: bad $flag: $bad is outside $range" \
    "$bin/$prog" "$flag" "$bad" --print-config
  checks=$((checks + 1))
done <<'TABLE'
evermap-stereo-check|step|--step|0|>= 1
evermap-vo-run|search_radius|--search-radius|0|> 0
evermap-map-render|width_px|--width|0|\[16, 20000\]
evermap-eval|max_dt_s|--max-dt|0|> 0
evermap-pipeline-eval|max_ate_m|--max-ate|-1|>= 0
evermap-place-eval|candidates|--candidates|0|>= 1
evermap-vocab-train|levels|--levels|11|\[1, 8\]
evermap-lcm-check|idle_timeout_s|--idle-timeout-s|0|> 0
evermap-lcm-fuzz|rate_hz|--rate-hz|-1|\[0, (1e\+07|10000000)\]
evermap-viewer-graph-pub|rate_hz|--rate-hz|2000|\(0, 1000\]
evermap-deputy|max_log_mb|--max-log-mb|0|> 0
evermap-deputy-ctl|timeout_s|--timeout-s|0|> 0
evermap-solver|wildfire|--wildfire|-1|>= 0
evermap-euroc2lcm|raw|-|-|-
evermap-log-recode|encoding|-|-|-
evermap-kitti2lcm|disparity_offset_px|--disparity-offset|2000|\[-1000, 1000\]
evermap-tum2lcm|max_difference_s|--max-difference|0|> 0
evermap-imu-elevator-run|max_ride_s|-|-1|> 0
evermap-landmark-graph|poses|-|1|>= 2
TABLE

# The simulators and the runners read one config file with keys of several parts: their
# --help lists the keys, --print-config prints what a --config file sets, read back the same.
for prog in evermap-sim-measure evermap-mapper-run; do
  "$bin/$prog" --help > "$tmp/help.txt"
  grep -Eq "^  patrol.sessions +14 " "$tmp/help.txt" || fail "$prog --help: no patrol.sessions"
  reads_back "$prog" --config "$src/config/sim-small.conf"
done
grep -Eq "^  mapper\.map_gate " "$tmp/help.txt" || fail "mapper-run --help: no mapper.map_gate"
reads_back evermap-sim-render --config "$src/config/sim-image-3floor.conf"
reads_back evermap-slam-run --set mapper.map_gate=20
refused "sim-small.conf.*option patrol.sessions: 0 is outside >= 1|option patrol.sessions: 0 is outside >= 1" \
  "$bin/evermap-sim-measure" --config "$src/config/sim-small.conf" --set patrol.sessions=0 --stats
refused "option render.rate_hz: 0 is outside \(0, 1000\]" \
  "$bin/evermap-sim-render" --config "$src/config/sim-image-3floor.conf" --set render.rate_hz=0 --stats

echo "OK: $checks checks of --help, --print-config and bad values over the programs under tools/"
