#!/usr/bin/env bash
# Sets up (deploy/setup.sh), builds, and runs every test through CTest: what CI runs. --sanitize adds the sanitizer
# stage (deploy/sanitize.sh: the same tests built with clang under ASan + UBSan in build-asan/, and a short bounded
# run of every fuzz target), which is not yet part of CI: a fresh sanitized build and its run took ~50 minutes on the
# shared 2-core machine (docs/FUZZING.md).
# Usage: deploy/test.sh [--sanitize] [BUILD_DIR]
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
sanitize=0
if [ "${1:-}" = "--sanitize" ]; then
  sanitize=1
  shift
fi
build="${1:-$top/build}"
"$top/deploy/setup.sh" "$build"
ctest --test-dir "$build" -j "$(nproc)" --output-on-failure
if ((sanitize)); then
  "$top/deploy/sanitize.sh"
fi
