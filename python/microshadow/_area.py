"""area_eval(): the term over sphere and rectangle lights (``microshadow area eval``)."""

from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from . import _microshadow as _core
from . import _options
from ._evaluate import _query_rows
from ._checks import (_check_memory, _array, ArrayLike, _broadcast, _check_finite, _check_range, _choice, _column, _directions,
                     _progress, ProgressArg, _rows, _sampling, _scalar_or_vector, _shown)


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
        # The number of lights follows from the shapes alone: too many for memory fails here, at once.
        centre_a, half_a = _array("light_direction", light_direction), _array("half_angle_deg", half_angle_deg)
        _check_memory("lights", max(centre_a.shape[0] if centre_a.ndim == 2 else 1, half_a.shape[0] if half_a.ndim == 1 else 1))
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
        _check_memory("lights", c.shape[0] if c.ndim == 3 else 1)
        _check_finite("corners", c)
        c3 = c if c.ndim == 3 else c[None]
        n = _broadcast({"surface": rows, "corners": c3})
        light_rows = np.ascontiguousarray(np.broadcast_to(c3.reshape(-1, 12), (n, 12)))
    surface = np.ascontiguousarray(np.broadcast_to(rows[:, :6], (n, 6)))
    if n == 0:
        return AreaResult(np.empty(0), np.empty(0), np.empty(0))
    options = _options.build(
        "AreaOptions", lobe=lobe,
        sampling=_options.sampling(method=method, tolerance=tolerance, samples=samples, replicates=replicates, seed=seed,
                                   sequence=sequence, form=form, ao_weighting=ao_weighting, backend=backend,
                                   device=device, fast_math=fast_math))
    out = _core.area_evaluate(surface, np.ascontiguousarray(light_rows), light, options, _progress("area eval", progress))
    return AreaResult(*(np.ascontiguousarray(out[:, k]) for k in range(3)))
