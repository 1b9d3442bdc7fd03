#!/usr/bin/env bash
# A year of operation at the measurement level (issue 22; docs/mapper.md, "A year"): the
# paper-scale building, 365 sessions over 365 days (~300 h of operation), mapped by the
# reduced graph with the registration oracle into a map store (a transaction per minute of
# operation). Prints nodes, factors, the store's edge rows and bytes against operating time
# (the spirit of the paper's Fig. 7), with the views the robot's true poses need (what a
# map growing with the area explored grows with; run_metrics.h, ViewCover), nodes per view
# at 10 h and at the end, the growth over the last 100 h, then the run's summary figures.
# The mapper's figures, not the visual system's. About 15 min of CPU, 5 GB of memory.
#   bench/year.sh [BUILD_DIR] [OUT_DIR] [SESSIONS] [MAPPER_RUN_OPTION ...]
# e.g. bench/year.sh build out/year-bound2 365 --set mapper.closure_partners=2
set -euo pipefail
build="${1:-build}"; out="${2:-out/year-bench}"; sessions="${3:-365}"
shift $(( $# < 3 ? $# : 3 ))
src="$(cd "$(dirname "$0")/.." && pwd)"
mkdir -p "$out"
rm -f "$out/map.db" "$out/map.db-wal" "$out/map.db-shm"
# total_hours counts the patrols after the exploration tours: 272 h of them make ~300 h.
hours="$(awk -v s="$sessions" 'BEGIN { printf "%.1f", 272 * s / 365 }')"
"$build/bin/evermap-mapper-run" --config "$src/config/sim-paper-scale.conf" \
  --set patrol.sessions="$sessions" --set patrol.total_hours="$hours" --set patrol.span_days=365 \
  --store "$out/map.db" --store-period-s 60 "$@" --out "$out" > "$out/summary.txt"
awk -F, 'NR == 1 { next }
  { h = $1; if (!base && h >= 10) { base = 1; n0 = $4; f0 = $5; r0 = $14; b0 = $15; w0 = $16 }
    for (i = 1; i <= 5; i++) if (!done[i] && h >= mark[i] + 0) { done[i] = 1; row(h) } last = $0; rows[++k] = $0 }
  function row(h) { printf "%8.1f h  nodes %6d  factors %6d  store rows %7d  bytes %9d  views %6d\n", h, $4, $5, $14, $15, $16 }
  BEGIN { split("10 50 100 200 250", mark, " ") }
  END { split(last, v, ","); printf "%8.1f h  nodes %6d  factors %6d  store rows %7d  bytes %9d  views %6d  (end)\n", v[1], v[4], v[5], v[14], v[15], v[16]
        if (base) printf "growth from 10 h: nodes %+.1f %%, factors %+.1f %%, rows %+.1f %%, bytes %+.1f %%; the truth'"'"'s views %+.1f %%\n",
          100 * (v[4] / n0 - 1), 100 * (v[5] / f0 - 1), 100 * (v[14] / r0 - 1), 100 * (v[15] / b0 - 1), 100 * (v[16] / w0 - 1)
        if (base && w0 > 0 && v[16] > 0) printf "nodes per view: %.3f at 10 h, %.3f at the end\n", n0 / w0, v[4] / v[16]
        # The last 100 h of operation (the bars of issue 51: nodes, factors and bytes within 1 % each).
        for (i = 1; i <= k; i++) { split(rows[i], u, ","); if (u[1] >= v[1] - 100) break }
        if (v[1] >= 110 && u[4] > 0) printf "growth over the last 100 h (from %.1f h): nodes %+.1f %%, factors %+.1f %%, bytes %+.1f %%; views %+.1f %%\n",
          u[1], 100 * (v[4] / u[4] - 1), 100 * (v[5] / u[5] - 1), 100 * (v[15] / u[15] - 1), 100 * (v[16] / u[16] - 1) }' \
  "$out/timeline-reduced.csv"
grep -E '^(nodes|factors|ate_rmse_m|operating_h|distance_m|step_cpu_p99_first_hour_ms|step_cpu_p99_last_hour_ms|store_transactions|wall_s) ' "$out/summary.txt"
