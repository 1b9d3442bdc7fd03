#!/usr/bin/env bash
# Senders and the key (issue 47, docs/lcm.md "Senders and the key"), in the LCM sandbox. A short
# simulated run (its logs carry the mapper's inputs: STEREO_CALIB, VO_DELTA, WHEEL_ODOM,
# ATTITUDE, FLOOR) is replayed by evermap-log-play into evermap-mapper-proc, three times:
#  1. control: with a key, nothing else on the network;
#  2. attacked: with the same key, while evermap-lcm-fuzz forges messages (no envelope) on every
#     input channel of the mapper, and afterwards lcm-logplayer replays what was captured of the
#     run's own signed traffic: every forgery is refused as unauthenticated, every replayed
#     message as replayed, and the map equals the control's;
#  3. no key, a second sender: evermap-lcm-fuzz on VO_DELTA once the mapper has locked onto the
#     player; its messages are ignored and counted, one line names it, the map equals the
#     control's.
# The maps are compared by evermap-pipeline-eval's whole output on the mapper's store (nodes,
# edges, floors, sessions, node ATE and its worst nodes): equal means every figure equal. Waits have generous time-outs against hangs; no speed is asserted.
source "$(dirname "$0")/lib.sh" "$@"
in_sandbox "$@"
speed="${EVERMAP_ENVELOPE_SPEED:-20}"
fail_logs=("$tmp/*.log"); fail_tail=20
keep_tmp="${EVERMAP_ENVELOPE_KEEP:-}"  # a folder the run, logs and maps are copied to
inputs="STEREO_CALIB,VO_DELTA,WHEEL_ODOM,ATTITUDE,FLOOR,REGISTER_RESULT"

"$bin/evermap-sim-measure" --config "$src/config/sim-small.conf" \
  --set patrol.total_hours="${EVERMAP_ENVELOPE_HOURS:-0.03}" --out "$tmp/run" > "$tmp/sim.txt" \
  || fail "simulator"
logs=("$tmp"/run/session-*.lcmlog)
(umask 077; head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$tmp/evermap.key")
key="$tmp/evermap.key"

mapper_pid=""
start_mapper() {  # NAME [FLAGS...]: mapper-proc writing $tmp/NAME.db, its output in NAME.log
  local name="$1"; shift
  "$bin/evermap-mapper-proc" --store "$tmp/$name.db" --graph-period-s 5 "$@" \
    > "$tmp/$name.log" 2>&1 &
  mapper_pid=$!
  kill_at_exit "$mapper_pid"
  sleep 1.5  # subscribed
}
stop_mapper() {  # NAME: SIGTERM, clean exit, then the map's figures in NAME.eval
  kill -TERM "$mapper_pid"
  local rc=0
  wait "$mapper_pid" || rc=$?
  [ "$rc" -eq 0 ] || fail "mapper-proc ($1) exited with $rc"
  "$bin/evermap-pipeline-eval" --run "$tmp/run" --store "$tmp/$1.db" --max-ate 100 \
    > "$tmp/$1.eval" || { cat "$tmp/$1.eval"; fail "evaluation of $1"; }
}
# The map's headline figures (the comparisons below are of the whole evaluation).
figures() { grep -E '^(nodes|floors|sessions|node_ate_rmse_m) ' "$tmp/$1.eval" | tr '\n' ' '; }
same_map() { cmp -s "$tmp/$1.eval" "$tmp/control.eval"; }
# The mapper's input summary ("input VO_DELTA 10 received, ...; ..."): the count of KIND
# ("from another sender") on CHANNEL, in the log NAME.
count() {
  { grep -o "[ ;] $2 [0-9]* received[^;]*" "$tmp/$1.log" || true; } |
    { grep -o "[0-9]* $3" || true; } | awk '{ s += $1 } END { print s + 0 }'
}

# 1. Control, with the key.
start_mapper control --key "$key"
"$bin/evermap-log-play" --key "$key" --speed "$speed" "${logs[@]}" > "$tmp/play-control.log" \
  || fail "log-play (control)"
sleep 1
stop_mapper control
echo "control: $(figures control)"
[ "$(value nodes "$tmp/control.eval")" -ge 10 ] || fail "the control map has too few nodes"

# 2. Attacked, with the key: forgeries during the replay, a replay of the capture after it.
start_mapper attacked --key "$key"
lcm-logger -q -f -c "${inputs//,/|}" "$tmp/capture.lcmlog" &
logger=$!
kill_at_exit "$logger"
"$bin/evermap-log-play" --key "$key" --speed "$speed" "${logs[@]}" > "$tmp/play-attacked.log" &
player=$!
kill_at_exit "$player"
"$bin/evermap-lcm-fuzz" --channels "$inputs" --count 300 --rate-hz 300 --seed 5 \
  --log "${logs[0]}" > "$tmp/fuzz.txt" || fail "fuzz sender"
wait "$player" || fail "log-play (attacked)"
sleep 1
kill -INT "$logger"; wait "$logger" || true
# The captured messages in an envelope (the player's; the capture holds forgeries too).
captured="$(python3 - "$tmp/capture.lcmlog" <<'PY'
import struct, sys
n = 0
with open(sys.argv[1], "rb") as f:
    while True:
        h = f.read(28)
        if len(h) < 28:
            break
        _, _, _, cl, dl = struct.unpack(">IqqII", h)
        f.read(cl)
        n += f.read(dl).endswith(b"evmenv01")
print(n)
PY
)"
lcm-logplayer -s 5 "$tmp/capture.lcmlog" > /dev/null || fail "replay of the capture"
sleep 1
stop_mapper attacked
unauthenticated="$(value unauthenticated "$tmp/attacked.log")"
replayed="$(value replayed "$tmp/attacked.log")"
echo "attacked: $(figures attacked)"
echo "attacked: $(cat "$tmp/fuzz.txt"); $unauthenticated refused as unauthenticated;" \
  "$captured captured messages replayed, $replayed refused as replayed"
[ "$unauthenticated" -ge 1500 ] || fail "only $unauthenticated forgeries refused (6 x 300 sent)"
[ "$replayed" -eq "$captured" ] || fail "$replayed of $captured replayed messages refused"
same_map attacked || fail "the attacked map differs from the control"

# 3. No key: a second sender on VO_DELTA once the mapper has locked onto the player.
start_mapper second
"$bin/evermap-log-play" --speed "$speed" "${logs[@]}" > "$tmp/play-second.log" &
player=$!
kill_at_exit "$player"
sleep 1
"$bin/evermap-lcm-fuzz" --channels VO_DELTA --count 300 --rate-hz 300 --seed 6 \
  --log "${logs[0]}" > "$tmp/fuzz-second.txt" || fail "second sender"
wait "$player" || fail "log-play (second sender)"
sleep 1
stop_mapper second
ignored="$(count second VO_DELTA 'from another sender')"
echo "second sender: $ignored of 300 VO_DELTA ignored; $(figures second)"
grep -m1 "VO_DELTA: ignoring anonymous, a second sender" "$tmp/second.log" | sed 's/^/  /' \
  || fail "no line names the second sender"
[ "$ignored" -eq 300 ] || fail "$ignored of 300 messages of the second sender ignored"
same_map second || fail "the map with a second sender differs from the control"
echo "PASS"
