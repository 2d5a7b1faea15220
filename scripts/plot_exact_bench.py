#!/usr/bin/env python3
"""Error against run time of the exact and sampled methods, from docs/bench/exact_{eval,bake,scene}.csv
(docs/bench/exact_bench.sh): one panel per job, log-log, each point labelled with its setting; and the
jobs' exact stages before and after the per-query azimuth grid, from docs/bench/exact_jobs_grid.csv
(docs/bench/exact_jobs_bench.sh): median CPU seconds with the range over the repeats."""
import csv
import os
import statistics
import sys

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt

bench = sys.argv[1] if len(sys.argv) > 1 else "docs/bench"
out = sys.argv[2] if len(sys.argv) > 2 else f"{bench}/exact_vs_sampled.png"


def rows(name):
    with open(f"{bench}/{name}") as f:
        return list(csv.DictReader(f))


fig, axes = plt.subplots(1, 4, figsize=(20, 4.6))
colours = {"exact": "tab:blue", "sampled": "tab:orange"}
# eval: max error against the 1e-13 run.
ax = axes[0]
for r in rows("exact_eval.csv"):
    kind = "exact" if r["method"].startswith("exact") else "sampled"
    x, y = float(r["eval_s"]), max(float(r["max_error"]), 1e-16)
    ax.loglog(x, y, "o", color=colours[kind])
    ax.annotate(f"{r['method'].replace('sampled-opencl', 'sampled')} {r['setting']}", (x, y), fontsize=7,
                xytext=(4, 3), textcoords="offset points")
ax.set_title("eval: 20,000 stress queries")
ax.set_ylabel("max |error| against exact at 1e-13")
# bake: max error against the exact 1e-6 bake (that bake's own bound: its tolerance).
ax = axes[1]
for r in rows("exact_bake.csv"):
    kind = "exact" if r["method"].startswith("exact") else "sampled"
    err = float(r["max_error_vs_exact_1e-6"])
    y = err if err > 0 else float(r["setting"])  # the reference itself: plotted at its tolerance
    x = float(r["wall_s"])
    ax.loglog(x, max(y, 1e-13), "o", color=colours[kind])
    ax.annotate(f"{r['method']} {r['setting']}", (x, max(y, 1e-13)), fontsize=7, xytext=(4, 3), textcoords="offset points")
ax.set_title("bake: 64^3 x 4 azimuth-mean LUT")
ax.set_ylabel("max |error| (exact 1e-6 bake: its tolerance)")
# scene: the per-pixel bound reached.
ax = axes[2]
for r in rows("exact_scene.csv"):
    x, y = float(r["wall_s"]), float(r["max_bound"])
    ax.loglog(x, y, "o", color=colours[r["method"]])
    ax.annotate(f"{r['method']} to {r['tolerance']}", (x, y), fontsize=7, xytext=(4, 3), textcoords="offset points")
ax.set_title("scene: 1024^2 example, one light")
ax.set_ylabel("largest per-pixel error bound")
for ax in axes[:3]:
    ax.set_xlabel("wall time (s), 2 CPU cores")
    ax.grid(True, which="both", alpha=0.3)
    # A panel spanning less than a decade may hold no 10^k tick: label it in plain seconds at 1, 1.5, 2,
    # 3, 5 and 7 times the powers of ten.
    lo, hi = ax.get_xlim()
    if hi / lo < 10:
        ax.xaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 1.5, 2.0, 3.0, 5.0, 7.0)))
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
# jobs: CPU seconds of each job's run, before and after (median bar, range as the error bar).
ax = axes[3]
if os.path.exists(f"{bench}/exact_jobs_grid.csv"):
    runs = rows("exact_jobs_grid.csv")
    jobs = list(dict.fromkeys(r["job"] for r in runs))
    for k, (build, colour) in enumerate((("before", "tab:gray"), ("after", "tab:blue"))):
        cpu = [[float(r["cpu_s"]) for r in runs if r["job"] == j and r["build"] == build] for j in jobs]
        med = [statistics.median(c) for c in cpu]
        err = [[m - min(c) for m, c in zip(med, cpu)], [max(c) - m for m, c in zip(med, cpu)]]
        ax.bar([i + (k - 0.5) * 0.4 for i in range(len(jobs))], med, 0.4, yerr=err, color=colour, label=build, capsize=2)
    ax.set_xticks(range(len(jobs)))
    ax.set_xticklabels(jobs, rotation=30, ha="right", fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("CPU seconds of the run (user + sys)")
    ax.set_title("exact references: per-query azimuth grid")
    ax.legend(fontsize=7)
    ax.grid(True, axis="y", which="both", alpha=0.3)
handles = [plt.Line2D([], [], marker="o", ls="", color=c, label=k) for k, c in colours.items()]
axes[0].legend(handles=handles, loc="center right")
fig.suptitle("Error against run time: exact method (blue) and VNDF sampling (orange)")
fig.tight_layout()
fig.savefig(out, dpi=110)
print(f"wrote {out}")
