#!/usr/bin/env bash
# The place-recognition tools on the real data: evermap-vocab-train trains the default
# vocabulary from the shared images, evermap-place-eval runs the loop detector over RTAB-Map's
# 84 samples with it (and with the DBoW3 vocabulary of slambook2) and must print precision
# 100 % with recall >= 70 % after the epipolar check; bad input is refused with exit status 1
# and a message naming the file, a bad command line with 2. Skips (77) without the data,
# except under CI.
source "$(dirname "$0")/lib.sh" "$@"
need_data rtabmap-lcd-samples vocab-orb-small kitti07-mono-160 kitti-mono-snippet euroc-v101-micro
train="$build/bin/evermap-vocab-train"
evaluate="$build/bin/evermap-place-eval"
samples="$data/rtabmap-lcd-samples"

# 1. Train the default vocabulary (never committed: it is made here).
"$train" --out "$tmp/default.evoc" --default-data "$data" | tee "$tmp/train.txt"
grep -q "^k=10 L=5: " "$tmp/train.txt"
[ "$(head -c 6 "$tmp/default.evoc")" = "EVMVOC" ]
ls -A "$tmp" | grep -q '\.tmp' && { echo "temporary file left behind"; exit 1; }

# 2. Precision-recall with it; the operating point after the epipolar check.
check_point() {  # file: "score + epipolar" line must show precision 100 % and recall >= 70 %
  python3 - "$1" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
m = re.search(r"score \+ epipolar >= [0-9.]+, >= \d+ inliers: precision ([0-9.]+)%, recall ([0-9.]+)%", text)
assert m, "no operating point printed"
precision, recall = float(m.group(1)), float(m.group(2))
assert precision == 100.0 and recall >= 70.0, (precision, recall)
assert "precision-recall, raw score (44 queries with a loop)" in text
assert "precision-recall, score + epipolar (44 queries with a loop)" in text
print("operating point: precision %.1f %%, recall %.1f %%" % (precision, recall))
PY
}
"$evaluate" --vocab "$tmp/default.evoc" --images "$samples/samples" --gt "$samples/samples_GT.bmp" \
  --csv "$tmp/candidates.csv" | tee "$tmp/eval.txt"
check_point "$tmp/eval.txt"
[ "$(head -1 "$tmp/candidates.csv")" = "query,rank,candidate,score,matches,inliers,geometric_ok,ground_truth" ]
[ "$(wc -l < "$tmp/candidates.csv")" -gt 300 ]

# 3. A DBoW3 vocabulary (YAML, gzip'd) works through the same path.
"$evaluate" --vocab "$data/vocab-orb-small/slambook2_vocabulary.yml.gz" --images "$samples/samples" \
  --gt "$samples/samples_GT.bmp" > "$tmp/eval_dbow3.txt"
check_point "$tmp/eval_dbow3.txt"

# 4. Bad input: exit 1 with the file named; bad command line: exit 2.
expect_fail() {  # status, text the message must contain, command...
  local want="$1" text="$2"; shift 2
  set +e; "$@" > /dev/null 2> "$tmp/err.txt"; local got=$?; set -e
  [ "$got" = "$want" ] || { echo "expected exit $want, got $got: $*"; cat "$tmp/err.txt"; exit 1; }
  grep -qF -- "$text" "$tmp/err.txt" || { echo "message lacks '$text':"; cat "$tmp/err.txt"; exit 1; }
}
head -c 1000 "$tmp/default.evoc" > "$tmp/truncated.evoc"
expect_fail 1 "$tmp/truncated.evoc" "$evaluate" --vocab "$tmp/truncated.evoc" \
  --images "$samples/samples" --gt "$samples/samples_GT.bmp"
expect_fail 1 "missing.bmp" "$evaluate" --vocab "$tmp/default.evoc" \
  --images "$samples/samples" --gt "$tmp/missing.bmp"
expect_fail 1 "84x84 matrix for 2 images" "$evaluate" --vocab "$tmp/default.evoc" \
  --images "$data/rtabmap-lcd-samples/stereo_rect/left" --gt "$samples/samples_GT.bmp"
mkdir -p "$tmp/empty"
expect_fail 1 "holds no image" "$train" --out "$tmp/x.evoc" "$tmp/empty"
expect_fail 2 "--out is required" "$train" "$samples/samples"
expect_fail 2 "unknown option" "$evaluate" --frobnicate 1
echo "place recognition tools: OK"
