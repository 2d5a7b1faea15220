#!/usr/bin/env python3
"""The exact inner term against the sampled kernel on the random sphere-light queries of an area sweep.

    scripts/area_exact_compare.py split SWEEP.csv --count N --out-dir DIR
        writes DIR/lambert.csv and DIR/ggx.csv: the first N queries of each lobe as `area eval` input
    scripts/area_exact_compare.py compare SWEEP.csv DIR
        reads DIR/lambert_exact.csv and DIR/ggx_exact.csv (`area eval --method exact` of the two files)
        and prints |exact - sampled| against the 99.9 % bars of both, and the error bars themselves
"""
import argparse
import csv
import math
import sys

T999_R8 = 5.408  # Student t at 99.9 %, 7 degrees of freedom (8 replicates)


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def split(args):
    per_lobe = {"lambert": [], "ggx": []}
    for r in rows(args.csv):
        if len(per_lobe[r["lobe"]]) < args.count:
            per_lobe[r["lobe"]].append(r)
    for lobe, sel in per_lobe.items():
        with open(f"{args.out_dir}/{lobe}.csv", "w") as f:
            f.write("visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,light_x,light_y,light_z,half_angle_deg\n")
            for r in sel:
                nv, rough = float(r["n_dot_v"]), float(r["roughness"])
                el, az = math.radians(float(r["elevation_deg"])), math.radians(float(r["azimuth_deg"]))
                a = rough * rough
                f.write(",".join(repr(x) for x in (float(r["visibility"]), a, a, math.sqrt(max(0.0, 1 - nv * nv)), 0.0, nv,
                                                   math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el),
                                                   float(r["half_angle_deg"]))) + "\n")


def compare(args):
    sampled = {"lambert": [], "ggx": []}
    for r in rows(args.csv):
        sampled[r["lobe"]].append(r)
    worst_ratio, worst, n = 0.0, 0.0, 0
    exact_se, sampled_se, inner = [], [], []
    for lobe in ("lambert", "ggx"):
        for s, e in zip(sampled[lobe], rows(f"{args.dir}/{lobe}_exact.csv")):
            d = abs(float(e["term"]) - float(s["area"]))
            b = T999_R8 * math.hypot(float(e["std_error"]), float(s["area_std_error"])) + float(e["inner_error"])
            n += 1
            worst = max(worst, d)
            if b > 0:
                worst_ratio = max(worst_ratio, d / b)
            exact_se.append(float(e["std_error"]))
            sampled_se.append(float(s["area_std_error"]))
            inner.append(float(e["inner_error"]))
    med = lambda v: sorted(v)[len(v) // 2]
    print(f"{n} queries: max |exact - sampled| {worst:.2e}, largest ratio to the 99.9 % bar {worst_ratio:.2f}")
    print(f"std error: exact inner median {med(exact_se):.2e} max {max(exact_se):.2e}; "
          f"sampled median {med(sampled_se):.2e} max {max(sampled_se):.2e}; inner_error max {max(inner):.2e}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("split")
    s.add_argument("csv")
    s.add_argument("--count", type=int, default=100)
    s.add_argument("--out-dir", required=True)
    c = sub.add_parser("compare")
    c.add_argument("csv")
    c.add_argument("dir")
    args = p.parse_args()
    split(args) if args.cmd == "split" else compare(args)


if __name__ == "__main__":
    sys.exit(main())
