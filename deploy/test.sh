#!/usr/bin/env bash
# Sets up (deploy/setup.sh), builds, and runs every test through CTest. This is what CI runs.
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$top/build}"
"$top/deploy/setup.sh" "$build"
ctest --test-dir "$build" -j "$(nproc)" --output-on-failure
