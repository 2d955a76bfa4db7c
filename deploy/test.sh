#!/usr/bin/env bash
# Sets up (deploy/setup.sh), builds, and runs every test through CTest; then the sanitizer stage (deploy/sanitize.sh:
# the same tests built with clang under ASan + UBSan in build-asan/, and a short bounded run of every fuzz target).
# This is what CI runs. --no-sanitize skips the sanitizer stage (a quicker local run).
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
ctest --test-dir "$build" -j "$(nproc)" --output-on-failure
if ((sanitize)); then
  "$top/deploy/sanitize.sh"
fi
