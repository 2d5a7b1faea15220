#!/usr/bin/python3
"""Time-to-error curves of the seed-3d bake from microshadow_bench's bake_time_to_error.csv.

Usage: /usr/bin/python3 bench/plot_bake_time_to_error.py docs/bench/bake_time_to_error.csv OUT.png
(run by `microshadow_bench --only bake-speed --out DIR`). Left: max error, right: RMS error, both
against the wall time of the whole bake (median of the interleaved runs; bars: min..max). Solid lines:
errors against bench/data/reference.csv (64 texels); dashed: against the tight reference (subset).
"""
import csv
import os
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(argv):
    if len(argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    src, dst = argv[1], argv[2]
    series = {}
    with open(src, newline="") as f:
        for row in csv.DictReader(f):
            series.setdefault(row["method"], []).append(row)
    if not series:
        sys.stderr.write(f"{src}: no rows\n")
        return 1
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5), sharex=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (col, tight_col, title) in zip(axes, (("max_error", "max_error_tight", "max error"),
                                                  ("rms_error", "rms_error_tight", "RMS error"))):
        for i, (method, rows) in enumerate(series.items()):
            c = colours[i % len(colours)]
            t = [float(r["wall_s"]) for r in rows]
            lo = [float(r["wall_s"]) - float(r["wall_min_s"]) for r in rows]
            hi = [float(r["wall_max_s"]) - float(r["wall_s"]) for r in rows]
            ax.errorbar(t, [float(r[col]) for r in rows], xerr=[lo, hi], fmt="o-", color=c, capsize=2,
                        label=method + " (vs reference.csv)")
            ax.plot(t, [float(r[tight_col]) for r in rows], "s--", color=c, alpha=0.6,
                    label=method + " (vs tight reference)")
            for r in rows:
                ax.annotate(r["samples_per_slice"], (float(r["wall_s"]), float(r[col])), fontsize=6,
                            textcoords="offset points", xytext=(3, 3))
        for y in (1e-3, 1e-4):
            ax.axhline(y, color="grey", linestyle=":", linewidth=1)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("bake wall time (s), 2-core CPU, PoCL")
        ax.set_ylabel(title + " of the baked texels (absolute, term in [0, 1])")
        ax.set_title(title + " against wall time (labels: samples per slice)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("microshadow: 64^3 x 4 seed-3d bake, time to error, azimuth nodes (old) vs stratified (new)")
    fig.tight_layout()
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=os.path.dirname(os.path.abspath(dst)))
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110)
        os.chmod(tmp, 0o644)
        os.replace(tmp, dst)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
