#!/usr/bin/env bash
# README command (b): install dependencies, build, run every test with ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh
cd build && ctest --output-on-failure -j"$(nproc)" --timeout 1500
