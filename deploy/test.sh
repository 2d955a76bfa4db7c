#!/usr/bin/env bash
# What CI runs (.ci/run): sets up (deploy/setup.sh), builds, runs every test through CTest, then the sanitizer stage
# (deploy/sanitize.sh: the same tests built with clang under ASan + UBSan in build-asan/, and a short bounded run of
# each fuzz target; docs/FUZZING.md). --no-sanitize stops after the first stage (a quicker check while developing).
# Usage: deploy/test.sh [--no-sanitize] [BUILD_DIR]
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
sanitize=1
if [ "${1:-}" = "--no-sanitize" ]; then
  sanitize=0
  shift
fi
build="${1:-$top/build}"
"$top/deploy/setup.sh" "$build"
start=$(date +%s)
ctest --test-dir "$build" -j "$(nproc)" --output-on-failure
echo "test: the tests took $(($(date +%s) - start)) s"
if ((sanitize)); then
  "$top/deploy/sanitize.sh"
fi
