#!/usr/bin/env bash
# Hostile input on the input channels of every process, in the LCM sandbox (issue 17): the two
# UDP packets that overflow LCM 1.3.1's fragment check, on every channel, then
# EVERMAP_FUZZ_COUNT (default 300; thousands on demand) mutated messages per channel
# (evermap-lcm-fuzz: byte flips, extreme lengths, truncation, extension, random bytes behind the
# right type hash). Every process must still be running afterwards and stop cleanly on SIGTERM;
# each prints what its input boundary received and dropped, and its peak RSS is printed.
# loopclose-proc joins when a vocabulary is given (EVERMAP_FUZZ_VOCAB=FILE.evoc); with
# EVERMAP_FUZZ_LOG=FILE.lcmlog the mutations start from that log's messages (real STEREO
# images, keyframes) instead of empty ones; EVERMAP_FUZZ_CHANNELS=A,B restricts the channels.
# Waits have generous time-outs against hangs; no speed is asserted.
source "$(dirname "$0")/lib.sh" "$@"
in_sandbox "$@"
count="${EVERMAP_FUZZ_COUNT:-300}"
rate="${EVERMAP_FUZZ_RATE_HZ:-3000}"
pids=()
names=()
fail_logs=("$tmp/*.log"); fail_tail=15
start() {  # NAME CMD...
  local name="$1"; shift
  "$@" > "$tmp/$name.log" 2>&1 &
  pids+=($!)
  kill_at_exit $!
  names+=("$name")
}
rss() { awk '/^VmHWM/ { print $2 }' "/proc/$1/status" 2>/dev/null || echo 0; }

cat > "$tmp/deputy.pmd" <<'PMD'
cmd "sleeper" { exec = "exec sleep 100000"; host = "sandbox"; }
PMD
start vo-proc "$bin/evermap-vo-proc" --ready-file "$tmp/vo.ready"
start imu-proc "$bin/evermap-imu-proc"
start elevator-proc "$bin/evermap-elevator-proc"
start mapper-proc "$bin/evermap-mapper-proc" --store "$tmp/map.db"
start deputy "$bin/evermap-deputy" "$tmp/deputy.pmd" --host sandbox --log-dir "$tmp/deputy-logs"
channels="STEREO,STEREO_CALIB,RGBD,RGBD_CALIB,IMU,ATTITUDE,VO_DELTA,WHEEL_ODOM,FLOOR,REGISTER_RESULT,DEPUTY_ORDER,KEYFRAME_REQUEST"
if [ -n "${EVERMAP_FUZZ_VOCAB:-}" ]; then
  start loopclose-proc "$bin/evermap-loopclose-proc" --vocab "$EVERMAP_FUZZ_VOCAB"
  channels="$channels,KEYFRAME,KEYFRAME_PART,NODE_ADDED,REGISTER_REQUEST,MAP_GRAPH"
fi
for _ in $(seq 600); do [ -f "$tmp/vo.ready" ] && break; sleep 0.1; done
[ -f "$tmp/vo.ready" ] || fail "vo-proc did not start"
sleep 2  # the others subscribe at start; a late one only sees fewer messages

declare -A before
for i in "${!pids[@]}"; do before[${names[$i]}]="$(rss "${pids[$i]}")"; done

# 1. The fragment overflow, twice on every channel.
"$bin/evermap-lcm-fuzz" --channels "$channels" --fragment-attack > "$tmp/fragments.txt" || fail "fragment attack"
"$bin/evermap-lcm-fuzz" --channels "$channels" --fragment-attack --seed 2 >> "$tmp/fragments.txt" || fail "fragment attack"
sleep 1
for i in "${!pids[@]}"; do
  kill -0 "${pids[$i]}" 2>/dev/null || fail "${names[$i]} died of the fragment attack"
done
echo "fragments: $(awk '{ s += $2 } END { print s }' "$tmp/fragments.txt") packets sent, every process alive"

# 2. Mutated messages on every channel.
[ -n "${EVERMAP_FUZZ_CHANNELS:-}" ] && channels="$EVERMAP_FUZZ_CHANNELS"
"$bin/evermap-lcm-fuzz" --channels "$channels" --count "$count" --rate-hz "$rate" --seed 17 \
  ${EVERMAP_FUZZ_LOG:+--log "$EVERMAP_FUZZ_LOG"} > "$tmp/fuzz.txt" || fail "fuzz sender"
sleep 2
for i in "${!pids[@]}"; do
  kill -0 "${pids[$i]}" 2>/dev/null || fail "${names[$i]} died of the fuzzed messages"
done
echo "fuzz: $(cat "$tmp/fuzz.txt") ($count per channel on $channels)"

# 3. Peak memory, then a clean stop with the boundary's counts.
for i in "${!pids[@]}"; do
  echo "${names[$i]}: peak RSS $(( ${before[${names[$i]}]} / 1024 )) MB before, $(( $(rss "${pids[$i]}") / 1024 )) MB after"
done
for i in "${!pids[@]}"; do kill -TERM "${pids[$i]}"; done
for i in "${!pids[@]}"; do
  rc=0
  wait "${pids[$i]}" || rc=$?
  [ "$rc" -eq 0 ] || fail "${names[$i]} exited with $rc"
done
pids=()
grep -h ": input: " "$tmp"/*.log | sed 's/^/  /'
grep -E "^(received_[A-Z_]+|undecodable|time_refused|handler_failed|refused|implausible_[a-z]+) " "$tmp/mapper-proc.log" \
  | tr '\n' ' ' | sed 's/^/  evermap-mapper-proc: /; s/$/\n/'
# loopclose-proc's own counts: places taken and NODE_ADDED refused (implausible, over capacity).
[ -f "$tmp/loopclose-proc.log" ] && grep -h "^loopclose-proc: keyframes" "$tmp/loopclose-proc.log" | sed 's/^/  /'
awk '/LCM fragment/ && n++ < 3 { print "  " $0 }' "$tmp"/*.log  # (head would break the pipe)
echo "PASS"
