#!/usr/bin/env bash
# Our single-mirror model side by side with the central models (bench/central_baselines.sh) on
# the SAME corners of real photos: each variant calibrated on the training photos and scored on
# the held-out ones with only the boards' poses solved (estimate: []), and on its own training
# photos the same way (every corner, no outlier left out), 2D RMS per corner.
#   bench/single_mirror_bench.sh PHOTOS_DIR CORNERS_FILE RIM_CX,CY,R_PX [OUT] [-- extra
#                                single_mirror_session.py flags]
# Variants: telecentric lens (the paraboloid's camera: R the scale, held), central (the mirror's
# axis along the lens's) and non-central (its tilt free); perspective lens over a free conic,
# central (the camera at the far focus) and non-central (the camera's pose free). Splits: every
# third photo held out, then 3 folds (photo i held out in fold i % 3). The photos and anything
# derived from their pixels stay outside the repository (OUT defaults to a temporary folder).
set -euo pipefail
photos=${1:?usage: bench/single_mirror_bench.sh PHOTOS_DIR CORNERS_FILE RIM [OUT] [-- flags]}
corners=${2:?corners file}
rim=${3:?rim cx,cy,r_px}
shift 3
out=""
if [ $# -gt 0 ] && [ "$1" != "--" ]; then out=$1; shift; fi
if [ $# -gt 0 ] && [ "$1" == "--" ]; then shift; fi
root="$(cd "$(dirname "$0")/.." && pwd)"
omni="$root/build/apps/omnistereo"
[ -x "$omni" ] || { echo "build first: cmake --build build --target omnistereo" >&2; exit 1; }
[ -n "$out" ] || out=$(mktemp -d)
n=$(grep -c '^photo ' "$corners")
rms() { grep -E '^residuals: rms' "$1" | sed -E 's/^residuals: rms ([0-9.]+) px.* over ([0-9]+) observations.*/\1 \2/'; }
printf '%-34s %-10s %8s %6s %8s %6s %8s\n' variant split train_px n heldout_px n solve_s
for variant in telecentric_central telecentric_noncentral perspective_central perspective_noncentral; do
  lens=${variant%%_*}
  case $variant in
    *_central) estimate=camera,distortion,mirror1_shape ;;
    *) estimate=camera,distortion,mirror1_shape,mirror1_pose ;;
  esac
  splits=("split:")
  for f in 0 1 2; do
    h=""
    for i in $(seq 1 "$n"); do [ $((i % 3)) -eq $f ] && h="$h${h:+,}$i"; done
    splits+=("fold$f:$h")
  done
  for s in "${splits[@]}"; do
    name=${s%%:*}
    holdout=${s#*:}
    d="$out/$variant/$name"
    python3 "$root/bench/single_mirror_session.py" --corners "$corners" --photos "$photos" \
      --out "$d" --rim "$rim" --lens "$lens" --estimate "$estimate" \
      ${holdout:+--holdout "$holdout"} "$@" > /dev/null
    start=$(date +%s.%N)
    "$omni" calibrate --session "$d/train/session.yaml" --detections "$d/train/detections.yaml" \
      --out "$d/train/calibrated.yaml" > "$d/train.log" 2>&1 || {
      printf '%-34s %-10s %s\n' "$variant" "$name" "$(grep '^omnistereo calibrate:' "$d/train.log" | cut -c22-)"
      continue
    }
    end=$(date +%s.%N)
    # The training photos scored like the held-out ones: every corner, poses by least squares.
    sed -e 's#^model: .*#model: calibrated.yaml#' -e 's#^estimate: .*#estimate: []#' \
      "$d/train/session.yaml" > "$d/train/score.yaml"
    "$omni" calibrate --session "$d/train/score.yaml" --detections "$d/train/detections.yaml" \
      --out "$d/train/scored.yaml" > "$d/train_score.log" 2>&1
    "$omni" calibrate --session "$d/heldout/session.yaml" --detections "$d/heldout/detections.yaml" \
      --out "$d/heldout/scored.yaml" > "$d/heldout.log" 2>&1
    read -r tr ntr < <(rms "$d/train_score.log")
    read -r ho nho < <(rms "$d/heldout.log")
    printf '%-34s %-10s %8s %6s %8s %6s %8.2f\n' "$variant" "$name" "$tr" "$ntr" "$ho" "$nho" \
      "$(echo "$end - $start" | bc)"
  done
done
echo "logs: $out"
