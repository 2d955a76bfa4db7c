#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks for kiln (quietly, only what is missing), then configures and builds.
# Usage: deploy/setup.sh [BUILD_DIR]   (default: build/ at the top of the repository)
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$top/build}"

packages=(
  build-essential cmake ninja-build pkg-config git
  libembree-dev libopenvdb-dev libopenimageio-dev openimageio-tools libopencolorio-dev opencolorio-tools
  libboost-dev libboost-system-dev libboost-iostreams-dev libprotobuf-dev protobuf-compiler libtbb-dev
  libsqlite3-dev libssl-dev openssl python3 python3-protobuf libassimp-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcgal-dev libeigen3-dev  # the lightmap-UV generator's chart flattening (bakers/uvgen/), header-only
  clang-14 libclang-rt-14-dev  # the sanitizer stage and the fuzz targets (deploy/sanitize.sh, tests/fuzz/)
  python3-venv python3-pip python3-setuptools python3-wheel  # the Python client's package and its install test
  help2man  # the man pages, made from each program's --help (cmake/install.cmake)
  libxml2-utils  # xmllint, which validates `kiln build`'s JUnit report against tests/integration/junit.xsd
  redis-server libhiredis-dev  # kilnd's farm mode (daemon/cluster/, docs/SCALING.md) and its tests' real Redis
  assimp-testmodels  # real models for the importer's test (tests/integration/assimp_models_test.cpp): 21 MB, 74 MB installed
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "kiln setup: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$top" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
fi
cmake --build "$build" -j "$(nproc)"
