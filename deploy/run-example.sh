#!/usr/bin/env bash
# The main job, as far as kiln goes today: set up and build, then bake the bundled example materials with kiln-brdf
# into out/ and say where they are and what they cost. (The daemon kilnd and the client kiln come with the service
# milestone; this script will then start kilnd and submit the same examples through it.)
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$top/build"
out="$top/out"
"$top/deploy/setup.sh" "$build"
mkdir -p "$out"
brdf="$build/bin/kiln-brdf"

bake() {  # bake NAME ARGS...: albedo and split-sum tables of one material
  local name="$1"; shift
  local start="$EPOCHREALTIME"
  "$brdf" table "$@" --n-mu 32 --n-roughness 32 --samples 4096 > "$out/$name.csv"
  printf '  %-28s %-60s %6.2f s\n' "$name.csv" "$*" "$(awk -v a="$start" -v b="$EPOCHREALTIME" 'BEGIN{print b-a}')"
}

echo "kiln: baking the example materials into $out"
bake ggx-dielectric      --model ggx --alpha 0.3 --fresnel schlick --f0 0.04
bake beckmann-rough      --model beckmann --alpha 0.7 --masking height-correlated
bake cook-torrance-glass --model cook-torrance --alpha 0.2 --fresnel exact --eta 1.5
bake oren-nayar-clay     --model oren-nayar --albedo 0.8,0.5,0.3 --sigma 0.5
bake schlick-brushed     --model schlick --c 0.9 --r 0.2 --p 0.3
echo "kiln: each CSV holds the directional albedo table (with standard errors) and the split-sum table."
