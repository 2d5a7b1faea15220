"""One job, three front ends, the same bytes: the CLI (``microshadow``), the C++ API (tests/frontends/
api_jobs.cpp, a program that calls only <microshadow/microshadow.hpp>) and Python (the microshadow
package) run each job below from ONE dict of options, whose keys are the options structs' field names:
the CLI gets them as ``--field-name value``, the C++ program as ``field_name=value`` (it sets the struct
field of that name) and Python as keywords. The C++ API's and Python's files must be byte-identical; the
CLI's must be too but for the provenance it records (its own command line, where the library records
its name and version): each OpenEXR file is compared with that field emptied (and a representation's
bake time, which differs from bake to bake). Values a front end
returns as numbers must be the bits the CLI's file holds (its CSV writes round-trip decimals).

Run by ctest (FrontEnds.IdenticalBytes, CLI and C++ API, plus Python when the build has the module) and
by the pytest suite (test_frontends.py, all three, in CI's Python stage):

    python3 frontends.py --cli build/microshadow --api build/tests/microshadow_api_jobs [--require-python]
"""

from __future__ import annotations

import argparse
import csv
import os
import pathlib
import re
import struct
import subprocess
import sys
import random
import tempfile

# The jobs: small enough for a second or so each on the 2-core CI machine. Every key is a field of the
# job's options struct (SamplingOptions, BakeOptions, ReprBakeOptions, AreaOptions).
EVAL_EXACT = dict(method="exact", tolerance=1e-8, backend="oracle")
EVAL_SAMPLED = dict(method="sampled", samples=512, replicates=4, seed=7, sequence="random", form="uncorrelated",
                    ao_weighting="uniform", backend="oracle")
BAKE = dict(layout="custom", size=4, n_dot_v_count=3, roughness=[0.3, 0.8], backend="oracle", samples=256, seed=5)
REPR = dict(kind="azimuth-harmonics", visibility_count=4, n_dot_l_count=4, n_dot_v_count=3, azimuth_nodes=7,
            roughness=[0.3, 0.9], tolerance=1e-6, backend="oracle")
AREA = dict(lobe="lambert", samples=1024, seed=3)

QUERY_COLUMNS = ["visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"]
SPHERE_COLUMNS = QUERY_COLUMNS[:6] + ["light_x", "light_y", "light_z", "half_angle_deg"]


def _text(value) -> str:
    if isinstance(value, (list, tuple)):
        return ",".join(_text(v) for v in value)
    return repr(value) if isinstance(value, float) else str(value)


def cli_flags(options: dict) -> list:
    """The options as the CLI's flags: each field name with dashes."""
    out = []
    for name, value in options.items():
        out += ["--" + name.replace("_", "-"), _text(value)]
    return out


def api_fields(options: dict) -> list:
    return [f"{name}={_text(value)}" for name, value in options.items()]


def _run(*args) -> None:
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"{' '.join(map(str, args))}: exit {done.returncode}\n{done.stderr}")


def _write_csv(path, header, rows) -> None:
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow([repr(float(x)) for x in r])


def _read_csv(path, columns) -> list:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header = rows[0]
    return [[float(r[header.index(c)]) for c in columns] for r in rows[1:]]


def _write_doubles(path, rows) -> None:
    flat = [x for r in rows for x in r]
    pathlib.Path(path).write_bytes(struct.pack(f"<{len(flat)}d", *flat))


def _read_doubles(path, columns: int) -> list:
    data = pathlib.Path(path).read_bytes()
    flat = struct.unpack(f"<{len(data) // 8}d", data)
    return [list(flat[i:i + columns]) for i in range(0, len(flat), columns)]


def _same_bits(what: str, got: list, want: list) -> None:
    """Rows of doubles identical bit for bit (-0.0 and 0.0, NaN payloads told apart)."""
    bits = [[struct.pack("<d", float(x)) for x in r] for r in got], [[struct.pack("<d", x) for x in r] for r in want]
    if bits[0] != bits[1]:
        where = next(((i, k) for i, (a, b) in enumerate(zip(*bits)) for k in range(min(len(a), len(b))) if a[k] != b[k]),
                     None)
        detail = f"; first at row {where[0]}, column {where[1]}: {got[where[0]][where[1]]!r} != {want[where[0]][where[1]]!r}" \
            if where else f"; {len(got)} rows against {len(want)}"
        raise AssertionError(f"{what}: the values differ{detail}")


def _same_file(what: str, a: pathlib.Path, b: pathlib.Path, provenance: bool = False) -> None:
    """Identical bytes; with provenance=True, identical but for the provenance field (OpenEXR files)."""
    x, y = a.read_bytes(), b.read_bytes()
    if provenance:
        x, y = exr_without_provenance(x), exr_without_provenance(y)
    if x != y:
        first = next((i for i in range(min(len(x), len(y))) if x[i] != y[i]), min(len(x), len(y)))
        raise AssertionError(f"{what}: {a} ({len(x)} bytes) and {b} ({len(y)} bytes) differ from byte {first}")


