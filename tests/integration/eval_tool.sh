#!/usr/bin/env bash
# Smoke test of evermap-eval on the real files: EuRoC ground truth reprocessed by OpenVINS
# against the original, KITTI 07 against a perturbed copy (1 % longer, heading drifting
# 2e-5 rad per frame, 5 cm noise), the KITTI snippet against itself; the JSON parsed back with
# python3, the figures checked by their magic bytes, and bad input refused with the right
# exit status and a message naming the file. Skips (77) without the data, except under CI.
source "$(dirname "$0")/lib.sh" "$@"
need_data euroc-v101-micro kitti-gt-poses kitti07-mono-160
eval_bin="$build/bin/evermap-eval"
gt_dir="$data/euroc-v101-micro/groundtruth_openvins"

# 1. EuRoC: two ground truths of V1_01_easy, TUM text against EuRoC CSV.
"$eval_bin" --gt "$gt_dir/V1_01_easy_original.txt" --est "$gt_dir/V1_01_easy.csv" \
  --json "$tmp/euroc.json" --plot "$tmp/euroc.png" | tee "$tmp/euroc.txt"
grep -q "^ATE" "$tmp/euroc.txt"
python3 -m json.tool "$tmp/euroc.json" > /dev/null
python3 - "$tmp/euroc.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
for k in ["ground_truth", "estimate", "association", "alignment", "ate", "rpe"]:
    assert k in r, k
for k in ["count", "rmse", "mean", "median", "std", "min", "max"]:
    assert k in r["ate"]["translation_m"] and k in r["rpe"]["rotation_deg"], k
assert r["ground_truth"]["format"] == "tum" and r["estimate"]["format"] == "euroc"
assert r["association"]["pairs"] > 2800, r["association"]
assert r["alignment"]["mode"] == "se3" and len(r["alignment"]["rotation_wxyz"]) == 4
# vicon2gt moves the positions by a few cm (SOURCE.txt).
assert 0.005 < r["ate"]["translation_m"]["rmse"] < 0.1, r["ate"]
assert "kitti_drift" not in r
PY
[ "$(head -c 8 "$tmp/euroc.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ]

# 2. KITTI 07 (1101 poses, 695 m) against a perturbed copy, with the drift and an SVG.
awk 'BEGIN { srand(7) }
  { c = cos(NR * 2e-5); s = sin(NR * 2e-5)
    for (j = 1; j <= 4; j++) { a[j] = c * $j + s * $(j + 8); b[j] = $(j + 4); d[j] = -s * $j + c * $(j + 8) }
    a[4] = 1.01 * a[4] + 0.1 * (rand() - 0.5); b[4] = 1.01 * b[4] + 0.1 * (rand() - 0.5)
    d[4] = 1.01 * d[4] + 0.1 * (rand() - 0.5)
    printf "%.6e %.6e %.6e %.6e %.6e %.6e %.6e %.6e %.6e %.6e %.6e %.6e\n",
           a[1], a[2], a[3], a[4], b[1], b[2], b[3], b[4], d[1], d[2], d[3], d[4] }' \
  "$data/kitti-gt-poses/07.txt" > "$tmp/07_perturbed.txt"
times="$data/kitti07-mono-160/times_full_seq07.txt"
"$eval_bin" --gt "$data/kitti-gt-poses/07.txt" --gt-times "$times" \
  --est "$tmp/07_perturbed.txt" --est-times "$times" --kitti-drift --rpe-distance 100 \
  --json "$tmp/kitti.json" --plot "$tmp/kitti.svg"
python3 - "$tmp/kitti.json" "$tmp/kitti.svg" <<'PY'
import json, sys, xml.etree.ElementTree as ET
r = json.load(open(sys.argv[1]))
d = r["kitti_drift"]
assert r["association"]["pairs"] == 1101
assert r["rpe"]["delta_m"] == 100
# 2e-5 rad per frame over ~0.63 m per frame: ~0.17 deg / 100 m; the 1 % scale shows as
# 1 % of each segment's end-to-end displacement (below 1 % on a loop).
assert 0.15 < d["rotation_deg_per_100m"] < 0.2, d
assert 0.3 < d["translation_percent"] < 1.0, d
assert [row["length_m"] for row in d["per_length"]] == [100, 200, 300, 400, 500, 600, 700, 800]
root = ET.parse(sys.argv[2]).getroot()
assert root.tag.endswith("svg")
assert len([e for e in root.iter() if e.tag.endswith("polyline")]) >= 2
PY

# 3. The KITTI snippet against itself with its times: zero error; Sim(3) recovers scale 1.
out="$("$eval_bin" --gt "$data/kitti07-mono-160/poses.txt" --gt-times "$data/kitti07-mono-160/times.txt" \
  --est "$data/kitti07-mono-160/poses.txt" --est-times "$data/kitti07-mono-160/times.txt" \
  --align sim3 --json "$tmp/self.json")"
python3 -c "
import json; r = json.load(open('$tmp/self.json'))
assert r['ate']['translation_m']['max'] < 1e-9, r['ate']
assert abs(r['alignment']['scale'] - 1) < 1e-12 and r['association']['pairs'] == 160"

# 4. Bad input: exit 1 and a message naming the file and line; bad command line: exit 2.
sed '3s/.*/1403715274.31214 0.8 2.1 nan 0 0 0 1/' "$gt_dir/V1_01_easy_original.txt" > "$tmp/bad.txt"
set +e
"$eval_bin" --gt "$tmp/bad.txt" --est "$gt_dir/V1_01_easy.csv" 2> "$tmp/err.txt"; rc=$?
set -e
[ "$rc" -eq 1 ] || { echo "FAIL: malformed line gave exit $rc"; exit 1; }
grep -q "bad.txt:3: non-finite" "$tmp/err.txt" || { cat "$tmp/err.txt"; exit 1; }
set +e
"$eval_bin" --gt "$data/kitti-gt-poses/07.txt" --est "$gt_dir/V1_01_easy.csv" 2> "$tmp/err.txt"; rc=$?
set -e
[ "$rc" -eq 1 ] && grep -q "do not overlap" "$tmp/err.txt" || { echo "FAIL: no-overlap gave $rc"; cat "$tmp/err.txt"; exit 1; }
set +e
"$eval_bin" --gt "$gt_dir/V1_01_easy.csv" --est "$gt_dir/V1_01_easy.csv" --align affine 2> /dev/null; rc=$?
set -e
[ "$rc" -eq 2 ] || { echo "FAIL: bad option gave exit $rc"; exit 1; }
[ -z "$(ls -A "$tmp" | grep '\.tmp')" ] || { echo "FAIL: temporary files left"; exit 1; }
echo "OK: evermap-eval on EuRoC and KITTI"
