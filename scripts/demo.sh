#!/usr/bin/env bash
# README command (a): install dependencies, build the omnistereo program (not the tests), run
# the main job on the bundled default.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh omnistereo
./build/apps/omnistereo demo
