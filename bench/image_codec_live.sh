#!/usr/bin/env bash
# vo-proc live on a log's images (issue 52): lcm-logplayer replays STEREO and STEREO_CALIB of
# LOG at SPEED x for SECONDS of data inside the LCM sandbox while evermap-vo-proc runs; prints
# the frames processed and dropped (its exit summary), the load average around the run and,
# with BUSY=1, while one busy loop of this script's own keeps a core occupied.
#   bench/image_codec_live.sh BUILD_DIR LOG SPEED [SECONDS]
# e.g. for e in png zstd; do for s in 1 2; do bench/image_codec_live.sh build s0.$e.lcmlog $s 60; done; done
set -euo pipefail
build="$(cd "$1" && pwd)"; log="$2"; speed="$3"; seconds="${4:-60}"
src="$(cd "$(dirname "$0")/.." && pwd)"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"; [ -z "${busy:-}" ] || kill "$busy" 2> /dev/null || true' EXIT
busy=""
if [ "${BUSY:-0}" = 1 ]; then ( while :; do :; done ) & busy=$!; fi
load0="$(cut -d' ' -f1 /proc/loadavg)"
"$src/scripts/lcm-sandbox" bash -c '
  set -euo pipefail
  "$1/bin/evermap-vo-proc" --ready-file "$2/ready" 2> "$2/proc.txt" &
  proc=$!
  for _ in $(seq 300); do [ -f "$2/ready" ] && break; sleep 0.1; done
  sleep 0.5
  timeout "$(awk -v s="$4" -v x="$5" "BEGIN { print s / x + 1 }")" \
    lcm-logplayer -s "$5" -e "STEREO|STEREO_CALIB" "$3" > /dev/null || true
  sleep 2
  kill -TERM "$proc"; wait "$proc"
' live "$build" "$tmp" "$log" "$seconds" "$speed"
load1="$(cut -d' ' -f1 /proc/loadavg)"
summary="$(grep -E '^evermap-vo-proc: [0-9]+ frames' "$tmp/proc.txt")"
echo "$(basename "$log") ${speed}x ${seconds}s busy=${BUSY:-0} load $load0..$load1: $summary"
