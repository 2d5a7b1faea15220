#!/usr/bin/python3
"""Plots and derived numbers for `microshadow sweep` outputs (run with Debian's /usr/bin/python3,
which has python3-matplotlib).

  plot_sweep.py heatmaps SWEEP.csv --out DIR [--where COL=VAL ...] [--facet roughness]
      Part 1-style heatmaps over (visibility, NdotL), NdotL increasing downwards as in the LUT: one
      figure of every term (generic term and each comparator; rows left over after --where, e.g.
      several azimuths, are averaged and the title says so) and one of the errors against the generic
      term per facet value: per comparator the max |error| over the cell's rows (errors of opposite
      sign cannot cancel) and, beside it, the mean signed error (its direction).

  plot_sweep.py spread SWEEP.csv --over COL [--where COL=VAL ...] [--by roughness]
      How much the generic term depends on COL: for every point of the other parameters, the
      term's range (max - min) over the values of COL; prints max, mean and RMS of that range per
      --by group, and the largest term std error (the noise floor of these numbers).

  plot_sweep.py errors SWEEP.csv [--where COL=VAL ...] [--by roughness] [--inside LO HI | --outside LO HI]
                [--zero-region only|exclude]
      Error (comparator - generic term) of each comparator: points, max abs, mean abs, RMS and bias per
      --by group (markdown). --inside keeps the points whose visibility and NdotL both lie in [LO, HI]
      (e.g. between the first and last texel centres of a LUT, where it never clamps), --outside the
      rest. --zero-region only keeps the points in part 2's zero region NdotL <= 2 cos_t^2 - 1 (where
      the term is exactly 0), --zero-region exclude the others. Also prints the term's max and RMS
      std error (its own noise).

  plot_sweep.py convergence SWEEP.csv --out PNG [--lut NAME=SIZE ...] [--where ...] [--inside LO HI]
                [--floor CONTROL.csv NAME]
      RMS and max error of LUT comparators against their size (texels per axis), one line per
      roughness, log-log. Without --lut every comparator with a whole number field in its name
      (lut3d-32-az0 -> 32) is taken, that number being the size. --floor draws comparator NAME's
      RMS and max error per roughness in CONTROL.csv (a sweep on that LUT's own texel centres: no
      interpolation, only noise) as dotted lines.

  plot_sweep.py errormap SWEEP.csv --out PNG [--comparators NAME ...] [--where ...]
      Where the error sits: max |comparator - term| over the rows left after --where (e.g. every
      NdotV) per (visibility, NdotL) cell, one row of panels per comparator, one column per
      roughness, NdotL increasing downwards, with the zero-region edge NdotL = 2 cos_t^2 - 1 (dashed)
      and the smooth-surface shadow edge NdotL = cos_t (dotted) drawn in, cos_t from the sweep's AO
      weighting.
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
    for facet_value, group in sorted(groups.items(), key=lambda kv: float_or_text(kv[0])):
        vs = sorted({float(r["visibility"]) for r in group})
        ls = sorted({float(r["n_dot_l"]) for r in group})
        vi = {v: i for i, v in enumerate(vs)}
        li = {l: i for i, l in enumerate(ls)}
        names = ["term"] + comparators
        # Per (NdotL, visibility) cell, over the rows left after --where (other azimuths, NdotV, ...):
        # the mean of each term, and for each comparator's error both the max |error| (errors that change
        # sign with the azimuth cannot cancel in it) and the mean signed error (shown beside it).
        acc = {n: np.zeros((len(ls), len(vs))) for n in names}
        err_max = {c: np.zeros((len(ls), len(vs))) for c in comparators}
        err_sum = {c: np.zeros((len(ls), len(vs))) for c in comparators}
        cnt = np.zeros((len(ls), len(vs)))
        for r in group:
            i, j = li[float(r["n_dot_l"])], vi[float(r["visibility"])]
            cnt[i, j] += 1
            t = float(r["term"])
            for n in names:
                acc[n][i, j] += float(r[n])
            for c in comparators:
                e = float(r[c]) - t
                err_max[c][i, j] = max(err_max[c][i, j], abs(e))
                err_sum[c][i, j] += e
        mean = {n: acc[n] / np.maximum(cnt, 1) for n in names}
        per_cell = int(cnt.max())
        over = f", {per_cell} points per cell" if per_cell > 1 else ""
        # Cell-centred extent with NdotL increasing downwards, as in the LUT (row 0 = smallest NdotL on top).
        dv = (vs[-1] - vs[0]) / max(1, len(vs) - 1) / 2 or 0.5
        dl = (ls[-1] - ls[0]) / max(1, len(ls) - 1) / 2 or 0.5
        extent = [vs[0] - dv, vs[-1] + dv, ls[-1] + dl, ls[0] - dl]
        tag = f"{args.facet}-{facet_value}"

        def panel(ax, data, cmap, vmin, vmax, title, label, fig, norm=None):
            im = ax.imshow(data, origin="upper", extent=extent, aspect="auto", cmap=cmap, vmin=None if norm else vmin,
                           vmax=None if norm else vmax, norm=norm, interpolation="nearest")
            ax.set_title(title, fontsize=8)
            ax.set_xlabel("visibility", fontsize=8)
            ax.set_ylabel("NdotL (increasing down)", fontsize=8)
            ax.tick_params(labelsize=7)
            fig.colorbar(im, ax=ax, label=label, shrink=0.9)

        def save(fig, filename):
            path = os.path.join(args.out, filename)
            fig.savefig(path, dpi=args.dpi)
            plt.close(fig)
            print(path)

        # Terms: mean over the cell's rows (the title says how many).
        n = len(names)
        cols = min(n, 4)
        nrows = (n + cols - 1) // cols
        fig, axes = plt.subplots(nrows, cols, figsize=(3.9 * cols, 3.4 * nrows + 0.5), squeeze=False, layout="constrained")
        for k, name in enumerate(names):
            panel(axes[k // cols][k % cols], mean[name], "viridis", 0, 1, "generic term" if name == "term" else name,
                  "term" + (" (mean)" if per_cell > 1 else ""), fig)
        for k in range(n, nrows * cols):
            axes[k // cols][k % cols].axis("off")
        fig.suptitle(f"{sweep_label(args.csv)}: terms, {args.facet} = {facet_value}" +
                     (f", mean of {per_cell} points per cell" if per_cell > 1 else ""), fontsize=9)
        save(fig, f"terms-{tag}.png")

        # Errors: one row per comparator, max |error| (left, the figure of merit) and mean signed error
        # (right, for the direction only), each with its own colour bar.
        if comparators:
            emax = max(1e-6, max(float(err_max[c].max()) for c in comparators))
            fig, axes = plt.subplots(len(comparators), 2, figsize=(8.6, 3.2 * len(comparators) + 0.5), squeeze=False,
                                     layout="constrained")
            for k, c in enumerate(comparators):
                signed = err_sum[c] / np.maximum(cnt, 1)
                lim = max(1e-6, float(np.abs(signed).max()))
                panel(axes[k][0], err_max[c], "magma_r", 0, emax, f"{c}: max |error|", "max |comparator - term|", fig)
                panel(axes[k][1], signed, "RdBu_r", -lim, lim, f"{c}: mean signed error", "mean (comparator - term)", fig)
            fig.suptitle(f"{sweep_label(args.csv)}: errors, {args.facet} = {facet_value}{over}", fontsize=9)
            save(fig, f"errors-{tag}.png")


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


def in_window(rows, inside, outside):
    """Rows whose visibility and NdotL both lie in [lo, hi] (inside), or the others (outside)."""
    if inside and outside:
        sys.exit("--inside and --outside exclude each other")
    if not inside and not outside:
        return rows
    lo, hi = inside or outside
    keep = bool(inside)
    out = [r for r in rows
           if (lo <= float(r["visibility"]) <= hi and lo <= float(r["n_dot_l"]) <= hi) == keep]
    if not out:
        sys.exit("no rows left after --inside/--outside")
    return out


def in_zero_region(row):
    """Part 2's exact-zero rule NdotL <= 2 cos_t^2 - 1 (cos_t = sqrt(1 - v) cosine, 1 - v uniform)."""
    v = float(row["visibility"])
    cos_t = math.sqrt(max(0.0, 1 - v)) if row["ao_weighting"] == "cosine" else 1 - v
    return float(row["n_dot_l"]) <= 2 * cos_t * cos_t - 1


