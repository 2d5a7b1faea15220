#!/usr/bin/python3
"""The Pareto plot of `microshadow design` (run with Debian's /usr/bin/python3, which has
python3-matplotlib; `design --plot` runs it).

  plot_pareto.py PARETO.csv --out PARETO.png [--title TEXT]

Two panels, one point per candidate, error against cost:
  left:  error against texture bytes (log; candidates without a texture sit at the "0" column);
  right: error against ALU instructions per light (log), marker filled for 0 fetches, hollow otherwise.
The error axis is logarithmic: the N.L-weighted RMS is the marker, a thin bar runs up to the
weighted 99th percentile (tick) and the max (x). Candidates on the Pareto front (over RMS, bytes,
fetches and ALU) are labelled in bold and joined by the front's staircase in the left panel (the
lowest RMS at each byte budget); the chosen one is circled.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

KIND_COLOURS = {"analytic": "tab:red", "lut": "tab:blue", "closed-form": "tab:green",
                "azimuth-axis": "tab:purple", "azimuth-harmonics": "tab:orange"}


def read(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"plot_pareto.py: {path}: {e.strerror}")
    need = {"name", "kind", "bytes", "fetches_per_light", "alu_per_light", "weighted_rms", "weighted_p99",
            "max_abs", "pareto", "chosen"}
    if not rows or not need <= set(rows[0]):
        sys.exit(f"plot_pareto.py: {path}: not a design pareto.csv (columns {sorted(need)})")
    for r in rows:
        for k in ("bytes", "fetches_per_light", "alu_per_light"):
            r[k] = int(r[k])
        for k in ("weighted_rms", "weighted_p99", "max_abs"):
            r[k] = float(r[k])
        r["pareto"] = r["pareto"] == "1"
        r["chosen"] = r["chosen"] == "1"
    return rows


def draw(ax, rows, xkey, zero_x):
    floor = min(max(r["weighted_rms"], 1e-5) for r in rows) / 2
    for r in rows:
        x = r[xkey] if r[xkey] > 0 else zero_x
        colour = KIND_COLOURS.get(r["kind"], "tab:gray")
        rms = max(r["weighted_rms"], floor)
        ax.plot([x, x], [rms, max(r["max_abs"], rms)], color=colour, lw=0.8, alpha=0.6)
        ax.plot([x], [max(r["weighted_p99"], floor)], marker="_", color=colour, ms=8)
        ax.plot([x], [max(r["max_abs"], floor)], marker="x", color=colour, ms=4)
        ax.plot([x], [rms], marker="o", ms=7, color=colour,
                mfc=colour if r["fetches_per_light"] == 0 else "white")
        if r["chosen"]:
            ax.plot([x], [rms], marker="o", ms=15, mfc="none", mec="black", mew=1.5)
        ax.annotate(r["name"], (x, rms), textcoords="offset points", xytext=(5, -3), fontsize=7,
                    fontweight="bold" if r["pareto"] else "normal")
    ax.set_yscale("log")
    ax.set_xscale("log")
    ax.grid(True, which="both", alpha=0.3)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv")
    p.add_argument("--out", required=True)
    p.add_argument("--title", default="")
    a = p.parse_args()
    rows = read(a.csv)
    textured = [r["bytes"] for r in rows if r["bytes"] > 0]
    zero_bytes = min(textured) / 8 if textured else 1.0
    fig, (left, right) = plt.subplots(1, 2, figsize=(14, 6.5), sharey=True)
    draw(left, rows, "bytes", zero_bytes)
    # The front's staircase over bytes: the lowest RMS reachable with at most that many bytes.
    by_bytes = sorted(rows, key=lambda r: (r["bytes"], r["weighted_rms"]))
    xs, ys, best = [], [], None
    for r in by_bytes:
        if best is None or r["weighted_rms"] < best:
            best = r["weighted_rms"]
            xs.append(r["bytes"] if r["bytes"] > 0 else zero_bytes)
            ys.append(best)
    if xs:
        right_end = max(xs[-1], max(textured) if textured else xs[-1]) * 2
        left.step(xs + [right_end], ys + [ys[-1]], where="post", color="black", lw=1, ls="--",
                  label="lowest RMS within the bytes")
        left.legend(loc="upper right", fontsize=8)
    ticks = [zero_bytes] + [t for t in (1024, 16 * 1024, 256 * 1024, 4 << 20, 64 << 20) if textured and
                            min(textured) / 2 <= t <= max(textured) * 2]
    left.set_xticks(ticks)
    left.set_xticklabels(["0 (none)"] + [f"{t // 1024} KiB" if t < (1 << 20) else f"{t >> 20} MiB" for t in ticks[1:]])
    left.set_xlabel("texture memory [bytes, log scale]")
    if not textured:
        # Every candidate sits at "0 (none)": an axis of bytes would only show matplotlib's zoom into
        # that one column; say instead what would give it a meaning.
        left.set_xlim(0.5, 2)
        left.minorticks_off()
        left.set_xticks([zero_bytes], ["0 (none)"])
        left.text(0.03, 0.5, "no candidate stores a texture:\n--lut FILE or --repr PRESET|FILE adds one",
                  transform=left.transAxes, ha="left", va="center", fontsize=10, color="0.35")
    left.set_ylabel("error vs reference term (N.L-weighted)  o RMS   - p99   x max   [log scale]")
    draw(right, rows, "alu_per_light", 1)
    right.set_xlabel("ALU instructions per light [count from the GLSL, log scale]  (hollow: >= 1 texture fetch)")
    for kind, colour in KIND_COLOURS.items():
        if any(r["kind"] == kind for r in rows):
            right.plot([], [], "o", color=colour, label=kind)
    right.legend(loc="lower left", fontsize=8)
    fig.suptitle("micro-shadowing representations: error against cost" + (f" ({a.title})" if a.title else "") +
                 "; bold = Pareto front, circled = chosen")
    fig.tight_layout()
    tmp = a.out + ".tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, a.out)  # the picture appears only when complete


if __name__ == "__main__":
    main()
