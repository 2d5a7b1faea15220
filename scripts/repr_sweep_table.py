#!/usr/bin/env python3
"""The error table of a sweep's comparators (docs/representations.md): per comparator max |e|, the 99th
percentile of |e|, RMS, the N.L-weighted RMS sqrt(sum NdotL e^2 / sum NdotL) (the lighting multiplies the
term by NdotL) and that RMS's ratio to a baseline comparator; then the N.L-weighted RMS per value of
delta_phi, NdotV, NdotL and visibility. e = comparator - term. Usage: repr_sweep_table.py SWEEP.csv [BASELINE]"""
import csv
import math
import sys

FIXED = ["point", "form", "ao_weighting", "roughness", "alpha_x", "alpha_y", "n_dot_v", "phi_i", "phi_o",
         "delta_phi", "n_dot_l", "visibility", "term", "std_error"]


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    names = [c for c in rows[0] if c not in FIXED]
    base = sys.argv[2] if len(sys.argv) > 2 else names[0]
    stats = {}
    for n in names:
        e = [float(r[n]) - float(r["term"]) for r in rows]
        w = [max(float(r["n_dot_l"]), 0.0) for r in rows]
        a = sorted(abs(x) for x in e)
        stats[n] = dict(max=a[-1], p99=a[int(0.99 * (len(a) - 1))], rms=math.sqrt(sum(x * x for x in e) / len(e)),
                        wrms=math.sqrt(sum(wi * x * x for wi, x in zip(w, e)) / sum(w)))
    se = max(float(r["std_error"]) for r in rows)
    print(f"{len(rows)} points, max std error of the term {se:.2g}\n")
    print("| comparator | max \\|e\\| | p99 \\|e\\| | RMS | N.L-weighted RMS | vs " + base + " |")
    print("|---|---|---|---|---|---|")
    for n in names:
        s = stats[n]
        print(f"| `{n}` | {s['max']:.3f} | {s['p99']:.3f} | {s['rms']:.4f} | {s['wrms']:.4f} | "
              f"{stats[base]['wrms'] / s['wrms']:.1f}x |")
    # The same N.L-weighted RMS per value of each swept parameter: where along an axis the errors sit.
    for axis, title in [("delta_phi", "relative azimuth (degrees)"), ("n_dot_v", "NdotV"), ("n_dot_l", "NdotL"),
                        ("visibility", "visibility")]:
        values = sorted({float(r[axis]) for r in rows})
        print(f"\nN.L-weighted RMS per {title}:\n")
        print("| comparator | " + " | ".join(f"{p:g}" for p in values) + " |")
        print("|---|" + "---|" * len(values))
        for n in names:
            cells = []
            for p in values:
                sel = [r for r in rows if float(r[axis]) == p]
                num = sum(max(float(r["n_dot_l"]), 0.0) * (float(r[n]) - float(r["term"])) ** 2 for r in sel)
                den = sum(max(float(r["n_dot_l"]), 0.0) for r in sel)
                cells.append(f"{math.sqrt(num / den):.4f}" if den > 0 else "-")
            print(f"| `{n}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
