#!/usr/bin/env bash
# Bakes a fixed set of jobs with fixed seeds through a real kilnd and prints the SHA-256 of every output file, so that
# a restructuring can show it changed no byte: run it before and after, and diff the two listings.
#
#   tests/tools/output_digests.sh [BUILD_DIR] > digests.txt      (BUILD_DIR defaults to build/)
#   KILN_DIGESTS_KEEP=DIR tests/tools/output_digests.sh ...         also keeps the outputs in DIR, to compare them
#
# The jobs: every example in client/examples/ (a GGX, Oren-Nayar and Schlick material, Cook-Torrance glass with its
# MERL table, a constant environment), an environment bake of a generated sky with a sun, and the lightmaps of the
# bundled Cornell box. Each report.json is hashed after its timing fields (seconds, rates, ETAs, wall-clock stamps,
# the file's own digest) are taken out and the rest is written back in a fixed layout: its keys, their order, the
# structure and the values count (a number as a number: 1 and 1.0 are the same JSON value), the layout of its
# whitespace does not. Every other file is hashed as it is.
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="$(cd "${1:-$top/build}" && pwd)"
work="$(mktemp -d)"
kilnd_pid=""
cleanup() {
  [ -n "$kilnd_pid" ] && { kill -TERM "$kilnd_pid" 2>/dev/null; wait "$kilnd_pid" 2>/dev/null || true; }
  rm -rf "$work"
}
trap cleanup EXIT

( umask 077; echo "output-digests-token-0123456789abcdef" > "$work/token" )
"$build/bin/kilnd" --listen 127.0.0.1:0 --store "$work/store" --token-file "$work/token" --workers 1 \
  > "$work/kilnd.out" 2> "$work/kilnd.log" &
kilnd_pid=$!
. "$top/deploy/kilnd_address.sh"
address=$(kilnd_address "$work/kilnd.out" "$kilnd_pid") ||
  { echo "kilnd did not start:" >&2; cat "$work/kilnd.log" >&2; exit 1; }
kiln() {
  "$build/bin/kiln" --server "$address" --token-file "$work/token" "$@" > "$work/kiln.log" 2>&1 ||
    { echo "kiln $*: failed" >&2; cat "$work/kiln.log" >&2; return 1; }
}

out="$work/out"
for job in "$top"/client/examples/*.textproto; do
  kiln submit "$job" --wait --out "$out/$(basename "$job" .textproto)"
done
"$build/bin/kiln-sky" --width 128 --out "$out/sky.exr" > /dev/null 2>&1
kiln bake env "$out/sky.exr" --size 32 --seed 7 --out "$out/sky_env"
/usr/bin/python3 "$top/client/examples/scenes/cornell_box.py" "$out/cornell_box.gltf" > /dev/null
kiln bake lightmap "$out/cornell_box.gltf" --resolution 32 --target-error 0.1 --seed 7 --out "$out/cornell_box"

[ -n "${KILN_DIGESTS_KEEP:-}" ] && cp -r "$out" "$KILN_DIGESTS_KEEP"

# Timing fields: measured times (and the environment bake's "time" object of per-stage times), rates derived from
# them, wall-clock stamps, and the report's own digest and size.
/usr/bin/python3 - "$out" <<'PY'
import hashlib, json, os, re, sys

root = sys.argv[1]
TIMING = re.compile(r"^(seconds|total_seconds|eta_seconds|mrays_per_second|time)$|_unix$")

def strip(v):
    if isinstance(v, dict):
        own = v.get("name") == "report.json"
        return {k: strip(x) for k, x in v.items()
                if not TIMING.search(k) and not (own and k in ("sha256", "size"))}
    if isinstance(v, list):
        return [strip(x) for x in v]
    if isinstance(v, int) and not isinstance(v, bool):
        return float(v)
    return v

for dirpath, _, files in sorted(os.walk(root)):
    for f in sorted(files):
        path = os.path.join(dirpath, f)
        data = open(path, "rb").read()
        if f.endswith(".json"):
            data = json.dumps(strip(json.loads(data)), indent=1, ensure_ascii=False).encode()
        print(hashlib.sha256(data).hexdigest(), os.path.relpath(path, root))
PY
