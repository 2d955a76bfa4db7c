#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, AddressSanitizer + UndefinedBehaviorSanitizer, -DKILN_FUZZ=ON) in their own
# build directory and runs each for a bounded time, one at a time, then prints executions and crashes per target.
#
# Usage: tests/fuzz/run.sh [--build DIR] [--time SECONDS] [--seeds] [TARGET...]
#   --build DIR     build directory (default: build-asan at the top; deploy/sanitize.sh shares it)
#   --time SECONDS  per target (default 60)
#   --seeds         regenerate the committed seed corpora (tests/fuzz/corpus/) first, and stop
#   --no-build      run the programs already built (while another build of DIR is under way)
#   TARGET          request job_spec mesh_blob exr png texture environment ktx2 vdb job_text scene_import (default: all)
# The corpus each run grows lives in BUILD/fuzz/corpus/TARGET (the committed seeds are read, never written); a crash's
# input is saved as BUILD/fuzz/artifacts/TARGET/crash-* and the script exits 1. Runs under `nice -n 19` (KILN_FUZZ_NICE
# sets another niceness); the table gives wall seconds (libFuzzer's) and CPU seconds (user + system), which differ on
# a busy machine. Two runs may share a build directory (each on its own targets).
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="$top/build-asan"
seconds=60
seeds=0
build_first=1
targets=()
while (($#)); do
  case "$1" in
    --build) build="$(realpath -m "$2")"; shift 2 ;;
    --time) seconds="$2"; shift 2 ;;
    --seeds) seeds=1; shift ;;
    --no-build) build_first=0; shift ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    -*) echo "run.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
all=(request job_spec mesh_blob exr png texture environment ktx2 vdb job_text scene_import)
((${#targets[@]})) || targets=("${all[@]}")

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$top" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" -DKILN_FUZZ=ON >/dev/null
fi
if ((seeds)); then
  cmake --build "$build" -j "$(nproc)" --target fuzz_make_seeds
  rm -rf "$top/tests/fuzz/corpus"
  "$build/tests/fuzz/fuzz_make_seeds" "$top/tests/fuzz/corpus" "$top/client/examples"
  echo "seed corpora written to tests/fuzz/corpus/"
  exit 0
fi
if ((build_first)); then
  cmake --build "$build" -j "$(nproc)" --target "${targets[@]/%/_fuzz}"
fi

# Leaks are findings too; a sanitizer report ends the run with the input saved.
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Leaks inside Debian's libraries that kiln cannot free (each explained in the file).
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$top/tests/fuzz/lsan.supp}"
found=0
report=()
# Sets cpu_now to the CPU seconds (user + system) of this shell's finished children so far: the `times` builtin,
# run in this shell (in a subshell it would count the subshell's children).
cpu_now=0
read_cpu() {
  times >"$build/fuzz/.times-$$"
  cpu_now="$(awk 'NR == 2 { t = 0; for (i = 1; i <= 2; ++i) { split($i, p, /[ms]/); t += p[1] * 60 + p[2] }
                            printf "%.0f", t }' "$build/fuzz/.times-$$")"
}
for t in "${targets[@]}"; do
  work="$build/fuzz/corpus/$t"
  artifacts="$build/fuzz/artifacts/$t"
  mkdir -p "$work" "$artifacts"
  dict=()
  [ -f "$top/tests/fuzz/dict/$t.dict" ] && dict=(-dict="$top/tests/fuzz/dict/$t.dict")
  log="$build/fuzz/$t.log"
  echo "fuzzing $t for ${seconds}s (log: $log)"
  stamp="$build/fuzz/.started-$t"
  touch "$stamp"
  status=0
  read_cpu
  cpu_before=$cpu_now
  nice -n "${KILN_FUZZ_NICE:-19}" "$build/fuzz/${t}_fuzz" -max_total_time="$seconds" -timeout=30 -print_final_stats=1 \
    -artifact_prefix="$artifacts/" "${dict[@]}" "$work" "$top/tests/fuzz/corpus/$t" >"$log" 2>&1 || status=$?
  read_cpu
  cpu=$((cpu_now - cpu_before))
  runs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)"
  secs="$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log" | tail -1)"
  crashes="$(find "$artifacts" -type f -newer "$stamp" \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' \
    -o -name 'oom-*' \) | wc -l)"
  # Inputs slower than 10 s are saved too; they are not failures (a busy machine makes them) but worth a look.
  slow="$(find "$artifacts" -type f -newer "$stamp" -name 'slow-unit-*' | wc -l)"
  ((slow == 0)) || echo "  $t: $slow input(s) took over 10 s, saved in $artifacts/slow-unit-*"
  if ((status != 0)); then
    found=1
    ((crashes > 0)) || crashes=1
    echo "  $t: the fuzzer stopped with status $status; see $log and $artifacts/"
  fi
  report+=("$(printf '%-14s %10s %8s %8s %8s' "$t" "${runs:-?}" "${secs:-$seconds}" "$cpu" "$crashes")")
  echo "  $t: ${runs:-?} executions, ${secs:-$seconds} s, $cpu CPU s, $crashes found"
done
printf '%-14s %10s %8s %8s %8s\n' target executions seconds cpu_s crashes
printf '%s\n' "${report[@]}"
exit "$found"
