"""Fuzzes the microshadow Python package: every public function and method gets valid, small arguments
with one or more of them replaced by a hostile value (NaN, infinities, huge and negative numbers, empty
and wrong-shaped arrays, complex, object, string and datetime arrays, non-contiguous and read-only
views, wrong types, FIFOs, folders and missing files as paths, callbacks that raise).

Each call must either return finite, valid results (checked per function) or raise one of the
exceptions the package documents (ValueError, TypeError, MemoryError, OSError and its subclasses,
RuntimeError for a file the engine cannot read); anything else is a finding. A crash kills the process
(the case is in the log, written before each call), a hang is stopped by faulthandler after
--timeout seconds with every thread's traceback. The cases come from one seeded generator, so a CI run
(fixed --seed) repeats the same cases on every machine.

    python3 fuzz/python_api_fuzz.py [--seconds 40] [--seed 1] [--log FILE] [--cases N]
"""

from __future__ import annotations

import argparse
import faulthandler
import math
import os
import random
import shutil
import sys
import tempfile
import time
import traceback
import warnings

import numpy as np

import microshadow as ms

ALLOWED = (ValueError, TypeError, MemoryError, OSError, RuntimeError)


# --- hostile values -------------------------------------------------------------------------------------


def _non_contiguous(a):
    """`a` as a view with gaps (every other element of an array twice as long)."""
    a = np.asarray(a, dtype=np.float64)
    big = np.zeros((a.shape[0] * 2,) + a.shape[1:] if a.ndim else (2,))
    if a.ndim == 0:
        big[0] = a
        return big[::2][0:1].reshape(())
    big[::2] = a
    return big[::2]


def _read_only(a):
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


NUMBERS = [math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -5e-324, -0.0, 0.0, -1.0, 2.0, 1e-300, 1e300,
           2**64, -(2**63), 2**1000, True, np.float16(0.5), np.float32(np.nan), np.longdouble(0.5), 1 + 2j,
           np.complex128(0.5 + 0j), "0.5", "nan", "", b"1", None, [], [[]], object(), np.datetime64("2020-01-01"),
           np.timedelta64(5, "s"), np.uint64(2**64 - 1), np.int8(-1)]

# Counts (sizes, samples, seeds, threads): none a valid count of real work (2^31 samples a query would be a
# legitimate minutes-long call, not a finding), so every one must be refused at once or be harmless.
COUNTS = [-1, -(2**63), 2**63, 2**64, 2**64 + 1, 10**30, True, False, 1.5, math.nan, math.inf, "3", None,
          np.int64(-1), np.uint64(2**64 - 1), np.float64(2.0), [3], 3 + 0j]

STRINGS = ["", "EXACT", "exact\0", " exact", "nan", "\u00e9", "x" * 10000, None, 1, b"exact", ["exact"], math.nan]


def hostile_array(rng: random.Random, shape):
    """A hostile value for an argument that wants a float array of `shape` (a tuple, () for a number)."""
    n = shape[0] if shape else 1
    kind = rng.randrange(24)
    if kind == 0:
        return rng.choice(NUMBERS)
    if kind == 1:
        return np.full(shape, rng.choice([math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324]))
    if kind == 2:
        return np.zeros((0,) + tuple(shape[1:]))
    if kind == 3:
        return np.zeros(tuple(s + 1 for s in shape) or (2,))
    if kind == 4:
        return np.zeros((2, 2, 2, 2))
    if kind == 5:
        return np.full(shape, 0.5 + 0.25j)
    if kind == 6:
        return np.array([0.5, "x", None], dtype=object)
    if kind == 7:
        return np.full(shape or (1,), "0.5")
    if kind == 8:
        return np.full(shape or (1,), np.datetime64("2020-01-01"))
    if kind == 9:
        return _non_contiguous(np.full(shape or (1,), 0.5))
    if kind == 10:
        return _read_only(np.full(shape or (1,), 0.5))
    if kind == 11:
        return np.asfortranarray(np.full(shape + (1,) if len(shape) == 1 else shape or (1,), 0.5))
    if kind == 12:
        return np.broadcast_to(0.5, (10**9,) + tuple(shape[1:]))  # a billion queries: MemoryError at once
    if kind == 13:
        return np.full(shape or (1,), 0.5, dtype=np.float16)
    if kind == 14:
        return np.full(shape or (1,), 1, dtype=np.int8)
    if kind == 15:
        return np.full(shape or (1,), True)
    if kind == 16:
        return np.zeros(shape or (1,), dtype=[("a", "f8"), ("b", "f8")])
    if kind == 17:
        return [[0.5] * (rng.randrange(3) + 1) for _ in range(n)] + [[0.5]]  # ragged
    if kind == 18:
        return np.ma.masked_array(np.full(shape or (1,), 0.5), mask=True)
    if kind == 19:
        a = np.full(shape or (1,), 0.5)
        a.flat[rng.randrange(a.size)] = rng.choice([math.nan, math.inf, -1.0, 2.0, -0.0, 1e-320])
        return a
    if kind == 20:
        return np.full(shape or (1,), rng.choice([-1.0, 2.0, 1e9, -1e-9, 1e-320]))
    if kind == 21:
        return rng.choice(STRINGS)
    if kind == 22:
        return np.zeros(()) if shape else np.zeros((3,))
    return np.full((n, 7) if len(shape) == 2 else (n, 2), 0.5)


