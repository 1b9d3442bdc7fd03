#!/usr/bin/env bash
# The live multi-process pipeline in the LCM sandbox (docs/pipeline.md): a short simulated
# 3-floor, 2-session run is written, evermap-deputy runs config/pipeline-oracle.pmd
# (mapper-proc + the registration oracle) while lcm-logplayer replays the run at
# EVERMAP_PIPELINE_SPEED (default 20x) and lcm-logger records what the mapper publishes.
# Mid-replay the oracle is killed with SIGKILL; the deputy must restart it (seen through
# evermap-deputy-ctl), the restarted oracle must learn the nodes from the mapper's store, and
# the run must finish. Then: every odometry message of the log reached the mapper, nothing
# was undecodable, and the final MAP_GRAPH is checked against ground truth with
# evermap-pipeline-eval (ATE limit: see docs/pipeline.md). Prints the replay's real-time factor.
# On demand, EVERMAP_PIPELINE_KILL_MAPPER=N SIGKILLs mapper-proc N times instead, evenly over
# the replay (with EVERMAP_PIPELINE_HOURS=1, a longer run: kills about 15 s apart, beyond the
# deputy's 10 s after which a process counts as stable and its restart delay is 250 ms again) (issue 17: each restart resumes from the store, relocalises and maps on); the
# final map's figures are then to be compared with a run without kills (docs/reliability.md).
source "$(dirname "$0")/lib.sh" "$@"
in_sandbox "$@"
speed="${EVERMAP_PIPELINE_SPEED:-20}"
# Node ATE limit, metres: the offline runner's node ATE on this run is 0.116 m; live runs
# measured 0.06-0.17 m at 20x-400x, with and without the kill (registrations lost while the
# oracle is down, answers later than offline; docs/pipeline.md). 0.4 m is 3.5x the offline
# figure; a broken map (floors mixed up, a false match accepted, a lost session) is metres off.
max_ate="${EVERMAP_PIPELINE_MAX_ATE:-0.4}"
ctl="$bin/evermap-deputy-ctl"
# EVERMAP_PIPELINE_KEEP=DIR: the run, the logs, the store and the recording are kept there.
keep_tmp="${EVERMAP_PIPELINE_KEEP:-}"
fail_logs=("$tmp/logs/*.log" "$tmp/deputy.err")

# 1. A short run: 3 floors, 2 sessions, about 15 simulated minutes (45 s at 20x).
"$bin/evermap-sim-measure" --config "$src/config/sim-small.conf" --set patrol.total_hours="${EVERMAP_PIPELINE_HOURS:-0.06}" \
  --out "$tmp/run" > "$tmp/sim.txt" || fail "simulator"
sim_s="$(awk -F'[ =]+' '/^meta.session\./ { for (i = 1; i < NF; i++) { if ($i == "start_utime") s = $(i+1);
          if ($i == "end_utime") e = $(i+1) } t += (e - s) / 1e6 } END { printf "%.1f", t }' "$tmp/run/run.sim.txt")"
meta() { awk -F' = ' -v k="meta.messages.$1" '$1 == k { print $2 }' "$tmp/run/run.sim.txt"; }
echo "run: $sim_s simulated s, $(ls "$tmp"/run/*.lcmlog | wc -l) session logs"

# 2. Record what the mapper publishes, then run the pipeline under the deputy.
lcm-logger -q -f -c 'MAP_GRAPH|MAPPER_STATS|POSE' "$tmp/mapper.lcmlog" &
lpid=$!
kill_at_exit "$lpid"
(cd "$src" && EVERMAP_BIN="$bin" EVERMAP_RUN="$tmp/run" EVERMAP_MAP="$tmp/map.db" EVERMAP_SPEED="$speed" \
  EVERMAP_GRAPH_PERIOD_S=5 exec "$bin/evermap-deputy" config/pipeline-oracle.pmd --log-dir "$tmp/logs" \
  --host sandbox --script replay --exit-after-script --quiet 2> "$tmp/deputy.err") &
dpid=$!
kill_at_exit "$dpid"

playing() { [ "$(field player 4)" = running ]; }
wait_until 60 playing || fail "the player did not start"

# 3. A third into the replay, SIGKILL the oracle; the deputy restarts it. (EVERMAP_PIPELINE_KILL=0
# skips this, to measure the replay speed the pipeline keeps up with.)
kill_mapper="${EVERMAP_PIPELINE_KILL_MAPPER:-0}"
kill_oracle="${EVERMAP_PIPELINE_KILL:-1}"
[ "$kill_mapper" -gt 0 ] && kill_oracle=0
for ((k = 1; k <= kill_mapper; k++)); do
  sleep "$(awk -v s="$sim_s" -v x="$speed" -v n="$kill_mapper" 'BEGIN { printf "%.1f", s / x / (n + 2) }')"
  status || continue  # the deputy busy: the next interval
  pid="$(field mapper-proc 6)"
  playing || { echo "the replay ended after $((k - 1)) kills"; break; }
  [ -n "$pid" ] && [ "$pid" -gt 0 ] || continue  # between a kill and its restart
  kill -KILL "$pid"
  wait_until 30 respawned mapper-proc "$pid" || { playing || break; fail "mapper-proc was not restarted after SIGKILL $k"; }
  echo "mapper-proc: kill $k, pid $pid, restarted as $(field mapper-proc 6) (restarts $(field mapper-proc 9))"
