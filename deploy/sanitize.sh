#!/usr/bin/env bash
# The sanitizer stage of CI (deploy/test.sh runs it after the normal build's tests): builds everything with clang
# under AddressSanitizer + UndefinedBehaviorSanitizer in its own build directory (-DKILN_FUZZ=ON, so the fuzz
# targets come from the same build), runs the unit and integration tests there, then each fuzz target for a short,
# bounded time (tests/fuzz/run.sh). Any sanitizer report fails the stage.
# Usage: deploy/sanitize.sh [BUILD_DIR]   (default: build-asan/ at the top)
# Environment: KILN_FUZZ_SECONDS per fuzz target (default 20; 0 skips the fuzz runs).
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$(realpath -m "${1:-$top/build-asan}")"
fuzz_seconds="${KILN_FUZZ_SECONDS:-20}"
jobs="$(nproc)"

# deploy/setup.sh has installed clang-14 and libclang-rt-14-dev with the rest.
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$top" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 \
    -DKILN_FUZZ=ON >/dev/null
fi
start=$(date +%s)
cmake --build "$build" -j "$jobs"
echo "sanitize: build took $(($(date +%s) - start)) s"

# Leaks are reported too; every finding ends the test that made it, with a stack trace.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Leaks inside Debian's libraries that kiln cannot free (each explained in the file).
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$top/tests/fuzz/lsan.supp}"

# Each GoogleTest program once, all its tests in one process, `jobs` at a time: CTest starts one process per test
# (1,700 of them), and a sanitized program's start (loading OpenImageIO, OpenColorIO, Embree) costs about a second.
# Then the CTest tests that are not GoogleTest programs (the Python client, the fuzz replays).
start=$(date +%s)
logs="$build/sanitize-logs"
rm -rf "$logs"
mkdir -p "$logs"
failed=0
find "$build/tests" -maxdepth 1 -name '*_test' -type f -perm -u+x | sort |
  xargs -P "$jobs" -I{} bash -c 'cd "$(dirname "$1")" && "$1" --gtest_brief=1 >"$2/$(basename "$1").log" 2>&1 ||
                                 { echo "sanitize: FAILED $(basename "$1") (log: $2/$(basename "$1").log)"; exit 1; }' \
    _ {} "$logs" || failed=1
ctest --test-dir "$build" -j "$jobs" --output-on-failure -R '^(python_client|fuzz_replay_)' || failed=1
echo "sanitize: tests took $(($(date +%s) - start)) s"
if ((failed)); then
  for log in "$logs"/*.log; do
    grep -q -E "FAILED|ERROR: (Address|Leak)Sanitizer|runtime error" "$log" && { echo "=== $log"; tail -60 "$log"; }
  done
  exit 1
fi

if ((fuzz_seconds > 0)); then
  start=$(date +%s)
  "$top/tests/fuzz/run.sh" --build "$build" --no-build --time "$fuzz_seconds"
  echo "sanitize: fuzzing took $(($(date +%s) - start)) s"
fi
