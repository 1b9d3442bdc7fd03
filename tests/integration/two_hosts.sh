#!/usr/bin/env bash
# The pipeline on two hosts (docs/deployment.md): a short rendered session through
# config/pipeline-two-hosts.pmd by scripts/two-hosts-run, three ways at once, each in its own
# LCM sandbox: on one host (the control); on two network namespaces "robot" and "base" joined
# by a veth pair with multicast TTL 1 (a clean LAN); and with evermap-lcm-link as the only
# link, 5 % of the datagrams lost and an 8 s partition. Checked: no process died or was
# restarted, the veth carried the traffic, the lossy link counted its drops per channel (a
# KEYFRAME among them), the lost KEYFRAMEs loopclose-proc needed were recovered by asking
# vo-proc again, the mapper went on mapping after the partition, both two-host maps are
# near the control's (nodes, node ATE) and no loop closure is false. Nothing outside the
# repository (the vocabulary is scripts/make-vocab.sh's). A few minutes.
source "$(dirname "$0")/lib.sh" "$@"
# Seconds of the session; the partition from 25 s to 33 s of the link's time (the log starts
# about 3 s after it).
duration="${EVERMAP_TWO_HOSTS_DURATION_S:-60}"
keep_tmp="${EVERMAP_KEEP_TMP:-}"
fail_logs=("$tmp/*.out" "$tmp/link/base0/mapper-proc.log"); fail_tail=30

BUILD_DIR="$build" bash "$src/scripts/make-vocab.sh" "$tmp/sim.evoc" > "$tmp/vocab.txt" \
  || { cat "$tmp/vocab.txt"; fail "scripts/make-vocab.sh"; }
"$bin/evermap-sim-render" --config "$src/config/sim-image-3floor.conf" \
  --set render.max_duration_s="$duration" --out "$tmp/s0.lcmlog" > "$tmp/render.txt" \
  || fail "sim-render"

export EVERMAP_BIN="$bin" EVERMAP_VOCAB="$tmp/sim.evoc"
run() {  # NAME MODE [LINK_SET]
  LINK_SET="${3:-}" "$src/scripts/two-hosts-run" "$tmp/$1" "$2" "$tmp/s0.lcmlog" > "$tmp/$1.out" 2>&1
}
run one one & p1=$!
run veth veth & p2=$!
run link link "loss_pct=5 partition_start_s=25 partition_s=8 seed=3" & p3=$!
for p in $p1 $p2 $p3; do wait "$p" || fail "scripts/two-hosts-run exited with an error"; done

for r in one veth link; do
  s="$tmp/$r/summary.txt"
  echo "$r: nodes $(value nodes "$s"), node ATE $(value node_ate_rmse_m "$s") m, loop edges $(value loop_edges "$s") (false $(value loop_edges_false "$s")), restarts $(value restarts "$s"), VO frames dropped behind $(value vo_frames_dropped_behind "$s")"
  [ ! -s "$tmp/$r/errors.txt" ] || { cat "$tmp/$r/errors.txt"; fail "$r: a deputy failed"; }
  [ "$(value died "$s")" = 0 ] || fail "$r: a process ended other than by its stop signal"
  [ "$(value restarts "$s")" = 0 ] || fail "$r: a process was restarted"
  [ "$(value loop_edges_false "$s")" = 0 ] || fail "$r: a false loop closure"
  [ "$(value nodes_on_consistent_floor "$s")" = "$(value nodes "$s")" ] || fail "$r: nodes on the wrong floor"
done
control="$(value nodes "$tmp/one/summary.txt")"
[ "$control" -ge 8 ] || fail "the one-host control made only $control nodes (11 measured)"

# The veth carried the pipeline (the base maps from the robot's messages; rx bytes counted).
veth_rx="$(value session0.veth_rx_bytes "$tmp/veth/summary.txt")"
echo "veth: $veth_rx bytes into the base"
[ "$veth_rx" -gt 1000000 ] || fail "the veth carried only $veth_rx bytes"

