#!/usr/bin/env bash
# Installs the Debian 12 packages the toolkit needs, only if one is missing (run as root).
# Extra packages may be named as arguments (scripts/fuzz.sh adds clang and its fuzzer runtime).
set -euo pipefail
packages=(cmake g++ make pkg-config libeigen3-dev libceres-dev libopencv-dev libopencv-contrib-dev
  libapriltag-dev libgflags-dev libgoogle-glog-dev libnlopt-cxx-dev libyaml-cpp-dev povray
  googletest libgtest-dev libbenchmark-dev gnuplot-nox chromium pybind11-dev python3-dev
  python3-numpy python3-yaml libcairo2-dev libdeflate-dev
  poppler-utils "$@")
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update
  apt-get install -y "${missing[@]}"
fi
