#!/usr/bin/env bash
# Floor plans from pixels with nothing outside the repository (as slam_rendered_no_data.sh):
# evermap-slam-run maps the first 60 s of session 0 of the demo's rendered 3-floor building
# with --places, then evermap-map-export writes the floor plans and scores them against the
# simulator's walls. Checked: map_server's files for the mapped floor, the nodes/edges CSV and
# the PLY, both stores byte-identical after the export, and the plan's occupied cells on the
# true walls. About half a minute of CPU.
source "$(dirname "$0")/lib.sh" "$@"
duration="${EVERMAP_MAP_EXPORT_DURATION_S:-60}"
conf="$src/config/sim-image-3floor.conf"

without_data_folder
map_rendered_session0 "$tmp/slam" "$duration"
[ -s "$tmp/slam/places.db" ] || fail "slam-run --places wrote no places.db"
before="$(sha256sum "$tmp/slam/map.db" "$tmp/slam/places.db")"

"$bin/evermap-map-export" --store "$tmp/slam/map.db" --places "$tmp/slam/places.db" \
  --out "$tmp/plans" --truth "$conf" --truth-nodes "$tmp/slam/nodes.csv" > "$tmp/export.txt" \
  2>&1 || { cat "$tmp/export.txt"; fail "evermap-map-export"; }
cat "$tmp/export.txt"
[ "$(sha256sum "$tmp/slam/map.db" "$tmp/slam/places.db")" = "$before" ] \
  || fail "the export changed a store"
grep -q ' (0 left out)' "$tmp/export.txt" || fail "nodes were left out"
for f in floor-0.pgm floor-0.yaml nodes.csv edges.csv points.ply floor-0-truth.png; do
  [ -s "$tmp/plans/$f" ] || fail "no $f"
done
for key in image resolution origin occupied_thresh free_thresh negate; do
  grep -q "^$key: " "$tmp/plans/floor-0.yaml" || fail "floor-0.yaml has no $key"
done
[ "$(head -c 2 "$tmp/plans/floor-0.pgm")" = "P5" ] || fail "floor-0.pgm is not a binary PGM"
# Occupied cells within 10 cm of a true wall; a plan placed by wrong poses or a wrong camera
# mounting is metres off (precision near 0).
precision="$(awk '$1 == "floor" && $2 == "0" { for (i = 1; i < NF; ++i) if ($i == "precision") print $(i + 1) }' "$tmp/export.txt")"
awk -v p="$precision" 'BEGIN { exit !(p != "" && p >= 0.8) }' \
  || fail "floor 0: occupied precision $precision under 0.8"
echo "OK: floor plans exported, stores unchanged, floor 0 occupied precision $precision"

# The plan under the graph in the viewer.
chromium="$(command -v chromium || command -v chromium-browser || true)"
if [ -z "$chromium" ] || ! command -v node > /dev/null || [ ! -x "$bin/evermap-viewer" ] \
  || [ ! -f "$src/viewer/web/node_modules/three/build/three.module.js" ]; then
  [ "${CI:-}" = true ] && fail "the viewer's plan needs chromium, node, three.js and evermap-viewer (scripts/setup.sh)"
  echo "SKIP: the viewer's plan (chromium, node, three.js or evermap-viewer missing: run scripts/setup.sh)"
  exit 0
fi
occupied="$(python3 -c 'import sys; print(open(sys.argv[1], "rb").read().split(b"\n", 3)[3].count(0))' "$tmp/plans/floor-0.pgm")"
"$bin/evermap-viewer" --store "$tmp/slam/map.db" --plans "$tmp/plans" --port 0 > "$tmp/viewer.log" 2>&1 &
kill_at_exit $!
fail_logs+=("$tmp/viewer.log")
for _ in $(seq 100); do grep -q '^evermap-viewer: serving' "$tmp/viewer.log" && break; sleep 0.1; done
url="$(grep -o 'http://[0-9.]*:[0-9]*/' "$tmp/viewer.log" | head -1)"
[ -n "$url" ] || fail "the viewer did not start"
node "$src/tests/integration/viewer_plan.mjs" --chromium "$chromium" --url "$url" --floor 0 \
  --occupied "$occupied" --screenshot "${EVERMAP_PLAN_SCREENSHOT:-$build/viewer-plan.png}" \
  > "$tmp/browser.log" 2>&1 || { cat "$tmp/browser.log"; fail "the viewer did not show floor 0's plan"; }
cat "$tmp/browser.log"
