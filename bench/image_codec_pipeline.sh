#!/usr/bin/env bash
# The image encodings over a whole run (issue 52): evermap-slam-run over two rendered sessions,
# once per encoding, the same frames each time (evermap-log-recode, lossless). Prints per
# encoding the log bytes per stereo frame, the reader's decode ms per frame, VO ms per frame,
# the real-time factor and the load average around the run; then whether the maps agree
# (summary.txt, nodes.csv, trajectory.tum, registrations.csv; timing and log names left
# out). About 2-6 min per run on 2 cores.
#   bench/image_codec_pipeline.sh BUILD_DIR OUT_DIR VOCAB LOG0 LOG1 [ENCODING ...]
# e.g. bench/image_codec_pipeline.sh build out/codec /work/baseline/default.evoc s0.lcmlog \
#        s1.lcmlog png zstd
# Logs of any encoding; ENCODING defaults to "png zstd" (gray8 logs are 1.8x PNG's size).
# To render the sessions: docs/simulators.md (config/sim-image-3floor.conf, render.session).
set -euo pipefail
build="$1"; out="$2"; vocab="$3"; log0="$4"; log1="$5"; shift 5
encodings=("$@"); [ ${#encodings[@]} -gt 0 ] || encodings=(png zstd)
mkdir -p "$out"
for e in "${encodings[@]}"; do
  for s in 0 1; do
    in="$log0"; [ $s = 1 ] && in="$log1"
    [ -f "$out/s$s.$e.lcmlog" ] || "$build/bin/evermap-log-recode" "$in" "$out/s$s.$e.lcmlog" \
      --encoding "$e" > "$out/s$s.$e.recode.txt"
  done
  load0="$(cut -d' ' -f1 /proc/loadavg)"
  "$build/bin/evermap-slam-run" --vocab "$vocab" --out "$out/run.$e" "$out/s0.$e.lcmlog" \
    "$out/s1.$e.lcmlog" > "$out/run.$e.stdout" 2> "$out/run.$e.stderr"
  load1="$(cut -d' ' -f1 /proc/loadavg)"
  bytes="$(awk '{ n += $2; b += $2 * $8 } END { printf "%.0f", b / n }' "$out"/s[01]."$e".recode.txt)"
  awk -v e="$e" -v bytes="$bytes" -v l0="$load0" -v l1="$load1" '
    /^realtime_factor/ { rtf = $2 } /^wall_s/ { wall = $2 }
    /^ms_per_frame/ { dec = $3; vo = $9 }
    END { printf "%-6s bytes/frame %7d  decode %6.2f ms/frame  vo %6.2f ms/frame  rtf %5.2fx  wall %6.1f s  load %s..%s\n",
          e, bytes, dec, vo, rtf, wall, l0, l1 }' "$out/run.$e.stdout"
done
# The maps: every line of summary.txt without timing, and nodes.csv, equal across encodings.
first="${encodings[0]}"
for e in "${encodings[@]:1}"; do
  same=yes
  for f in summary.txt nodes.csv trajectory.tum registrations.csv; do
    diff -q <(grep -vE 'wall_s|realtime|peak_rss|_ms|ms_per' "$out/run.$first/$f" |
      sed -E 's/ log [^ ]+//') <(grep -vE 'wall_s|realtime|peak_rss|_ms|ms_per' "$out/run.$e/$f" |
      sed -E 's/ log [^ ]+//') > /dev/null || same=no
  done
  echo "map of $e equals map of $first: $same"
done
