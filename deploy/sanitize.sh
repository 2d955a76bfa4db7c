#!/usr/bin/env bash
# The sanitizer stage (deploy/test.sh --sanitize runs it after the normal build's tests): builds everything with clang
# under AddressSanitizer + UndefinedBehaviorSanitizer in its own build directory (-DKILN_FUZZ=ON, so the fuzz
# targets come from the same build), runs the unit and integration tests there, then each fuzz target for a short,
# bounded time (tests/fuzz/run.sh). Any sanitizer report fails the stage. Each step prints its wall and CPU seconds,
# so every CI log measures the stage (docs/FUZZING.md).
# Usage: deploy/sanitize.sh [BUILD_DIR]   (default: build-asan/ at the top)
# Environment: KILN_FUZZ_SECONDS per fuzz target (default 20; 0 skips the fuzz runs); KILN_FUZZ_TARGETS, the targets
# to run (default: all of them).
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$(realpath -m "${1:-$top/build-asan}")"
fuzz_seconds="${KILN_FUZZ_SECONDS:-20}"
read -r -a fuzz_targets <<<"${KILN_FUZZ_TARGETS:-request job_spec mesh_blob exr png texture environment ktx2 vdb job_text scene_import}"
jobs="$(nproc)"

# CPU seconds (user + system) of this shell's finished children so far, in cpu_now: the `times` builtin, run in this
# shell (in a pipeline or a subshell it would count that subshell's children).
cpu_now=0
read_cpu() {
  times >"$build/.sanitize-times"
  cpu_now="$(awk 'NR == 2 { t = 0; for (i = 1; i <= 2; ++i) { split($i, p, /[ms]/); t += p[1] * 60 + p[2] }
                            printf "%.0f", t }' "$build/.sanitize-times")"
}
# Starts timing a step; took STEP prints its wall and CPU seconds.
step_start() { start=$(date +%s); read_cpu; cpu_start=$cpu_now; }
took() { read_cpu; echo "sanitize: $1 took $(($(date +%s) - start)) s wall, $((cpu_now - cpu_start)) CPU s"; }

# deploy/setup.sh has installed clang-14 and libclang-rt-14-dev with the rest. Line tables only, not -g: the
# sanitizers' stack traces keep their files and lines, and compiling and linking cost less (docs/FUZZING.md).
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$top" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" -DKILN_FUZZ=ON >/dev/null
fi
mkdir -p "$build"
stage_start=$(date +%s)
step_start
cmake --build "$build" -j "$jobs"
took build

# Leaks are reported too; every finding ends the test that made it, with a stack trace.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Leaks inside Debian's libraries that kiln cannot free (each explained in the file).
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$top/tests/fuzz/lsan.supp}"

# Each GoogleTest program once, all its tests in one process, `jobs` at a time: CTest starts one process per test
# (1,700 of them), and a sanitized program's start (loading OpenImageIO, OpenColorIO, Embree) costs about a second.
# Then the CTest tests that are not GoogleTest programs: the Python client's against the sanitized kilnd, plain and
# over TLS, and the fuzz replays. Not install_prefix: it checks the install layout, which the normal stage proves, and
# its find_package program would link the sanitized libraries without the sanitizers' runtime.
step_start
logs="$build/sanitize-logs"
rm -rf "$logs"
mkdir -p "$logs"
failed=0
find "$build/tests" -maxdepth 1 -name '*_test' -type f -perm -u+x | sort |
  xargs -P "$jobs" -I{} bash -c 'cd "$(dirname "$1")" && "$1" --gtest_brief=1 >"$2/$(basename "$1").log" 2>&1 ||
                                 { echo "sanitize: FAILED $(basename "$1") (log: $2/$(basename "$1").log)"; exit 1; }' \
    _ {} "$logs" || failed=1
ctest --test-dir "$build" -j "$jobs" --output-on-failure -R '^(python_client|python_tls|fuzz_replay_)' || failed=1
took tests
if ((failed)); then
  for log in "$logs"/*.log; do
    grep -q -E "FAILED|ERROR: (Address|Leak)Sanitizer|runtime error" "$log" && { echo "=== $log"; tail -60 "$log"; }
  done
  exit 1
fi

if ((fuzz_seconds > 0)); then
  step_start
  "$top/tests/fuzz/run.sh" --build "$build" --no-build --time "$fuzz_seconds" "${fuzz_targets[@]}"
  took fuzzing
fi
echo "sanitize: the stage took $(($(date +%s) - stage_start)) s"
