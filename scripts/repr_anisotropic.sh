#!/usr/bin/env bash
# The anisotropic preset's figures (docs/representations.md, "Presets: what to ship" and "Anisotropic
# surfaces"): bakes `repr bake --preset anisotropic` and, for comparison, full-range and part 2's seed 3D
# LUT (both read the isotropic-equivalent roughness), draws random anisotropic queries
# (scripts/repr_queries.py anisotropic: ratio 1-25, any tangent-relative azimuths), judges every file
# against the exact term with `microshadow eval --compare`, and prints per comparator the N.L-weighted
# RMS, p99 (of the N.L weight) and max |error|, the RMS per ratio band, and the queries outside each
# file's domain; then the preset's cost and bake time.
# Usage: scripts/repr_anisotropic.sh OUTDIR [MICROSHADOW] [QUERIES]
set -euo pipefail
out=${1:?usage: repr_anisotropic.sh OUTDIR [MICROSHADOW] [QUERIES]}
ms=${2:-build/microshadow}
count=${3:-10000}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
start=$(date +%s)
"$ms" repr bake -q --preset anisotropic --out "$out/anisotropic.exr"
echo "anisotropic bake: $(( $(date +%s) - start )) s wall"
[ -f "$out/full-range.exr" ] || "$ms" repr bake -q --preset full-range --out "$out/full-range.exr"
[ -f "$out/lut3d.exr" ] || "$ms" bake -q --out "$out/lut3d.exr"
python3 "$here/repr_queries.py" anisotropic "$out/queries-anisotropic.csv" "$count" 1
"$ms" eval -q --backend oracle --in "$out/queries-anisotropic.csv" --out "$out/results-anisotropic.csv" \
    --compare "anisotropic=$out/anisotropic.exr" --compare "full-range=$out/full-range.exr" --compare "lut3d=$out/lut3d.exr"
python3 - "$out" <<'PY'
import csv, json, math, sys
out = sys.argv[1]
rows = list(csv.DictReader(open(f"{out}/results-anisotropic.csv")))
meta = json.load(open(f"{out}/results-anisotropic.csv.json"))
outside = {c["name"]: (c["outside_domain"], c["lookups"]) for c in meta["comparators"]}
ratio = lambda r: max(float(r["alpha_x"]), float(r["alpha_y"])) / min(float(r["alpha_x"]), float(r["alpha_y"]))
bands = [(1, 2), (2, 5), (5, 10), (10, 25.0001)]
print(f"## anisotropic queries ({len(rows)})")
print("| comparator | N.L-weighted RMS | p99 | max | " + " | ".join(f"RMS ratio {a}-{round(b)}" for a, b in bands) + " | outside domain |")
for name in ("anisotropic", "full-range", "lut3d"):
    def stat(sel):
        e = [(float(r[name + "_error"]), max(float(r["wo_z"]), 0.0)) for r in rows if sel(r)]
        w = sum(x[1] for x in e)
        rms = math.sqrt(sum(x[1] * x[0] ** 2 for x in e) / w)
        by = sorted(e, key=lambda x: abs(x[0]))
        acc, p99 = 0.0, abs(by[-1][0])
        for x in by:
            acc += x[1]
            if acc >= 0.99 * w:
                p99 = abs(x[0])
                break
        return rms, p99, max(abs(x[0]) for x in e)
    a = stat(lambda r: True)
    cells = [f"{stat(lambda r, lo=lo, hi=hi: lo <= ratio(r) < hi)[0]:.4f}" for lo, hi in bands]
    o, n = outside[name]
    print(f"| {name} | {a[0]:.4f} | {a[1]:.3f} | {a[2]:.3f} | " + " | ".join(cells) + f" | {o} of {n} |")
PY
echo "anisotropic: $("$ms" repr info "$out/anisotropic.exr" | sed -n "s/^cost: //p")"
