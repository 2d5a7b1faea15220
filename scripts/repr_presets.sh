#!/usr/bin/env bash
# The presets' figures (docs/representations.md, "Presets: what to ship"): bakes `repr bake --preset`
# realistic and full-range and part 2's seed 3D LUT, draws random queries on each preset's domain
# (scripts/repr_queries.py), judges every file against the exact term with `microshadow eval --compare`,
# and prints per domain and comparator the N.L-weighted RMS, p99 and max |error|, the RMS per roughness
# band and the queries outside each file's domain, then each file's cost.
# Usage: scripts/repr_presets.sh OUTDIR [MICROSHADOW] [QUERIES]
set -euo pipefail
out=${1:?usage: repr_presets.sh OUTDIR [MICROSHADOW] [QUERIES]}
ms=${2:-build/microshadow}
count=${3:-20000}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
"$ms" bake -q --out "$out/lut3d.exr"
"$ms" repr bake -q --preset realistic --half --out "$out/realistic.exr"
"$ms" repr bake -q --preset full-range --half --out "$out/full-range.exr"
for domain in realistic full-range; do
    python3 "$here/repr_queries.py" "$domain" "$out/queries-$domain.csv" "$count" 24
    "$ms" eval -q --backend oracle --in "$out/queries-$domain.csv" --out "$out/results-$domain.csv" \
        --compare "lut3d=$out/lut3d.exr" --compare "realistic=$out/realistic.exr" --compare "full-range=$out/full-range.exr"
done
python3 - "$out" <<'PY'
import csv, json, math, sys
out = sys.argv[1]
bands = [(0.05, 0.1), (0.1, 0.2), (0.2, 0.3), (0.3, 0.9), (0.9, 1.0)]
for domain in ("realistic", "full-range"):
    rows = list(csv.DictReader(open(f"{out}/results-{domain}.csv")))
    meta = json.load(open(f"{out}/results-{domain}.csv.json"))
    outside = {c["name"]: (c["outside_domain"], c["lookups"]) for c in meta["comparators"]}
    print(f"## {domain} queries ({len(rows)})")
    print("| comparator | N.L-weighted RMS | p99 | max | " + " | ".join(f"RMS r {a}-{b}" for a, b in bands) + " | outside domain |")
    for name in ("lut3d", "realistic", "full-range"):
        def stat(sel):
            e = [(float(r[name + "_error"]), max(float(r["wo_z"]), 0.0)) for r in rows if sel(r)]
            w = sum(x[1] for x in e)
            if w == 0:
                return None
            rms = math.sqrt(sum(x[1] * x[0] ** 2 for x in e) / w)
            by = sorted(e, key=lambda x: abs(x[0]))
            acc, p99 = 0.0, abs(by[-1][0])
            for x in by:
                acc += x[1]
                if acc >= 0.99 * w:
                    p99 = abs(x[0])
                    break
            return rms, p99, max(abs(x[0]) for x in e)
        rough = lambda r: math.sqrt(float(r["alpha_x"]))
        a = stat(lambda r: True)
        cells = []
        for lo, hi in bands:
            s = stat(lambda r, lo=lo, hi=hi: lo <= rough(r) < hi or (hi == 1.0 and rough(r) == 1.0))
            cells.append("-" if s is None else f"{s[0]:.4f}")
        o, n = outside[name]
        print(f"| {name} | {a[0]:.4f} | {a[1]:.3f} | {a[2]:.3f} | " + " | ".join(cells) + f" | {o} of {n} |")
    print()
PY
for f in lut3d realistic full-range; do
    if [ "$f" = lut3d ]; then continue; fi
    echo "$f: $("$ms" repr info "$out/$f.exr" | sed -n "s/^cost: //p")"
done
