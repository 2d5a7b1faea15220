#!/usr/bin/env python3
"""Which approximation to ship? Part 2's seed LUT against a representation that keeps the azimuth.

Bakes the seed 3D LUT (the relative azimuth averaged away) and the recommended representation
(azimuth harmonics, docs/representations.md), evaluates the term itself with the exact method on
random realistic queries, and reports each one's error: overall, N.L-weighted (as shading sees it) and
against the relative azimuth between light and view, with its plot (matplotlib: Debian's
python3-matplotlib, or `pip install '.[plot]'`; --no-plot goes without).

    python3 examples/python/study.py --out study-out            # the full sizes (a few minutes)
    python3 examples/python/study.py --small --out study-out    # CI: small bakes, seconds
"""

import argparse
import os
import sys
import time

import numpy as np

import microshadow as ms


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="study-out", help="folder for the baked files and the plot")
    parser.add_argument("--queries", type=int, default=20000, help="random queries to judge on")
    parser.add_argument("--small", action="store_true", help="small bakes and 500 queries (CI)")
    parser.add_argument("--backend", default="opencl", choices=["opencl", "oracle"])
    parser.add_argument("--seed", type=int, default=1, help="seed of the random queries")
    parser.add_argument("--no-plot", action="store_true", help="the tables only (no matplotlib needed)")
    args = parser.parse_args()
    plt = None
    if not args.no_plot:
        # Checked before any work: a missing plotting library is said at once, with the ways out.
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError as e:
            print(f"study.py: the plot needs matplotlib, which this Python cannot import ({e}); install it with "
                  "`pip install '.[plot]'` (or Debian's python3-matplotlib in a --system-site-packages venv), "
                  "or run with --no-plot", file=sys.stderr)
            return 2
    os.makedirs(args.out, exist_ok=True)
    queries = 500 if args.small else args.queries

    # The seed LUT as `microshadow bake` makes it by default (32^3 x 4 roughness channels, sampled).
    t0 = time.monotonic()
    if args.small:
        lut = ms.bake(layout="seed-3d", size=8, samples=4096, backend=args.backend)
    else:
        lut = ms.bake(layout="seed-3d", progress=True, backend=args.backend)
    lut.save(os.path.join(args.out, "seed_lut.exr"))
    print(f"seed LUT {lut.data.shape} baked in {time.monotonic() - t0:.1f} s, bound {lut.max_total_error:.2g}")

    # The recommended representation: harmonics over 32 v x 16 l x 8 nv, 8 roughness slabs 0.3 .. 0.9,
    # texels dense near v = 1 (the best N.L-weighted RMS at the LUT's memory in docs/representations.md).
    t0 = time.monotonic()
    if args.small:
        rep = ms.repr_bake(kind="azimuth-harmonics", visibility_count=6, n_dot_l_count=6, n_dot_v_count=4,
                           roughness=[0.3, 0.6, 0.9], visibility_warp="sqrt-top", tolerance=1e-5, backend=args.backend)
    else:
        rep = ms.repr_bake(kind="azimuth-harmonics", visibility_count=32, n_dot_l_count=16, n_dot_v_count=8,
                           roughness=np.linspace(0.3, 0.9, 8), visibility_warp="sqrt-top", progress=True,
                           backend=args.backend)
    rep.save(os.path.join(args.out, "harmonics.exr"))
    print(f"representation {rep.kind} {rep.data.shape} baked in {time.monotonic() - t0:.1f} s")

    # Realistic queries (docs/representations.md): v in [0.5, 0.98], roughness [0.3, 0.9], NdotV [0.2, 1],
    # NdotL [0, 1], relative azimuth [0, 180] degrees.
    rng = np.random.default_rng(args.seed)
    v = rng.uniform(0.5, 0.98, queries)
    roughness = rng.uniform(0.3, 0.9, queries)
    n_dot_v = rng.uniform(0.2, 1.0, queries)
    n_dot_l = rng.uniform(0.0, 1.0, queries)
    azimuth = rng.uniform(0.0, 180.0, queries)
    t0 = time.monotonic()
    term, error_bar = ms.evaluate_iso(v, n_dot_l, n_dot_v, roughness=roughness, relative_azimuth_deg=azimuth, method="exact",
                                      tolerance=1e-6,
                                      backend=args.backend)
    print(f"{queries} exact terms in {time.monotonic() - t0:.1f} s (max estimated error {error_bar.max():.1e})")

    errors = {
        "seed LUT": lut.lookup(v, n_dot_l, n_dot_v, roughness=roughness) - term,
        "harmonics": rep.lookup(v, n_dot_l, n_dot_v, roughness=roughness, relative_azimuth_deg=azimuth) - term,
    }
    weights = np.maximum(n_dot_l, 0)
    print(f"\n{'':12} {'max |e|':>9} {'RMS':>9} {'N.L RMS':>9}")
    for name, e in errors.items():
        weighted = np.sqrt(np.sum(weights * e * e) / np.sum(weights))
        print(f"{name:12} {np.abs(e).max():9.4f} {np.sqrt(np.mean(e * e)):9.4f} {weighted:9.4f}")

    # Error against the relative azimuth: the LUT's mean is right on average and wrong at both ends.
    edges = np.linspace(0, 180, 13)
    centres = 0.5 * (edges[1:] + edges[:-1])
    which = np.clip(np.digitize(azimuth, edges) - 1, 0, len(centres) - 1)
    print(f"\nRMS error by relative azimuth (degrees)\n{'':12}" + "".join(f"{c:7.0f}" for c in centres))
    rms_by_bin = {}
    for name, e in errors.items():
        rms_by_bin[name] = np.array([np.sqrt(np.mean(e[which == b] ** 2)) if (which == b).any() else np.nan
                                     for b in range(len(centres))])
        print(f"{name:12}" + "".join(f"{x:7.4f}" for x in rms_by_bin[name]))

    if plt is None:
        return 0
    fig, ax = plt.subplots(figsize=(6.4, 4))
    for name, rms in rms_by_bin.items():
        ax.plot(centres, rms, marker="o", label=name)
    ax.set_xlabel("relative azimuth between light and view (degrees)")
    ax.set_ylabel("RMS error against the term")
    ax.set_title(f"{queries} random queries, exact term")
    ax.set_xlim(0, 180)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    plot = os.path.join(args.out, "error_vs_azimuth.png")
    fig.savefig(plot, dpi=120)
    print(f"\nwrote {plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
