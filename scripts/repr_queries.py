#!/usr/bin/env python3
"""Random query CSVs for `microshadow eval --compare` on a preset's domain (docs/representations.md).

Uniform random samples, isotropic (alpha = roughness^2), V in the xz plane, L at the relative azimuth
from it (uniform in [0, 180] degrees), NdotL uniform in [0, 1]:
  realistic:   visibility [0.5, 0.98], roughness [0.3, 0.9], NdotV [0.2, 1]
  full-range:  visibility [0.02, 1],   roughness [0.05, 1],  NdotV [0.02, 1]
  anisotropic: visibility [0.02, 1], NdotV [0.02, 1], alpha ratio rho uniform in [1, 25], the rougher
               axis's roughness uniform in [0.05 sqrt(rho), 1] (so both alphas lie in [0.0025, 1]), which
               axis is rougher at random, V and L at azimuths uniform in [0, 360) degrees from the tangent
Usage: repr_queries.py DOMAIN OUT.csv [COUNT] [SEED]
"""
import math
import random
import sys

DOMAINS = {
    "realistic": {"visibility": (0.5, 0.98), "roughness": (0.3, 0.9), "n_dot_v": (0.2, 1.0)},
    "full-range": {"visibility": (0.02, 1.0), "roughness": (0.05, 1.0), "n_dot_v": (0.02, 1.0)},
    "anisotropic": {"visibility": (0.02, 1.0), "roughness": (0.05, 1.0), "n_dot_v": (0.02, 1.0), "max_ratio": 25.0},
}


def anisotropic_row(rng, d):
    v = rng.uniform(*d["visibility"])
    ratio = rng.uniform(1.0, d["max_ratio"])
    r_max = rng.uniform(d["roughness"][0] * math.sqrt(ratio), d["roughness"][1])
    a_max = r_max * r_max
    ax, ay = (a_max, a_max / ratio) if rng.random() < 0.5 else (a_max / ratio, a_max)
    nv = rng.uniform(*d["n_dot_v"])
    nl = rng.uniform(0.0, 1.0)
    pv, pl = rng.uniform(0.0, 2 * math.pi), rng.uniform(0.0, 2 * math.pi)
    sv, sl = math.sqrt(1 - nv * nv), math.sqrt(1 - nl * nl)
    return (f"{v:.9g},{ax:.9g},{ay:.9g},{sv * math.cos(pv):.9g},{sv * math.sin(pv):.9g},{nv:.9g},"
            f"{sl * math.cos(pl):.9g},{sl * math.sin(pl):.9g},{nl:.9g}\n")


def main():
    if len(sys.argv) < 3 or sys.argv[1] not in DOMAINS:
        sys.exit(__doc__)
    d = DOMAINS[sys.argv[1]]
    out, count = sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 4000
    rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 15)
    with open(out, "w") as f:
        f.write("visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n")
        for _ in range(count):
            if "max_ratio" in d:
                f.write(anisotropic_row(rng, d))
                continue
            v = rng.uniform(*d["visibility"])
            alpha = rng.uniform(*d["roughness"]) ** 2
            nv = rng.uniform(*d["n_dot_v"])
            nl = rng.uniform(0.0, 1.0)
            phi = rng.uniform(0.0, math.pi)
            sv, sl = math.sqrt(1 - nv * nv), math.sqrt(1 - nl * nl)
            f.write(f"{v:.9g},{alpha:.9g},{alpha:.9g},{sv:.9g},0,{nv:.9g},"
                    f"{sl * math.cos(phi):.9g},{sl * math.sin(phi):.9g},{nl:.9g}\n")


if __name__ == "__main__":
    main()
