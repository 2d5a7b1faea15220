#!/usr/bin/python3
"""Plots and derived numbers for `microshadow sweep` outputs (run with Debian's /usr/bin/python3,
which has python3-matplotlib).

  plot_sweep.py heatmaps SWEEP.csv --out DIR [--where COL=VAL ...] [--facet roughness]
      Part 1-style heatmaps over (NdotL, visibility): one figure of every term (generic term and each
      comparator) and one of each comparator's error against the generic term, per facet value.
      Rows left over after --where (e.g. several azimuths) are averaged, and the title says so.

  plot_sweep.py spread SWEEP.csv --over COL [--where COL=VAL ...] [--by roughness]
      How much the generic term depends on COL: for every point of the other parameters, the
      term's range (max - min) over the values of COL; prints max, mean and RMS of that range per
      --by group, and the largest term std error (the noise floor of these numbers).
"""
import argparse
import collections
import csv
import math
import os
import sys

FIXED = ["point", "form", "ao_weighting", "roughness", "alpha_x", "alpha_y", "n_dot_v", "phi_i", "phi_o",
         "delta_phi", "n_dot_l", "visibility", "term", "std_error"]
PARAMS = ["form", "ao_weighting", "roughness", "alpha_x", "alpha_y", "n_dot_v", "phi_i", "phi_o", "delta_phi",
          "n_dot_l", "visibility"]


def read(path, where):
    with open(path, newline="") as f:
        r = csv.DictReader(f)
        comparators = [c for c in r.fieldnames if c not in FIXED]
        missing = [c for c in FIXED if c not in r.fieldnames]
        if missing:
            sys.exit(f"{path}: not a sweep CSV (missing {', '.join(missing)})")
        rows = []
        for row in r:
            if all(matches(row[k], v) for k, v in where):
                rows.append(row)
    if not rows:
        sys.exit(f"{path}: no rows match {where}")
    return rows, comparators


def matches(cell, wanted):
    try:
        return math.isclose(float(cell), float(wanted), rel_tol=1e-9, abs_tol=1e-12)
    except ValueError:
        return cell == wanted


def parse_where(items):
    out = []
    for item in items or []:
        if "=" not in item:
            sys.exit(f"--where expects COL=VAL, got {item!r}")
        k, v = item.split("=", 1)
        if k not in PARAMS:
            sys.exit(f"--where: unknown column {k!r} (columns: {', '.join(PARAMS)})")
        out.append((k, v))
    return out


def heatmaps(args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    rows, comparators = read(args.csv, parse_where(args.where))
    os.makedirs(args.out, exist_ok=True)
    groups = collections.defaultdict(list)
    for row in rows:
        groups[row[args.facet]].append(row)
    for facet_value, group in sorted(groups.items(), key=lambda kv: kv[0]):
        vs = sorted({float(r["visibility"]) for r in group})
        ls = sorted({float(r["n_dot_l"]) for r in group})
        vi = {v: i for i, v in enumerate(vs)}
        li = {l: i for i, l in enumerate(ls)}
        names = ["term"] + comparators
        acc = {n: np.zeros((len(ls), len(vs))) for n in names}
        cnt = np.zeros((len(ls), len(vs)))
        for r in group:
            i, j = li[float(r["n_dot_l"])], vi[float(r["visibility"])]
            cnt[i, j] += 1
            for n in names:
                acc[n][i, j] += float(r[n])
        mean = {n: acc[n] / np.maximum(cnt, 1) for n in names}
        averaged = int(cnt.max())
        note = f"{args.facet} = {facet_value}" + (f", mean of {averaged} points per cell" if averaged > 1 else "")
        extent = [vs[0], vs[-1], ls[0], ls[-1]]

        def grid(title_names, data, cmap, vmin, vmax, filename, label):
            n = len(title_names)
            cols = min(n, 4)
            nrows = (n + cols - 1) // cols
            fig, axes = plt.subplots(nrows, cols, figsize=(3.6 * cols, 3.3 * nrows), squeeze=False)
            for k, name in enumerate(title_names):
                ax = axes[k // cols][k % cols]
                im = ax.imshow(data[k], origin="lower", extent=extent, aspect="auto", cmap=cmap, vmin=vmin,
                               vmax=vmax, interpolation="nearest")
                ax.set_title(name, fontsize=9)
                ax.set_xlabel("visibility")
                ax.set_ylabel("NdotL")
            for k in range(n, nrows * cols):
                axes[k // cols][k % cols].axis("off")
            fig.subplots_adjust(hspace=0.45, wspace=0.35)
            fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.8, label=label)
            fig.suptitle(note, fontsize=9)
            path = os.path.join(args.out, filename)
            fig.savefig(path, dpi=args.dpi)
            plt.close(fig)
            print(path)

        tag = f"{args.facet}-{facet_value}"
        grid(["generic term"] + comparators, [mean[n] for n in names], "viridis", 0, 1, f"terms-{tag}.png", "term")
        if comparators:
            errs = [mean[c] - mean["term"] for c in comparators]
            lim = max(1e-6, max(float(np.abs(e).max()) for e in errs))
            grid([f"{c} - generic" for c in comparators], errs, "RdBu_r", -lim, lim, f"errors-{tag}.png", "error")


def spread(args):
    rows, _ = read(args.csv, parse_where(args.where))
    if args.over not in PARAMS:
        sys.exit(f"--over: unknown column {args.over!r}")
    others = [p for p in PARAMS if p != args.over and not (args.over == "delta_phi" and p == "phi_o")
              and not (args.over == "phi_o" and p == "delta_phi")]
    cells = collections.defaultdict(list)
    max_se = 0.0
    for r in rows:
        cells[tuple(r[p] for p in others)].append(float(r["term"]))
        max_se = max(max_se, float(r["std_error"]))
    by_index = others.index(args.by)
    groups = collections.defaultdict(list)
    for key, terms in cells.items():
        rng = max(terms) - min(terms)
        groups[key[by_index]].append(rng)
        groups["all"].append(rng)
    print(f"range of the generic term over {args.over} ({len(cells)} cells, max std error {max_se:.2g})")
    print(f"| {args.by} | cells | max range | mean range | RMS range |")
    print("|---|---|---|---|---|")
    for g in ["all"] + sorted(k for k in groups if k != "all"):
        v = groups[g]
        print(f"| {g} | {len(v)} | {max(v):.4f} | {sum(v) / len(v):.4f} | {math.sqrt(sum(x * x for x in v) / len(v)):.4f} |")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    h = sub.add_parser("heatmaps")
    h.add_argument("csv")
    h.add_argument("--out", required=True)
    h.add_argument("--where", nargs="*")
    h.add_argument("--facet", default="roughness", choices=PARAMS)
    h.add_argument("--dpi", type=int, default=90)
    s = sub.add_parser("spread")
    s.add_argument("csv")
    s.add_argument("--over", required=True)
    s.add_argument("--where", nargs="*")
    s.add_argument("--by", default="roughness", choices=PARAMS)
    args = p.parse_args()
    heatmaps(args) if args.cmd == "heatmaps" else spread(args)


if __name__ == "__main__":
    main()
