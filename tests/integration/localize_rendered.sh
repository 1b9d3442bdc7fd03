#!/usr/bin/env bash
# Localization against a stored map with nothing outside the repository (as
# map_export_rendered.sh): evermap-slam-run maps the first 60 s of session 0 of the rendered
# 3-floor building with --places, then localizes the first 60 s of session 1 (other lighting)
# against it with --localize. Checked: both stores byte-identical after the run (sha256), the
# session localized, its pose error while localized under a bound, no false localization.
# About a minute of CPU.
source "$(dirname "$0")/lib.sh" "$@"
duration="${EVERMAP_LOCALIZE_DURATION_S:-60}"
conf="$src/config/sim-image-3floor.conf"

without_data_folder
map_rendered_session0 "$tmp/map" "$duration"
before="$(sha256sum "$tmp/map/map.db" "$tmp/map/places.db")"

"$bin/evermap-slam-run" --vocab "$tmp/sim.evoc" --localize "$tmp/map" --out "$tmp/loc" \
  --render "$conf" --render-set "render.max_duration_s=$duration" --render-set render.session=1 \
  > "$tmp/loc.txt" 2>&1 || { tail -20 "$tmp/loc.txt"; fail "evermap-slam-run --localize"; }
cat "$tmp/loc.txt"
[ "$(sha256sum "$tmp/map/map.db" "$tmp/map/places.db")" = "$before" ] \
  || fail "localization changed a store"
[ -s "$tmp/loc/localization.csv" ] || fail "no localization.csv"
field() { awk -v k="$1" '{ for (i = 1; i < NF; ++i) if ($i == k) { print $(i + 1); exit } }' "$tmp/loc.txt"; }
localized="$(awk '$1 == "localized_frames" { print $2 }' "$tmp/loc.txt")"
frames="$(awk '$1 == "frames" { print $2 }' "$tmp/loc.txt")"
rmse="$(field ate_rmse_m)"
false_frames="$(field false_frames)"
awk -v l="$localized" -v n="$frames" 'BEGIN { exit !(n > 0 && l >= 0.3 * n) }' \
  || fail "localized in $localized of $frames frames (under 30 %)"
awk -v r="$rmse" 'BEGIN { exit !(r != "" && r >= 0 && r < 0.3) }' \
  || fail "pose error while localized: rmse $rmse m (bound 0.3 m)"
[ "$false_frames" = "0" ] || fail "$false_frames frames localized more than 0.5 m or 5 deg off"
echo "OK: localized $localized of $frames frames, rmse $rmse m, stores unchanged"