done
if [ "$kill_oracle" = 1 ]; then
sleep "$(awk -v s="$sim_s" -v x="$speed" 'BEGIN { printf "%.1f", s / x / 3 }')"
status
pid="$(field sim-oracle 6)"
[ -n "$pid" ] && [ "$pid" -gt 0 ] || fail "no pid for sim-oracle"
playing || fail "the replay ended before the kill (raise the speed's divisor)"
kill -KILL "$pid"
wait_until 30 restarted_after_kill sim-oracle "$pid" || fail "sim-oracle was not restarted after SIGKILL"
echo "sim-oracle: pid $pid killed, restarted as $(field sim-oracle 6)"
fi

# 4. The run finishes: the script stops the pipeline after the replay, the deputy exits 0.
rc=0
wait "$dpid" || rc=$?
[ "$rc" -eq 0 ] || fail "deputy exited with $rc"
sleep 0.5
kill -INT "$lpid"; wait "$lpid" || true

logs="$tmp/logs"
if [ "$kill_oracle" = 1 ]; then
  grep -q "ended: killed by signal 9" "$logs/sim-oracle.log" || fail "sim-oracle.log lacks the kill"
  # The restarted oracle knew the nodes announced before it started.
  told="$(grep -o 'keyframes known, [0-9]* nodes from the map store' "$logs/sim-oracle.log" | tail -1 | awk '{ print $3 }')"
  [ -n "$told" ] && [ "$told" -gt 0 ] || fail "the restarted oracle read no nodes from the map store"
  echo "restarted oracle: $told nodes read from the map store"
fi
if [ "$kill_mapper" -gt 0 ]; then
  echo "mapper-proc started $(grep -c 'started pid' "$logs/mapper-proc.log") times;" \
    "relocalisations: $(awk '$1 == "relocalizations" { s += $2 } END { print s + 0 }' "$logs/mapper-proc.log");" \
    "warm restarts: $(grep -c ': warm restart: ' "$logs/mapper-proc.log")" \
    "(bridged by VO's odometry: $(grep -c ': warm restart: .*(bridged by odometry' "$logs/mapper-proc.log")," \
    "by the wheels': $(grep -c ': warm restart: .*(bridged by wheel odometry' "$logs/mapper-proc.log"))," \
    "lost restarts: $(grep -c ': lost restart: ' "$logs/mapper-proc.log")"
  grep -o '[a-z]* restart: [0-9.]* s of message time.*' "$logs/mapper-proc.log" | sed 's/^/  /' || true
else
# The mapper ran once, start to end, and saw every odometry message of the log.
[ "$(grep -c 'started pid' "$logs/mapper-proc.log")" -eq 1 ] || fail "mapper-proc was restarted"
for ch in VO_DELTA WHEEL_ODOM ATTITUDE FLOOR; do
  got="$(awk -v k="received_$ch" '$1 == k { print $2 }' "$logs/mapper-proc.log")"
  [ "$got" = "$(meta "$ch")" ] || fail "$ch: mapper received ${got:-0} of $(meta "$ch")"
done
fi
grep -q '^undecodable 0$' "$logs/mapper-proc.log" || fail "undecodable messages reached the mapper"
sed -n 's/^\(steps\|nodes\|loop_closures\|timeouts\|dropped\|store_transactions\) /mapper \1 /p' "$logs/mapper-proc.log"
player_s="$(grep -o 'ended: exit code 0 after [0-9.]* s' "$logs/player.log" | awk '{ print $6 }')"
[ -n "$player_s" ] || fail "the player did not finish cleanly"
echo "replay: $sim_s simulated s in $player_s s at -s $speed: real-time factor $(awk -v a="$sim_s" -v b="$player_s" 'BEGIN { printf "%.1f", a / b }')"

# 5. The final map against ground truth.
"$bin/evermap-pipeline-eval" --run "$tmp/run" --log "$tmp/mapper.lcmlog" --max-ate "$max_ate" > "$tmp/eval.txt" \
  || { cat "$tmp/eval.txt"; fail "evaluation"; }
cat "$tmp/eval.txt"
nodes="$(awk '$1 == "nodes" { print $2 }' "$tmp/eval.txt")"
[ "$nodes" -ge 30 ] || fail "only $nodes nodes"
grep -q '^floors 3 (3 at' "$tmp/eval.txt" || fail "the map does not hold the 3 floors at their heights"
[ "$kill_mapper" -gt 0 ] || grep -q '^sessions 2 (run: 2)' "$tmp/eval.txt" || fail "the map does not hold both sessions"
if [ "$kill_mapper" -gt 0 ]; then echo "OK: the pipeline finished after $kill_mapper mapper-proc SIGKILLs; map within $max_ate m ATE"
elif [ "$kill_oracle" = 1 ]; then echo "OK: the pipeline finished after an oracle SIGKILL and restart; map within $max_ate m ATE"
else echo "OK: the pipeline finished; map within $max_ate m ATE"; fi
