#!/usr/bin/env python3
"""Call overhead of the Python package: microshadow.evaluate() on N queries against `microshadow eval` on
the same queries and options, measured in one run, with what the command's time is made of.

    python3 bench/python_eval_overhead.py --cli build/microshadow --queries 1000000

The command reads its queries from a CSV and writes a CSV; its time splits into
  - start-up: the process, the device and the kernel cache (measured: the command on one query),
  - evaluation: the engine's own time, as the command reports it on stderr ("... s on <backend>"),
  - the rest: reading and checking the CSV, writing the result CSV and its sidecar (by difference).
evaluate() does the same evaluation on arrays (argument checks, row packing, the engine, unpacking).
The script prints every figure and two ratios:
  - evaluate() / the command: what a study gains by calling the package instead of the command;
  - evaluate() / (start-up + evaluation): the package's call overhead on the same work, without the
    command's file I/O; the target is at most 1.10.
It exits 1 when the values differ from the command's or the overhead ratio is above 1.10.
"""

import argparse
import csv
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

import microshadow as ms

QUERY_COLUMNS = ["visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"]


def write_queries(path, columns):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(QUERY_COLUMNS)
        # repr: every number in round-trip precision, so that the command reads the same bits.
        w.writerows([[repr(x) for x in row] for row in columns.tolist()])


def run_cli(cli, q, out, options):
    """Wall time of `microshadow eval` and the evaluation seconds it reports."""
    t0 = time.monotonic()
    done = subprocess.run([cli, "eval", "--in", q, "--out", out, *options], capture_output=True, text=True)
    wall = time.monotonic() - t0
    if done.returncode != 0:
        sys.exit(f"microshadow eval failed ({done.returncode}):\n{done.stderr}")
    found = re.search(r"([0-9.eE+-]+) s on ", done.stderr)
    if not found:
        sys.exit(f"microshadow eval did not report its evaluation time:\n{done.stderr}")
    return wall, float(found.group(1))


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
    cli_options = ["--method", args.method, "--backend", args.backend]
    if args.method == "exact":
        options["tolerance"] = args.tolerance
        cli_options += ["--tolerance", repr(args.tolerance)]
    else:
        options["samples"] = args.samples
        cli_options += ["--samples", str(args.samples)]

    with tempfile.TemporaryDirectory() as tmp:
        q = os.path.join(tmp, "q.csv")
        one = os.path.join(tmp, "one.csv")
        out = os.path.join(tmp, "r.csv")
        columns = np.column_stack([v, ax, ay, wi, wo])
        write_queries(q, columns)
        write_queries(one, columns[:1])
        # Both sides once first, so that neither pays the kernel build (PoCL caches it).
        ms.evaluate(v[:8], ax[:8], ay[:8], wi[:8], wo[:8], **options)
        startup_s, _ = run_cli(args.cli, one, out, cli_options)

        t0 = time.monotonic()
        term, _ = ms.evaluate(v, ax, ay, wi, wo, **options)
        python_s = time.monotonic() - t0
        t0 = time.monotonic()
        ms._query_rows(v, ax, ay, wi, wo)
        checks_s = time.monotonic() - t0

        cli_s, evaluation_s = run_cli(args.cli, q, out, cli_options)
        with open(out) as f:
            cli_term = np.array([float(row["term"]) for row in csv.DictReader(f)])
    same = bool(np.array_equal(term, cli_term))
    rest_s = cli_s - startup_s - evaluation_s
    overhead = python_s / (startup_s + evaluation_s)
    print(f"{n} queries, {args.method} ({args.backend}), identical values: {same}")
    print(f"  microshadow eval   {cli_s:8.2f} s = start-up {startup_s:.2f} s + evaluation {evaluation_s:.2f} s "
          f"+ CSV read, checks and write {rest_s:.2f} s")
    print(f"  evaluate()         {python_s:8.2f} s (of which argument checks and packing {checks_s:.2f} s)")
    print(f"  evaluate() / command                    {python_s / cli_s:.3f}")
    print(f"  evaluate() / (start-up + evaluation)    {overhead:.3f} (target <= 1.10)")
    return 0 if same and overhead <= 1.10 else 1


if __name__ == "__main__":
    sys.exit(main())
