#!/usr/bin/env bash
# kilnd's resident memory under a mixed load against its --memory-limit: one kilnd with two workers and a memory
# limit, fed at once with lightmaps of the bundled Cornell box's 8 meshes (at 4096², 134 M texels, and at 1448², the
# 16.8 M texels of issue 19's report, each of which must either fit the limit in tiles or be refused at submit, and
# two at 1024²), environments (a 2048 × 1024 sky into 256² cubes) and material tables. kilnd's
# VmRSS is sampled every 0.1 s from /proc until every job has ended; the script prints the peak against the limit
# and each job's outcome. A benchmark, not a test: it needs minutes of two cores.
#
#   tests/bench/mixed_load_rss.sh [--limit 1536M] [--build build]
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="$top/build"
limit="1536M"
while (($#)); do
  case "$1" in
    --limit) limit="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    *) echo "usage: $0 [--limit BYTES] [--build DIR]" >&2; exit 2 ;;
  esac
done

work="$(mktemp -d "${TMPDIR:-/tmp}/kiln-mixed-XXXXXX")"
token_file="$work/token"
( umask 077; od -An -N32 -tx1 /dev/urandom | tr -d ' \n' > "$token_file"; echo >> "$token_file" )
"$build/bin/kilnd" --listen 127.0.0.1:0 --store "$work/store" --token-file "$token_file" --workers 2 \
  --memory-limit "$limit" > "$work/kilnd.out" 2> "$work/kilnd.log" &
kilnd_pid=$!
cleanup() { kill -TERM "$kilnd_pid" 2>/dev/null && wait "$kilnd_pid" 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
. "$top/deploy/kilnd_address.sh"
address=$(kilnd_address "$work/kilnd.out" "$kilnd_pid") || { cat "$work/kilnd.log"; exit 1; }
kiln() { "$build/bin/kiln" --server "$address" --token-file "$token_file" "$@"; }

"$build/bin/kiln-sky" --width 2048 --out "$work/sky.exr" > /dev/null
/usr/bin/python3 "$top/client/examples/scenes/cornell_box.py" "$work/box.gltf" > /dev/null

# The RSS sampler: the largest VmRSS seen (kB), written when it grows.
rss_of() { awk '/^VmRSS:/ { print $2 }' "/proc/$kilnd_pid/status" 2>/dev/null || echo 0; }
( peak=0
  while kill -0 "$kilnd_pid" 2>/dev/null; do
    now=$(rss_of); if ((now > peak)); then peak=$now; echo "$peak" > "$work/peak"; fi
    sleep 0.1
  done ) &
sampler=$!
idle_kb=$(rss_of)

bake() {  # NAME KIND ARGS...: one bake, its outcome line in $work/NAME.outcome
  local name="$1"; shift
  if kiln bake "$@" --out "$work/out/$name" > "$work/$name.log" 2>&1; then
    echo "$name: succeeded" > "$work/$name.outcome"
  else
    echo "$name: $(grep -v '^$' "$work/$name.log" | tail -n 2 | tr '\n' ' ' | cut -c1-240)" > "$work/$name.outcome"
  fi
}
start=$(date +%s.%N)
names=()
pids=()
launch() { bake "$@" & pids+=($!); names+=("$1"); }
launch lm4096 lightmap "$work/box.gltf" --env "$work/sky.exr" --resolution 4096 --time-limit 20
launch lm1448 lightmap "$work/box.gltf" --env "$work/sky.exr" --resolution 1448 --time-limit 20
for i in 1 2; do
  launch "lm1024_$i" lightmap "$work/box.gltf" --env "$work/sky.exr" --resolution 1024 --time-limit 15 --seed "$i"
done
for i in 1 2 3; do launch "env_$i" env "$work/sky.exr" --size 256 --intensity "$i"; done
for a in 0.2 0.5 0.8 1.0; do launch "ggx_$a" material --model ggx --alpha "$a"; done
wait "${pids[@]}" || true
end=$(date +%s.%N)
kill "$sampler" 2>/dev/null || true
peak_kb=$(cat "$work/peak" 2>/dev/null || echo 0)

for n in "${names[@]}"; do cat "$work/$n.outcome"; done
limit_bytes=$(grep -m1 -oE "memory limit [0-9.]+ [KMG]iB" "$work/kilnd.log" || true)
echo
echo "kilnd: RSS idle $((idle_kb / 1024)) MiB, peak $((peak_kb / 1024)) MiB under --memory-limit $limit" \
  "(${limit_bytes:-the limit as given}); $(awk "BEGIN { printf \"%.1f\", $end - $start }") s for ${#names[@]} jobs"
grep -E "waiting for memory|refused" "$work/kilnd.log" | sed 's/^/  log: /' | head -20 || true
