#!/usr/bin/env bash
# evermap-sim-measure end to end: writes a small run (logs, TUM, sidecar), refuses a bad
# configuration with a file:line message and exit status 2, and --serve, started from the
# run's own sidecar, publishes on LCM exactly the bytes of the written log (checked by
# evermap-lcm-check inside the LCM sandbox).
set -euo pipefail
build="$1"; src="$2"
tool="$build/bin/evermap-sim-measure"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT

# One session of ~8 simulated minutes on two floors, VO at 10 Hz: ~24K messages.
"$tool" --config "$src/config/sim-small.conf" --set patrol.sessions=1 --set patrol.total_hours=0.02 \
  --set building.floors=2 --set building.main_floor=0 --set vo.rate_hz=10 --out "$tmp/run" > "$tmp/out.txt"
for f in session-00.lcmlog session-00.tum run.sim.txt; do
  [ -s "$tmp/run/$f" ] || { echo "sim_measure: $f missing or empty"; exit 1; }
done
grep -q "elevator rides              2" "$tmp/out.txt"

printf 'seed = 1\nvo.rate_hz = -3\n' > "$tmp/bad.conf"
set +e
"$tool" --config "$tmp/bad.conf" --stats 2> "$tmp/err.txt"
rc=$?
set -e
[ "$rc" -eq 2 ] || { echo "sim_measure: bad configuration gave exit status $rc, not 2"; exit 1; }
grep -q "bad.conf:2: option vo.rate_hz: -3 is outside > 0" "$tmp/err.txt" || { cat "$tmp/err.txt"; exit 1; }

# 504 simulated seconds at 10x: about 50 s, ~500 messages/s (gentle enough for loopback
# multicast on a busy machine).
exec "$src/scripts/lcm-sandbox" bash -c '
  set -euo pipefail
  "$1/bin/evermap-lcm-check" --log "$2/run/session-00.lcmlog" --ready-file "$2/ready" --idle-timeout-s 10 &
  checker=$!
  for _ in $(seq 300); do [ -f "$2/ready" ] && break; sleep 0.1; done
  "$1/bin/evermap-sim-measure" --config "$2/run/run.sim.txt" --serve --speed 10 > "$2/serve.txt"
  wait "$checker"
' sim_measure "$build" "$tmp"
