#!/bin/bash
# The paper's sparse triangulation experiment (tab:rmse_triangulation_experiment) end to end:
#   omnistereo render (sample_configs/rmse_scene.yaml: 4 chessboards per range at 0.25..8 m)
#   -> omnistereo detect -> omnistereo triangulate --truth (RMSE, SD, points per range).
# Cases: (a) ideal rig, ideal model; (b) misaligned rig (big_rig_misaligned.yaml), ideal model;
# (t) misaligned rig, its true model (the bound a calibration can reach); (c) misaligned rig,
# calibrated model: set CALIBRATED_MODEL=path/to/calibrated.yaml.
# If `omnistereo detect` is not available yet, the truth's own pixels are triangulated with
# Gaussian noise NOISE_PX (default 0.08 px per coordinate: a 2D error of ~0.1 px mean, the
# paper's corner accuracy) instead, and the output says so.
# Usage: scripts/rmse_table.sh [OUT_DIR]   (OMNISTEREO=path/to/omnistereo, SIGMA_PX=1)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
EXE=${OMNISTEREO:-$ROOT/build/apps/omnistereo}
OUT=${1:-/tmp/omnistereo_rmse}
SIGMA_PX=${SIGMA_PX:-1}
NOISE_PX=${NOISE_PX:-0.08}
CONFIGS=$ROOT/sample_configs
mkdir -p "$OUT"

render() {  # rig name -> $OUT/<rig>/0001.png, truth.yaml
  local rig=$1
  if [ ! -f "$OUT/$rig/truth.yaml" ] || [ ! -f "$OUT/$rig/0001.png" ]; then
    "$EXE" render --model="$CONFIGS/$rig.yaml" --scene="$CONFIGS/rmse_scene.yaml" --out="$OUT/$rig"
  fi
}

detect() {  # rig name -> $OUT/<rig>/detections.yaml (returns 1 if detect is unavailable)
  local rig=$1 dir=$OUT/$1
  # `render` writes a session file beside its images; older versions did not.
  [ -f "$dir/session.yaml" ] || {
    echo "format: omnistereo-session/1"
    echo "model: $CONFIGS/big_rig_ideal.yaml"
    echo "images: [$dir/0001.png]"
    echo "targets:"
    # The scene's targets, as the truth file lists them.
    sed -n '/^targets:/,/^images:/p' "$dir/truth.yaml" | grep '^  - {type:'
  } > "$dir/session.yaml"
  [ -f "$dir/detections.yaml" ] && return 0
  "$EXE" detect --session="$dir/session.yaml" --out="$dir/detections.yaml" 2> "$dir/detect.log"
}

run_case() {  # label, rig, model
  local label=$1 rig=$2 model=$3
  echo "== ($label) rig $rig, model $(basename "$model")"
  if [ "$HAVE_DETECT" = 1 ]; then
    "$EXE" triangulate --model="$model" --detections="$OUT/$rig/detections.yaml" \
      --truth="$OUT/$rig/truth.yaml" --sigma_px="$SIGMA_PX" --out="$OUT/$label.csv"
  else
    "$EXE" triangulate --model="$model" --truth="$OUT/$rig/truth.yaml" --noise_px="$NOISE_PX" \
      --sigma_px="$NOISE_PX" --out="$OUT/$label.csv"
  fi
}

HAVE_DETECT=1
for rig in big_rig_ideal big_rig_misaligned; do
  render "$rig"
  if ! detect "$rig"; then
    HAVE_DETECT=0
    echo "omnistereo detect failed ($(tail -n 1 "$OUT/$rig/detect.log")):" \
         "using truth pixels + ${NOISE_PX} px noise"
  fi
done
run_case a big_rig_ideal "$CONFIGS/big_rig_ideal.yaml"
run_case b big_rig_misaligned "$CONFIGS/big_rig_ideal.yaml"
run_case t big_rig_misaligned "$CONFIGS/big_rig_misaligned.yaml"
if [ -n "${CALIBRATED_MODEL:-}" ]; then
  run_case c big_rig_misaligned "$CALIBRATED_MODEL"
fi