def error_stats(errs):
    n = len(errs)
    return {"points": n, "max": max(abs(x) for x in errs), "mean": sum(abs(x) for x in errs) / n,
            "rms": math.sqrt(sum(x * x for x in errs) / n), "bias": sum(errs) / n}


def group_errors(rows, comparator, by):
    groups = collections.defaultdict(list)
    for r in rows:
        err = float(r[comparator]) - float(r["term"])
        groups["all"].append(err)
        groups[r[by]].append(err)
    return {g: error_stats(v) for g, v in groups.items()}


def errors(args):
    rows, comparators = read(args.csv, parse_where(args.where))
    rows = in_window(rows, args.inside, args.outside)
    if args.zero_region:
        rows = [r for r in rows if in_zero_region(r) == (args.zero_region == "only")]
        if not rows:
            sys.exit(f"no rows left after --zero-region {args.zero_region}")
    if not comparators:
        sys.exit(f"{args.csv}: no comparator columns")
    se = [float(r["std_error"]) for r in rows]
    window = ""
    if args.inside:
        window = f", visibility and NdotL in [{args.inside[0]:g}, {args.inside[1]:g}]"
    elif args.outside:
        window = f", visibility or NdotL outside [{args.outside[0]:g}, {args.outside[1]:g}]"
    if args.zero_region:
        window += ", in the zero region" if args.zero_region == "only" else ", outside the zero region"
    print(f"error = comparator - generic term ({len(rows)} points{window}; term std error max "
          f"{max(se):.2g}, RMS {math.sqrt(sum(x * x for x in se) / len(se)):.2g})")
    print(f"| comparator | {args.by} | points | max abs | mean abs | RMS | bias |")
    print("|---|---|---|---|---|---|---|")
    for c in comparators:
        stats = group_errors(rows, c, args.by)
        for g in ["all"] + sorted((k for k in stats if k != "all"), key=float_or_text):
            s = stats[g]
            print(f"| {c} | {g} | {s['points']} | {s['max']:.4f} | {s['mean']:.5f} | {s['rms']:.5f} | {s['bias']:.2g} |")


