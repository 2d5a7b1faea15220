#!/usr/bin/env python3
"""Call overhead of the Python package: microshadow.evaluate() on N queries against `microshadow eval`
on the same queries and options (the CLI reads them from a CSV and writes a CSV; its input file is made
before the clock starts). Prints both wall times and their ratio, Python / CLI.

    python3 bench/python_eval_overhead.py --cli build/microshadow --queries 1000000
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import microshadow as ms


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", default="build/microshadow")
    parser.add_argument("--queries", type=int, default=1_000_000)
    parser.add_argument("--method", default="exact", choices=["exact", "sampled"])
    parser.add_argument("--tolerance", type=float, default=1e-6, help="exact method's tolerance")
    parser.add_argument("--samples", type=int, default=256, help="sampled method's samples")
    parser.add_argument("--backend", default="opencl", choices=["opencl", "oracle"])
    args = parser.parse_args()

    rng = np.random.default_rng(1)
    n = args.queries
    v = rng.uniform(0.3, 0.98, n)
    ax = rng.uniform(0.05, 1.0, n)
    ay = rng.uniform(0.05, 1.0, n)
    wi = rng.normal(size=(n, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.05
    wo = rng.normal(size=(n, 3))
    options = {"method": args.method, "backend": args.backend}
    cli_options = ["--method", args.method, "--backend", args.backend, "-q"]
    if args.method == "exact":
        options["tolerance"] = args.tolerance
        cli_options += ["--tolerance", repr(args.tolerance)]
    else:
        options["samples"] = args.samples
        cli_options += ["--samples", str(args.samples)]

    with tempfile.TemporaryDirectory() as tmp:
        q = os.path.join(tmp, "q.csv")
        with open(q, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"])
            w.writerows(np.column_stack([v, ax, ay, wi, wo]).tolist())
        # Both sides once on a few queries first, so that neither pays the kernel build (PoCL caches it).
        ms.evaluate(v[:8], ax[:8], ay[:8], wi[:8], wo[:8], **options)
        t0 = time.monotonic()
        term, _ = ms.evaluate(v, ax, ay, wi, wo, **options)
        python_s = time.monotonic() - t0
        t0 = time.monotonic()
        subprocess.run([args.cli, "eval", "--in", q, "--out", os.path.join(tmp, "r.csv"), *cli_options], check=True)
        cli_s = time.monotonic() - t0
        with open(os.path.join(tmp, "r.csv")) as f:
            cli_term = np.array([float(row["term"]) for row in csv.DictReader(f)])
    same = bool(np.array_equal(term, cli_term))
    print(f"{n} queries, {args.method} ({args.backend}): evaluate() {python_s:.2f} s, CLI {cli_s:.2f} s, "
          f"ratio {python_s / cli_s:.3f}; identical values: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
