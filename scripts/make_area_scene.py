#!/usr/bin/env python3
"""The example scene (examples/scene) under area lights, on a window of its pixels.

    scripts/make_area_scene.py OUT_DIR [--window 32]

writes OUT_DIR/mask.png (8-bit grey: 255 on a WINDOW x WINDOW square at the centre of the 256 x 256 texture
set, where the rough and the polished halves meet; 0 elsewhere) and OUT_DIR/area.toml: the example's
surface, view and comparators under a sphere light (GGX lobe) and a rectangle light (Lambert lobe), with
the mask. Then: build/microshadow scene OUT_DIR/area.toml --out OUT_DIR/out --no-seed-luts
(docs/scenes.md, "Area lights", has the figures).
"""
import argparse
import os
import struct
import sys
import zlib

SIZE = 256  # the example scene's


def png_grey8(path, width, height, value_at):
    raw = b"".join(b"\x00" + bytes(value_at(x, y) for x in range(width)) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out")
    p.add_argument("--window", type=int, default=32)
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    lo, hi = (SIZE - args.window) // 2, (SIZE + args.window) // 2
    png_grey8(os.path.join(args.out, "mask.png"), SIZE, SIZE, lambda x, y: 255 if lo <= x < hi and lo <= y < hi else 0)
    example = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "examples", "scene"))
    with open(os.path.join(args.out, "area.toml"), "w") as f:
        f.write(f'''# The example scene under area lights (scripts/make_area_scene.py).
name = "plaster-area"

[normal]
file = "{example}/normal.png"
space = "tangent"

[visibility]
file = "{example}/ao.png"
channel = "Y"

[roughness]
file = "{example}/roughness.png"
channel = "Y"

[mask]
file = "mask.png"
channel = "Y"
kind = "alpha"

[view]
direction = [0.0, -0.643, 0.766]

[[light]]
name = "bulb"                   # about 12 degrees half-angle over the window, 38 degrees above the plane
type = "sphere"
position = [2.1, 1.4, 1.45]
radius = 0.5
lobe = "ggx"
intensity = 1.0

[[light]]
name = "window"                 # a 1.5 x 1 panel standing 1.5 units behind the texture set's far edge
type = "rect"
corners = [[-0.25, 2.5, 0.2], [1.25, 2.5, 0.2], [1.25, 2.5, 1.2], [-0.25, 2.5, 1.2]]
intensity = 1.0

[comparators]
analytic = ["naughty-dog", "activision-adjusted", "pz-analytic"]

[sampling]
area_tolerance = 5e-3
''')


if __name__ == "__main__":
    sys.exit(main())
