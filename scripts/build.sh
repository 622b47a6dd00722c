#!/usr/bin/env bash
# Configures and builds into ./build (Release), incrementally. With arguments, builds only those
# targets (scripts/demo.sh builds just `omnistereo`: a fresh machine reaches the demo without
# compiling every test).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
if [ "$#" -gt 0 ]; then
  cmake --build build -j"$(nproc)" --target "$@"
else
  cmake --build build -j"$(nproc)"
fi
