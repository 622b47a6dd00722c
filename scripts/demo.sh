#!/usr/bin/env bash
# README command (a): install dependencies, build, run the main job on the bundled default.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh
./build/apps/omnistereo demo
