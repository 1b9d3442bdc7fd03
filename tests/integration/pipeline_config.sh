#!/usr/bin/env bash
# What the processes run with under the deputy: every config/pipeline-*.pmd starts each process
# with --config ${EVERMAP_CONFIG:-config}/<process>.cfg. The five processes of
# config/pipeline-log.pmd are started by evermap-deputy in the LCM sandbox (no log replayed):
#  1. with a folder of settings that differ from the defaults, each process's log names them;
#  2. with the shipped folder (config/), no process runs with an option off its default;
#  3. a key vo-proc does not know stops it with one line naming the file and line.
# Waits have generous time-outs against hangs; no speed is asserted.
source "$(dirname "$0")/lib.sh" "$@"
in_sandbox "$@"
fail_logs=("$tmp/logs-*/*.log" "$tmp/deputy-*.err")
procs="vo-proc imu-proc elevator-proc mapper-proc loopclose-proc"

# pipeline CONFIG_DIR NAME: the "pipeline" script of config/pipeline-log.pmd (the five
# processes, no replay) until each has started, then the deputy stopped; CONFIG_DIR empty: the
# default (config/ of the repository root, where the deputy runs). The processes' logs go to
# $tmp/logs-NAME.
pipeline() {
  local logs="$tmp/logs-$2" p
  (cd "$src" && if [ -n "$1" ]; then export EVERMAP_CONFIG="$1"; else unset EVERMAP_CONFIG; fi &&
    EVERMAP_BIN="$bin" EVERMAP_MAP="$tmp/map-$2.db" \
    EVERMAP_VOCAB="$tmp/no-vocabulary.evoc" EVERMAP_PLACES="$tmp/places-$2.db" \
    exec "$bin/evermap-deputy" config/pipeline-log.pmd --log-dir "$logs" --host sandbox \
    --script pipeline --quiet 2> "$tmp/deputy-$2.err") &
  local dpid=$!
  kill_at_exit "$dpid"
  # Each reads its options first thing (loopclose-proc, without a vocabulary here, then stops
  # and is respawned).
  for p in $procs; do
    for _ in $(seq 300); do
      grep -q "started pid" "$logs/$p.log" 2> /dev/null && break
      sleep 0.2
    done
    grep -q "started pid" "$logs/$p.log" 2> /dev/null || fail "$2: $p was not started"
  done
  sleep 2
  kill -TERM "$dpid"
  wait "$dpid" || fail "$2: the deputy did not stop cleanly"
}

# 1. Settings that differ from the defaults, one per process.
mkdir -p "$tmp/changed"
cp "$src"/config/{vo-proc,imu-proc,elevator-proc,mapper-proc,loopclose-proc}.cfg "$tmp/changed/"
echo "odometry.line_delay_us = 28.3" >> "$tmp/changed/vo-proc.cfg"
echo "publish_rate_hz = 25" >> "$tmp/changed/imu-proc.cfg"
echo "max_ride_s = 200" >> "$tmp/changed/elevator-proc.cfg"
echo "mapper.overlap_radius_cells = 2" >> "$tmp/changed/mapper-proc.cfg"
echo "max_places = 5000" >> "$tmp/changed/loopclose-proc.cfg"
pipeline "$tmp/changed" changed
while read -r p setting; do
  line="$(grep -m 1 "^evermap-$p: options not at their defaults" "$tmp/logs-changed/$p.log" || true)"
  [ -n "$line" ] || fail "$p's log does not say which options differ from the defaults"
  echo "$line"
  [[ "$line" == *": $setting ($tmp/changed/$p.cfg)" ]] ||
    fail "$p does not run with its config file's $setting"
done <<'LIST'
vo-proc odometry.line_delay_us = 28.3
imu-proc publish_rate_hz = 25
elevator-proc max_ride_s = 200
mapper-proc mapper.overlap_radius_cells = 2
loopclose-proc max_places = 5000
LIST
grep -q "^evermap-vo-proc: input: " "$tmp/logs-changed/vo-proc.log" ||
  fail "vo-proc did not run with its settings (no summary at its stop)"

# 2. The shipped settings (EVERMAP_CONFIG unset) are the defaults.
pipeline "" shipped
for p in $procs; do
  [ -s "$tmp/logs-shipped/$p.log" ] || fail "no log of $p"
  if grep -q "options not at their defaults" "$tmp/logs-shipped/$p.log"; then
    fail "$p runs with options off their defaults from config/$p.cfg"
  fi
done
echo "config/: every process at its defaults"

# 3. A key vo-proc does not know: one line naming the file and the line; it does not run.
mkdir -p "$tmp/bad"
cp "$src"/config/*-proc.cfg "$tmp/bad/"
echo "odometry.line_delay = 28.3" >> "$tmp/bad/vo-proc.cfg"
pipeline "$tmp/bad" bad
bad_line="$(wc -l < "$tmp/bad/vo-proc.cfg")"
grep -m 1 "vo-proc.cfg:$bad_line" "$tmp/logs-bad/vo-proc.log" | grep -q "odometry.line_delay" ||
  fail "vo-proc does not name $tmp/bad/vo-proc.cfg:$bad_line and the unknown key"
grep -m 1 "vo-proc.cfg:$bad_line" "$tmp/logs-bad/vo-proc.log"
if grep -q "^evermap-vo-proc: input: " "$tmp/logs-bad/vo-proc.log"; then
  fail "vo-proc ran with a config file it could not read"
fi
echo "pipeline config: ok"
