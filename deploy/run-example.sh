#!/usr/bin/env bash
# The main job: set up and build, start kilnd (loopback only, a store under out/, a freshly generated token), submit
# the bundled example jobs (client/examples/*.textproto) with the kiln client, write each job's outputs into
# out/<example>/, bake a generated HDR sky (out/sky.exr, uploaded by `kiln bake env`) into out/sky_env/, say where
# they are and what they cost, and stop the daemon.
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$top/build"
out="$top/out"
"$top/deploy/setup.sh" "$build"

state="$out/.kilnd"
mkdir -p "$state"
token_file="$state/token"
# A new token for this run, readable only by its owner (kilnd refuses a token file others can read).
( umask 077; od -An -N32 -tx1 /dev/urandom | tr -d ' \n' > "$token_file"; echo >> "$token_file" )

"$build/bin/kilnd" --listen 127.0.0.1:0 --store "$state/store" --token-file "$token_file" \
  > "$state/kilnd.out" 2> "$state/kilnd.log" &
kilnd_pid=$!
stop_daemon() { kill -TERM "$kilnd_pid" 2>/dev/null && wait "$kilnd_pid" 2>/dev/null || true; }
trap stop_daemon EXIT

address=""
for _ in $(seq 1 300); do
  address=$(sed -n 's/^kilnd: listening on \(127\.0\.0\.1:[0-9]*\)$/\1/p' "$state/kilnd.out")
  [ -n "$address" ] && break
  kill -0 "$kilnd_pid" 2>/dev/null || { echo "kilnd did not start:"; cat "$state/kilnd.log"; exit 1; }
  sleep 0.1
done
[ -n "$address" ] || { echo "kilnd did not start within 30 s:"; cat "$state/kilnd.log"; exit 1; }
echo "kiln: kilnd is listening on $address (store $state/store, log $state/kilnd.log)"

status=0
for job in "$top"/client/examples/*.textproto; do
  name="$(basename "$job" .textproto)"
  echo
  echo "kiln: baking $name"
  "$build/bin/kiln" --server "$address" --token-file "$token_file" submit "$job" --wait --out "$out/$name" || status=1
done

# An environment for image-based lighting: a synthetic HDR sky (a sun 10^4 times the zenith) uploaded and baked.
echo
echo "kiln: generating an HDR sky (out/sky.exr) and baking it for image-based lighting"
"$build/bin/kiln-sky" --width 256 --out "$out/sky.exr" || status=1
"$build/bin/kiln" --server "$address" --token-file "$token_file" bake env "$out/sky.exr" --size 128 \
  --out "$out/sky_env" || status=1

# A second run of the same jobs is answered from the result cache: that is what makes a CI asset build fast.
echo
echo "kiln: submitting the first example again (a cache hit, no bake)"
first="$(ls "$top"/client/examples/*.textproto | head -n 1)"
"$build/bin/kiln" --server "$address" --token-file "$token_file" submit "$first" --wait --out "$out/cache-hit" || status=1

echo
"$build/bin/kiln" --server "$address" --token-file "$token_file" status || true
echo
echo "kiln: outputs are in $out/<example>/ (EXR tables, MERL where asked, report.json) and $out/sky_env/ (the"
echo "     prefiltered specular cube as KTX2 and EXR faces, irradiance, SH, DFG table, preview.png, report.json)"
exit $status
