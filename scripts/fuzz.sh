#!/usr/bin/env bash
# Fuzzes the toolkit's file parsers (fuzz/fuzz_parser.cc): each parser's libFuzzer target runs
# for SECONDS (default 60), seeded with the sample configs, under ASan + UBSan. A finding (a crash,
# a hang, a memory error, an exception other than io::InputError) stops that target and leaves
# its input as build_fuzz/findings/<parser>/crash-*; add it to a regression test.
#   bash scripts/fuzz.sh [SECONDS] [PARSER ...]   parsers: model session detections design
#                                                 tolerance scene points_csv pixels_csv ply
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
[ $# -gt 0 ] && shift
parsers=(model session detections design tolerance scene points_csv pixels_csv ply)
[ $# -gt 0 ] && parsers=("$@")
bash scripts/install_deps.sh clang libclang-rt-14-dev
cmake -S . -B build_fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DOMNI_FUZZ=ON >/dev/null
targets=()
for p in "${parsers[@]}"; do targets+=("fuzz_$p"); done
cmake --build build_fuzz -j"$(nproc)" --target "${targets[@]}"

failed=0
for p in "${parsers[@]}"; do
  corpus=build_fuzz/corpus/$p findings=build_fuzz/findings/$p
  mkdir -p "$corpus" "$findings"
  case "$p" in
    points_csv) printf 'x_mm,y_mm,z_mm\n1000,0,100\n-500.5,20,nan\n' > "$corpus/seed.csv" ;;
    pixels_csv) printf 'u,v,image\n640.5,480,a.png\n1e3,-2,b.png\n' > "$corpus/seed.csv" ;;
    ply) printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 1\n1 2 3\n' > "$corpus/seed.ply" ;;
    # Seeds named by their path (two folders hold a calibrated_big_rig.yaml: cp refused to
    # overwrite the one it had just copied, and the script stopped before fuzzing).
    *) for f in sample_configs/*.yaml tests/data/*.yaml tests/model/data/*.yaml; do
         cp "$f" "$corpus/${f//\//_}"
       done ;;
  esac
  echo "== fuzz_$p for ${seconds} s"
  log=build_fuzz/fuzz_$p.log
  if ! ./build_fuzz/fuzz/fuzz_$p "$corpus" -max_total_time="$seconds" -timeout=10 \
      -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 -artifact_prefix="$findings/" \
      >"$log" 2>&1; then
    echo "FINDING in fuzz_$p: see $log and $findings/"
    failed=1
  fi
  grep -E "DONE|stat::number_of_executed_units|stat::average_exec_per_sec" "$log" || true
done
exit $failed
