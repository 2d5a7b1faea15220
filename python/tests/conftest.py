"""Shared fixtures: the CLI to compare with, and small inputs.

The CLI is $MICROSHADOW_CLI, or build/microshadow of this checkout. Tests that compare with it are
skipped when neither exists, unless MICROSHADOW_REQUIRE_CLI=1 (scripts/ci-python.sh sets it): then its
absence fails them.
"""

import csv
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _cli_path():
    env = os.environ.get("MICROSHADOW_CLI")
    if env:
        return pathlib.Path(env)
    return ROOT / "build" / "microshadow"


@pytest.fixture(scope="session")
def cli():
    path = _cli_path()
    if not path.is_file():
        if os.environ.get("MICROSHADOW_REQUIRE_CLI") == "1":
            pytest.fail(f"the microshadow program is not at {path} (set MICROSHADOW_CLI)")
        pytest.skip(f"the microshadow program is not at {path} (set MICROSHADOW_CLI)")

    def run(*args, check=True):
        done = subprocess.run([str(path), *map(str, args)], capture_output=True, text=True)
        if check and done.returncode != 0:
            raise AssertionError(f"microshadow {' '.join(map(str, args))}: exit {done.returncode}\n{done.stderr}")
        return done

    return run


@pytest.fixture(autouse=True, scope="session")
def _pocl_cache(tmp_path_factory):
    # PoCL needs a writable kernel cache.
    os.environ.setdefault("POCL_CACHE_DIR", str(tmp_path_factory.mktemp("pocl")))


QUERY_COLUMNS = ["visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"]


def random_queries(n, seed=5):
    """n varied queries: anisotropic, every azimuth, lights above and below the horizon, v = 1 included."""
    rng = np.random.default_rng(seed)
    v = rng.uniform(0.2, 1.0, n)
    v[0] = 1.0
    ax = rng.uniform(0.05, 1.0, n)
    ay = rng.uniform(0.05, 1.0, n)
    wi = rng.normal(size=(n, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.05
    wo = rng.normal(size=(n, 3))
    return v, ax, ay, wi, wo


def write_queries(path, v, ax, ay, wi, wo):
    """The query CSV of `microshadow eval`, every number in round-trip precision (repr)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(QUERY_COLUMNS)
        for i in range(len(v)):
            w.writerow([repr(float(x)) for x in (v[i], ax[i], ay[i], *wi[i], *wo[i])])


def read_csv_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: [r[k] for r in body] for k, name in enumerate(header)}


def write_grey_png(path, values):
    """An 8-bit greyscale PNG of `values` in [0, 1] (rows top first), written with zlib alone."""
    import struct
    import zlib

    a = np.clip(np.round(np.asarray(values, dtype=np.float64) * 255), 0, 255).astype(np.uint8)
    h, w = a.shape

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))  # filter type 0 on every row
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def write_hdr(path, rgb):
    """A Radiance .hdr of float (h, w, 3) radiance, flat (uncompressed) RGBE scanlines."""
    rgb = np.asarray(rgb, dtype=np.float64)
    h, w, _ = rgb.shape
    peak = rgb.max(axis=2)
    mantissa, exponent = np.frexp(peak)
    scale = np.where(peak > 1e-32, mantissa * 256.0 / np.where(peak > 0, peak, 1), 0.0)
    rgbe = np.zeros((h, w, 4), dtype=np.uint8)
    rgbe[..., :3] = np.clip(rgb * scale[..., None], 0, 255).astype(np.uint8)
    rgbe[..., 3] = np.where(peak > 1e-32, exponent + 128, 0).astype(np.uint8)
    with open(path, "wb") as f:
        f.write(f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode())
        f.write(rgbe.tobytes())


def read_scanline_exr(path):
    """The FLOAT channels of a single-part scanline OpenEXR file (no or ZIP compression), as a dict of
    float32 (height, width) arrays: enough to read scene.exr back bit for bit."""
    import struct
    import zlib

    data = open(path, "rb").read()
    assert data[:4] == b"\x76\x2f\x31\x01", "not an OpenEXR file"
    pos = 8
    channels, window, compression = [], None, None
    while True:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        pos = end + 1
        if not name:
            break
        end = data.index(b"\0", pos)
        kind = data[pos:end].decode()
        size = struct.unpack_from("<i", data, end + 1)[0]
        value = data[end + 5:end + 5 + size]
        pos = end + 5 + size
        if kind == "chlist":
            k = 0
            while value[k] != 0:
                e = value.index(b"\0", k)
                pixel_type = struct.unpack_from("<i", value, e + 1)[0]
                assert pixel_type == 2, "FLOAT channels only"
                channels.append(value[k:e].decode())
                k = e + 1 + 16
        elif name == "dataWindow":
            window = struct.unpack("<iiii", value)
        elif name == "compression":
            compression = value[0]
    assert compression in (0, 3), "no or ZIP compression only"
    width, height = window[2] - window[0] + 1, window[3] - window[1] + 1
    lines = 16 if compression == 3 else 1
    chunks = (height + lines - 1) // lines
    offsets = struct.unpack_from(f"<{chunks}Q", data, pos)
    planes = {c: np.empty((height, width), dtype=np.float32) for c in channels}
    for offset in offsets:
        y, size = struct.unpack_from("<ii", data, offset)
        block = data[offset + 8:offset + 8 + size]
        rows = min(lines, window[3] + 1 - y)
        expected = rows * len(channels) * width * 4
        if compression == 3 and size < expected:
            u = np.frombuffer(zlib.decompress(block), dtype=np.uint8).astype(np.int64)
            # Undo the predictor (t[i] = t[i - 1] + u[i] - 128, mod 256), then the split into even and odd bytes.
            d = u - 128
            d[0] = u[0]
            t = (np.cumsum(d) % 256).astype(np.uint8)
            half = (len(t) + 1) // 2
            raw = np.empty(len(t), dtype=np.uint8)
            raw[0::2] = t[:half]
            raw[1::2] = t[half:]
            block = raw.tobytes()
        k = 0
        for r in range(rows):
            for c in channels:
                planes[c][y - window[1] + r] = np.frombuffer(block, dtype="<f4", count=width, offset=k)
                k += 4 * width
    return planes
