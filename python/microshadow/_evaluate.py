"""evaluate(), evaluate_iso() and lookup_inputs(): the term at queries (``microshadow eval``)."""

from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from . import _microshadow as _core
from . import _options
from ._files import _lookup_rows
from ._checks import (_BYTES_PER_QUERY, _array, ArrayLike, _broadcast, _broadcast_shape, _check_finite, _check_memory,
                     _check_range, _column, _directions, _index, _progress, ProgressArg, _renamed_keyword, _rows,
                     _sampling, _scalar_or_vector, _shown)


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
    options = _options.sampling(method=method, tolerance=tolerance, samples=samples, replicates=replicates, seed=seed,
                                sequence=sequence, form=form, ao_weighting=ao_weighting, backend=backend, device=device,
                                fast_math=fast_math, exact_float=exact_float)
    out = _core.evaluate_rows(rows, options, _progress("evaluate", progress))
    return np.ascontiguousarray(out[:, 0]), np.ascontiguousarray(out[:, 1])


def evaluate_iso(
    visibility: ArrayLike,
    n_dot_l: ArrayLike,
    n_dot_v: ArrayLike,
    *,
    roughness: ArrayLike,
    relative_azimuth_deg: Optional[ArrayLike] = None,
    relative_azimuth: Optional[ArrayLike] = None,
    **options,
) -> Tuple[np.ndarray, np.ndarray]:
    """The term of an isotropic surface in the LUTs' parameters: :func:`evaluate` on its query.

    The parameters come in the order of every isotropic call (:meth:`Lut.lookup`, :func:`analytic`, the
    C++ isotropic_query): visibility, n_dot_l, n_dot_v, then roughness and relative_azimuth_deg as keywords
    (so that an alpha is never passed for the roughness by position).

    Args:
        visibility: in [0, 1].
        n_dot_l: cosine of the light in [-1, 1] (below 0 the term is 0).
        n_dot_v: cosine of the view in (0, 1]; wi = (sqrt(1 - n_dot_v^2), 0, n_dot_v).
        roughness: perceptual roughness in (0, 1] (alpha_x = alpha_y = roughness^2).
        relative_azimuth_deg: the light's azimuth from the view's, in degrees (0, the default: on the
            view's side, 180: opposite); wo = (s cos phi, s sin phi, n_dot_l) with s = sqrt(1 - n_dot_l^2):
            the directions of a sweep point with phi_i = 0 and delta_phi = relative_azimuth_deg.
        relative_azimuth: the older name of relative_azimuth_deg (DeprecationWarning).
        **options: :func:`evaluate`'s keyword options (method, tolerance, samples, ...).

    All arguments broadcast against each other (any shapes, as :meth:`Lut.lookup`). Returns (term,
    std_error), float64 of the broadcast shape.
    """
    for key in options:
        if key not in _EVALUATE_OPTIONS:
            raise TypeError(f"evaluate_iso() got an unexpected keyword argument {key!r}")
    azimuth_deg = _renamed_keyword("evaluate_iso", "relative_azimuth", "relative_azimuth_deg", relative_azimuth,
                                   relative_azimuth_deg)
    if azimuth_deg is None:
        azimuth_deg = 0.0
    given = {"visibility": _array("visibility", visibility), "n_dot_l": _array("n_dot_l", n_dot_l),
             "n_dot_v": _array("n_dot_v", n_dot_v), "roughness": _array("roughness", roughness),
             "relative_azimuth_deg": _array("relative_azimuth_deg", azimuth_deg)}
    _broadcast_shape("evaluate_iso", given, _BYTES_PER_QUERY)
    # Each argument checked as given (the message indexes it in its own shape), then broadcast.
    _check_range("visibility", given["visibility"], 0.0, 1.0)
    _check_range("n_dot_l", given["n_dot_l"], -1.0, 1.0)
    _check_range("n_dot_v", given["n_dot_v"], 0.0, 1.0, lo_open=True)
    _check_range("roughness", given["roughness"], 0.0, 1.0, lo_open=True)
    _check_finite("relative_azimuth_deg", given["relative_azimuth_deg"])
    rows, shape = _lookup_rows("evaluate_iso", visibility, n_dot_l, n_dot_v, roughness, azimuth_deg)
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
    "roughness" = (alpha_x alpha_y)^(1/4) and "relative_azimuth_deg" in degrees in [0, 180]. The arguments
    are :func:`evaluate`'s; returns a dict of (N,) arrays, ready for ``lut.lookup(**inputs)``."""
    rows = _query_rows(visibility, alpha_x, alpha_y, wi, wo)
    out = _core.lookup_input_rows(rows) if rows.shape[0] else np.empty((0, 5))
    names = ("visibility", "n_dot_l", "n_dot_v", "roughness", "relative_azimuth_deg")
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
