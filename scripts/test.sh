#!/usr/bin/env bash
# README command (b): install dependencies, build, run every test with ctest.
#   bash scripts/test.sh                the Release build in ./build, every test
#   bash scripts/test.sh --sanitize     the same suite built with AddressSanitizer + UBSan
#                                       (-DOMNI_SANITIZE=ON) in ./build_sanitize: a memory error,
#                                       leak or undefined behaviour fails its test. Reports from
#                                       other projects' libraries only: scripts/{lsan,ubsan}.supp.
#   bash scripts/test.sh --sanitize --targets io_tests,model_tests [ctest args]
#                                       only those test executables (CI's subset, .ci/run)
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" != "--sanitize" ]; then
  bash scripts/install_deps.sh
  bash scripts/build.sh
  cd build && ctest --output-on-failure -j"$(nproc)" --timeout 1500
  exit
fi
shift
targets=()
if [ "${1:-}" = "--targets" ]; then
  IFS=, read -r -a targets <<<"$2"
  shift 2
fi
bash scripts/install_deps.sh
supp="$PWD/scripts"
# Set before building too: gtest_discover_tests runs each test binary when it is linked.
# halt_on_error: the first report fails the test (a child process's non-zero exit shows it).
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$supp/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="suppressions=$supp/ubsan.supp:print_stacktrace=1:halt_on_error=1"
cmake -S . -B build_sanitize -DCMAKE_BUILD_TYPE=Release -DOMNI_SANITIZE=ON >/dev/null
if [ ${#targets[@]} -gt 0 ]; then
  cmake --build build_sanitize -j"$(nproc)" --target "${targets[@]}"
else
  cmake --build build_sanitize -j"$(nproc)" --target omni_tests
fi
# Sanitized tests run ~2-4x slower: tests/CMakeLists.txt gives each three times its time limit.
# With --targets, only their tests (each test is labelled with its executable's name).
only=()
if [ ${#targets[@]} -gt 0 ]; then
  only=(-L "^($(IFS='|'; echo "${targets[*]}"))\$")
fi
cd build_sanitize && ctest --output-on-failure -j"$(nproc)" --timeout 4500 "${only[@]}" "$@"
