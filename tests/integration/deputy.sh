#!/usr/bin/env bash
# The deputy as users run it, in the LCM sandbox (real UDP multicast on a private loopback):
# evermap-deputy supervises real processes and evermap-deputy-ctl operates it. A child killed
# with SIGKILL is restarted (seen through the ctl tool), groups stop and start by order,
# output arrives on DEPUTY_OUTPUT, and SIGTERM to the deputy leaves no child behind.
# Waits have generous time-outs against hangs; no speed is asserted.
source "$(dirname "$0")/lib.sh" "$@"
in_sandbox "$@"
deputy="$build/bin/evermap-deputy"
ctl="$build/bin/evermap-deputy-ctl"
fail_logs=("$tmp/deputy.err")

cat > "$tmp/test.pmd" <<'EOF'
group "workers" {
    cmd "sleeper" { exec = "sleep 1000"; auto_respawn = "true"; host = "sandbox"; }
    cmd "ticker" {
        exec = "while :; do echo tick; sleep 0.2; done";
        host = "sandbox";
        stop_signal = 15;
    }
}
cmd "elsewhere" { exec = "sleep 1000"; host = "other-host"; }
script "go" {
    start group "workers" wait "running";
}
EOF
"$deputy" --check "$tmp/test.pmd" --host sandbox | grep -q '3 commands (2 for host "sandbox")' \
  || fail "--check summary"

"$deputy" "$tmp/test.pmd" --log-dir "$tmp/logs" --host sandbox --script go \
  --backoff-initial-ms 100 2> "$tmp/deputy.err" &
dpid=$!
kill_at_exit "$dpid"

# Column of `status --tsv`: 1 HOST 2 NAME 3 GROUP 4 STATE 5 DESIRED 6 PID 7 CPU% 8 RSS_MB
# 9 RESTARTS 10 LAST_EXIT.

"$ctl" --host sandbox --timeout-s 60 wait running group workers > /dev/null \
  || fail "workers not running"
status
[ "$(field sleeper 3)" = "workers" ] || fail "group of sleeper"
[ -z "$(field elsewhere 2)" ] || fail "a command of another host is supervised here"
pid="$(field sleeper 6)"
[ "$pid" -gt 0 ] || fail "no pid for sleeper"

# 1. A child killed with SIGKILL comes back: new pid, one restart, last exit -9.
kill -KILL "$pid"
wait_until 60 restarted_after_kill sleeper "$pid" || fail "sleeper was not restarted after SIGKILL"
echo "sleeper: pid $pid killed, restarted as $(field sleeper 6), restarts $(field sleeper 9)"
grep -q "ended: killed by signal 9" "$tmp/logs/sleeper.log" || fail "sleeper.log lacks the kill"
grep -q "restarted pid" "$tmp/logs/sleeper.log" || fail "sleeper.log lacks the restart"

# 2. Output: in the log file, and on DEPUTY_OUTPUT.
grep -q "^tick$" "$tmp/logs/ticker.log" || fail "ticker.log has no output"
timeout 5 "$ctl" output ticker > "$tmp/output.txt" || true
grep -q "^\[sandbox/ticker\] tick$" "$tmp/output.txt" || fail "no ticker output on DEPUTY_OUTPUT"

# 3. Orders by group and by name.
pids="$(field sleeper 6) $(field ticker 6)"
"$ctl" --host sandbox --timeout-s 30 stop group workers > /dev/null || fail "stop order"
"$ctl" --host sandbox --timeout-s 60 wait stopped workers > /dev/null || fail "workers did not stop"
status
[ "$(field sleeper 5)" = stop ] && [ "$(field sleeper 6)" = 0 ] || fail "sleeper still running"
"$ctl" --host sandbox --timeout-s 30 start ticker > /dev/null || fail "start order"
"$ctl" --host sandbox --timeout-s 60 wait running cmd ticker > /dev/null || fail "ticker did not start"
status
[ "$(field sleeper 4)" = stopped ] || fail "sleeper started with the ticker"
set +e
"$ctl" --host sandbox --timeout-s 30 start nothing 2> "$tmp/err.txt"; rc=$?
set -e
[ "$rc" -eq 1 ] && grep -q 'no command or group "nothing"' "$tmp/err.txt" || fail "unknown target gave $rc"

# 4. SIGTERM to the deputy: every child stops, the deputy exits 0.
pids="$pids $(field ticker 6)"
kill -TERM "$dpid"
rc=0; wait "$dpid" || rc=$?
[ "$rc" -eq 0 ] || fail "deputy exited with $rc after SIGTERM"
for p in $pids; do
  for _ in $(seq 600); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
  ! kill -0 "$p" 2>/dev/null || fail "pid $p outlived the deputy"
done
grep -q "all stopped" "$tmp/deputy.err" || fail "no clean-stop summary"
echo "OK: deputy restarts a killed child, obeys orders, publishes output, stops cleanly"
