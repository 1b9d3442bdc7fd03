#!/usr/bin/env bash
# Replays an LCM log with lcm-logplayer inside the LCM sandbox while evermap-lcm-check
# listens, and prints what was received per channel. Exit 0 when every message arrived intact.
#   scripts/replay-check.sh LOG [SPEED]        (BUILD_DIR=build by default)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
log="${1:?usage: replay-check.sh LOG [SPEED]}"
speed="${2:-1}"
[ -f "$log" ] || { echo "replay-check: $log: no such log" >&2; exit 2; }
ready="$(mktemp -u /tmp/evermap-ready.XXXXXX)"
exec "$root/scripts/lcm-sandbox" bash -c '
  set -euo pipefail
  "$1/bin/evermap-lcm-check" --log "$2" --ready-file "$4" --idle-timeout-s 10 &
  checker=$!
  for _ in $(seq 300); do [ -f "$4" ] && break; sleep 0.1; done
  rm -f "$4"
  lcm-logplayer -s "$3" "$2" >/dev/null
  status=0
  wait "$checker" || status=$?
  # Kernel UDP counters of this namespace: where lost messages went, if any.
  awk '"'"'/^Udp:/ { if (!h) { split($0, k); h = 1 } else { split($0, v);
       for (i = 2; i <= NF; i++) if (k[i] ~ /InErrors|RcvbufErrors|InDatagrams/) printf "%s=%s ", k[i], v[i];
       print "" } }'"'"' /proc/net/snmp
  exit "$status"
' replay-check "$build" "$log" "$speed" "$ready"