def sweep_label(path):
    """'DIR/sweep.csv' for a sweep's output file (the directory names the sweep)."""
    return os.path.join(os.path.basename(os.path.dirname(os.path.abspath(path))), os.path.basename(path))


def float_or_text(x):
    try:
        return (0, float(x), "")
    except ValueError:
        return (1, 0.0, x)


def lut_sizes(comparators, specs):
    import re
    if specs:
        out = []
        for item in specs:
            name, _, size = item.partition("=")
            if name not in comparators or not size.isdigit():
                sys.exit(f"--lut expects NAME=SIZE with NAME a comparator of the sweep, got {item!r}")
            out.append((name, int(size)))
        return out
    out = []
    for name in comparators:
        m = re.search(r"(?:^|[-_])(\d+)(?=$|[-_])", name)  # lut3d-32-az0 -> 32
        if m:
            out.append((name, int(m.group(1))))
    if not out:
        sys.exit("no comparator name holds a size; give --lut NAME=SIZE")
    return out


def convergence(args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    where = parse_where(args.where)
    rows, comparators = read(args.csv, where)
    rows = in_window(rows, args.inside, args.outside)
    luts = sorted(lut_sizes(comparators, args.lut), key=lambda t: t[1])
    groups = sorted({r["roughness"] for r in rows}, key=float_or_text)
    fig, axes = plt.subplots(1, 2, figsize=(9.5, 3.8))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    floor = None
    if args.floor:
        control, _ = read(args.floor[0], where)
        if args.floor[1] not in control[0]:
            sys.exit(f"{args.floor[0]}: no comparator {args.floor[1]!r}")
        floor = group_errors(control, args.floor[1], "roughness")
    sizes = [n for _, n in luts]
    for k, g in enumerate(groups):
        col = colours[k % len(colours)]
        stats = [group_errors(rows, name, "roughness")[g] for name, _ in luts]
        for ax, key in zip(axes, ("rms", "max")):
            ax.plot(sizes, [s[key] for s in stats], "o-", color=col, label=f"roughness {g}")
            if floor and g in floor:
                ax.axhline(floor[g][key], color=col, ls=":", lw=1)
    ref = [group_errors(rows, name, "roughness")[groups[len(groups) // 2]]["rms"] for name, _ in luts]
    axes[0].plot(sizes, [ref[0] * (sizes[0] / n) ** 2 for n in sizes], "k--", lw=0.8, label="slope -2 (h^2)")
    axes[0].plot(sizes, [ref[0] * (sizes[0] / n) for n in sizes], "k-.", lw=0.8, label="slope -1 (h)")
    for ax, title in zip(axes, ("RMS error", "max abs error")):
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xticks(sizes)
        ax.set_xticklabels([str(n) for n in sizes])
        ax.set_xlabel("LUT texels per axis")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", lw=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=7, frameon=False)
    note = "" if not floor else f"; dotted: {args.floor[1]} on its own texel centres (noise floor)"
    if args.inside or args.outside:
        lo, hi = args.inside or args.outside
        note = f", visibility and NdotL {'in' if args.inside else 'not both in'} [{lo:g}, {hi:g}]" + note
    fig.suptitle(f"{sweep_label(args.csv)}: LUT error against size{note}", fontsize=9)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    fig.savefig(args.out, dpi=args.dpi)
    plt.close(fig)
    print(args.out)


def errormap(args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    rows, comparators = read(args.csv, parse_where(args.where))
    names = args.comparators or comparators
    for n in names:
        if n not in comparators:
            sys.exit(f"{args.csv}: no comparator {n!r}")
    groups = sorted({r["roughness"] for r in rows}, key=float_or_text)
    vs = sorted({float(r["visibility"]) for r in rows})
    ls = sorted({float(r["n_dot_l"]) for r in rows})
    vi = {v: i for i, v in enumerate(vs)}
    li = {l: i for i, l in enumerate(ls)}
    gi = {g: i for i, g in enumerate(groups)}
    err = np.zeros((len(names), len(groups), len(ls), len(vs)))
    per_cell = collections.Counter()
    for r in rows:
        g, i, j = gi[r["roughness"]], li[float(r["n_dot_l"])], vi[float(r["visibility"])]
        per_cell[(g, i, j)] += 1
        t = float(r["term"])
        for k, n in enumerate(names):
            err[k, g, i, j] = max(err[k, g, i, j], abs(float(r[n]) - t))
    weightings = {r["ao_weighting"] for r in rows}
    vmax = float(err.max()) or 1e-6
    fig, axes = plt.subplots(len(names), len(groups), figsize=(2.9 * len(groups), 2.6 * len(names)), squeeze=False)
    dv = (vs[-1] - vs[0]) / max(1, len(vs) - 1) / 2
    dl = (ls[-1] - ls[0]) / max(1, len(ls) - 1) / 2
    extent = [vs[0] - dv, vs[-1] + dv, ls[0] - dl, ls[-1] + dl]
    vline = np.linspace(0, 1, 400)
    for k, n in enumerate(names):
        for g, gname in enumerate(groups):
            ax = axes[k][g]
            im = ax.imshow(err[k, g], origin="lower", extent=extent, aspect="auto", cmap="magma_r",
                           norm=matplotlib.colors.LogNorm(vmin=max(vmax * 1e-3, 1e-5), vmax=vmax),
                           interpolation="nearest")
            if len(weightings) == 1:
                cos_t = np.sqrt(1 - vline) if "cosine" in weightings else 1 - vline
                ax.plot(vline, 2 * cos_t ** 2 - 1, "c--", lw=0.8)
                ax.plot(vline, cos_t, "c:", lw=0.9)
            ax.set_xlim(extent[0], extent[1])
            ax.set_ylim(extent[3], extent[2])  # NdotL increasing downwards, as in the LUT
            ax.set_title(f"{n}, roughness {gname}", fontsize=8)
            ax.tick_params(labelsize=7)
            if g == 0:
                ax.set_ylabel("NdotL", fontsize=8)
            if k == len(names) - 1:
                ax.set_xlabel("visibility", fontsize=8)
    fig.subplots_adjust(hspace=0.4, wspace=0.25, right=0.88)
    cax = fig.add_axes([0.90, 0.15, 0.015, 0.7])
    fig.colorbar(im, cax=cax, label="|error|")
    most = max(per_cell.values())
    fig.suptitle(f"{sweep_label(args.csv)}: max |comparator - term|" +
                 (f" over {most} points per cell" if most > 1 else "") +
                 "; dashed: zero-region edge, dotted: NdotL = cos_t", fontsize=9)
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    fig.savefig(args.out, dpi=args.dpi)
    plt.close(fig)
    print(args.out)


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
    e = sub.add_parser("errors")
    e.add_argument("csv")
    e.add_argument("--where", nargs="*")
    e.add_argument("--by", default="roughness", choices=PARAMS)
    e.add_argument("--inside", nargs=2, type=float, metavar=("LO", "HI"))
    e.add_argument("--outside", nargs=2, type=float, metavar=("LO", "HI"))
    e.add_argument("--zero-region", choices=["only", "exclude"])
    c = sub.add_parser("convergence")
    c.add_argument("csv")
    c.add_argument("--out", required=True)
    c.add_argument("--lut", nargs="*", default=[])
    c.add_argument("--where", nargs="*")
    c.add_argument("--inside", nargs=2, type=float, metavar=("LO", "HI"))
    c.add_argument("--outside", nargs=2, type=float, metavar=("LO", "HI"))
    c.add_argument("--floor", nargs=2, metavar=("CONTROL_CSV", "NAME"))
    c.add_argument("--dpi", type=int, default=90)
    m = sub.add_parser("errormap")
    m.add_argument("csv")
    m.add_argument("--out", required=True)
    m.add_argument("--comparators", nargs="*")
    m.add_argument("--where", nargs="*")
    m.add_argument("--dpi", type=int, default=90)
    args = p.parse_args()
    {"heatmaps": heatmaps, "spread": spread, "errors": errors, "convergence": convergence,
     "errormap": errormap}[args.cmd](args)


if __name__ == "__main__":
    main()
