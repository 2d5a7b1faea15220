"""microshadow: the generic VNDF-based micro-shadowing term of rough GGX surfaces, from Python.

The term is the fraction of visible microfacets of a rough, anisotropic GGX microsurface that are not
micro-shadowed, seen through the visibility cone of a micro-occlusion (AO) map ("Improving Direct
Lighting Material Occlusion", part 2). This package calls the same C++ engine as the ``microshadow``
command: every function takes numpy arrays (broadcast against each other) and keyword options with the
command's names and defaults, and returns numpy arrays.

- :func:`evaluate` / :func:`evaluate_iso`: the term at queries (``microshadow eval``);
- :func:`bake`: a LUT (``microshadow bake``), with ``.data``, ``.metadata``, ``.save(path)``;
- :func:`repr_bake`: a representation that keeps the relative azimuth (``microshadow repr bake``);
- :func:`open`: any LUT or representation file, with ``.lookup(...)`` as a renderer samples it;
- :func:`analytic`: part 1's analytic terms by name (``eval --compare NAME``);
- :func:`sweep`: a parameter study (``microshadow sweep``) as a dict of arrays;
- :func:`ibl_dfg`, :func:`ibl_prefilter`, :func:`ibl_irradiance`, :func:`ibl_sh`: the image-based
  lighting integrals (``microshadow ibl dfg | prefilter | irradiance | sh``);
- :func:`area_eval`: the term over sphere and rectangle lights (``microshadow area eval``);
- :func:`scene`: every pixel of a scene against the approximations (``microshadow scene``);
- :func:`design`: every candidate representation against a reference set (``microshadow design``).

Bad arguments raise ValueError naming the argument and the index of the first bad element. Long calls
release the GIL, report progress when asked (``progress=True`` or a callable ``(done, total)``) and stop
on Ctrl-C with KeyboardInterrupt, leaving nothing half written. Documentation: docs/python.md.
"""

from __future__ import annotations

import json
import os
import sys
import time
import warnings
from typing import Callable, Dict, List, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np

from . import _microshadow as _core

__all__ = [
    "__version__",
    "evaluate",
    "evaluate_iso",
    "lookup_inputs",
    "bake",
    "open",
    "Lut",
    "Representation",
    "repr_bake",
    "REPR_PRESETS",
    "analytic",
    "ANALYTIC_TERMS",
    "sweep",
    "SweepTable",
    "ibl_dfg",
    "DfgLut",
    "ibl_prefilter",
    "PrefilteredEnvironment",
    "ibl_irradiance",
    "IrradianceMap",
    "ibl_sh",
    "ShIrradiance",
    "area_eval",
    "AreaResult",
    "scene",
    "SceneRun",
    "design",
    "DesignTable",
]

__version__: str = _core.version()

ArrayLike = Union[float, Sequence[float], np.ndarray]
ProgressArg = Union[bool, Callable[[int, int], object], None]
PathArg = Union[str, "os.PathLike[str]"]

#: Part 1's analytic terms, by the names ``eval --compare`` and sweep specs use.
ANALYTIC_TERMS: Tuple[str, ...] = tuple(_core.analytic_term_names())


# --- argument checks ----------------------------------------------------------------------------------


def _index(flat_index: int, shape: Tuple[int, ...]) -> str:
    """The index of element `flat_index` of an array of `shape`, as the user would write it."""
    if len(shape) == 0:
        return ""
    return "[" + ", ".join(str(i) for i in np.unravel_index(flat_index, shape)) + "]"


def _shown(value):
    """A numpy scalar as the Python number it holds, so that a message shows 'nan', not 'np.float64(nan)'."""
    return value.item() if isinstance(value, np.generic) else value


