#!/usr/bin/env bash
# The realistic sweep (docs/representations.md): bakes part 2's 3D LUT and the representations at
# its memory (256 KiB as RGBA16F, 2 fetches per light), draws the query CSV, and judges every one against
# the term with `microshadow eval --compare`, in one run. Prints eval's per-comparator statistics and
# each file's cost. Usage: scripts/repr_realistic.sh OUTDIR [MICROSHADOW] [QUERIES]
set -euo pipefail
out=${1:?usage: repr_realistic.sh OUTDIR [MICROSHADOW] [QUERIES]}
ms=${2:-build/microshadow}
count=${3:-4000}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
samples="--samples 16384"
dense=0.3,0.35,0.4,0.45,0.5,0.55,0.6,0.65,0.7,0.75,0.8,0.85,0.9
python3 "$here/repr_realistic_queries.py" "$out/queries.csv" "$count" 15
"$ms" bake -q --out "$out/lut3d.exr"
# azimuth as an axis: 16 visibility x 16 NdotL x 16 NdotV x 8 azimuth nodes, RGBA = 4 roughness nodes
"$ms" repr bake -q $samples --half --kind azimuth-axis --azimuth-nodes 8 --roughness 0.1,0.4,0.7,1.0 --out "$out/axis-16-seedr.exr"
"$ms" repr bake -q $samples --half --kind azimuth-axis --azimuth-nodes 8 --roughness 0.3,0.5,0.7,0.9 --out "$out/axis-16.exr"
"$ms" repr bake -q $samples --half --kind azimuth-axis --azimuth-nodes 8 --roughness $dense --roughness-count 4 --out "$out/axis-16-chosenr.exr"
"$ms" repr bake -q $samples --half --kind azimuth-axis --azimuth-nodes 8 --n-dot-v-warp sqrt --n-dot-l-warp shadow-edge \
    --roughness 0.3,0.5,0.7,0.9 --out "$out/axis-16-warped.exr"
"$ms" repr bake -q $samples --half --kind azimuth-axis --azimuth-nodes 8 --visibility-count 32 --n-dot-v-count 8 \
    --roughness 0.3,0.5,0.7,0.9 --out "$out/axis-v32.exr"
# azimuth harmonics: a0..a3 in RGBA, roughness slabs along z
"$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --roughness 0.1,0.25,0.4,0.55,0.7,0.8,0.9,1.0 \
    --out "$out/harm-16-r8.exr"
"$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --roughness $dense --roughness-count 8 --out "$out/harm-16-chosenr.exr"
"$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --n-dot-v-warp sqrt --n-dot-l-warp shadow-edge \
    --roughness $dense --roughness-count 8 --out "$out/harm-16-chosenr-warped.exr"
"$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --visibility-count 32 --roughness 0.3,0.5,0.7,0.9 \
    --out "$out/harm-v32.exr"
"$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --visibility-count 32 --n-dot-v-count 8 \
    --roughness 0.3,0.386,0.471,0.557,0.643,0.729,0.814,0.9 --out "$out/harm-v32-nv8-r8.exr"
"$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --visibility-count 32 --n-dot-v-count 8 \
    --roughness 0.3,0.386,0.471,0.557,0.643,0.729,0.814,0.9 --visibility-warp sqrt-top --out "$out/harm-v32-nv8-r8-vtop.exr"
"$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --visibility-count 32 --n-dot-v-count 8 \
    --roughness 0.3,0.386,0.471,0.557,0.643,0.729,0.814,0.9 --visibility-warp sqrt-top --n-dot-l-warp sqrt-top --out "$out/harm-v32-nv8-r8-vltop.exr"
"$ms" repr bake -q $samples --half --kind azimuth-axis --azimuth-nodes 8 --visibility-count 32 --n-dot-v-count 8 \
    --roughness 0.3,0.5,0.7,0.9 --visibility-warp sqrt-top --out "$out/axis-v32-vtop.exr"
compare=(--compare "lut3d=$out/lut3d.exr")
for f in "$out"/axis-*.exr "$out"/harm-*.exr; do compare+=(--compare "$f"); done
"$ms" eval --in "$out/queries.csv" --out "$out/results.csv" --samples 65536 "${compare[@]}" 2>&1 | grep 'term:'
for f in "$out"/axis-*.exr "$out"/harm-*.exr; do echo "$(basename "$f" .exr): $("$ms" repr info "$f" | sed -n "s/^cost: //p")"; done
# The 99th percentile of |error| per comparator (eval prints max, RMS and N.L-weighted RMS).
python3 - "$out/results.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
for name in [c[:-6] for c in rows[0] if c.endswith("_error") and c != "std_error"]:
    e = sorted(abs(float(r[name + "_error"])) for r in rows)
    print(f"{name}: p99 |error| {e[int(0.99 * (len(e) - 1))]:.4g}")
PY
