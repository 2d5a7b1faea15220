"""scene(): every pixel of a scene against the approximations (``microshadow scene``)."""

from __future__ import annotations

import json
import os
from typing import Dict, List, Optional, Sequence

import numpy as np

from . import _microshadow as _core
from . import _options
from ._checks import _BACKENDS, _choice, _METHODS, PathArg, _progress, ProgressArg, _shown


class SceneRun:
    """The result of :func:`scene`.

    Attributes:
        layers: dict of float32 (height, width) arrays, keyed as scene.exr's layers: "mask" (1 shaded,
            0 masked), and per light "<light>.reference", "<light>.std_error", "<light>.weight"
            (max(N.L, 0) x intensity), "<light>.<comparator>" and "<light>.<comparator>_error" (weighted).
        report: dict, report.json's content (counts, tolerance, per light and comparator the error
            statistics, provenance).
        width, height: the image size; lights, comparators: their names in order.
    """

    def __init__(self, native: "_core.SceneResult") -> None:
        self._native = native
        self.width: int = native.width
        self.height: int = native.height
        self.lights: List[str] = list(native.lights)
        self.comparators: List[str] = list(native.comparators)
        self.layers: Dict[str, np.ndarray] = dict(native.layers())
        for a in self.layers.values():
            a.setflags(write=False)
        self.report: dict = json.loads(native.report_json)

    def save(self, out: PathArg) -> None:
        """Writes the command's outputs into the folder `out` (created if missing): scene.exr,
        report.json, report.md and the PNG images, all or none."""
        self._native.save(os.fspath(out))


def scene(
    path: PathArg,
    *,
    tolerance: Optional[float] = None,
    method: Optional[str] = None,
    luts: Sequence[PathArg] = (),
    skip: bool = True,
    seed_luts: bool = True,
    strict_domain: bool = False,
    backend: str = "opencl",
    device: str = "default",
    fast_math: bool = False,
    progress: ProgressArg = None,
) -> SceneRun:
    """The term of every pixel of a scene against the approximations: ``microshadow scene PATH`` without
    its files (call ``.save(out)``); docs/scenes.md has the description's format.

    Args:
        path: the scene description (TOML).
        tolerance: the per-pixel error bound of the reference, 1e-12 to 0.5 (None: the description's
            sampling.tolerance, else the method's default).
        method: "exact" or "sampled" (None: the description's sampling.method, default exact).
        luts: more LUT files to compare (``--lut``).
        skip: False sends every unmasked pixel's own query to the integrand (``--no-skip``).
        seed_luts: False leaves out the seed's 3D and 2D LUTs (``--no-seed-luts``).
        strict_domain: refuse a comparator looked up outside its domain at a lit pixel.
        backend, device, fast_math: as :func:`evaluate`.
        progress: True prints progress on stderr; a callable gets (done, total) of each phase.
    """
    if method is not None:
        _choice("method", method, _METHODS)
    _choice("backend", backend, _BACKENDS)
    if tolerance is not None:
        t = float(tolerance)
        if not (np.isfinite(t) and 1e-12 <= t <= 0.5):
            raise ValueError(f"tolerance = {_shown(tolerance)!r}: 1e-12 to 0.5 (None: the description's)")
    if isinstance(luts, (str, os.PathLike)):
        raise ValueError("luts: a list of LUT files (give [path] for one)")
    lut_paths = [os.fspath(p) for p in luts]
    for i, p in enumerate(lut_paths):
        if not os.path.isfile(p):
            raise FileNotFoundError(f"luts[{i}] = {p!r}: no such file")
    description = os.fspath(path)
    if not os.path.isfile(description):
        raise FileNotFoundError(f"{description}: no such file")
    options = _options.build(
        "SceneOptions", tolerance=0.0 if tolerance is None else float(tolerance), method=method, luts=lut_paths,
        skip=bool(skip), seed_luts=bool(seed_luts), strict_domain=bool(strict_domain), fast_math=bool(fast_math),
        **_options.where(backend, device))
    native = _core.scene(description, options, _progress("scene", progress))
    return SceneRun(native)