def _write_hdr(path: str, width: int, height: int) -> None:
    """A small Radiance .hdr sky (flat RGBE scanlines): a gradient with one bright texel."""
    rgbe = np.zeros((height, width, 4), dtype=np.uint8)
    rgbe[..., 0] = np.linspace(60, 200, width).astype(np.uint8)
    rgbe[..., 1] = 128
    rgbe[..., 2] = np.linspace(200, 60, height).astype(np.uint8)[:, None]
    rgbe[..., 3] = 128
    rgbe[1, 2] = [200, 180, 160, 134]
    with open(path, "wb") as f:
        f.write(f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode())
        f.write(rgbe.tobytes())


class Paths:
    """Hostile paths, made once: a folder, a FIFO (would block a reader in open()), an empty file, a
    garbage file, a missing file, a NUL byte, a very long name, a file named like a LUT that is not one,
    and (add_damaged) real LUT files damaged."""

    def __init__(self, root: str) -> None:
        self.root = root
        self.folder = os.path.join(root, "folder.exr")
        os.mkdir(self.folder)
        self.fifo = os.path.join(root, "fifo.exr")
        os.mkfifo(self.fifo)
        self.empty = os.path.join(root, "empty.exr")
        open(self.empty, "wb").close()
        self.garbage = os.path.join(root, "garbage.exr")
        with open(self.garbage, "wb") as f:
            f.write(b"\x76\x2f\x31\x01" + os.urandom(200))
        self.toml_garbage = os.path.join(root, "garbage.toml")
        with open(self.toml_garbage, "w") as f:
            f.write("[points\nregion = 'x'\n" + "[[a]]\n" * 50)
        self.missing = os.path.join(root, "missing.exr")
        self.environment = os.path.join(root, "sky.hdr")
        _write_hdr(self.environment, 8, 4)

        self.damaged = []

    def add_damaged(self, lut, rng: random.Random) -> None:
        """LUT files made from a real one and then damaged: cut short, bytes flipped, a .dds whose metadata
        sidecar nests 100,000 deep (a recursive reader would overflow the stack)."""
        for ext in ("exr", "ktx2", "dds", "h", "png"):
            path = os.path.join(self.root, f"real.{ext}")
            lut.save(path)
            data = open(path, "rb").read()
            for k, damaged in enumerate([data[: len(data) // 2], bytes(b ^ (0xFF if rng.random() < 0.01 else 0) for b in data)]):
                name = os.path.join(self.root, f"damaged{k}.{ext}")
                with open(name, "wb") as f:
                    f.write(damaged)
                if ext == "dds":
                    with open(name + ".json", "wb") as f:
                        f.write(open(path + ".json", "rb").read()[: 40 if k == 0 else None])
                self.damaged.append(name)
        deep = os.path.join(self.root, "deep.dds")
        shutil.copy(os.path.join(self.root, "real.dds"), deep)
        with open(deep + ".json", "w") as f:
            f.write('{"microshadow":' + "[" * 100000 + "]" * 100000 + "}")
        self.damaged.append(deep)

    def hostile(self, rng: random.Random):
        if self.damaged and rng.random() < 0.3:
            return rng.choice(self.damaged)
        return rng.choice([self.folder, self.fifo, self.empty, self.garbage, self.toml_garbage, self.missing, "", "a\0b",
                           "x" * 5000, "/dev/null", "/proc/self/mem", 5, None, b"\xff.exr", ["x.exr"]])

    def output(self, rng: random.Random):
        return rng.choice([self.folder, self.fifo, "", "a\0b", os.path.join(self.missing, "x.exr"), "x" * 5000,
                           os.path.join(self.root, "out.unknown"), 5, None])


# --- the calls ------------------------------------------------------------------------------------------


def _finite(name, a, lo=-math.inf, hi=math.inf):
    a = np.asarray(a)
    if a.dtype.kind != "f":
        raise AssertionError(f"{name}: dtype {a.dtype}, not floating point")
    if not np.isfinite(a).all():
        raise AssertionError(f"{name}: not finite: {a.ravel()[:8]}")
    if a.size and (a.min() < lo or a.max() > hi):
        raise AssertionError(f"{name}: outside [{lo}, {hi}]: {a.ravel()[:8]}")


def _term(name, result, n=None):
    term, error = result
    _finite(name + " term", term, -1e-9, 1 + 1e-9)
    _finite(name + " std_error", error, 0, 1)
    if term.shape != error.shape or (n is not None and term.shape != (n,)):
        raise AssertionError(f"{name}: shapes {term.shape}, {error.shape}")


FAST = dict(backend="oracle", tolerance=1e-4)


class Fuzzer:
    def __init__(self, rng: random.Random, paths: Paths, lut, representation) -> None:
        self.rng = rng
        self.paths = paths
        self.lut = lut
        self.representation = representation

    def _mutate(self, kwargs: dict, kinds: dict) -> dict:
        """kwargs with one to three of them replaced by a hostile value of the argument's kind."""
        self.must_refuse = None
        names = list(kinds)
        for name in self.rng.sample(names, min(len(names), self.rng.choice([1, 1, 1, 2, 3]))):
            kind = kinds[name]
            if kind == "count":
                kwargs[name] = self.rng.choice(COUNTS)
            elif kind == "string":
                kwargs[name] = self.rng.choice(STRINGS)
            elif kind == "path":
                kwargs[name] = self.paths.hostile(self.rng)
            elif kind == "out":
                kwargs[name] = self.paths.output(self.rng)
            elif kind == "progress":
                kwargs[name] = self.rng.choice([5, "yes", _raising_progress, _returning_garbage, math.nan])
            elif kind == "number":
                kwargs[name] = self.rng.choice(NUMBERS)
            else:
                kwargs[name] = hostile_array(self.rng, kind)
                if _meaningless(kwargs[name]):
                    self.must_refuse = name
        self.shown = dict(kwargs)  # every argument, positional ones included, for the log and the findings
        return kwargs

    def case(self):
        """One call: (name, its arguments, a function of no arguments, the result's check, the argument
        that must make it raise or None)."""
        n = self.rng.choice([1, 2, 3])
        target = self.rng.choice(TARGETS)
        self.must_refuse = None
        self.shown = None
        name, kw, call, check = target(self, n)
        return name, dict(self.shown) if self.shown is not None else kw, call, check, self.must_refuse


def _meaningless(value) -> bool:
    """A value no numeric argument may accept: complex numbers (their imaginary part would be dropped),
    dates and durations, records, text, masked values."""
    try:
        a = np.asarray(value)
    except Exception:  # noqa: BLE001 - ragged lists and the like: numpy's own refusal decides
        return False
    if np.ma.isMaskedArray(value) and np.ma.getmaskarray(value).any():
        return True
    return a.dtype.kind in "cMmVUS" and a.size > 0


# Numbers in messages as numpy spells them (np.float64(nan)): a message shows the number itself.
_NUMPY_REPR = ("np.float64(", "np.int64(", "np.float32(", "np.uint64(", "np.int8(", "np.float16(", "np.complex128(")


def _raising_progress(done, total):
    raise ValueError("progress callback refuses")


def _returning_garbage(done, total):
    return object()


def t_evaluate(f: Fuzzer, n):
    kw = dict(visibility=np.full(n, 0.5), alpha_x=np.full(n, 0.3), alpha_y=np.full(n, 0.2),
              wi=np.tile([0.3, 0.1, 0.9], (n, 1)), wo=np.tile([-0.2, 0.4, 0.8], (n, 1)), **FAST)
    f._mutate(kw, dict(visibility=(n,), alpha_x=(n,), alpha_y=(n,), wi=(n, 3), wo=(n, 3), tolerance="number",
                       method="string", samples="count", replicates="count", seed="count", sequence="string",
                       form="string", ao_weighting="string", backend="string", device="string", progress="progress"))
    pos = [kw.pop(k) for k in ("visibility", "alpha_x", "alpha_y", "wi", "wo")]
    return "evaluate", kw, lambda: ms.evaluate(*pos, **kw), lambda r: _term("evaluate", r)


def t_evaluate_iso(f: Fuzzer, n):
    kw = dict(visibility=np.full(n, 0.5), n_dot_l=np.full(n, 0.6), n_dot_v=np.full(n, 0.7), roughness=np.full(n, 0.5),
              relative_azimuth_deg=np.full(n, 30.0), **FAST)
    f._mutate(kw, dict(visibility=(n,), n_dot_l=(n,), n_dot_v=(n,), roughness=(n,), relative_azimuth_deg=(n,),
                       tolerance="number", method="string"))
    pos = [kw.pop(k) for k in ("visibility", "n_dot_l", "n_dot_v")]
    return "evaluate_iso", kw, lambda: ms.evaluate_iso(*pos, **kw), lambda r: _term("evaluate_iso", r)


def t_lookup_inputs(f: Fuzzer, n):
    kw = dict(visibility=np.full(n, 0.5), alpha_x=np.full(n, 0.3), alpha_y=np.full(n, 0.2),
              wi=np.tile([0.3, 0.1, 0.9], (n, 1)), wo=np.tile([-0.2, 0.4, 0.8], (n, 1)))
    f._mutate(kw, dict(visibility=(n,), alpha_x=(n,), alpha_y=(n,), wi=(n, 3), wo=(n, 3)))

    def check(r):
        for k, v in r.items():
            _finite(k, v)
    return "lookup_inputs", kw, lambda: ms.lookup_inputs(**kw), check


def t_analytic(f: Fuzzer, n):
    kw = dict(name=f.rng.choice(ms.ANALYTIC_TERMS), visibility=np.full(n, 0.5), n_dot_l=np.full(n, 0.6),
              n_dot_v=np.full(n, 0.7), roughness=np.full(n, 0.5), ao_weighting="cosine")
    f._mutate(kw, dict(name="string", visibility=(n,), n_dot_l=(n,), n_dot_v=(n,), roughness=(n,), ao_weighting="string"))
    pos = [kw.pop(k) for k in ("name", "visibility", "n_dot_l")]
    return "analytic", kw, lambda: ms.analytic(*pos, **kw), lambda r: _finite("analytic", r)


def t_lookup(f: Fuzzer, n):
    table = f.rng.choice([f.lut, f.representation])
    kw = dict(visibility=np.full(n, 0.5), n_dot_l=np.full(n, 0.6), n_dot_v=np.full(n, 0.7), roughness=np.full(n, 0.5),
              relative_azimuth_deg=np.full(n, 30.0))
    f._mutate(kw, dict(visibility=(n,), n_dot_l=(n,), n_dot_v=(n,), roughness=(n,), relative_azimuth_deg=(n,)))
    pos = [kw.pop(k) for k in ("visibility", "n_dot_l", "n_dot_v")]
    return f"{type(table).__name__}.lookup", kw, lambda: table.lookup(*pos, **kw), lambda r: _finite("lookup", r)


def t_save(f: Fuzzer, n):
    table = f.rng.choice([f.lut, f.representation])
    kw = dict(path=os.path.join(f.paths.root, f.rng.choice(["s.exr", "s.ktx2", "s.dds", "s.h", "s.png"])))
    kinds = dict(path="out")
    if isinstance(table, ms.Lut):
        kw["encoding"] = "float32"
        kinds["encoding"] = "string"
    else:
        kw["half"] = False
        kinds["half"] = "number"
    f._mutate(kw, kinds)
    return f"{type(table).__name__}.save", kw, lambda: table.save(**kw), lambda r: None


def t_open(f: Fuzzer, n):
    kw = dict(path=f.paths.hostile(f.rng))

    def check(table):  # what a reader accepts must be what a bake could have written
        _finite("open data", table.data, -1e-6 if isinstance(table, ms.Lut) else -math.inf,
                1 + 1e-6 if isinstance(table, ms.Lut) else math.inf)
    return "open", kw, lambda: ms.open(**kw), check


def t_bake(f: Fuzzer, n):
    kw = dict(layout="custom", size=2, roughness=[0.5], samples=64, replicates=2, backend="oracle")
    f._mutate(kw, dict(layout="string", size="count", visibility_count="count", n_dot_l_count="count",
                       n_dot_v_count="count", roughness=(2,), visibility_range=(2,), n_dot_l_range=(2,),
                       n_dot_v_range=(2,), texel="string", azimuth="number", samples="count", max_batches="count",
                       seed="count", replicates="count", tolerance="number", method="string", progress="progress"))

    def check(lut):
        _finite("bake data", lut.data, -1e-6, 1 + 1e-6)
    return "bake", kw, lambda: ms.bake(**kw), check


def t_repr_bake(f: Fuzzer, n):
    kw = dict(kind="azimuth-axis", visibility_count=2, n_dot_l_count=2, n_dot_v_count=2, azimuth_nodes=2,
              roughness=[0.5], tolerance=1e-3, backend="oracle")
    f._mutate(kw, dict(preset="string", kind="string", visibility_count="count", n_dot_l_count="count",
                       n_dot_v_count="count", azimuth_nodes="count", roughness=(2,), roughness_count="count",
                       n_dot_v_warp="string", n_dot_l_warp="string", visibility_warp="string", tolerance="number"))

    def check(r):
        _finite("repr_bake data", r.data)
    return "repr_bake", kw, lambda: ms.repr_bake(**kw), check


def t_ibl_dfg(f: Fuzzer, n):
    kw = dict(size=2, method="exact", threads=1)
    f._mutate(kw, dict(size="count", n_dot_v_count="count", roughness_count="count", texel="string", method="string",
                       channels="string", parameterization="string", samples="count", replicates="count",
                       seed="count", threads="count", backend="string"))

    def check(d):
        _finite("ibl_dfg data", d.data)
    return "ibl_dfg", kw, lambda: ms.ibl_dfg(**kw), check


def t_area_eval(f: Fuzzer, n):
    light = f.rng.choice(["sphere", "rect"])
    kw = dict(visibility=np.full(n, 0.5), alpha_x=np.full(n, 0.3), alpha_y=np.full(n, 0.2),
              wi=np.tile([0.3, 0.1, 0.9], (n, 1)), light=light, lobe="lambert", samples=64, replicates=2,
              backend="oracle")
    kinds = dict(visibility=(n,), alpha_x=(n,), alpha_y=(n,), wi=(n, 3), light="string", lobe="string",
                 samples="count", method="string", tolerance="number")
    if light == "sphere":
        kw.update(light_direction=np.tile([0.0, 0.2, 1.0], (n, 1)), half_angle_deg=np.full(n, 10.0))
        kinds.update(light_direction=(n, 3), half_angle_deg=(n,))
    else:
        kw["corners"] = np.tile([[-0.5, -0.5, 1.0], [0.5, -0.5, 1.0], [0.5, 0.5, 1.0], [-0.5, 0.5, 1.0]], (n, 1, 1))
        kinds["corners"] = (n, 4, 3)
    f._mutate(kw, kinds)
    pos = [kw.pop(k) for k in ("visibility", "alpha_x", "alpha_y", "wi")]

    def check(r):
        _finite("area term", r.term, -1e-9, 1 + 1e-9)
        _finite("area std_error", r.std_error, 0)
    return "area_eval", kw, lambda: ms.area_eval(*pos, **kw), check


def t_files(f: Fuzzer, n):
    """The functions that read a file or a folder (scene, sweep, design, the environment integrals)."""
    which = f.rng.randrange(6)
    p = f.paths.hostile(f.rng)
    if which == 0:
        return "scene", dict(path=p), lambda: ms.scene(p), lambda r: None
    if which == 1:
        return "sweep", dict(spec=p), lambda: ms.sweep(p), lambda r: None
    if which == 2:
        toml = f.rng.choice(["", "[points", "[points]\nregion = 'x'\n", "a = " + "[" * 100000, "\0", p if isinstance(p, str) else "x"])
        return "sweep(toml=)", dict(toml=toml), lambda: ms.sweep(toml=toml), lambda r: None
    if which == 3:
        kw = dict(reference=p, luts=[f.paths.hostile(f.rng)], cache=f.paths.output(f.rng))
        return "design", kw, lambda: ms.design(**kw), lambda r: None
    name = f.rng.choice(["ibl_prefilter", "ibl_irradiance", "ibl_sh"])
    kw = f.rng.choice([dict(environment=p), dict(faces=[p] * f.rng.choice([1, 6, 7])), dict(faces=p)])
    return name, kw, lambda: getattr(ms, name)(**kw), lambda r: None


def t_environment(f: Fuzzer, n):
    """The environment integrals on a valid 8 x 4 sky, their options hostile; then their save()."""
    name = f.rng.choice(["ibl_prefilter", "ibl_irradiance", "ibl_sh"])
    if name == "ibl_prefilter":
        kw = dict(environment=f.paths.environment, size=4, levels=2, samples=16, max_samples=64, replicates=2,
                  tolerance=0.0, threads=1, irradiance_size=2)
        kinds = dict(size="count", levels="count", mapping="string", tolerance="number", samples="count",
                     max_samples="count", replicates="count", seed="count", lod_bias="number", bright="string",
                     bright_threshold="number", bright_min_roughness="number", wide_samples_factor="count",
                     bright_max="count", device="string", threads="count", verify="count", irradiance_size="count")
    elif name == "ibl_irradiance":
        kw = dict(environment=f.paths.environment, face_size=2, source_size=4, backend="oracle", threads=1)
        kinds = dict(face_size="count", source_size="count", backend="string", device="string", threads="count",
                     verify="count")
    else:
        kw = dict(environment=f.paths.environment, face_size=2)
        kinds = dict(face_size="count")
    f._mutate(kw, kinds)
    out = f.paths.output(f.rng) if f.rng.random() < 0.5 else os.path.join(f.paths.root, "env-out")
    save = dict(format=f.rng.choice(["exr", "ktx2", "dds", "png", "", None, 3]),
                encoding=f.rng.choice(["float16", "float32", "unorm8", None]), exposure=f.rng.choice(NUMBERS))

    def call():
        result = getattr(ms, name)(**kw)
        for array in (getattr(result, "irradiance", None), getattr(result, "data", None)):
            if array is not None:
                _finite(name, array)
        try:
            if name == "ibl_sh":
                result.save(out if isinstance(out, str) and out.endswith(".json") else out)
            else:
                result.save(out, **save)
        except ALLOWED:
            pass
        return result
    return name, dict(kw, out=out, **save), call, lambda r: None


def t_dfg_save(f: Fuzzer, n):
    dfg = f.dfg
    kw = dict(path=f.paths.output(f.rng) if f.rng.random() < 0.5 else os.path.join(
        f.paths.root, f.rng.choice(["d.exr", "d.h", "d.inc", "d.png", "d.ktx2", "d.dds", "d.tga"])),
        half=f.rng.choice([False, True, 2, None, "yes"]), symbol=f.rng.choice(STRINGS + ["ok_symbol", "2bad", "a-b"]))
    return "DfgLut.save", kw, lambda: dfg.save(**kw), lambda r: None


def t_sweep_options(f: Fuzzer, n):
    """A valid one-point sweep spec, its overrides hostile."""
    toml = ('[sampling]\nmethod = "exact"\ntolerance = 1e-4\n[parameters]\nroughness = [0.5]\nn_dot_v = [0.5]\n'
            'phi_i = [0.0]\nphi_o = [30.0]\nn_dot_l = [0.5]\nvisibility = [0.5]\n')
    kw = dict(toml=toml, backend="oracle")
    f._mutate(kw, dict(method="string", tolerance="number", samples="count", replicates="count", seed="count",
                       sequence="string", form="string", ao_weighting="string", backend="string", out="out"))

    def check(table):
        _finite("sweep term", table["term"], -1e-9, 1 + 1e-9)
    return "sweep(options)", kw, lambda: ms.sweep(**kw), check


TARGETS = [t_environment, t_dfg_save, t_sweep_options, t_evaluate, t_evaluate_iso, t_lookup_inputs, t_analytic, t_lookup, t_lookup, t_save, t_open, t_bake,
           t_repr_bake, t_ibl_dfg, t_area_eval, t_files]


# --- the loop -------------------------------------------------------------------------------------------


def _shown(kw: dict) -> str:
    def one(v):
        if isinstance(v, np.ndarray):
            return f"array(shape={v.shape}, dtype={v.dtype}, flags={'C' if v.flags.c_contiguous else 'nc'})"
        r = repr(v)
        return r if len(r) < 80 else r[:77] + "..."
    return ", ".join(f"{k}={one(v)}" for k, v in kw.items())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=40.0, help="how long to fuzz (default 40)")
    parser.add_argument("--cases", type=int, default=0, help="stop after this many cases (0: the time decides)")
    parser.add_argument("--seed", type=int, default=None, help="the generator's seed (default: random)")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds one call may take (a hang otherwise)")
    parser.add_argument("--log", default=None, help="each case, written before it runs (default: a temporary file)")
    args = parser.parse_args()
    seed = args.seed if args.seed is not None else random.SystemRandom().randrange(2**32)
    rng = random.Random(seed)
    root = tempfile.mkdtemp(prefix="microshadow-pyfuzz-")
    log_path = args.log or os.path.join(root, "cases.log")
    os.environ.setdefault("POCL_CACHE_DIR", os.path.join(root, "pocl"))
    print(f"python-fuzz: seed {seed}, cases logged to {log_path}", flush=True)
    warnings.simplefilter("ignore")  # numpy's and the package's warnings are not findings
    findings = []
    counts = {}
    try:
        paths = Paths(root)
        lut = ms.bake(layout="custom", size=2, roughness=[0.3, 0.8], samples=64, replicates=2, backend="oracle")
        representation = ms.repr_bake(kind="azimuth-axis", visibility_count=2, n_dot_l_count=2, n_dot_v_count=2,
                                      azimuth_nodes=2, roughness=[0.5], tolerance=1e-3, backend="oracle")
        paths.add_damaged(lut, rng)
        fuzzer = Fuzzer(rng, paths, lut, representation)
        fuzzer.dfg = ms.ibl_dfg(size=2, method="exact", threads=1)
        t0 = time.monotonic()
        with open(log_path, "w") as log:
            case = 0
            while time.monotonic() - t0 < args.seconds and (not args.cases or case < args.cases):
                name, kw, call, check, must_refuse = fuzzer.case()
                log.write(f"{case}: {name}({_shown(kw)})\n")
                log.flush()
                faulthandler.dump_traceback_later(args.timeout, exit=True)
                outcome = "returned"
                try:
                    check(call())
                    if must_refuse:
                        findings.append(f"case {case}: {name}({_shown(kw)}): accepted {must_refuse} = "
                                        f"{_shown({'': kw[must_refuse]})[1:]}")
                except ALLOWED as e:
                    outcome = type(e).__name__
                    if not str(e):
                        findings.append(f"case {case}: {name}({_shown(kw)}): {type(e).__name__} without a message")
                    elif any(r in str(e) for r in _NUMPY_REPR):
                        findings.append(f"case {case}: {name}({_shown(kw)}): a numpy repr in the message: {e}")
                except AssertionError as e:
                    findings.append(f"case {case}: {name}({_shown(kw)}): garbage returned: {e}")
                except KeyboardInterrupt:
                    raise
                except BaseException as e:  # noqa: B902 - every other exception is a finding
                    findings.append(f"case {case}: {name}({_shown(kw)}): {type(e).__name__}: {e}\n"
                                    + "".join(traceback.format_exception(type(e), e, e.__traceback__)[-3:]))
                finally:
                    faulthandler.cancel_dump_traceback_later()
                counts.setdefault(name, {}).setdefault(outcome, 0)
                counts[name][outcome] += 1
                case += 1
        print(f"python-fuzz: seed {seed}, {case} cases in {time.monotonic() - t0:.0f} s, {len(findings)} findings")
        for name in sorted(counts):
            print(f"  {name}: " + ", ".join(f"{k} {v}" for k, v in sorted(counts[name].items())))
        for finding in findings[:20]:
            print("FINDING " + finding)
        return 1 if findings else 0
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    faulthandler.enable()
    sys.exit(main())
