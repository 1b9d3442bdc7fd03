#!/usr/bin/env bash
# imu-proc and elevator-proc as real processes over LCM (in a private network namespace):
# a synthetic building run is played from an LCM log into IMU; imu-proc publishes ATTITUDE,
# elevator-proc FLOOR; ATTITUDE must come at >= 10 Hz, and the FLOOR messages must report
# the same rides, on the same floors, as the offline runner finds in the same samples.
#   imu_elevator_lcm.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1
src=$2
bin=$build/bin
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$bin/evermap-imu-elevator-run" --synthetic 3 --rate 100 --write-lcm-log "$tmp/imu.lcm" \
  > "$tmp/offline.txt"
# Offline: the ride table's "from->to" column.
grep -E '^ +[0-9]+ ' "$tmp/offline.txt" | awk '{for (i = 1; i <= NF; i++) if ($i ~ /->/) print $i}' | sed 's/\*//' > "$tmp/offline_floors.txt"
n_offline=$(wc -l < "$tmp/offline_floors.txt")
if [ "$n_offline" -lt 3 ]; then
  echo "offline runner found $n_offline rides, expected 3"; cat "$tmp/offline.txt"; exit 1
fi

cat > "$tmp/run.sh" <<SCRIPT
set -euo pipefail
"$bin/evermap-imu-proc" 2> "$tmp/imu-proc.log" & imu_pid=\$!
"$bin/evermap-elevator-proc" 2> "$tmp/elevator-proc.log" & elevator_pid=\$!
lcm-logger --quiet "$tmp/out.lcm" > /dev/null 2>&1 & logger_pid=\$!
sleep 1
lcm-logplayer --speed=4 "$tmp/imu.lcm"
# On a loaded machine the processes may still be working through the log's tail: wait for
# elevator-proc to report the rides' ends (at most 60 s; the check below says what is missing).
for _ in \$(seq 120); do
  [ "\$(grep -c 'ride end' "$tmp/elevator-proc.log" || true)" -ge $n_offline ] && break
  sleep 0.5
done
sleep 1
kill -TERM \$imu_pid \$elevator_pid \$logger_pid
wait \$imu_pid \$elevator_pid \$logger_pid || true
SCRIPT
"$src/scripts/lcm-sandbox" bash "$tmp/run.sh"

"$bin/evermap-imu-elevator-run" --print-floor-log "$tmp/out.lcm" > "$tmp/floor.txt"
starts=$(grep -c 'event start' "$tmp/floor.txt" || true)
ends=$(grep 'event end' "$tmp/floor.txt" | awk '{print $7}' | paste -sd' ')
echo "offline rides: $(paste -sd' ' "$tmp/offline_floors.txt")"
echo "FLOOR messages: $starts starts; ends on floors: $ends"
tail -1 "$tmp/elevator-proc.log"
grep ATTITUDE "$tmp/floor.txt"
rate=$(grep ATTITUDE "$tmp/floor.txt" | sed -E 's/.*: ([0-9.]+) Hz.*/\1/')
if awk -v r="$rate" 'BEGIN { exit !(r < 10) }'; then echo "FAIL: ATTITUDE at $rate Hz"; exit 1; fi
if [ "$starts" -ne "$n_offline" ]; then echo "FAIL: ride starts"; cat "$tmp/floor.txt"; exit 1; fi
expected=$(awk -F'->' '{print $2}' "$tmp/offline_floors.txt" | paste -sd' ')
if [ "$ends" != "$expected" ]; then echo "FAIL: ride ends on floors '$ends', offline '$expected'"; exit 1; fi
echo "PASS"
