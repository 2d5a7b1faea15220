#!/usr/bin/env bash
# The realistic sweep as a `microshadow sweep` grid (docs/study/repr-realistic.toml): bakes part
# 2's 3D LUT and the two best representations of docs/representations.md into docs/study/luts/ (RGBA16F,
# 256 KiB of texels each), runs the sweep, and prints the table of docs/representations.md ("the realistic
# sweep as a grid"). Usage: scripts/repr_realistic_sweep.sh OUTDIR [MICROSHADOW] [--no-bake]
set -euo pipefail
out=${1:?usage: repr_realistic_sweep.sh OUTDIR [MICROSHADOW] [--no-bake]}
ms=${2:-build/microshadow}
here=$(cd "$(dirname "$0")" && pwd)
luts="$here/../docs/study/luts"
if [[ "${3:-}" != "--no-bake" ]]; then
    mkdir -p "$luts"
    samples="--samples 65536"
    # part 2's seed 3D LUT: 32^3, roughness 0.1/0.4/0.7/1.0 in RGBA, mean over the azimuth
    "$ms" bake -q $samples --half --out "$luts/repr-lut3d-32.exr"
    # azimuth axis: 32 visibility x 16 NdotL x 8 NdotV x 8 azimuth slots, RGBA = roughness 0.3/0.5/0.7/0.9
    "$ms" repr bake -q $samples --half --kind azimuth-axis --azimuth-nodes 8 --visibility-count 32 --n-dot-v-count 8 \
        --roughness 0.3,0.5,0.7,0.9 --out "$luts/repr-axis-v32.exr" --shader-glsl "$luts/repr-axis-v32.glsl"
    # harmonics: a0..a3 per texel, 32 visibility x 16 NdotL x 16 NdotV x 4 roughness slabs
    "$ms" repr bake -q $samples --half --kind azimuth-harmonics --azimuth-nodes 9 --visibility-count 32 \
        --roughness 0.3,0.5,0.7,0.9 --out "$luts/repr-harm-v32.exr" --shader-glsl "$luts/repr-harm-v32.glsl"
    # the same harmonics as an engine loads it
    "$ms" repr export "$luts/repr-harm-v32.exr" --half --out "$luts/repr-harm-v32.ktx2"
fi
ls -l "$luts"/repr-*
"$ms" sweep "$here/../docs/study/repr-realistic.toml" --out "$out" --restart
python3 "$here/repr_sweep_table.py" "$out/sweep.csv" lut3d-32
for f in "$luts"/repr-axis-v32.exr "$luts"/repr-harm-v32.exr; do echo "$(basename "$f" .exr): $("$ms" repr info "$f" | sed -n "s/^cost: //p")"; done
