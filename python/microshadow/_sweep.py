"""sweep(): a parameter study (``microshadow sweep``) as a dict of arrays."""

from __future__ import annotations

import os
from typing import Dict, Optional

import numpy as np

from . import _microshadow as _core
from . import _options
from ._checks import (_BACKENDS, _choice, _count, _FORMS, _MAX_REPLICATES, _MAX_SAMPLES, _METHODS, PathArg,
                     _progress, ProgressArg, _SEQUENCES, _shown, _WEIGHTINGS)


def sweep(
    spec: Optional[PathArg] = None,
    *,
    toml: Optional[str] = None,
    out: Optional[PathArg] = None,
    method: Optional[str] = None,
    tolerance: Optional[float] = None,
    samples: Optional[int] = None,
    replicates: Optional[int] = None,
    seed: Optional[int] = None,
    sequence: Optional[str] = None,
    form: Optional[str] = None,
    ao_weighting: Optional[str] = None,
    backend: str = "opencl",
    device: str = "default",
    fast_math: bool = False,
    exact_float: bool = False,
    progress: ProgressArg = None,
) -> Dict[str, np.ndarray]:
    """Runs a parameter sweep: ``microshadow sweep SPEC.toml`` (docs/sweep-spec.md has the format).

    Args:
        spec: the spec file, or None with `toml`: the spec as TOML text (its comparator files relative
            to the current directory).
        out: the output directory (chunks, sweep.csv, summary.md; resumable as the command's); None: a
            temporary one, removed afterwards.
        method, tolerance, samples, replicates, seed, sequence: override the spec's [sampling] values
            (default: the spec's, else the exact method at 1e-10). form, ao_weighting: for specs that do not
            sweep them. backend, device, fast_math, exact_float: as :func:`evaluate`.
        progress: True prints progress on stderr; a callable gets (chunks done, chunks).

    Returns:
        sweep.csv as a dict of arrays, one per column in order: "point", "form", "ao_weighting" (text),
        "roughness", "alpha_x", "alpha_y", "n_dot_v", "phi_i", "phi_o", "delta_phi", "n_dot_l",
        "visibility", "term", "std_error", then one per comparator (a :class:`SweepTable`, a dict whose
        ``summary`` attribute holds summary.md: each comparator's error against the term).
    """
    if (spec is None) == (toml is None):
        raise ValueError("give spec (a file) or toml (the spec's text), one of them")
    if method is not None:
        _choice("method", method, _METHODS)
    if sequence is not None:
        _choice("sequence", sequence, _SEQUENCES)
    if form is not None:
        _choice("form", form, _FORMS)
    if ao_weighting is not None:
        _choice("ao_weighting", ao_weighting, _WEIGHTINGS)
    _choice("backend", backend, _BACKENDS)
    if samples is not None:
        _count("samples", samples, 16, _MAX_SAMPLES)
    if replicates is not None:
        _count("replicates", replicates, 2, _MAX_REPLICATES)
    if seed is not None:
        _count("seed", seed, 0, 2**64 - 1)
    if tolerance is not None and not (np.isfinite(float(tolerance)) and float(tolerance) > 0):
        raise ValueError(f"tolerance = {_shown(tolerance)!r}: a finite number > 0")
    spec_path = "" if spec is None else os.fspath(spec)
    if spec_path and not os.path.isfile(spec_path):
        raise FileNotFoundError(f"{spec_path}: no such file")
    options = _options.build(
        "SweepOptions", out="" if out is None else os.fspath(out), method=method,
        tolerance=None if tolerance is None else float(tolerance), samples=None if samples is None else int(samples),
        replicates=None if replicates is None else int(replicates), seed=None if seed is None else int(seed),
        sequence=sequence, form=form, ao_weighting=ao_weighting, fast_math=bool(fast_math),
        exact_float=bool(exact_float), **_options.where(backend, device))
    table, summary = _core.sweep(spec_path, toml or "", os.getcwd(), options, _progress("sweep", progress))
    return SweepTable(table, summary)


class SweepTable(dict):
    """sweep.csv as a dict of numpy arrays (column name -> array), plus ``summary``: the markdown table of
    each comparator's error against the term (summary.md)."""

    def __init__(self, columns: Dict[str, np.ndarray], summary: str) -> None:
        super().__init__(columns)
        self.summary = summary
