"""The 20,000 stress queries of the exact-method benchmarks (alpha 0.002-1 log-uniform, anisotropy up to
1:50, view z 0.01-1, any light), written as an eval input CSV: python3 exact_stress_queries.py OUT.csv"""
import math
import random
import sys

random.seed(11)
with open(sys.argv[1], "w") as f:
    f.write("visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n")
    for _ in range(20000):
        v = random.random()
        ax = math.exp(math.log(0.002) * random.random())
        ay = min(1.0, max(0.002, ax * math.exp(math.log(50) * (2 * random.random() - 1))))
        cv = 0.01 + 0.99 * random.random(); pv = 2 * math.pi * random.random()
        cl = random.random(); pl = 2 * math.pi * random.random()
        sv = math.sqrt(1 - cv * cv); sl = math.sqrt(1 - cl * cl)
        f.write(f"{v!r},{ax!r},{ay!r},{sv*math.cos(pv)!r},{sv*math.sin(pv)!r},{cv!r},{sl*math.cos(pl)!r},{sl*math.sin(pl)!r},{max(cl,1e-6)!r}\n")
