#!/usr/bin/python3
"""Generates microshadow's example scene: a plaster-like height field on a plane, rough on the left
half and smooth on the right (as in part 2's figure), with its tangent-space normal map (+Y green),
cosine-weighted AO and perceptual roughness as 16-bit PNGs. Deterministic: the same bytes every run.

    /usr/bin/python3 scripts/make_example_scene.py [--size N] [--bits 8|16] [OUT_DIR]   # default examples/scene, 256

Another OUT_DIR gets a copy of examples/scene/scene.toml too (the 1024 x 1024 benchmark of
docs/scenes.md: --size 1024 /tmp/scene1024).

examples/scene/scene.toml (committed) describes the images, the view and a low sun. Needs numpy only
(PNG is written here with zlib)."""
import argparse
import os
import struct
import zlib

import numpy as np


def write_png16(path, image, bits=16):
    """A 16-bit (or 8-bit) grey (H x W) or RGB (H x W x 3) PNG of values in [0, 1]."""
    top = 65535.0 if bits == 16 else 255.0
    a = np.clip(np.round(np.asarray(image, dtype=np.float64) * top), 0, top).astype(">u2" if bits == 16 else "u1")
    h, w = a.shape[:2]
    colour = 2 if a.ndim == 3 else 0
    rows = a.reshape(h, -1)
    raw = b"".join(b"\x00" + rows[y].tobytes() for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bits, colour, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


def value_noise(rng, size, cells):
    """Tileable smooth noise: a random cells x cells lattice, smoothstep-interpolated to size x size."""
    lattice = rng.standard_normal((cells, cells))
    t = np.arange(size) * cells / size
    i0 = np.floor(t).astype(int)
    f = t - i0
    f = f * f * (3 - 2 * f)
    i1 = (i0 + 1) % cells
    rows0, rows1 = lattice[i0], lattice[i1]
    top = rows0[:, i0] * (1 - f)[None, :] + rows0[:, i1] * f[None, :]
    bottom = rows1[:, i0] * (1 - f)[None, :] + rows1[:, i1] * f[None, :]
    return top * (1 - f)[:, None] + bottom * f[:, None]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default=os.path.join(os.path.dirname(__file__), "..", "examples", "scene"))
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--bits", type=int, choices=(8, 16), default=16, help="PNG bit depth (8: as many texture sets ship)")
    args = parser.parse_args()
    n = args.size
    rng = np.random.RandomState(20161)
    # Plaster: broad trowel swells, mid-scale lumps, fine grain; ridged (|noise|) lumps read as dabs.
    height = (0.60 * value_noise(rng, n, 4) + 0.35 * (1 - np.abs(value_noise(rng, n, 12))) +
              0.12 * value_noise(rng, n, 32) + 0.04 * value_noise(rng, n, 64))
    height -= height.mean()
    pixel = 1.0 / n                 # the plane is 1 x 1 units
    height *= 0.05                  # relief of a few percent of the width
    # Normals in tangent space (+Y: up the image), from central differences on the tileable field.
    dh_dx = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) / (2 * pixel)
    dh_dup = (np.roll(height, 1, axis=0) - np.roll(height, -1, axis=0)) / (2 * pixel)  # rows go down
    normal = np.stack([-dh_dx, -dh_dup, np.ones_like(height)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    # Cosine-weighted AO from the horizon in 16 directions: the unoccluded share of a direction's slice
    # of the cosine-weighted hemisphere is cos^2(horizon elevation).
    ao = np.zeros_like(height)
    directions = 16
    radius = max(4, n // 12)
    for k in range(directions):
        a = 2 * np.pi * (k + 0.5) / directions
        dx, dy = np.cos(a), np.sin(a)
        tan_max = np.zeros_like(height)
        for s in range(1, radius + 1):
            ox, oy = int(round(dx * s)), int(round(dy * s))
            d = np.hypot(ox, oy) * pixel
            if d == 0:
                continue
            tan_max = np.maximum(tan_max, (np.roll(np.roll(height, -oy, axis=0), -ox, axis=1) - height) / d)
        ao += 1.0 / (1.0 + tan_max ** 2)  # cos^2(atan t)
    ao /= directions
    # Roughness (perceptual): rough plaster on the left half, polished on the right, with grain.
    grain = value_noise(rng, n, 24)
    x = np.arange(n)[None, :].repeat(n, axis=0)
    roughness = np.where(x < n // 2, 0.75 + 0.08 * grain, 0.30 + 0.05 * grain)
    roughness = np.clip(roughness, 0.05, 1.0)
    os.makedirs(args.out, exist_ok=True)
    write_png16(os.path.join(args.out, "normal.png"), 0.5 * normal + 0.5, args.bits)
    write_png16(os.path.join(args.out, "ao.png"), np.clip(ao, 0, 1), args.bits)
    write_png16(os.path.join(args.out, "roughness.png"), roughness, args.bits)
    # Elsewhere (a benchmark at --size 1024), the description comes along.
    toml = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "scene", "scene.toml")
    target = os.path.join(args.out, "scene.toml")
    if os.path.abspath(toml) != os.path.abspath(target) and os.path.exists(toml):
        with open(toml, "rb") as f_in, open(target, "wb") as f_out:
            f_out.write(f_in.read())
    print("wrote %s/{normal,ao,roughness}.png (%d x %d): AO %.3f..%.3f, roughness %.2f..%.2f" %
          (args.out, n, n, ao.min(), ao.max(), roughness.min(), roughness.max()))


if __name__ == "__main__":
    main()
