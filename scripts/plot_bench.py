#!/usr/bin/python3
"""Log-log plot of error against run time from microshadow_bench's error_vs_time.csv.

Usage: /usr/bin/python3 scripts/plot_bench.py docs/bench/error_vs_time.csv docs/bench/error_vs_time.png
(Debian's python3-matplotlib; run by `microshadow_bench --all --out DIR`.)
The x axis is wall time per evaluated value (a query for eval, a sampled texel for the bakes), so
methods that share work across values and methods that do not sit on one axis.
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
            series.setdefault(row["method"], []).append(
                (float(row["seconds_per_value"]), float(row["max_error"]), float(row["rms_error"])))
    if not series:
        sys.stderr.write(f"{src}: no rows\n")
        return 1
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), sharex=True)
    for ax, col, title in ((axes[0], 1, "max error"), (axes[1], 2, "RMS error")):
        for method, pts in series.items():
            # In budget order (the CSV order): at small budgets the time is fixed overhead and noise,
            # and sorting by time would zigzag the line.
            pts = [p for p in pts if p[col] > 0]
            if pts:
                ax.loglog([p[0] for p in pts], [p[col] for p in pts], "o-", label=method)
        ax.axhline(1e-3, color="grey", linestyle="--", linewidth=1)
        ax.set_xlabel("wall time per value (s)")
        ax.set_ylabel(title + " against the reference")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("microshadow: error against run time (eval: reference queries; bakes: seed-3d texels)")
    fig.tight_layout()
    # Write beside the target and rename, so a failed run never leaves half a PNG.
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=os.path.dirname(os.path.abspath(dst)))
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; the plot is a published file
        os.replace(tmp, dst)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
