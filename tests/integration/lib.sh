# Sourced by the integration tests (tests/integration/*.sh; not a test itself, tests/CMakeLists.txt
# leaves it out), first thing:   source "$(dirname "$0")/lib.sh" "$@"
# Sets build, src (the two arguments every test takes), bin, data (EVERMAP_DATA, else the
# default beside the repository) and tmp (a folder removed when the script exits, after the
# background processes given to kill_at_exit are stopped), and the checks the tests share.
set -euo pipefail
build="$1"; src="$2"; bin="$build/bin"
data="${EVERMAP_DATA:-${EVERMAP_DATA_DEFAULT:-$src/../shared/data}}"
tmp="$(mktemp -d)"
at_exit_pids=()
keep_tmp=""      # a folder the contents of $tmp are copied to at exit (for a look after a run)
fail_logs=()     # glob patterns of the logs whose last lines fail() shows
fail_tail=30

# kill_at_exit PID: a background process stopped when the script exits (TERM, then KILL after
# 2 s).
kill_at_exit() { at_exit_pids+=("$1"); }

cleanup() {
  local p i
  for p in "${at_exit_pids[@]}"; do kill -TERM "$p" 2> /dev/null || true; done
  for i in $(seq 20); do
    for p in "${at_exit_pids[@]}"; do kill -0 "$p" 2> /dev/null && break; p=""; done
    [ -z "${p:-}" ] && break
    sleep 0.1
  done
  for p in "${at_exit_pids[@]}"; do kill -KILL "$p" 2> /dev/null || true; done
  if [ -n "$keep_tmp" ]; then mkdir -p "$keep_tmp" && cp -r "$tmp"/. "$keep_tmp"/ || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT

# in_sandbox "$@": runs this script again inside the LCM sandbox (private network namespace).
in_sandbox() {
  if [ "${EVERMAP_LCM_SANDBOX:-}" != "1" ]; then
    rm -rf "$tmp"
    exec "$src/scripts/lcm-sandbox" bash "$0" "$@"
  fi
}

# need_data PATH...: each PATH (below $data unless absolute) must exist, else the test is
# skipped (exit 77), or fails under CI.
need_data() {
  local p
  for p in "$@"; do
    [[ "$p" = /* ]] || p="$data/$p"
    if [ ! -e "$p" ]; then
      echo "$p not found (set EVERMAP_DATA)"
      [ "${CI:-}" = "true" ] && exit 1
      exit 77
    fi
  done
}

fail() {
  echo "FAIL: $*" >&2
  local pattern f
  for pattern in "${fail_logs[@]}"; do
    for f in $pattern; do
      if [ -f "$f" ]; then { echo "--- $f"; tail -n "$fail_tail" "$f"; } >&2; fi
    done
  done
  exit 1
}
expect_line() {  # expect_line FILE REGEX
  grep -Eq "$2" "$1" || { cat "$1" >&2; fail "no line matching '$2'"; }
}
# Nothing outside the repository: EVERMAP_DATA an empty folder (as for anyone who clones the
# repository alone), and the project's own vocabulary (scripts/make-vocab.sh) in $tmp/sim.evoc.
without_data_folder() {
  mkdir "$tmp/no-data"
  export EVERMAP_DATA="$tmp/no-data"
  BUILD_DIR="$build" bash "$src/scripts/make-vocab.sh" "$tmp/sim.evoc" > "$tmp/vocab.txt" \
    || { cat "$tmp/vocab.txt"; fail "scripts/make-vocab.sh"; }
}
# map_rendered_session0 OUT SECONDS: evermap-slam-run maps the first SECONDS of session 0 of
# the rendered 3-floor building into OUT with its place store (--places).
map_rendered_session0() {
  "$bin/evermap-slam-run" --vocab "$tmp/sim.evoc" --out "$1" --places \
    --render "$src/config/sim-image-3floor.conf" --render-set "render.max_duration_s=$2" \
    --sessions 1 > "$tmp/slam.txt" 2>&1 || { tail -20 "$tmp/slam.txt"; fail "evermap-slam-run"; }
}
value() { awk -v k="$1" '$1 == k { print $2; exit }' "$2"; }  # value KEY FILE: "KEY VALUE" lines

# The deputy's status (evermap-deputy-ctl status --tsv, host "sandbox") in $tmp/status.tsv;
# field NAME COLUMN reads it (2 NAME, 3 GROUP, 4 STATE, 6 PID, 9 RESTARTS, 10 LAST_EXIT).
status() {
  "$bin/evermap-deputy-ctl" --host sandbox --timeout-s 30 status --tsv > "$tmp/status.tsv" \
    2> /dev/null
}
field() { awk -F'\t' -v n="$1" -v c="$2" 'NR > 1 && $2 == n { print $c }' "$tmp/status.tsv"; }
wait_until() {  # SECONDS COMMAND...: polls the status until COMMAND succeeds
  local end=$((SECONDS + $1)); shift
  while [ "$SECONDS" -lt "$end" ]; do
    status && "$@" && return 0
    sleep 0.2
  done
  return 1
}
# respawned NAME OLD_PID: NAME runs again, under another pid.
respawned() { [ "$(field "$1" 4)" = running ] && [ "$(field "$1" 6)" != "$2" ]; }
# restarted_after_kill NAME OLD_PID: respawned, restarted at least once, last exit SIGKILL (-9).
restarted_after_kill() {
  respawned "$1" "$2" && [ "$(field "$1" 9)" -ge 1 ] && [ "$(field "$1" 10)" = "-9" ]
}

# vo_proc_live NAME LOG CHANNELS FRAMES [VO_ARGS [SPEED [REACH]]]: evermap-vo-proc (with VO_ARGS)
# inside the LCM sandbox while lcm-logplayer replays CHANNELS of LOG in real time (or at SPEED x;
# stopped after 15 s); checks that each frame vo-proc received was processed or counted (and
# named) as dropped, that the FRAMES frames were all received or counted lost on the way (by
# LCM's queue, or by the kernel as UDP receive errors of the sandbox: at 20x a starved receive
# thread lets the socket buffer overflow), that at least REACH % of them (default 90) reached
# vo-proc, at least 10 processed, and that VO_DELTA/KEYFRAME arrived. Sets vo_summary, vo_frames
# and vo_dropped; vo-proc's output is in $tmp/proc.txt.
vo_proc_live() {
  local name="$1" log="$2" channels="$3" want="$4" vo_args="${5:-}" speed="${6:-1}"
  local reach="${7:-90}"
  "$src/scripts/lcm-sandbox" bash -c '
    set -euo pipefail
    rm -f "$3" "$2/live.lcmlog"
    # shellcheck disable=SC2086  # the extra arguments are words
    "$1/bin/evermap-vo-proc" --ready-file "$3" $6 2> "$2/proc.txt" &
    proc=$!
    lcm-logger -q -c "VO_DELTA|KEYFRAME" "$2/live.lcmlog" &
    logger=$!
    for _ in $(seq 300); do [ -f "$3" ] && break; sleep 0.1; done
    sleep 0.5
    timeout 15 lcm-logplayer -s "$7" -e "$5" "$4" > /dev/null || true
    sleep 2
    kill -TERM "$proc"; wait "$proc"
    kill -INT "$logger"; wait "$logger" || true
    # The sandbox network namespace'"'"'s UDP receive-buffer overflows (vo-proc'"'"'s and the
    # logger'"'"'s sockets: evidence that the kernel dropped datagrams here, not whose).
    awk '"'"'/^Udp:/ { if (!h) { split($0, k); h = 1 } else { split($0, v); for (i = 2; i <= NF; i++) if (k[i] == "RcvbufErrors") e += v[i] } } END { print e + 0 }'"'"' /proc/net/snmp > "$2/udp_errors.txt"
  ' "$name" "$build" "$tmp" "$tmp/ready" "$log" "$channels" "$vo_args" "$speed"
  tail -n 3 "$tmp/proc.txt"
  vo_summary="$(grep -E '^evermap-vo-proc: [0-9]+ frames' "$tmp/proc.txt")" ||
    fail "no summary line"
  vo_frames="$(sed -E 's/^evermap-vo-proc: ([0-9]+) frames.*/\1/' <<< "$vo_summary")"
  vo_dropped="$(sed -E 's/.*; ([0-9]+) frames dropped.*/\1/' <<< "$vo_summary")"
  # The frames that reached vo-proc (STEREO or RGBD in its input line), and those LCM's queue
  # dropped before (core/messages/inbox.cpp): every one received is processed or dropped.
  local input received queue_lost udp_errors lost
  input="$(grep -E '^evermap-vo-proc: input: ' "$tmp/proc.txt")" || fail "no input line"
  # One record per channel ("; "): "NAME N received, ..., M dropped by LCM's full queue".
  read -r received queue_lost < <(awk -v RS='; ' '{
    for (c = 1; c + 2 <= NF; c++) if (($c == "STEREO" || $c == "RGBD") && $(c + 2) == "received,") break
    if (c + 2 > NF) next
    r += $(c + 1)
    for (i = c; i + 3 <= NF; i++) if ($(i + 1) == "dropped" && $(i + 2) == "by" && $(i + 3) == "LCM\x27s") q += $i
  } END { print r + 0, q + 0 }' <<< "$input")
  [ "$((vo_frames + vo_dropped))" = "$received" ] ||
    fail "$vo_frames processed + $vo_dropped dropped != $received frames received"
  # What never reached it was counted on the way, and is a small part.
  udp_errors="$(cat "$tmp/udp_errors.txt")"
  lost=$((want - received - queue_lost))
  if [ "$lost" -gt 0 ] && [ "$udp_errors" = 0 ]; then
    fail "$lost of $want frames never reached vo-proc, and the kernel counted no UDP receive error"
  fi
  [ "$lost" -ge 0 ] || fail "$received frames received + $queue_lost lost in LCM's queue, of $want sent"
  [ "$((100 * received))" -ge "$((reach * want))" ] ||
    fail "only $received of $want frames reached vo-proc ($queue_lost dropped by LCM's queue, $udp_errors UDP receive errors)"
  [ "$received" = "$want" ] ||
    echo "$((want - received)) of $want frames lost before vo-proc: $queue_lost by LCM's queue, $lost by the kernel ($udp_errors UDP receive errors, packets)"
  # Each frame dropped is named by its time, one line each (evermap-slam-run --drop-utimes).
  local named
  named="$(grep -c '^evermap-vo-proc: dropped behind the queue: frame [0-9]*$' "$tmp/proc.txt" || true)"
  [ "$named" = "$vo_dropped" ] || fail "$vo_dropped frames dropped, $named named in the log"
  [ "$vo_frames" -ge 10 ] || fail "only $vo_frames frames processed"
  [ -s "$tmp/live.lcmlog" ] || fail "nothing received on VO_DELTA/KEYFRAME"
}
