#!/usr/bin/env bash
# The map store survives SIGKILL: evermap-mapper-run writes the store of a simulated session
# and is killed at 20 random moments (seeded). After each kill the store opens, passes
# PRAGMA integrity_check and holds every node the run reported committed before the kill; the
# next run resumes the map (its first commit keeps every stored node and comes later in the
# session). A last run maps the rest of the session to its end.
set -euo pipefail
build="$1"; src="$2"
tool="$build/bin/evermap-mapper-run"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
store="$tmp/map.db"
# One session of about three hours of simulated time on the small building (~6 s of CPU), so
# that 20 kills at 30-530 ms after each start fall before its end.
args=(--config "$src/config/sim-small.conf" --set patrol.sessions=1 --set patrol.total_hours=3.0
      --store "$store" --progress)
fail() { echo "mapper_sigkill: $*"; exit 1; }
field() { awk -v k="$2" '{for (i = 1; i < NF; ++i) if ($i == k) print $(i + 1)}' <<< "$1"; }

RANDOM=20261121  # the kill moments are the same on every run of the test
stored_nodes=0
stored_utime=0  # the newest keyframe the store mentions before each run
kills=0
for k in $(seq 1 20); do
  delay_ms=$(( 30 + RANDOM % 500 ))
  "$tool" "${args[@]}" > "$tmp/run$k.txt" 2> "$tmp/err$k.txt" &
  pid=$!
  sleep "$(printf '%d.%03d' $(( delay_ms / 1000 )) $(( delay_ms % 1000 )))"
  if kill -KILL "$pid" 2> /dev/null; then kills=$((kills + 1)); fi
  wait "$pid" 2> /dev/null || true

  if [ ! -e "$store" ]; then
    # Killed before the store was created: nothing can have been committed.
    ! grep -q '^committed' "$tmp/run$k.txt" || fail "kill $k: commits reported, no store"
    echo "kill $k after ${delay_ms} ms: no store yet"
    continue
  fi
  check=$("$tool" --check-store "$store") || fail "kill $k after ${delay_ms} ms: store check failed"
  if command -v sqlite3 > /dev/null; then
    [ "$(sqlite3 "$store" 'PRAGMA integrity_check')" = ok ] || fail "kill $k: sqlite3 integrity_check"
  fi
  nodes=$(field "$check" nodes)
  last=$(grep '^committed' "$tmp/run$k.txt" | tail -1 || true)
  first=$(grep '^committed' "$tmp/run$k.txt" | head -1 || true)
  if [ -n "$last" ]; then
    committed=$(field "$last" nodes)
    [ "$nodes" -ge "$committed" ] || fail "kill $k: $nodes nodes in the store, $committed were committed"
  fi
  if [ -n "$first" ]; then
    # Resumed: the map grew from the stored one, after the point it had reached.
    [ "$(field "$first" nodes)" -ge "$stored_nodes" ] || fail "kill $k: the run did not resume the map ($first)"
    [ "$(field "$first" utime)" -gt "$stored_utime" ] || fail "kill $k: the run went back in time ($first)"
  fi
  stored_utime=$(field "$check" updated_utime)
  [ "$nodes" -ge "$stored_nodes" ] || fail "kill $k: the store lost nodes ($nodes < $stored_nodes)"
  stored_nodes=$nodes
  echo "kill $k after ${delay_ms} ms: $check"
done
[ "$kills" -ge 15 ] || fail "only $kills of 20 runs were still running when killed"
[ "$stored_nodes" -gt 0 ] || fail "no node was ever committed"

# The rest of the session, to its end.
"$tool" "${args[@]}" > "$tmp/final.txt"
grep -q "^restored_nodes $stored_nodes\$" "$tmp/final.txt" || fail "the last run did not restore $stored_nodes nodes"
# The last run resumes right after the stored tracking state (no gap offline): a warm
# restart, bridged by the odometry frame (VO's chain went on) or else placed by two agreeing
# registrations that confirm it; a store without a state (the kill before the first one)
# re-localises, with two agreeing registrations too. One of them is required when the rest
# was long enough, and the rest must map.
steps=$(awk '$1 == "steps" {print $2}' "$tmp/final.txt")
if [ "$steps" -ge 20 ]; then
  grep -q "^relocalizations [1-9]\|^warm_confirmations [1-9]\|^warm_bridged [1-9]" "$tmp/final.txt" ||
    fail "the last run ($steps steps) was never bridged, re-localised nor confirmed"
  grep -q "^loop_closures [1-9]" "$tmp/final.txt" || fail "the last run ($steps steps) closed no loop"
fi
"$tool" --check-store "$store"
echo "mapper_sigkill: $kills kills, $stored_nodes nodes stored before the last run"
