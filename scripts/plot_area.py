#!/usr/bin/python3
"""Figures and tables for `microshadow area sweep` outputs (Debian's /usr/bin/python3 has matplotlib).

  plot_area.py grid SWEEP.csv --out DIR      # the representative-point error against the light's size
  plot_area.py random RANDOM.csv --out DIR   # the approximations' error on random queries

grid writes DIR/area_point_error.png (max |approximation - T_area| over the other axes, against the
half-angle, one line per roughness, for the centre, Karis's representative point and the 7 taps, Lambert
and GGX lobes), DIR/area_point_error_visibility.png (the same against visibility at a few sizes) and
prints, per lobe and roughness, the largest half-angle whose max error stays under 0.01, 0.02 and 0.05.
random prints the max, RMS and 99th percentile of each approximation's error, overall and by size band.
"""
import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k, v in r.items():
            if k != "lobe":
                r[k] = float(v)
    return rows


def grid(args):
    rows = read(args.csv)
    os.makedirs(args.out, exist_ok=True)
    lobes = sorted({r["lobe"] for r in rows})
    roughs = sorted({r["roughness"] for r in rows})
    sizes = sorted({r["half_angle_deg"] for r in rows})
    fig, axes = plt.subplots(1, len(lobes), figsize=(6.2 * len(lobes), 4.6), squeeze=False, sharey=True)
    colours = plt.cm.viridis([i / max(1, len(roughs) - 1) for i in range(len(roughs))])
    table = []
    for ax, lobe in zip(axes[0], lobes):
        for colour, rough in zip(colours, roughs):
            for col, style, label in (("representative_error", "-", "representative point"), ("centre_error", ":", "centre"),
                                      ("taps_error", "-.", "7 taps")):
                if lobe == "lambert" and col == "representative_error":
                    continue  # Lambert's representative point is the centre
                ys = []
                for g in sizes:
                    sel = [abs(r[col]) for r in rows if r["lobe"] == lobe and r["roughness"] == rough and r["half_angle_deg"] == g]
                    ys.append(max(sel) if sel else float("nan"))
                ax.plot(sizes, ys, style, color=colour, marker="o", ms=3,
                        label=f"roughness {rough:g}, {label}")
                if col == ("centre_error" if lobe == "lambert" else "representative_error"):
                    limits = []
                    for tol in (0.01, 0.02, 0.05):
                        ok = [g for g, y in zip(sizes, ys) if y < tol]
                        # largest size such that every size up to it passes
                        best = 0
                        for g, y in zip(sizes, ys):
                            if y < tol:
                                best = g
                            else:
                                break
                        limits.append(best)
                    table.append((lobe, rough, limits))
        for tol in (0.01, 0.02, 0.05):
            ax.axhline(tol, color="grey", lw=0.6, ls="--")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("light half-angle gamma (degrees)")
        ax.set_title(f"{lobe} lobe: max |approximation - T_area| over visibility, elevation, NdotV, azimuth", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
    axes[0][0].set_ylabel("max |point term - T_area| (term units)")
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "area_point_error.png"), dpi=120)

    vis = sorted({r["visibility"] for r in rows})
    pick = [g for g in sizes if g in (2, 10, 30)] or sizes[-3:]
    fig, axes = plt.subplots(1, len(lobes), figsize=(6.2 * len(lobes), 4.2), squeeze=False, sharey=True)
    for ax, lobe in zip(axes[0], lobes):
        col = "centre_error" if lobe == "lambert" else "representative_error"
        for g, style in zip(pick, ("-", "--", ":")):
            for colour, rough in zip(colours, roughs):
                ys = [max([abs(r[col]) for r in rows if r["lobe"] == lobe and r["roughness"] == rough and
                           r["half_angle_deg"] == g and r["visibility"] == v] or [float("nan")]) for v in vis]
                ax.plot(vis, ys, style, color=colour, label=f"gamma {g:g} deg, roughness {rough:g}")
        ax.set_yscale("log")
        ax.set_xlabel("visibility")
        ax.set_title(f"{lobe}: {'centre' if lobe == 'lambert' else 'representative point'} error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
    axes[0][0].set_ylabel("max |point term - T_area| over elevation")
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "area_point_error_visibility.png"), dpi=120)

    print("| lobe | roughness | largest half-angle with max error < 0.01 | < 0.02 | < 0.05 |")
    print("|---|---|---|---|---|")
    for lobe, rough, lim in table:
        print(f"| {lobe} | {rough:g} | " + " | ".join(f"{x:g} deg" if x else "none" for x in lim) + " |")


def stats(errors):
    if not errors:
        return "-"
    a = sorted(abs(e) for e in errors)
    rms = math.sqrt(sum(e * e for e in a) / len(a))
    p99 = a[min(len(a) - 1, int(math.ceil(0.99 * len(a))) - 1)]
    return f"{a[-1]:.4f} | {rms:.4f} | {p99:.4f}"


def random_table(args):
    everything = read(args.csv)
    # Lights that barely clear the horizon are sampled by a sliver of their points and carry wide error
    # bars (and almost no light); the statistics keep the queries whose 99.9 % bar (t(0.999, 7) = 5.41
    # times the standard error) is under 0.01 and say how many were left out.
    rows = [r for r in everything if 5.41 * r["area_std_error"] < 0.01]
    print(f"{len(rows)} of {len(everything)} queries with a 99.9 % error bar under 0.01 on T_area "
          f"(the other {len(everything) - len(rows)}: lights straddling the horizon, whose grazing directions the joint sampler resolves slowly)\n")
    bands = [(0, 5), (5, 10), (10, 20), (20, 30.0001)]
    print("| queries | approximation | max | RMS | p99 |")
    print("|---|---|---|---|---|")
    for lobe in ("all", "lambert", "ggx"):
        sel = [r for r in rows if lobe == "all" or r["lobe"] == lobe]
        for name, col in (("centre", "centre_error"), ("representative point", "representative_error"), ("taps", "taps_error")):
            print(f"| {lobe} ({len(sel)}) | {name} | {stats([r[col] for r in sel])} |")
    print()
    print("| half-angle band | representative point max / RMS / p99 | taps max / RMS / p99 |")
    print("|---|---|---|")
    for lo, hi in bands:
        sel = [r for r in rows if lo < r["half_angle_deg"] <= hi]
        print(f"| {lo}-{hi:.0f} deg ({len(sel)}) | {stats([r['representative_error'] for r in sel])} | {stats([r['taps_error'] for r in sel])} |")
    print()
    print("max area std error of the kept queries:", max(r["area_std_error"] for r in rows))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("grid")
    g.add_argument("csv")
    g.add_argument("--out", required=True)
    r = sub.add_parser("random")
    r.add_argument("csv")
    args = p.parse_args()
    if args.cmd == "grid":
        grid(args)
    else:
        random_table(args)


if __name__ == "__main__":
    sys.exit(main())
