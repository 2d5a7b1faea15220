#!/usr/bin/env python3
"""Query CSV of the realistic sweep, for `microshadow eval --compare` (docs/representations.md).

Uniform random samples of visibility in [0.5, 0.98], roughness in [0.3, 0.9] (isotropic, alpha =
roughness^2), NdotV in [0.2, 1], NdotL in [0, 1] and the relative azimuth in [0, 180] degrees; V in
the xz plane, L at the azimuth from it. Usage: repr_realistic_queries.py OUT.csv [COUNT] [SEED]
"""
import math
import random
import sys


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out, count = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 4000
    rng = random.Random(int(sys.argv[3]) if len(sys.argv) > 3 else 15)
    with open(out, "w") as f:
        f.write("visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n")
        for _ in range(count):
            v = rng.uniform(0.5, 0.98)
            alpha = rng.uniform(0.3, 0.9) ** 2
            nv = rng.uniform(0.2, 1.0)
            nl = rng.uniform(0.0, 1.0)
            phi = rng.uniform(0.0, math.pi)
            sv, sl = math.sqrt(1 - nv * nv), math.sqrt(1 - nl * nl)
            f.write(f"{v:.9g},{alpha:.9g},{alpha:.9g},{sv:.9g},0,{nv:.9g},"
                    f"{sl * math.cos(phi):.9g},{sl * math.sin(phi):.9g},{nl:.9g}\n")


if __name__ == "__main__":
    main()