# The lossy link counted what it dropped, per channel; KEYFRAMEs among them (one lost
# fragment loses the message).
grep -E '^robot->base (KEYFRAME|VO_DELTA|total) ' "$tmp/link/summary.txt"
read -r kf_lost kf_messages < <(awk '$1 == "robot->base" && $2 == "KEYFRAME" { print $10, $8 }' "$tmp/link/summary.txt")
[ "${kf_lost:-0}" -ge 1 ] || fail "no KEYFRAME lost on the link (of ${kf_messages:-0})"
grep -q '^robot->base STEREO .* local [1-9]' "$tmp/link/summary.txt" || fail "STEREO was not kept on the robot"
# The lost KEYFRAMEs loopclose-proc needed were asked for again and recovered from vo-proc's
# buffer (docs/deployment.md), in parts of one packet: at 5 % packet loss an ask and a part
# both arrive 9 times in 10, so 16 asks leave practically none missing; asks still open when
# the session ends are neither (measured: 19 asked, 19 recovered, 42 asks, 34 answers of 585
# parts; with whole resends CI once gave up 2 of 17; none asked on one host).
for k in keyframes_asked keyframes_recovered keyframes_given_up keyframes_resent keyframe_parts_resent nodes_rejected; do
  echo "link: $k $(value "$k" "$tmp/link/summary.txt") (one host: $(value "$k" "$tmp/one/summary.txt"))"
done
asked="$(value keyframes_asked "$tmp/link/summary.txt")"
recovered="$(value keyframes_recovered "$tmp/link/summary.txt")"
given_up="$(value keyframes_given_up "$tmp/link/summary.txt")"
[ "${recovered:-0}" -ge 1 ] || fail "no lost KEYFRAME recovered (${asked:-0} asked for again)"
[ "$((10 * ${given_up:-0}))" -le "${asked:-0}" ] || fail "$given_up of $asked KEYFRAMEs asked for again were given up"
[ "$(value keyframes_resent "$tmp/link/summary.txt")" -ge "$recovered" ] || fail "vo-proc resent fewer KEYFRAMEs than were recovered"
# The mapper went on after the partition: its node count grew from the partition's end on.
read -r at_end_of_partition at_end < <(awk '/^progress:/ { w = $3 + 0; n = $0; sub(/.*nodes /, "", n); n = n + 0
  if (w >= 35 && first == "") first = n; last = n } END { print first + 0, last + 0 }' "$tmp/link/base0/mapper-proc.log")
echo "link: $at_end_of_partition nodes after the partition, $at_end at the end"
[ "$at_end" -gt "$at_end_of_partition" ] || fail "the map did not grow after the partition"

# Both two-host maps near the control: nodes within 10 % on a clean veth; within 50 % with
# 5 % packet loss and the partition: about 70 % of the KEYFRAMEs (24 packets each) are lost
# at first; before they were asked for again, their registrations failed and the mapper made
# a node where it would have merged (15 against 11; 10 and 12 against 11 with the recovery). Node ATE within 0.3 m (the control's is centimetres; before the tracker
# bridged the wheels' hole, an 8 s partition put it at 1.8 m).
nodes_near() { awk -v a="$1" -v b="$control" -v f="$2" 'BEGIN { exit !(a >= (1 - f) * b && a <= (1 + f) * b) }'; }
nodes_near "$(value nodes "$tmp/veth/summary.txt")" 0.1 || fail "veth: nodes not within 10 % of the control's $control"
nodes_near "$(value nodes "$tmp/link/summary.txt")" 0.5 || fail "lossy link: nodes not within 50 % of the control's $control"
for r in one veth link; do
  ate="$(value node_ate_rmse_m "$tmp/$r/summary.txt")"
  awk -v a="$ate" 'BEGIN { exit !(a != "" && a <= 0.3) }' || fail "$r: node ATE $ate m over 0.3 m"
done
echo "OK: two hosts: clean veth $(value nodes "$tmp/veth/summary.txt") nodes, lossy link $(value nodes "$tmp/link/summary.txt") nodes (control $control), $kf_lost of $kf_messages KEYFRAMEs lost, node ATE $(value node_ate_rmse_m "$tmp/link/summary.txt") m"
