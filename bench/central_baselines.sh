#!/usr/bin/env bash
# Central baselines on a folder of real photos (bench/central_baselines.cc): cv::omnidir's unified
# model and an OCamCalib-style polynomial, the default split (every third photo held out) and
# 3-fold cross-validation, once with OpenCV's findChessboardCornersSB corners and once with
# findChessboardCorners + cornerSubPix. Full logs go to OUT (default: a temporary folder); the
# summaries are printed. Defaults fit Mei's paracatadioptric set (6 x 8 inner corners, 42 mm).
# The photos and anything derived from their pixels (logs with corners, corners files) stay
# outside the repository.
#   bench/central_baselines.sh PHOTOS_DIR [OUT] [-- extra bench_central_baselines flags]
set -euo pipefail
photos=${1:?usage: bench/central_baselines.sh PHOTOS_DIR [OUT] [-- flags]}
shift
out=""
if [ $# -gt 0 ] && [ "$1" != "--" ]; then out=$1; shift; fi
if [ $# -gt 0 ] && [ "$1" == "--" ]; then shift; fi
root="$(cd "$(dirname "$0")/.." && pwd)"
bench="$root/build/bench/bench_central_baselines"
[ -x "$bench" ] || { echo "build first: cmake --build build --target bench_central_baselines" >&2; exit 1; }
[ -n "$out" ] || out=$(mktemp -d)
mkdir -p "$out"
for detector in sb classic; do
  log="$out/central_baselines_$detector.log"
  "$bench" --photos "$photos" --rows 6 --cols 8 --square_mm 42 --detector "$detector" --folds 3 \
    --write_corners "$out/corners_$detector.txt" "$@" > "$log"
  echo "### corners: $detector (log: $log)"
  grep -E '^photos:|^== (split|fold)|dropped:' "$log" | sed 's/^ *//'
  sed -n '/^== summary/,$p' "$log"
done