def _array(name: str, value: ArrayLike) -> np.ndarray:
    """`value` as a float64 array; ValueError naming the argument when it holds no real numbers."""
    try:
        a = np.asarray(value)
        # Converting complex numbers to float64 would drop their imaginary parts with only a warning.
        if np.iscomplexobj(a):
            raise ValueError("complex numbers: give real ones")
        a = a.astype(np.float64, copy=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: not an array of numbers ({e})") from None
    return a


# Bytes a query needs while it is evaluated: its 9 input and 2 output float64 columns, the rows handed to
# the library and the library's own copies of both, with room to spare.
_BYTES_PER_QUERY = 512


def _check_memory(what: str, count: int) -> None:
    """MemoryError at once, before any work, for a call whose queries cannot fit in this machine's memory."""
    try:
        physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return  # no figure on this platform: numpy's own MemoryError is the answer
    needed = count * _BYTES_PER_QUERY
    if needed > physical:
        raise MemoryError(f"{count} {what} need about {needed / 2**30:.0f} GiB, more than this machine's "
                          f"{physical / 2**30:.0f} GiB of memory: split the call")


def _check_finite(name: str, a: np.ndarray) -> None:
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{name}{_index(i, a.shape)} = {float(a.flat[i])!r}: not a finite number")


def _check_range(name: str, a: np.ndarray, lo: float, hi: float, lo_open: bool = False, hi_open: bool = False) -> None:
    """Finite and within [lo, hi] (or open at an end); the message names the first offender."""
    _check_finite(name, a)
    below = a <= lo if lo_open else a < lo
    above = a >= hi if hi_open else a > hi
    bad = below | above
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        interval = ("(" if lo_open else "[") + f"{lo:g}, {hi:g}" + (")" if hi_open else "]")
        raise ValueError(f"{name}{_index(i, a.shape)} = {float(a.flat[i])!r}: outside {interval}")


def _scalar_or_vector(name: str, value: ArrayLike) -> np.ndarray:
    a = _array(name, value)
    if a.ndim > 1:
        raise ValueError(f"{name}: shape {a.shape}; expected a number or a 1-D array (N,)")
    return a


def _directions(name: str, value: ArrayLike) -> np.ndarray:
    """(3,) or (N, 3) finite, non-zero directions."""
    a = _array(name, value)
    if a.ndim not in (1, 2) or a.shape[-1] != 3:
        raise ValueError(f"{name}: shape {a.shape}; expected (3,) or (N, 3) (x, y, z in the tangent frame)")
    _check_finite(name, a)
    rows = a.reshape(-1, 3)
    zero = ~(np.einsum("ij,ij->i", rows, rows) > 0)
    if zero.any():
        i = int(np.flatnonzero(zero)[0])
        where = f"[{i}]" if a.ndim == 2 else ""
        raise ValueError(f"{name}{where} = {tuple(float(x) for x in rows[i])}: a zero-length direction")
    return a


def _broadcast(named: Dict[str, np.ndarray]) -> int:
    """The common length N of 1-D arguments (scalars broadcast); ValueError naming two that differ."""
    n = 1
    first = None
    for name, a in named.items():
        length = a.shape[0] if a.ndim >= 1 else 1
        if a.ndim >= 1 and length != 1:
            if first is not None and length != n:
                raise ValueError(
                    f"{first[0]} has {first[1]} queries and {name} has {length}: they do not broadcast "
                    "(give arrays of one length, or numbers)"
                )
            if first is None:
                first = (name, length)
                n = length
    return n


def _column(a: np.ndarray, n: int) -> np.ndarray:
    return np.broadcast_to(a.reshape(-1) if a.ndim else a, (n,))


def _rows(a: np.ndarray, n: int) -> np.ndarray:
    return np.broadcast_to(a.reshape(-1, 3), (n, 3))


def _choice(name: str, value: str, allowed: Sequence[str]) -> str:
    if value not in allowed:
        raise ValueError(f"{name} = {_shown(value)!r}: one of {', '.join(allowed)}")
    return value


def _count(name: str, value: int, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= int(value) <= hi:
        raise ValueError(f"{name} = {_shown(value)!r}: an integer from {lo} to {hi}")
    return int(value)


class _StderrProgress:
    """progress=True: one line on stderr, redrawn at most ten times a second, like the CLI's."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.last = 0.0

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if done < total and now - self.last < 0.1:
            return
        self.last = now
        percent = 100.0 * done / total if total else 100.0
        sys.stderr.write(f"\r{self.what}: {done}/{total} ({percent:.0f} %)")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def _progress(what: str, progress: ProgressArg):
    if progress is True:
        return _StderrProgress(what)
    if progress is None or progress is False:
        return None
    if not callable(progress):
        raise ValueError(f"progress = {progress!r}: True, False, None or a callable (done, total)")
    return progress


_METHODS = ("exact", "sampled")
_SEQUENCES = ("sobol", "random")
_FORMS = ("height-correlated", "uncorrelated")
_WEIGHTINGS = ("cosine", "uniform")
_BACKENDS = ("opencl", "oracle")
_MAX_REPLICATES = 1024
_MAX_SAMPLES = (1 << 28) * _MAX_REPLICATES


def _sampling(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device):
    _choice("method", method, _METHODS)
    _choice("sequence", sequence, _SEQUENCES)
    _choice("form", form, _FORMS)
    _choice("ao_weighting", ao_weighting, _WEIGHTINGS)
    _choice("backend", backend, _BACKENDS)
    if not isinstance(device, str):
        raise ValueError(f"device = {device!r}: 'default', 'all', an index or part of a name, as a string")
    _count("samples", samples, 16, _MAX_SAMPLES)
    _count("replicates", replicates, 2, _MAX_REPLICATES)
    _count("seed", seed, 0, 2**64 - 1)
    t = float(tolerance)
    if not (np.isfinite(t) and t >= 0):
        raise ValueError(f"tolerance = {_shown(tolerance)!r}: a finite number >= 0 (0: the method's default)")
    return t


# --- evaluation -----------------------------------------------------------------------------------------


def _query_rows(visibility, alpha_x, alpha_y, wi, wo) -> np.ndarray:
    """The (N, 9) rows of checked, broadcast queries (the columns of ``microshadow eval``'s CSV)."""
    v = _scalar_or_vector("visibility", visibility)
    ax = _scalar_or_vector("alpha_x", alpha_x)
    ay = _scalar_or_vector("alpha_y", alpha_y)
    # The number of queries follows from the shapes alone: a call too large for memory fails here, at once,
    # not after seconds of checks and copies.
    shapes = {"visibility": v, "alpha_x": ax, "alpha_y": ay}
    for name, value in (("wi", wi), ("wo", wo)):
        d = _array(name, value)
        shapes[name] = d.reshape(1, -1) if d.ndim <= 1 else d
    _check_memory("queries", _broadcast(shapes))
    _check_range("visibility", v, 0.0, 1.0)
    for name, a in (("alpha_x", ax), ("alpha_y", ay)):
        _check_finite(name, a)
        bad = ~(a > 0)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{name}{_index(i, a.shape)} = {float(a.flat[i])!r}: must be > 0")
    wi_a = _directions("wi", wi)
    wo_a = _directions("wo", wo)
    wi_rows = wi_a.reshape(-1, 3)
    below = ~(wi_rows[:, 2] / np.linalg.norm(wi_rows, axis=1) > 0)
    if below.any():
        i = int(np.flatnonzero(below)[0])
        where = f"[{i}]" if wi_a.ndim == 2 else ""
        raise ValueError(f"wi{where} = {tuple(float(x) for x in wi_rows[i])}: below the horizon (wi_z must be > 0)")
    n = _broadcast(
        {
            "visibility": v,
            "alpha_x": ax,
            "alpha_y": ay,
            "wi": wi_a if wi_a.ndim == 2 else wi_a[None, :],
            "wo": wo_a if wo_a.ndim == 2 else wo_a[None, :],
        }
    )
    rows = np.empty((n, 9))
    rows[:, 0] = _column(v, n)
    rows[:, 1] = _column(ax, n)
    rows[:, 2] = _column(ay, n)
    rows[:, 3:6] = _rows(wi_a, n)
    rows[:, 6:9] = _rows(wo_a, n)
    return rows


def evaluate(
    visibility: ArrayLike,
    alpha_x: ArrayLike,
    alpha_y: ArrayLike,
    wi: ArrayLike,
    wo: ArrayLike,
    *,
    method: str = "exact",
    tolerance: float = 0.0,
    samples: int = 65536,
    seed: int = 0,
    replicates: int = 8,
    sequence: str = "sobol",
    form: str = "height-correlated",
    ao_weighting: str = "cosine",
    backend: str = "opencl",
    device: str = "default",
    fast_math: bool = False,
    exact_float: bool = False,
    progress: ProgressArg = None,
) -> Tuple[np.ndarray, np.ndarray]:
    """The micro-shadowing term at each query: ``microshadow eval`` on the same columns.

    Args:
        visibility: AO visibility in [0, 1], a number or (N,).
        alpha_x, alpha_y: GGX roughness along the tangent and bitangent (> 0), numbers or (N,).
        wi: the view V, the direction the VNDF is sampled from, (3,) or (N, 3) in the tangent frame
            (normal = +z, normalised here); above the horizon (wi_z > 0).
        wo: the light L, (3,) or (N, 3); below the horizon it is legal and gives 0.
        method: "exact" (the deterministic boundary-integral evaluator; its error estimate is the
            std_error) or "sampled" (VNDF sampling; the replicates' standard error).
        tolerance: exact: the estimated error asked of each value (0: 1e-10; 1e-13 to 0.1). sampled: the
            standard error asked, reached by quadrupling the samples of the queries above it (0: one pass).
        samples, seed, replicates, sequence: the sampled method's point sets (samples rounded up to
            replicates x a power of two).
        form: Smith form of the masking-shadowing weight, "height-correlated" or "uncorrelated".
        ao_weighting: how the AO map was baked: "cosine" (cone cos = sqrt(1 - v)) or "uniform" (1 - v).
        backend, device: "opencl" on `device` ("default": PoCL's CPU device, "all", an index or part of
            a name, as ``microshadow devices`` lists them) or "oracle" (scalar double on CPU threads).
        fast_math: kernels built with -cl-fast-relaxed-math. exact_float: the exact method's float kernel
            even on fp64 devices.
        progress: True prints progress on stderr; a callable gets (done, total) queries.

    Returns:
        (term, std_error): two float64 arrays of shape (N,). Visibility 1 and the provable zero region
        are exact (std_error 0). The values are the bits ``microshadow eval`` writes for the same inputs.
    """
    tolerance = _sampling(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device)
    if method == "exact" and tolerance > 0 and not (1e-13 <= tolerance <= 0.1):
        raise ValueError(f"tolerance = {_shown(tolerance)!r}: the exact method takes 1e-13 to 0.1 (0: 1e-10)")
    rows = _query_rows(visibility, alpha_x, alpha_y, wi, wo)
    return _evaluate_rows(rows, method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend,
                          device, fast_math, exact_float, progress)


def _evaluate_rows(rows, method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device,
                   fast_math, exact_float, progress):
    if rows.shape[0] == 0:
        return np.empty(0), np.empty(0)
    out = _core.evaluate_rows(rows, method, tolerance, int(samples), int(replicates), int(seed), sequence, form,
                              ao_weighting, backend, device, bool(fast_math), bool(exact_float),
                              _progress("evaluate", progress))
    return np.ascontiguousarray(out[:, 0]), np.ascontiguousarray(out[:, 1])


def evaluate_iso(
    visibility: ArrayLike,
    n_dot_l: ArrayLike,
    n_dot_v: ArrayLike,
    *,
    roughness: ArrayLike,
    relative_azimuth: ArrayLike = 0.0,
    **options,
) -> Tuple[np.ndarray, np.ndarray]:
    """The term of an isotropic surface in the LUTs' parameters: :func:`evaluate` on its query.

    The parameters come in the order of every isotropic call (:meth:`Lut.lookup`, :func:`analytic`, the
    C++ isotropic_query): visibility, n_dot_l, n_dot_v, then roughness and relative_azimuth as keywords
    (so that an alpha is never passed for the roughness by position).

    Args:
        visibility: in [0, 1].
        n_dot_l: cosine of the light in [-1, 1] (below 0 the term is 0).
        n_dot_v: cosine of the view in (0, 1]; wi = (sqrt(1 - n_dot_v^2), 0, n_dot_v).
        roughness: perceptual roughness in (0, 1] (alpha_x = alpha_y = roughness^2).
        relative_azimuth: the light's azimuth from the view's, in degrees (0: on the view's side,
            180: opposite); wo = (s cos phi, s sin phi, n_dot_l) with s = sqrt(1 - n_dot_l^2): the
            directions of a sweep point with phi_i = 0 and delta_phi = relative_azimuth.
        **options: :func:`evaluate`'s keyword options (method, tolerance, samples, ...).

    All arguments broadcast against each other (any shapes, as :meth:`Lut.lookup`). Returns (term,
    std_error), float64 of the broadcast shape.
    """
    for key in options:
        if key not in _EVALUATE_OPTIONS:
            raise TypeError(f"evaluate_iso() got an unexpected keyword argument {key!r}")
    # Each argument checked as given (the message indexes it in its own shape), then broadcast.
    _check_range("visibility", _array("visibility", visibility), 0.0, 1.0)
    _check_range("n_dot_l", _array("n_dot_l", n_dot_l), -1.0, 1.0)
    _check_range("n_dot_v", _array("n_dot_v", n_dot_v), 0.0, 1.0, lo_open=True)
    _check_range("roughness", _array("roughness", roughness), 0.0, 1.0, lo_open=True)
    _check_finite("relative_azimuth", _array("relative_azimuth", relative_azimuth))
    rows, shape = _lookup_rows("evaluate_iso", visibility, n_dot_l, n_dot_v, roughness, relative_azimuth)
    queries = _core.isotropic_rows(np.ascontiguousarray(rows)) if rows.shape[0] else np.empty((0, 9))
    merged = dict(_EVALUATE_DEFAULTS)
    merged.update(options)
    tolerance = _sampling(merged["method"], merged["tolerance"], merged["samples"], merged["replicates"], merged["seed"],
                          merged["sequence"], merged["form"], merged["ao_weighting"], merged["backend"], merged["device"])
    term, error = _evaluate_rows(queries, merged["method"], tolerance, merged["samples"], merged["replicates"],
                                 merged["seed"], merged["sequence"], merged["form"], merged["ao_weighting"],
                                 merged["backend"], merged["device"], merged["fast_math"], merged["exact_float"],
                                 merged["progress"])
    return term.reshape(shape), error.reshape(shape)


def lookup_inputs(
    visibility: ArrayLike, alpha_x: ArrayLike, alpha_y: ArrayLike, wi: ArrayLike, wo: ArrayLike
) -> Dict[str, np.ndarray]:
    """What a LUT lookup and the analytic terms read of queries, as ``eval --compare`` and the sweeps
    compute it: "visibility", "n_dot_l" (wo_z) and "n_dot_v" (wi_z) of the normalised directions,
    "roughness" = (alpha_x alpha_y)^(1/4) and "relative_azimuth" in degrees in [0, 180]. The arguments
    are :func:`evaluate`'s; returns a dict of (N,) arrays, ready for ``lut.lookup(**inputs)``."""
    rows = _query_rows(visibility, alpha_x, alpha_y, wi, wo)
    out = _core.lookup_input_rows(rows) if rows.shape[0] else np.empty((0, 5))
    names = ("visibility", "n_dot_l", "n_dot_v", "roughness", "relative_azimuth")
    return {name: np.ascontiguousarray(out[:, k]) for k, name in enumerate(names)}


_EVALUATE_DEFAULTS = {
    "method": "exact",
    "tolerance": 0.0,
    "samples": 65536,
    "seed": 0,
    "replicates": 8,
    "sequence": "sobol",
    "form": "height-correlated",
    "ao_weighting": "cosine",
    "backend": "opencl",
    "device": "default",
    "fast_math": False,
    "exact_float": False,
    "progress": None,
}
_EVALUATE_OPTIONS = frozenset(_EVALUATE_DEFAULTS)


# --- LUTs and representations ---------------------------------------------------------------------------


def _lookup_rows(name_prefix: str, visibility, n_dot_l, n_dot_v, roughness, relative_azimuth) -> Tuple[np.ndarray, Tuple[int, ...]]:
    """The (N, 5) rows of a lookup and the broadcast shape of its arguments (any shapes that broadcast)."""
    arrays = {
        "visibility": _array("visibility", visibility),
        "n_dot_l": _array("n_dot_l", n_dot_l),
        "n_dot_v": _array("n_dot_v", n_dot_v),
        "roughness": _array("roughness", roughness),
        "relative_azimuth": _array("relative_azimuth", 0.0 if relative_azimuth is None else relative_azimuth),
    }
    for name, a in arrays.items():
        # NaN would make every blend weight NaN; the renderer's clamps cover the rest.
        if np.isnan(a).any():
            i = int(np.flatnonzero(np.isnan(a))[0])
            raise ValueError(f"{name}{_index(i, a.shape)} = nan: not a number")
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in arrays.items())
        raise ValueError(f"{name_prefix}: the arguments do not broadcast ({shapes})") from None
    rows = np.empty(shape + (5,))
    for k, a in enumerate(arrays.values()):
        rows[..., k] = a
    return rows.reshape(-1, 5), shape


class Lut:
    """A baked or opened LUT: texels over (visibility, NdotL, NdotV) per roughness channel.

    Attributes:
        data: float32 array (n_dot_v, n_dot_l, visibility, channels): the stored texels (for a 2D LUT
            n_dot_v has one entry, standing for NdotV = 1).
        metadata: dict, how it was made (the file's "microshadow" record: layout, axes, roughness,
            azimuth policy, samples, error budget, ...).
        roughness: the roughness of each channel.
        visibility, n_dot_l, n_dot_v: the parameter of each texel along each axis.
        max_total_error: the bound on |texel - term| recorded (sampling + azimuth quadrature +
            quantisation).
    """

    def __init__(self, native: "_core.Lut", path: Optional[str] = None) -> None:
        self._native = native
        self.path = path
        self.data: np.ndarray = native.texels()
        self.data.setflags(write=False)
        self.metadata: dict = json.loads(native.metadata_json)
        self.roughness: np.ndarray = np.array(native.roughness)
        self.visibility: np.ndarray = np.array(native.axis_values("visibility"))
        self.n_dot_l: np.ndarray = np.array(native.axis_values("n_dot_l"))
        self.n_dot_v: np.ndarray = np.array(native.axis_values("n_dot_v"))
        self.max_total_error: float = native.max_total_error

    kind = "lut"
    keeps_azimuth = False

    def lookup(self, visibility: ArrayLike, n_dot_l: ArrayLike, n_dot_v: ArrayLike, *, roughness: ArrayLike,
               relative_azimuth: Optional[ArrayLike] = None) -> np.ndarray:
        """The renderer's lookup: linear filtering, clamp to edge, linear blend between roughness channels.

        The arguments broadcast against each other (any shapes); roughness (keyword only, so that an
        alpha is never passed for it by position) is the perceptual roughness, alpha = roughness^2 (an
        anisotropic surface uses (alpha_x alpha_y)^(1/4)). A LUT stores the azimuth's mean, so
        relative_azimuth is accepted and ignored. Returns float64 of the broadcast shape.
        """
        rows, shape = _lookup_rows("Lut.lookup", visibility, n_dot_l, n_dot_v, roughness, relative_azimuth)
        return self._native.lookup_rows(np.ascontiguousarray(rows)).reshape(shape)

    def save(self, path: PathArg, encoding: Optional[str] = None) -> None:
        """Writes the LUT, the format from the extension as ``microshadow bake --out``: .exr, .ktx2, .dds
        (+ .dds.json), .h/.hpp, .inc or .png; encoding "float32", "float16", "unorm16" or "unorm8" (None:
        the format's default). The file appears complete or not at all."""
        if encoding is not None:
            _choice("encoding", encoding, ("float32", "float16", "unorm16", "unorm8"))
        self._native.save(os.fspath(path), encoding or "")

    def __repr__(self) -> str:
        n_v, n_l, n_nv = self.data.shape[2], self.data.shape[1], self.data.shape[0]
        return f"<microshadow.Lut {n_v} x {n_l} x {n_nv}, roughness {list(self.roughness)}>"


class Representation:
    """A representation file of ``microshadow repr bake`` (azimuth-axis or azimuth-harmonics): a texture
    that keeps the relative azimuth between view and light.

    Attributes:
        kind: "azimuth-axis" or "azimuth-harmonics". metadata: dict, how it was made.
    """

    keeps_azimuth = True

    def __init__(self, native: "_core.LookupFile", path: Optional[str] = None) -> None:
        self._native = native
        self.path = path
        self.kind: str = native.kind
        self.metadata: dict = json.loads(native.metadata_json)
        #: float32 (depth, height, width, 4): the RGBA texture as a renderer uploads it (its layout: docs/representations.md).
        self.data: np.ndarray = native.texture()
        self.data.setflags(write=False)

    def save(self, path: PathArg, half: bool = False) -> None:
        """Writes it as ``repr bake --out``: .exr (what eval --compare and sweeps open), .ktx2 or .dds
        (+ .dds.json); half: 16-bit channels, as an engine uploads them."""
        p = os.fspath(path)
        if os.path.splitext(p)[1].lower() not in (".exr", ".ktx2", ".dds"):  # any case, as the C++ job takes it
            raise ValueError(f"path = {p!r}: a representation is written as .exr, .ktx2 or .dds")
        self._native.save(p, bool(half))

    def lookup(self, visibility: ArrayLike, n_dot_l: ArrayLike, n_dot_v: ArrayLike, *, roughness: ArrayLike,
               relative_azimuth: Optional[ArrayLike] = None) -> np.ndarray:
        """The renderer's lookup (the generated shader's arithmetic, in double) at the relative azimuth in
        degrees (0: light on the view's side, 180: opposite). The arguments broadcast; roughness (the
        perceptual roughness) and relative_azimuth are keywords, relative_azimuth required (this file
        keeps the azimuth)."""
        if relative_azimuth is None:
            raise ValueError(f"relative_azimuth: required by a {self.kind} representation (it keeps the azimuth)")
        rows, shape = _lookup_rows("Representation.lookup", visibility, n_dot_l, n_dot_v, roughness, relative_azimuth)
        return self._native.lookup_rows(np.ascontiguousarray(rows)).reshape(shape)

    def __repr__(self) -> str:
        return f"<microshadow.Representation {self.kind} {self.path!r}>"


def open(path: PathArg) -> Union[Lut, Representation]:  # noqa: A001 - the module's open, as in PIL / h5py
    """Opens any LUT file the bake writes (OpenEXR, KTX2, DDS with its .dds.json, C header, .inc, PNG) or
    a representation file of ``repr bake``, told apart by its metadata. RuntimeError naming the file when
    it cannot be read."""
    p = os.fspath(path)
    if not os.path.exists(p):
        raise FileNotFoundError(f"{p}: no such file")
    native = _core.open_file(p)
    if native.kind == "lut":
        return Lut(native.lut(), p)
    return Representation(native, p)


_LAYOUTS = ("seed-3d", "seed-2d", "custom")


def bake(
    *,
    layout: str = "seed-3d",
    size: int = 32,
    visibility_count: int = 0,
    n_dot_l_count: int = 0,
    n_dot_v_count: int = 0,
    roughness: Optional[Sequence[float]] = None,
    visibility_range: Optional[Tuple[float, float]] = None,
    n_dot_l_range: Optional[Tuple[float, float]] = None,
    n_dot_v_range: Optional[Tuple[float, float]] = None,
    texel: str = "centres",
    azimuth: Union[str, float] = "mean",
    method: str = "sampled",
    tolerance: float = 0.0,
    samples: int = 0,
    max_batches: int = 64,
    seed: int = 0,
    replicates: int = 8,
    sequence: str = "sobol",
    form: str = "height-correlated",
    ao_weighting: str = "cosine",
    backend: str = "opencl",
    device: str = "default",
    fast_math: bool = False,
    exact_float: bool = False,
    progress: ProgressArg = None,
    size_visibility: Optional[int] = None,
    size_n_dot_l: Optional[int] = None,
    size_n_dot_v: Optional[int] = None,
) -> Lut:
    """Bakes a LUT: ``microshadow bake`` without its file outputs (call ``.save(path)``).

    Args:
        layout: "seed-3d" (visibility x NdotL x NdotV, roughness 0.1, 0.4, 0.7, 1 in RGBA), "seed-2d" (the
            NdotV = 1 slice) or "custom" (roughness and ranges from here).
        size: texels on every axis; visibility_count, n_dot_l_count, n_dot_v_count: one axis's own (0:
            size), the names :func:`repr_bake` and the C++ BakeOptions use (size_visibility, size_n_dot_l,
            size_n_dot_v: the same, deprecated).
        roughness: custom layout: 1 to 4 values in (0, 1]. *_range: custom layout: (min, max) of an axis.
        texel: "centres" ((i + 0.5) / n) or "endpoints" (i / (n - 1)).
        azimuth: "mean" (the mean over [0, 180] degrees) or a fixed relative azimuth in degrees.
        method: "sampled" (the command's default) or "exact" (every texel to `tolerance`, default 1e-6).
        tolerance: sampled: batches until every texel's standard error is at most this (up to
            max_batches); exact: the error asked of each texel. samples: per batch and slice (0: the
            default batch); seed, replicates, sequence, form, ao_weighting, backend, device, fast_math,
            exact_float: as :func:`evaluate`.
        progress: True prints progress on stderr; a callable gets (slices done, slices).
    """
    _choice("layout", layout, _LAYOUTS)
    _choice("texel", texel, ("centres", "centers", "endpoints"))
    counts = {"visibility_count": visibility_count, "n_dot_l_count": n_dot_l_count, "n_dot_v_count": n_dot_v_count}
    for old, new, value in (("size_visibility", "visibility_count", size_visibility),
                            ("size_n_dot_l", "n_dot_l_count", size_n_dot_l), ("size_n_dot_v", "n_dot_v_count", size_n_dot_v)):
        if value is None:
            continue
        warnings.warn(f"bake({old}=) is deprecated: use {new}=", DeprecationWarning, stacklevel=2)
        if counts[new]:
            raise TypeError(f"bake() got both {old}= and {new}= (the same count; give {new}= only)")
        counts[new] = value
    _count("size", size, 1, 4096)
    for name, value in counts.items():
        _count(name, value, 0, 4096)
    _count("max_batches", max_batches, 1, 4096)
    if samples != 0:
        _count("samples", samples, 16, _MAX_SAMPLES)
    tolerance = _sampling(method, tolerance, 65536, replicates, seed, sequence, form, ao_weighting, backend, device)
    if tolerance and not 1e-7 <= tolerance <= 1.0:
        raise ValueError(f"tolerance = {_shown(tolerance)!r}: 1e-7 to 1 (0: one batch, or the exact method's 1e-6)")
    if samples and tolerance:
        raise ValueError("give samples or tolerance, not both (tolerance adds batches of the default size)")
    if method == "exact" and samples:
        raise ValueError("samples applies to method='sampled' only (the exact method integrates every texel to tolerance)")
    rough: List[float] = []
    if roughness is not None:
        if layout != "custom":
            raise ValueError("roughness needs layout='custom' (the seeds fix theirs)")
        r = _scalar_or_vector("roughness", roughness).reshape(-1)
        if not 1 <= r.size <= 4:
            raise ValueError(f"roughness: {r.size} values; 1 to 4 (channels R, G, B, A)")
        _check_range("roughness", r, 0.0, 1.0, lo_open=True)
        rough = [float(x) for x in r]
    ranges = {}
    for name, value in (("visibility_range", visibility_range), ("n_dot_l_range", n_dot_l_range),
                        ("n_dot_v_range", n_dot_v_range)):
        if value is None:
            ranges[name] = []
            continue
        if layout != "custom":
            raise ValueError(f"{name} needs layout='custom'")
        a = _array(name, value)
        if a.shape != (2,):
            raise ValueError(f"{name}: shape {a.shape}; expected (min, max)")
        _check_range(name, a, 0.0, 1.0)
        ranges[name] = [float(a[0]), float(a[1])]
    if isinstance(azimuth, str):
        if azimuth != "mean":
            raise ValueError(f"azimuth = {_shown(azimuth)!r}: 'mean' or degrees in [0, 180]")
        azimuth_text = "mean"
    else:
        a = float(azimuth)
        if not (np.isfinite(a) and 0 <= a <= 180):
            raise ValueError(f"azimuth = {_shown(azimuth)!r}: 'mean' or degrees in [0, 180]")
        azimuth_text = repr(a)
    native = _core.bake(layout, int(size), int(counts["visibility_count"]), int(counts["n_dot_l_count"]),
                        int(counts["n_dot_v_count"]), rough,
                        ranges["visibility_range"], ranges["n_dot_l_range"], ranges["n_dot_v_range"], texel,
                        azimuth_text, tolerance, int(max_batches), method, int(samples), int(replicates), int(seed),
                        sequence, form, ao_weighting, backend, device, bool(fast_math), bool(exact_float),
                        _progress("bake", progress))
    return Lut(native)


_REPR_KINDS = ("azimuth-axis", "azimuth-harmonics")
#: The representation presets (``repr bake --preset``; docs/representations.md, the presets table).
REPR_PRESETS = ("full-range", "realistic", "anisotropic")
# repr_bake()'s layout arguments as their defaults: what a preset leaves alone.
_REPR_LAYOUT_DEFAULTS = dict(kind="", visibility_count=16, n_dot_l_count=16, n_dot_v_count=16, azimuth_nodes=9,
                             roughness=(0.1, 0.4, 0.7, 1.0), roughness_count=0, n_dot_v_warp="linear",
                             n_dot_l_warp="linear", visibility_warp="linear")


def repr_bake(
    *,
    preset: str = "",
    kind: str = "",
    visibility_count: int = 16,
    n_dot_l_count: int = 16,
    n_dot_v_count: int = 16,
    azimuth_nodes: int = 9,
    roughness: Sequence[float] = (0.1, 0.4, 0.7, 1.0),
    roughness_count: int = 0,
    n_dot_v_warp: str = "linear",
    n_dot_l_warp: str = "linear",
    visibility_warp: str = "linear",
    method: str = "exact",
    tolerance: float = 0.0,
    samples: int = 65536,
    seed: int = 0,
    replicates: int = 8,
    sequence: str = "sobol",
    form: str = "height-correlated",
    ao_weighting: str = "cosine",
    backend: str = "opencl",
    device: str = "default",
    fast_math: bool = False,
    exact_float: bool = False,
    progress: ProgressArg = None,
) -> Representation:
    """Bakes a representation that keeps the relative azimuth: ``microshadow repr bake`` without its
    files (call ``.save(path)``); docs/representations.md compares them.

    Args:
        preset: "full-range" (the whole isotropic domain), "realistic" (roughness 0.3-0.9) or
            "anisotropic" (alpha_x, alpha_y and tangent-relative azimuths; its fit takes about 40 s of
            CPU): ``repr bake --preset``, the whole layout (leave kind and the layout arguments out).
        kind: "azimuth-axis" (the azimuth as a texture axis; 1 to 4 roughness nodes in RGBA) or
            "azimuth-harmonics" (cos(m phi) coefficients, m <= 3; roughness slabs).
        visibility_count, n_dot_l_count, n_dot_v_count: texels (2 to 256). azimuth_nodes: nodes over
            [0, 180] degrees, ends included (2 to 64; harmonics: at least 7).
        roughness: roughness nodes, increasing, in (0, 1]; roughness_count > 0: keep that many of them,
            chosen by error.
        n_dot_v_warp: "linear" or "sqrt"; n_dot_l_warp: "linear", "shadow-edge" or "sqrt-top";
            visibility_warp: "linear" or "sqrt-top".
        method ... exact_float, progress: as :func:`evaluate` (progress counts queries).
    """
    if preset:
        _choice("preset", preset, REPR_PRESETS)
        layout = dict(kind=kind, visibility_count=visibility_count, n_dot_l_count=n_dot_l_count,
                      n_dot_v_count=n_dot_v_count, azimuth_nodes=azimuth_nodes, roughness=tuple(roughness),
                      roughness_count=roughness_count, n_dot_v_warp=n_dot_v_warp, n_dot_l_warp=n_dot_l_warp,
                      visibility_warp=visibility_warp)
        given = [k for k, v in layout.items() if v != _REPR_LAYOUT_DEFAULTS[k]]
        if given:
            raise ValueError(f"preset = {preset!r} sets the whole layout: {', '.join(given)} cannot be given beside it")
        kind = "azimuth-harmonics"  # the library's default; the preset chooses its own
    elif not kind:
        raise ValueError("kind: required for a custom layout (or name a preset: " + ", ".join(REPR_PRESETS) + ")")
    _choice("kind", kind, _REPR_KINDS)
    for name, value in (("visibility_count", visibility_count), ("n_dot_l_count", n_dot_l_count),
                        ("n_dot_v_count", n_dot_v_count)):
        _count(name, value, 2, 256)
    _count("azimuth_nodes", azimuth_nodes, 2, 64)
    _count("roughness_count", roughness_count, 0, 64)
    _choice("n_dot_v_warp", n_dot_v_warp, ("linear", "sqrt"))
    _choice("n_dot_l_warp", n_dot_l_warp, ("linear", "shadow-edge", "sqrt-top"))
    _choice("visibility_warp", visibility_warp, ("linear", "sqrt-top"))
    r = _scalar_or_vector("roughness", roughness).reshape(-1)
    if r.size == 0:
        raise ValueError("roughness: no values")
    _check_range("roughness", r, 0.0, 1.0, lo_open=True)
    if (np.diff(r) <= 0).any():
        i = int(np.flatnonzero(np.diff(r) <= 0)[0]) + 1
        raise ValueError(f"roughness[{i}] = {float(r[i])!r}: the nodes must increase")
    tolerance = _sampling(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device)
    native = _core.repr_bake(preset, kind, int(visibility_count), int(n_dot_l_count), int(n_dot_v_count), int(azimuth_nodes),
                             [float(x) for x in r], int(roughness_count), n_dot_v_warp, n_dot_l_warp, visibility_warp,
                             method, tolerance, int(samples), int(replicates), int(seed), sequence, form, ao_weighting,
                             backend, device, bool(fast_math), bool(exact_float), _progress("repr bake", progress))
    return Representation(native)


# --- analytic terms -------------------------------------------------------------------------------------


def analytic(
    name: str,
    visibility: ArrayLike,
    n_dot_l: ArrayLike,
    n_dot_v: ArrayLike = 1.0,
    *,
    roughness: ArrayLike = 0.5,
    ao_weighting: str = "cosine",
) -> np.ndarray:
    """Part 1's analytic term `name` (one of :data:`ANALYTIC_TERMS`), as ``eval --compare NAME`` and the
    sweeps evaluate it.

    roughness (keyword only) is the perceptual roughness (alpha = roughness^2; "activision-adjusted" converts it to
    Activision's own roughness of that alpha, the other terms ignore it); n_dot_v is read by
    "naughty-dog-ao-fresnel" and "activision-adjusted". The arguments broadcast (any shapes); returns
    float64 of the broadcast shape.
    """
    if name not in ANALYTIC_TERMS:
        raise ValueError(f"name = {name!r}: one of {', '.join(ANALYTIC_TERMS)}")
    _choice("ao_weighting", ao_weighting, _WEIGHTINGS)
    arrays = {
        "visibility": _array("visibility", visibility),
        "n_dot_l": _array("n_dot_l", n_dot_l),
        "n_dot_v": _array("n_dot_v", n_dot_v),
        "roughness": _array("roughness", roughness),
    }
    _check_range("visibility", arrays["visibility"], 0.0, 1.0)
    _check_range("n_dot_l", arrays["n_dot_l"], -1.0, 1.0)
    _check_range("n_dot_v", arrays["n_dot_v"], -1.0, 1.0)
    _check_range("roughness", arrays["roughness"], 0.0, 1.0, lo_open=True)
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in arrays.items())
        raise ValueError(f"analytic: the arguments do not broadcast ({shapes})") from None
    rows = np.empty(shape + (4,))
    for k, a in enumerate(arrays.values()):
        rows[..., k] = a
    return _core.analytic_rows(name, np.ascontiguousarray(rows.reshape(-1, 4)), ao_weighting).reshape(shape)


# --- sweeps ---------------------------------------------------------------------------------------------


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
    table, summary = _core.sweep(spec_path, toml or "", os.getcwd(), "" if out is None else os.fspath(out), method,
                                 tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device,
                                 bool(fast_math), bool(exact_float), _progress("sweep", progress))
    return SweepTable(table, summary)


class SweepTable(dict):
    """sweep.csv as a dict of numpy arrays (column name -> array), plus ``summary``: the markdown table of
    each comparator's error against the term (summary.md)."""

    def __init__(self, columns: Dict[str, np.ndarray], summary: str) -> None:
        super().__init__(columns)
        self.summary = summary


# --- image-based lighting -------------------------------------------------------------------------------


class DfgLut:
    """The split-sum DFG LUT: x = NdotV (or sqrt(NdotV)), y = roughness (alpha = roughness^2).

    Attributes:
        data: float64 (roughness, n_dot_v, channels): the channels asked for, by default scale, bias and the
            single-scattering albedo E = scale + bias.
        std_error: their standard errors (sampled) or error estimates (exact, quadrature), alike.
        channels: the channels' names in order ("scale", "bias", "E", "sheen").
        n_dot_v, roughness: the NdotV of each column and the roughness of each row.
        metadata: dict, how it was made.
    """

    def __init__(self, native: "_core.DfgLut") -> None:
        self._native = native
        self.data: np.ndarray = native.values()
        self.std_error: np.ndarray = native.std_errors()
        self.channels: List[str] = list(native.channels)
        self.n_dot_v: np.ndarray = np.array(native.n_dot_v)
        self.roughness: np.ndarray = np.array(native.roughness)
        self.metadata: dict = json.loads(native.metadata_json)

    def save(self, path: PathArg, half: bool = False, symbol: str = "microshadow_dfg") -> None:
        """Writes it as ``microshadow ibl dfg --out``: .exr, .ktx2, .dds (+ .dds.json), .png (16-bit), .h or .inc;
        half: float16; symbol: the C array name of a .h file."""
        if not isinstance(symbol, str) or not symbol:
            raise ValueError(f"symbol = {symbol!r}: a C identifier")
        self._native.save(os.fspath(path), bool(half), symbol)


def ibl_dfg(
    *,
    size: int = 64,
    size_n_dot_v: int = 0,
    size_roughness: int = 0,
    texel: str = "centres",
    method: str = "sampled",
    channels: str = "scale,bias,E",
    parameterization: str = "linear",
    samples: int = 65536,
    replicates: int = 8,
    seed: int = 0,
    backend: str = "opencl",
    device: str = "default",
    threads: int = 0,
    fast_math: bool = False,
    progress: ProgressArg = None,
) -> DfgLut:
    """Bakes the DFG LUT: ``microshadow ibl dfg`` without its file (call ``.save(path)``).

    size: texels on both axes (size_n_dot_v, size_roughness: one axis's own, 0: size); texel: "centres" or
    "endpoints"; method: "exact" (Gauss-Legendre, ~1e-12), "sampled" (the VNDF kernel, error bars) or
    "quadrature" (the independent check); channels: 1-4 of scale, bias, E, sheen in the file's order (a
    comma-separated string or a list); parameterization: "linear" or "sqrt-n-dot-v" (x = sqrt(NdotV));
    samples: VNDF samples per texel (all replicates; at most 2^24 a replicate; sampled only); backend
    "oracle": the older spelling of method "quadrature"; threads: host threads of exact / quadrature (0:
    all). progress: True or a callable (texels done, texels).
    """
    _choice("texel", texel, ("centres", "centers", "endpoints"))
    _choice("method", method, ("exact", "sampled", "quadrature"))
    _choice("parameterization", parameterization, ("linear", "sqrt-n-dot-v"))
    _choice("backend", backend, _BACKENDS)
    if not isinstance(channels, str):
        channels = ",".join(channels)
    _count("size", size, 1, 4096)
    _count("size_n_dot_v", size_n_dot_v, 0, 4096)
    _count("size_roughness", size_roughness, 0, 4096)
    _count("replicates", replicates, 2, 64)
    _count("samples", samples, 1, (1 << 24) * 64)
    _count("seed", seed, 0, 2**64 - 1)
    _count("threads", threads, 0, 1024)
    native = _core.bake_dfg(int(size), int(size_n_dot_v), int(size_roughness), texel, method, channels, parameterization,
                            int(samples), int(replicates), int(seed), backend, device, int(threads), bool(fast_math),
                            _progress("ibl dfg", progress))
    return DfgLut(native)


# --- area lights ----------------------------------------------------------------------------------------


class AreaResult(NamedTuple):
    """What :func:`area_eval` returns: three float64 arrays of shape (N,)."""

    term: np.ndarray          #: T_area, the term averaged over the light weighted by the lobe's f cos
    std_error: np.ndarray     #: the (outer) sampling's standard error
    inner_error: np.ndarray   #: method="exact": a bound on the inner values' part of the error; else 0


def area_eval(
    visibility: ArrayLike,
    alpha_x: ArrayLike,
    alpha_y: ArrayLike,
    wi: ArrayLike,
    *,
    light: str = "sphere",
    light_direction: Optional[ArrayLike] = None,
    half_angle_deg: Optional[ArrayLike] = None,
    corners: Optional[ArrayLike] = None,
    lobe: str = "ggx",
    method: str = "sampled",
    tolerance: float = 0.0,
    samples: Optional[int] = None,
    seed: int = 0,
    replicates: int = 8,
    sequence: str = "sobol",
    form: str = "height-correlated",
    ao_weighting: str = "cosine",
    backend: Optional[str] = None,
    device: Optional[str] = None,
    fast_math: bool = False,
    progress: ProgressArg = None,
) -> AreaResult:
    """The term over a sphere or rectangle light: ``microshadow area eval`` on the same columns
    (docs/area-lights.md).

    Args:
        visibility, alpha_x, alpha_y, wi: the surface, as :func:`evaluate` takes them.
        light: "sphere" (give light_direction (3,) / (N, 3), the direction to its centre, and
            half_angle_deg, its angular radius in (0, 90) degrees) or "rect" (give corners (4, 3) /
            (N, 4, 3): the corners in order, positions relative to the shaded point in the tangent frame).
        lobe: the BRDF lobe weighting the light: "ggx" (Fresnel-free specular at the surface's alpha) or
            "lambert".
        method: "sampled" (the joint kernel on `backend`) or "exact" (the exact inner term at each of
            `samples` outer light directions, on the host's threads; backend and device do not apply).
        tolerance: method="exact": the error asked of each inner value (0: 1e-6; 1e-13 to 0.1).
        samples: per query (None: 65536, exact 8192 outer directions); seed, replicates, sequence, form,
            ao_weighting, backend, device, fast_math: as :func:`evaluate`.
        progress: True prints progress on stderr; a callable gets (done, total) queries.

    Returns:
        :class:`AreaResult` (term, std_error, inner_error), the values ``area eval`` writes.
    """
    _choice("light", light, ("sphere", "rect"))
    _choice("lobe", lobe, ("ggx", "lambert"))
    if method == "exact":
        for name, value in (("backend", backend), ("device", device)):
            if value is not None:
                raise ValueError(f"{name} applies to method='sampled' only (the exact inner term runs on the host's threads)")
        if fast_math:
            raise ValueError("fast_math applies to method='sampled' only (the exact inner term runs on the host's threads)")
    elif tolerance:
        raise ValueError("tolerance applies to method='exact' only (the inner term's tolerance)")
    backend = "opencl" if backend is None else backend
    device = "default" if device is None else device
    if samples is None:
        samples = 8192 if method == "exact" else 65536
    tolerance = _sampling(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device)
    if method == "exact" and tolerance > 0 and not (1e-13 <= tolerance <= 0.1):
        raise ValueError(f"tolerance = {_shown(tolerance)!r}: the exact method takes 1e-13 to 0.1 (0: 1e-6)")
    # The surface columns, checked as evaluate() checks them (wi also serves as the unused wo).
    rows = _query_rows(visibility, alpha_x, alpha_y, wi, wi)
    n = rows.shape[0]
    if light == "sphere":
        if corners is not None:
            raise ValueError("corners are a rect light's; a sphere takes light_direction and half_angle_deg")
        if light_direction is None or half_angle_deg is None:
            raise ValueError("light='sphere' needs light_direction and half_angle_deg")
        centre = _directions("light_direction", light_direction)
        half = _scalar_or_vector("half_angle_deg", half_angle_deg)
        _check_range("half_angle_deg", half, 0.0, 90.0, lo_open=True, hi_open=True)
        n = _broadcast({"surface": rows, "light_direction": centre if centre.ndim == 2 else centre[None, :],
                        "half_angle_deg": half})
        light_rows = np.empty((n, 4))
        light_rows[:, 0:3] = _rows(centre, n)
        light_rows[:, 3] = _column(half, n)
    else:
        if light_direction is not None or half_angle_deg is not None:
            raise ValueError("light_direction and half_angle_deg are a sphere light's; a rect takes corners")
        if corners is None:
            raise ValueError("light='rect' needs corners (4, 3) or (N, 4, 3)")
        c = _array("corners", corners)
        if c.shape != (4, 3) and not (c.ndim == 3 and c.shape[1:] == (4, 3)):
            raise ValueError(f"corners: shape {c.shape}; expected (4, 3) or (N, 4, 3)")
        _check_finite("corners", c)
        c3 = c if c.ndim == 3 else c[None]
        n = _broadcast({"surface": rows, "corners": c3})
        light_rows = np.ascontiguousarray(np.broadcast_to(c3.reshape(-1, 12), (n, 12)))
    surface = np.ascontiguousarray(np.broadcast_to(rows[:, :6], (n, 6)))
    if n == 0:
        return AreaResult(np.empty(0), np.empty(0), np.empty(0))
    out = _core.area_evaluate(surface, np.ascontiguousarray(light_rows), light, lobe, method, tolerance, int(samples),
                              int(replicates), int(seed), sequence, form, ao_weighting, backend, device, bool(fast_math),
                              _progress("area eval", progress))
    return AreaResult(*(np.ascontiguousarray(out[:, k]) for k in range(3)))


# --- scenes ---------------------------------------------------------------------------------------------


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
    native = _core.scene(description, 0.0 if tolerance is None else float(tolerance), method, lut_paths, bool(skip),
                         bool(seed_luts), bool(strict_domain), backend, device, bool(fast_math), _progress("scene", progress))
    return SceneRun(native)


# --- environment integrals ------------------------------------------------------------------------------


def _environment(environment: Optional[PathArg], faces: Optional[Sequence[PathArg]]) -> Tuple[str, List[str]]:
    """ENV or six face files, exactly one of them, each an existing file."""
    if (environment is None) == (faces is None):
        raise ValueError("give environment (one image) or faces (six files +X -X +Y -Y +Z -Z), one of them")
    if environment is not None:
        image = os.fspath(environment)
        if not os.path.isfile(image):
            raise FileNotFoundError(f"{image}: no such file")
        return image, []
    if isinstance(faces, (str, os.PathLike)):
        raise ValueError("faces: six files +X -X +Y -Y +Z -Z, as a list")
    files = [os.fspath(f) for f in faces]
    if len(files) != 6:
        raise ValueError(f"faces: {len(files)} files; six (+X -X +Y -Y +Z -Z)")
    for i, f in enumerate(files):
        if not os.path.isfile(f):
            raise FileNotFoundError(f"faces[{i}] = {f!r}: no such file")
    return "", files


def _real(name: str, value: float, lo: float, hi: float) -> float:
    v = float(value)
    if not (np.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} = {_shown(value)!r}: a number from {lo:g} to {hi:g}")
    return v


def _cube_format(format: str, encoding: str) -> None:
    _choice("format", format, ("exr", "ktx2", "dds"))
    _choice("encoding", encoding, ("float16", "float32"))


class PrefilteredEnvironment:
    """The result of :func:`ibl_prefilter`.

    Attributes:
        mips: list of float32 (6, n, n, 3) cubemaps, faces +X -X +Y -Y +Z -Z (mip 0: the source).
        roughness: float64 (mips,): the roughness each mip is prefiltered at.
        irradiance: float32 (6, m, m, 3): E / pi from order-2 SH (m = irradiance_size).
        sh: float64 (9, 3): the radiance SH coefficients.
        metadata: dict, ibl.json's content ("specular", "irradiance").
    """

    def __init__(self, native: "_core.PrefilteredEnvironment") -> None:
        self._native = native
        self.mips: List[np.ndarray] = list(native.mips())
        self.roughness: np.ndarray = np.array(native.mip_roughness)
        self.irradiance: np.ndarray = native.irradiance()
        self.sh: np.ndarray = native.sh()
        self.metadata: dict = json.loads(native.metadata_json)

    def save(self, out: PathArg, format: str = "exr", encoding: str = "float16", exposure: float = 1.0) -> None:
        """Writes ``ibl prefilter``'s files into the folder `out` (created), all or none: the chain
        (format "exr": specular_m<m>.exr crosses; "ktx2" / "dds": specular.<format>, one cubemap with
        every mip, encoding "float16" or "float32"), irradiance.<format>, the previews, sh.json, ibl.json."""
        _cube_format(format, encoding)
        self._native.save(os.fspath(out), format, encoding, _real("exposure", exposure, 0, 1e12))


def ibl_prefilter(
    environment: Optional[PathArg] = None,
    *,
    faces: Optional[Sequence[PathArg]] = None,
    size: int = 0,
    levels: int = 0,
    mapping: str = "cmgen",
    tolerance: float = 0.02,
    samples: int = 256,
    max_samples: int = 1 << 16,
    replicates: int = 16,
    seed: int = 0,
    no_fis: bool = False,
    lod_bias: float = 0.0,
    bright: str = "auto",
    bright_threshold: float = 0.0,
    bright_min_roughness: float = 0.0,
    wide_samples_factor: int = 1,
    bright_max: int = 4096,
    device: Optional[str] = None,
    threads: int = 0,
    verify: int = 0,
    irradiance_size: int = 32,
    progress: ProgressArg = None,
) -> PrefilteredEnvironment:
    """The GGX-prefiltered specular mip chain and the SH irradiance of an environment: ``microshadow ibl
    prefilter`` without its files (call ``.save(out)``); docs/ibl.md.

    Args:
        environment: an equirectangular (2:1) image or a 4:3 / 3:4 cross, .exr or .hdr; or faces: six
            face files +X -X +Y -Y +Z -Z.
        size: the base face size, a power of two (0: the source's). levels: mips (0: down to 4 x 4).
        mapping: roughness per mip, "cmgen" (r = 1 - sqrt(1 - m / (levels - 1))) or "linear".
        tolerance: sample each texel until its relative 95% error bar (t over the replicates plus the
            explicit part's bound) is at most this, 0 to 1 (0: a fixed `samples` per texel); docs/ibl.md.
        samples: GGX samples per texel, 16 to 2^20 (all replicates; the first round's with a tolerance);
            max_samples: with a tolerance, at most this many per texel; replicates: 2 to 64; seed.
        no_fis: read every sample from the full-resolution source (no filtered importance sampling).
        lod_bias: filtered importance sampling's LOD bias, -16 to 16.
        bright: "auto" sums the bright texels explicitly, chosen for the tolerance (at most bright_max), or
            "off"; bright_threshold: > 0 takes those brighter than this x the mean radiance instead; on the mips
            of roughness >= bright_min_roughness, whose first samples are multiplied by wide_samples_factor.
        device: OpenCL devices for the kernel (None: C++ on CPU threads, `threads` of them, 0: all).
        verify: > 0 compares that many random texels with the brute-force oracle (in the metadata) and raises
            when one is outside its bars.
        irradiance_size: the SH irradiance cubemap's face size.
        progress: True prints progress on stderr; a callable gets (texels done, texels).
    """
    image, files = _environment(environment, faces)
    _choice("mapping", mapping, ("cmgen", "linear"))
    _count("size", size, 0, 4096)
    if size and size & (size - 1):
        raise ValueError(f"size = {_shown(size)!r}: a power of two (0: the source's)")
    _count("levels", levels, 0, 13)
    _count("samples", samples, 16, 1 << 20)
    _count("max_samples", max_samples, 16, 1 << 24)
    if max_samples < samples:
        raise ValueError(f"max_samples = {_shown(max_samples)!r}: at least samples ({_shown(samples)!r})")
    _choice("bright", bright, ("auto", "off"))
    _count("replicates", replicates, 2, 64)
    _count("seed", seed, 0, 2**64 - 1)
    _count("wide_samples_factor", wide_samples_factor, 1, 64)
    _count("bright_max", bright_max, 1, 1 << 20)
    _count("threads", threads, 0, 1024)
    _count("verify", verify, 0, 100000)
    _count("irradiance_size", irradiance_size, 1, 1024)
    if device is not None and not isinstance(device, str):
        raise ValueError(f"device = {device!r}: 'default', 'all', an index or part of a name, as a string")
    native = _core.prefilter(image, files, int(size), int(levels), mapping, _real("tolerance", tolerance, 0, 1), int(samples),
                             int(max_samples), int(replicates), int(seed), not no_fis, _real("lod_bias", lod_bias, -16, 16),
                             bright == "auto", _real("bright_threshold", bright_threshold, 0, 1e12),
                             _real("bright_min_roughness", bright_min_roughness, 0, 1), int(wide_samples_factor),
                             int(bright_max), device or "", int(threads), int(verify), int(irradiance_size),
                             _progress("ibl prefilter", progress))
    return PrefilteredEnvironment(native)


class IrradianceMap:
    """The result of :func:`ibl_irradiance`.

    Attributes:
        data: float32 (6, n, n, 3): E / pi, faces +X -X +Y -Y +Z -Z.
        bound: float32 (6, n, n, 3): a bound on |data - the exact E / pi of the full-resolution source|.
        metadata: dict, irradiance.json's content (with the comparison against order-2 SH).
    """

    def __init__(self, native: "_core.IrradianceMap") -> None:
        self._native = native
        self.data: np.ndarray = native.map()
        self.bound: np.ndarray = native.bound()
        self.metadata: dict = json.loads(native.metadata_json)

    def save(self, out: PathArg, format: str = "exr", encoding: str = "float16", exposure: float = 1.0) -> None:
        """Writes ``ibl irradiance``'s files into the folder `out` (created), all or none:
        irradiance.<format> ("exr": a horizontal cross; "ktx2" / "dds": one cubemap level, encoding
        "float16" or "float32"), irradiance.json and irradiance_preview.png."""
        _cube_format(format, encoding)
        self._native.save(os.fspath(out), format, encoding, _real("exposure", exposure, 0, 1e12))


def ibl_irradiance(
    environment: Optional[PathArg] = None,
    *,
    faces: Optional[Sequence[PathArg]] = None,
    face_size: int = 32,
    source_size: int = 128,
    backend: str = "opencl",
    device: str = "default",
    threads: int = 0,
    verify: int = 0,
    progress: ProgressArg = None,
) -> IrradianceMap:
    """The irradiance cubemap (E / pi) by direct clamped-cosine convolution, with error bounds:
    ``microshadow ibl irradiance`` without its files (call ``.save(out)``).

    Args:
        environment / faces: as :func:`ibl_prefilter`.
        face_size: output faces (1 to 1024); source_size: the reduced source the kernel convolves (1 to 8192).
        backend: "opencl" (the kernel on `device`) or "oracle" (the exact convolution of the full source in
            double, `threads` CPU threads, 0: all).
        verify: > 0 checks that many random texels against their bound (RuntimeError if one exceeds it).
        progress: True prints progress on stderr; a callable gets (done, total).
    """
    image, files = _environment(environment, faces)
    _count("face_size", face_size, 1, 1024)
    _count("source_size", source_size, 1, 8192)
    _choice("backend", backend, _BACKENDS)
    _count("threads", threads, 0, 1024)
    _count("verify", verify, 0, 100000)
    native = _core.irradiance(image, files, int(face_size), int(source_size), backend, device, int(threads), int(verify),
                              _progress("ibl irradiance", progress))
    return IrradianceMap(native)


class ShIrradiance:
    """The result of :func:`ibl_sh`.

    Attributes:
        coefficients: float64 (9, 3): the radiance SH coefficients L_lm (real SH, k = l(l+1)+m).
        irradiance: float32 (6, n, n, 3): E / pi from them, faces +X -X +Y -Y +Z -Z.
        metadata: dict, the command's JSON (coefficients, irradiance coefficients, the SH error).
    """

    def __init__(self, native: "_core.ShIrradiance") -> None:
        self._native = native
        self.coefficients: np.ndarray = native.sh()
        self.irradiance: np.ndarray = native.irradiance()
        self.metadata: dict = json.loads(native.metadata_json)

    def save(self, out: PathArg, *, irradiance: Optional[PathArg] = None, preview: Optional[PathArg] = None,
             shader: Optional[PathArg] = None, symbol: str = "microshadow_sh") -> None:
        """Writes ``ibl sh``'s files, all or none: the JSON `out` and, where given, the irradiance cross
        (.exr), its preview (.png) and the shader constants (.glsl or .hlsl, named `symbol`)."""
        self._native.save(os.fspath(out), "" if irradiance is None else os.fspath(irradiance),
                          "" if preview is None else os.fspath(preview), "" if shader is None else os.fspath(shader), symbol)


def ibl_sh(environment: Optional[PathArg] = None, *, faces: Optional[Sequence[PathArg]] = None,
           face_size: int = 32) -> ShIrradiance:
    """Order-2 spherical harmonics of an environment (9 coefficients per channel) and the irradiance
    cubemap through the clamped-cosine convolution: ``microshadow ibl sh`` (call ``.save(out, ...)``).

    environment / faces: as :func:`ibl_prefilter`; face_size: the irradiance cubemap's (1 to 1024)."""
    image, files = _environment(environment, faces)
    _count("face_size", face_size, 1, 1024)
    return ShIrradiance(_core.spherical_harmonics(image, files, int(face_size)))


# --- the design study -----------------------------------------------------------------------------------


class DesignTable(dict):
    """The design study's table (pareto.csv) as a dict of arrays, one row per candidate, sorted by weighted
    RMS: "name", "kind", "storage" (text), "bytes", "fetches_per_light", "alu_per_light", "weighted_rms",
    "weighted_p99", "max_abs", "pareto", "chosen", "within_budget" (bool), "outside_domain" and "points".

    Attributes:
        by_roughness: dict: "edges" (the roughness bands [edges[k], edges[k + 1])) and "points",
            "weighted_rms", "weighted_p99", "max_abs" as (candidates, bands) arrays, rows as the table's.
        chosen: the chosen candidate's name (the best inside the budget, or `choose`).
        reference: dict of the evaluation reference set: "file" (the cached CSV), "points",
            "max_std_error", "rms_std_error".
    """

    def __init__(self, table: Dict[str, np.ndarray], by_roughness: Dict[str, np.ndarray], chosen: str,
                 reference: dict) -> None:
        super().__init__(table)
        self.by_roughness = dict(by_roughness)
        self.chosen = chosen
        self.reference = dict(reference)


def _files(name: str, value: Sequence[PathArg]) -> List[str]:
    if isinstance(value, (str, os.PathLike)):
        raise ValueError(f"{name}: a list of FILE or NAME=FILE entries (give [entry] for one)")
    return [os.fspath(v) for v in value]


def design(
    reference: PathArg,
    *,
    fit_reference: Optional[PathArg] = None,
    cache: PathArg = "out/design-cache",
    luts: Sequence[PathArg] = (),
    reprs: Sequence[PathArg] = (),
    closed_forms: Sequence[PathArg] = (),
    fit_orders: Sequence[int] = (1, 2, 3),
    max_bytes: Optional[int] = None,
    max_fetches: Optional[int] = None,
    max_alu: Optional[int] = None,
    choose: Optional[str] = None,
    analytic: bool = True,
    strict_domain: bool = False,
    backend: str = "opencl",
    device: str = "default",
    progress: ProgressArg = None,
) -> DesignTable:
    """Judges every candidate representation against one cached reference set: ``microshadow design``'s
    table (pareto.csv) without its files (docs/study.md).

    Args:
        reference: the reference spec (TOML: [points] region or csv, [sampling]); computed once and
            cached in `cache` by the hash of its definition.
        fit_reference: fit the closed form to this spec (other points than `reference`) at each of
            fit_orders (1 to 4): candidates "closed-form-<order>".
        luts, reprs, closed_forms: more candidates, each FILE or NAME=FILE: baked LUTs, representations
            (files, or a preset's name: realistic, full-range, anisotropic) and fitted closed forms (JSON).
        max_bytes, max_fetches, max_alu: the budget (None: unlimited); choose: this candidate instead of
            the best inside it.
        analytic: False leaves part 1's terms out (``--no-analytic``). strict_domain: refuse a candidate
            whose domain leaves out reference points (else they are counted in "outside_domain").
        backend, device: where a missing reference is computed.
        progress: True prints progress on stderr; a callable gets (points done, points) while a reference
            set is computed.
    """
    _choice("backend", backend, _BACKENDS)
    spec = os.fspath(reference)
    if not os.path.isfile(spec):
        raise FileNotFoundError(f"{spec}: no such file")
    fit = "" if fit_reference is None else os.fspath(fit_reference)
    if fit and not os.path.isfile(fit):
        raise FileNotFoundError(f"{fit}: no such file")
    orders = []
    for i, order in enumerate(fit_orders):
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 1 <= int(order) <= 4:
            raise ValueError(f"fit_orders[{i}] = {_shown(order)!r}: an integer from 1 to 4")
        orders.append(int(order))
    budget = {}
    for name, value, top in (("max_bytes", max_bytes, 2**64 - 1), ("max_fetches", max_fetches, 2**32 - 1),
                             ("max_alu", max_alu, 2**32 - 1)):
        budget[name] = top if value is None else _count(name, value, 0, top)
    if choose is not None and not isinstance(choose, str):
        raise ValueError(f"choose = {choose!r}: a candidate's name")
    table, by_roughness, chosen, ref = _core.design(
        spec, fit, os.fspath(cache), _files("luts", luts), _files("reprs", reprs), _files("closed_forms", closed_forms),
        orders, budget["max_bytes"], budget["max_fetches"], budget["max_alu"], choose or "", bool(analytic),
        bool(strict_domain), backend, device, _progress("design", progress))
    return DesignTable(table, by_roughness, chosen, ref)
