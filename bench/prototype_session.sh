#!/usr/bin/env bash
# Timed CLI run of the paper's prototype as a user photographs it: the 10-photo
# 5 MP session of sample_configs/prototype_scene.yaml (webcam preset, three posts), rendered once
# into DIR (~45 s per frame per POV-Ray process; kept for later runs), then followed as
# docs/guide.md says: init --posts 3, detect, calibrate. Prints each step's wall and CPU time and
# the calibration's distance from the true rig (--truth_model: the render's model).
#   bench/prototype_session.sh DIR [JOBS=2]
set -euo pipefail
dir=${1:?usage: bench/prototype_session.sh DIR [JOBS]}
jobs=${2:-2}
root="$(cd "$(dirname "$0")/.." && pwd)"
omni="$root/build/apps/omnistereo"
[ -x "$omni" ] || { echo "build first: bash scripts/build.sh omnistereo" >&2; exit 1; }
mkdir -p "$dir/work"
if [ ! -f "$dir/render/model.yaml" ]; then
  "$omni" render --model "$root/sample_configs/big_rig_prototype.yaml" \
    --scene "$root/sample_configs/prototype_scene.yaml" --out "$dir/render" --jobs "$jobs"
fi
targets='[{type: chessboard, rows: 5, cols: 6, square: 35}, {type: chessboard, rows: 3, cols: 8, square: 90}, {type: kalibr_aprilgrid, rows: 2, cols: 3, tag_size: 65, spacing: 0.3, first_id: 50}, {type: kalibr_aprilgrid, rows: 2, cols: 4, tag_size: 140, spacing: 0.3, first_id: 60}]'
timed() {  # name, command...: the command's last lines and its wall / CPU seconds
  local name=$1; shift
  local t0 c0 t1 c1
  t0=$(date +%s.%N)
  /usr/bin/time -f "%U %S" -o "$dir/$name.time" "$@" > "$dir/$name.log" 2>&1
  t1=$(date +%s.%N)
  read -r user sys < "$dir/$name.time"
  printf '%-10s wall %6.2f s  CPU %6.2f s\n' "$name" "$(echo "$t1 - $t0" | bc)" "$(echo "$user + $sys" | bc)"
}
timed init "$omni" init --images "$dir/render/*.jpg" --design big_rig --posts 3 \
  --targets "$targets" --out "$dir/work/session.yaml"
timed detect "$omni" detect --session "$dir/work/session.yaml" --out "$dir/work/detections.yaml"
timed calibrate "$omni" calibrate --session "$dir/work/session.yaml" \
  --detections "$dir/work/detections.yaml" --out "$dir/work/calibrated.yaml" \
  --truth_model "$dir/render/model.yaml"
grep -E "posts|corners, detections" "$dir/init.log" "$dir/detect.log" | sed 's/^[^:]*://' || true
grep -A2 "against the true model" "$dir/calibrate.log" || true
