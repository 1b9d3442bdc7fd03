#!/usr/bin/env bash
# The main job, from a fresh machine: set up, build, turn the real EuRoC excerpt into an LCM
# log, replay it with lcm-logplayer inside the LCM sandbox and print what was received; run
# stereo VO over the log and evaluate it against the ground truth (plot in OUT_DIR); train a
# vocabulary and measure loop detection on the RTAB-Map samples.
# (Later issues grow this into the full multi-process SLAM demo.)
#   scripts/demo.sh [EUROC_DIR]      (BUILD_DIR=build, OUT_DIR=out by default)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
out="${OUT_DIR:-$root/out}"
data="${EVERMAP_DATA:-$root/../shared/data}"
euroc="${1:-$data/euroc-v101-micro}"
[ -d "$euroc/mav0" ] || { echo "demo: $euroc/mav0 not found (give the EuRoC folder or set EVERMAP_DATA)" >&2; exit 2; }

bash "$root/scripts/setup.sh"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2

mkdir -p "$out"
gt=()
[ -f "$euroc/groundtruth_openvins/V1_01_easy.csv" ] && gt=(--gt "$euroc/groundtruth_openvins/V1_01_easy.csv")
echo "== converting $euroc"
"$build/bin/evermap-euroc2lcm" "$euroc" "$out/euroc.lcmlog" "${gt[@]}"
echo "== replaying $out/euroc.lcmlog with lcm-logplayer (4x) in the LCM sandbox"
BUILD_DIR="$build" "$root/scripts/replay-check.sh" "$out/euroc.lcmlog" 4

echo "== stereo VO over the log (evermap-vo-run), evaluated against the ground truth"
"$build/bin/evermap-vo-run" "$out/euroc.lcmlog" "$out/euroc_vo.tum" --body --stats "$out/euroc_vo.csv"
if [ ${#gt[@]} -gt 0 ]; then
  # The vehicle barely moves in the excerpt: align on the first pose, not by Umeyama.
  "$build/bin/evermap-eval" --gt "${gt[1]}" --est "$out/euroc_vo.tum" --align first \
    --plot "$out/euroc_vo.png" --json "$out/euroc_vo.json"
fi

if [ -d "$data/rtabmap-lcd-samples" ]; then
  echo "== place recognition: vocabulary from real images, loop detection on the RTAB-Map samples"
  "$build/bin/evermap-vocab-train" --out "$out/default.evoc" --default-data "$data"
  "$build/bin/evermap-place-eval" --vocab "$out/default.evoc" \
    --images "$data/rtabmap-lcd-samples/samples" --gt "$data/rtabmap-lcd-samples/samples_GT.bmp"
fi
echo "== done: outputs in $out"
