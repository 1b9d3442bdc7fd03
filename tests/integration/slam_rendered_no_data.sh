#!/usr/bin/env bash
# The visual SLAM system from pixels with nothing outside the repository: EVERMAP_DATA is an
# empty folder (as for anyone who clones the repository alone), the vocabulary is the one that
# comes with the project (scripts/make-vocab.sh: trained on renders of another building), and
# evermap-slam-run renders two sessions of the demo's 3-floor building on the fly (procedural
# posters: there are no photographs to hang) and maps them, the second under other lighting.
# Checked: the map has nodes on both floors, every node on a consistent floor, no false
# closure, the node ATE against the simulator's truth, and session 1 relocalised in session
# 0's map. About a minute of CPU.
source "$(dirname "$0")/lib.sh" "$@"
# Seconds of each session: the elevator ride of session 0 ends at 85 s; at 100 s slam-run
# made 44 nodes on 2 floors, relocalised session 1 after 3.3 s of it, node ATE 0.024 m.
duration="${EVERMAP_NO_DATA_DURATION_S:-100}"

without_data_folder
tail -n 1 "$tmp/vocab.txt"
"$build/bin/evermap-slam-run" --vocab "$tmp/sim.evoc" --out "$tmp/slam" \
  --render "$src/config/sim-image-3floor.conf" --render-set "render.max_duration_s=$duration" \
  --sessions 2 > "$tmp/slam.txt" 2>&1 || { tail -20 "$tmp/slam.txt"; fail "evermap-slam-run"; }
summary="$tmp/slam/summary.txt"
grep -E '^(session\.|nodes |floors |accepted_closures|false_closures|relocalizations|node_ate_rmse_m|nodes_on_consistent_floor|realtime_factor)' "$summary"

nodes="$(value nodes "$summary")"
[ "$nodes" -ge 25 ] || fail "$nodes nodes (measured 44 at 100 s)"
[ "$(value floors "$summary")" -ge 2 ] || fail "the map does not hold the 2 floors of session 0"
[ "$(value nodes_on_consistent_floor "$summary")" = "$nodes" ] || fail "nodes on the wrong floor"
[ "$(value false_closures "$summary")" = 0 ] || fail "a false closure"
# Node ATE limit, metres: 0.024 measured; a session placed at the wrong spot, a floor at the
# wrong height or an aliased closure is metres off.
ate="$(value node_ate_rmse_m "$summary")"
awk -v a="$ate" 'BEGIN { exit !(a != "" && a <= 0.25) }' || fail "node ATE $ate m over 0.25 m"
# Session 1 starts where session 0 did: the place recognition (the shipped vocabulary) finds
# it in session 0's map within seconds (3.3 s measured).
relocalised_after="$(awk '$1 == "session.1" { for (i = 2; i < NF; ++i) if ($i == "relocalised_after_s") print $(i + 1) }' "$summary")"
awk -v r="$relocalised_after" 'BEGIN { exit !(r != "" && r >= 0 && r <= 30) }' \
  || fail "session 1 was not relocalised in session 0's map within 30 s (relocalised_after_s $relocalised_after)"
echo "OK: from pixels with an empty data folder: $nodes nodes, 0 false closures, node ATE $ate m, session 1 relocalised after $relocalised_after s"
