#!/usr/bin/env bash
# The vocabulary that comes with evermap: trained from the image simulator's own renders, so
# that the visual system needs nothing outside the repository.
#
#   scripts/make-vocab.sh OUT.evoc          Environment: BUILD_DIR (build)
#
# It is the two commands below; about 20 s of CPU, deterministic (the same build gives the same
# file, byte for byte: compare the fingerprint it prints). The file is about 4.8 MB, so it is
# made, not committed.
#  1. evermap-sim-render --snapshots: the left image every 2 s of session 0 of another
#     building than the one the demo and the tests map (seed 7 of config/sim-image-3floor.conf;
#     they render seed 2): 300 images, 752x480, lit rooms, dark rooms, featureless walls,
#     passers-by, the elevator cab. Posters are procedural (render.posters=none): by default
#     they are RTAB-Map's sample photographs when the data folder holds them, and those are the
#     place-recognition test set (evermap-place-eval).
#  2. evermap-vocab-train with its defaults: k=10, L=5, 1000 ORB features per image, seed 1.
# Training on the sessions being mapped would flatter the result; seed 7 is rendered by no
# demo, test or benchmark.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="${BUILD_DIR:-$root/build}/bin"
if [ $# -ne 1 ]; then
  echo "usage: scripts/make-vocab.sh OUT.evoc   (environment: BUILD_DIR, default build)" >&2
  exit 2
fi
out="$1"
for p in evermap-sim-render evermap-vocab-train; do
  [ -x "$bin/$p" ] || { echo "make-vocab: $bin/$p not found (build first, or set BUILD_DIR)" >&2; exit 2; }
done
images="$(mktemp -d)"
trap 'rm -rf "$images"' EXIT
"$bin/evermap-sim-render" --config "$root/config/sim-image-3floor.conf" --seed 7 \
  --set render.session=0 --set render.posters=none --snapshots "$images" --every 2
"$bin/evermap-vocab-train" --out "$out" "$images" | grep -v '^folder '