# The fields in which the files of two front ends may differ: the provenance each records of how it was
# made ("command_line": the CLI's own command line, or "microshadow::bake (library 0.1.0)" for the library,
# which the C++ API and Python share) and, in a representation, how long its bake took ("seconds").
_PROVENANCE = [(re.compile(rb'"command_line":"(?:[^"\\]|\\.)*"'), b'"command_line":""'),
               (re.compile(rb'"seconds":[-+0-9.eE]+'), b'"seconds":0')]
# Scanlines per chunk of each OpenEXR compression (none, RLE, ZIPS, ZIP, PIZ, PXR24, B44, B44A, DWAA, DWAB).
_EXR_LINES = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def exr_without_provenance(data: bytes) -> bytes:
    """A single-part scanline OpenEXR file as it would be with its provenance emptied (_PROVENANCE):
    the header's attributes rewritten (sizes included) and the chunk offsets moved by the change in the
    header's length; every other byte as it was."""
    if data[:4] != b"\x76\x2f\x31\x01" or data[5] & 0x1a:  # magic; single-part scanline only (no tiles, deep data, parts)
        raise AssertionError("not a single-part scanline OpenEXR file")
    pos, header = 8, [data[:8]]
    window = compression = None
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        type_end = data.index(b"\0", name_end + 1)
        size = struct.unpack_from("<i", data, type_end + 1)[0]
        value = data[type_end + 5:type_end + 5 + size]
        name = data[pos:name_end]
        if name == b"dataWindow":
            window = struct.unpack("<iiii", value)
        elif name == b"compression":
            compression = value[0]
        if name.endswith(b"command_line"):  # the provenance as an attribute of its own
            value = b""
        elif name.endswith(b".seconds"):
            value = bytes(len(value))
        for pattern, blank in _PROVENANCE:  # and inside the JSON metadata
            value = pattern.sub(blank, value)
        header.append(data[pos:type_end + 1] + struct.pack("<i", len(value)) + value)
        pos = type_end + 5 + size
    header.append(b"\0")
    pos += 1
    chunks = -(-(window[3] - window[1] + 1) // _EXR_LINES[compression])
    new_header = b"".join(header)
    shift = len(new_header) - pos
    offsets = struct.unpack_from(f"<{chunks}Q", data, pos)
    return new_header + struct.pack(f"<{chunks}Q", *(o + shift for o in offsets)) + data[pos + 8 * chunks:]


def queries(n: int = 16, seed: int = 5) -> list:
    """n varied query rows: anisotropic, every azimuth, lights above and below the horizon, v = 1 first."""
    rng = random.Random(seed)
    rows = []
    for i in range(n):
        wi = [rng.gauss(0, 1), rng.gauss(0, 1), abs(rng.gauss(0, 1)) + 0.05]
        wo = [rng.gauss(0, 1) for _ in range(3)]
        rows.append([1.0 if i == 0 else rng.uniform(0.2, 1.0), rng.uniform(0.05, 1.0), rng.uniform(0.05, 1.0)] + wi + wo)
    return rows


def sphere_lights(n: int, seed: int = 3) -> list:
    rng = random.Random(seed)
    return [[rng.gauss(0, 1), rng.gauss(0, 1), abs(rng.gauss(0, 1)) + 0.1, rng.uniform(2, 30)] for _ in range(n)]


def _columns(rows, a, b=None):
    """Columns a (to b) of rows, as numpy arrays for the Python front end: (N,) or (N, b - a)."""
    import numpy as np  # only where Python is compared: the package needs it anyway
    m = np.array(rows, dtype=np.float64)
    return m[:, a] if b is None else m[:, a:b]


def check_eval(cli, api, ms, work: pathlib.Path, options: dict, tag: str) -> None:
    rows = queries()
    _write_csv(work / f"{tag}.csv", QUERY_COLUMNS, rows)
    _run(cli, "eval", "--in", work / f"{tag}.csv", "--out", work / f"{tag}-cli.csv", "-q", *cli_flags(options))
    want = _read_csv(work / f"{tag}-cli.csv", ["term", "std_error"])
    _write_doubles(work / f"{tag}.bin", rows)
    _run(api, "eval", work / f"{tag}.bin", work / f"{tag}-api.bin", *api_fields(options))
    _same_bits(f"eval {tag}: C++ API against the CLI", _read_doubles(work / f"{tag}-api.bin", 2), want)
    if ms is not None:
        term, error = ms.evaluate(_columns(rows, 0), _columns(rows, 1), _columns(rows, 2), _columns(rows, 3, 6),
                                  _columns(rows, 6, 9), **options)
        _same_bits(f"eval {tag}: Python against the CLI", [list(r) for r in zip(term.tolist(), error.tolist())], want)


def check_area(cli, api, ms, work: pathlib.Path) -> None:
    surface = [r[:6] for r in queries(6, seed=8)]
    light = sphere_lights(len(surface))
    _write_csv(work / "area.csv", SPHERE_COLUMNS, [s + l for s, l in zip(surface, light)])
    _run(cli, "area", "eval", "--in", work / "area.csv", "--out", work / "area-cli.csv", "--light", "sphere", "-q",
         *cli_flags(AREA))
    # The sampled method's CSV has no inner_error column (the value the other front ends return is 0).
    want = [r + [0.0] for r in _read_csv(work / "area-cli.csv", ["term", "std_error"])]
    _write_doubles(work / "area-surface.bin", surface)
    _write_doubles(work / "area-light.bin", light)
    _run(api, "area", work / "area-surface.bin", work / "area-light.bin", work / "area-api.bin", *api_fields(AREA))
    _same_bits("area eval: C++ API against the CLI", _read_doubles(work / "area-api.bin", 3), want)
    if ms is not None:
        got = ms.area_eval(_columns(surface, 0), _columns(surface, 1), _columns(surface, 2), _columns(surface, 3, 6),
                           light_direction=_columns(light, 0, 3), half_angle_deg=_columns(light, 3), **AREA)
        _same_bits("area eval: Python against the CLI", [list(r) for r in zip(*(a.tolist() for a in got))], want)


def check_bake(cli, api, ms, work: pathlib.Path) -> None:
    # One file name in a folder per front end: a C header's symbols come from its name.
    for d in ("cli", "api", "py"):
        (work / d).mkdir(exist_ok=True)
    _run(cli, "bake", "--out", work / "cli" / "lut.exr", "-q", *cli_flags(BAKE))
    for ext in ("exr", "ktx2", "dds", "h"):
        _run(api, "bake", work / "api" / f"lut.{ext}", *api_fields(BAKE))
    _same_file("bake: C++ API against the CLI", work / "api" / "lut.exr", work / "cli" / "lut.exr", provenance=True)
    if ms is not None:
        lut = ms.bake(**BAKE)
        for ext in ("exr", "ktx2", "dds", "h"):
            lut.save(work / "py" / f"lut.{ext}")
            _same_file(f"bake .{ext}: Python against the C++ API", work / "py" / f"lut.{ext}", work / "api" / f"lut.{ext}")
        # A .dds keeps its metadata in a .dds.json beside it.
        _same_file("bake .dds.json: Python against the C++ API", work / "py" / "lut.dds.json", work / "api" / "lut.dds.json")


def check_repr(cli, api, ms, work: pathlib.Path) -> None:
    _run(cli, "repr", "bake", "--out", work / "repr-cli.exr", "-q", *cli_flags(REPR))
    _run(api, "repr", work / "repr-api.exr", *api_fields(REPR))
    # A representation records its bake's wall time, so even two bakes by one front end differ there.
    _same_file("repr bake: C++ API against the CLI", work / "repr-api.exr", work / "repr-cli.exr", provenance=True)
    if ms is not None:
        ms.repr_bake(**REPR).save(work / "repr-py.exr")
        _same_file("repr bake: Python against the C++ API", work / "repr-py.exr", work / "repr-api.exr", provenance=True)


def check_all(cli, api, ms, work: pathlib.Path) -> None:
    check_eval(cli, api, ms, work, EVAL_EXACT, "exact")
    check_eval(cli, api, ms, work, EVAL_SAMPLED, "sampled")
    check_bake(cli, api, ms, work)
    check_repr(cli, api, ms, work)
    check_area(cli, api, ms, work)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cli", required=True, help="the microshadow program")
    parser.add_argument("--api", required=True, help="microshadow_api_jobs (tests/frontends/api_jobs.cpp)")
    parser.add_argument("--require-python", action="store_true", help="fail when the microshadow package cannot be imported")
    args = parser.parse_args()
    try:
        import microshadow as ms
    except ImportError as e:
        if args.require_python:
            print(f"frontends: the microshadow package cannot be imported ({e})", file=sys.stderr)
            return 1
        print(f"frontends: Python not compared (the package cannot be imported: {e}); CLI and C++ API only")
        ms = None
    os.environ.setdefault("POCL_CACHE_DIR", os.path.join(tempfile.gettempdir(), "microshadow-frontends-pocl"))
    with tempfile.TemporaryDirectory(prefix="microshadow-frontends-") as work:
        check_all(args.cli, args.api, ms, pathlib.Path(work))
    print("frontends: eval (exact, sampled), bake, repr bake and area eval identical across the CLI, "
          "the C++ API" + (" and Python" if ms is not None else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
