"""analytic(): part 1's analytic terms by name (``eval --compare NAME``)."""

from __future__ import annotations


from typing import Tuple

import numpy as np

from . import _microshadow as _core
from ._checks import _broadcast_shape, _array, ArrayLike, _check_range, _choice, _WEIGHTINGS


#: Part 1's analytic terms, by the names ``eval --compare`` and sweep specs use.
ANALYTIC_TERMS: Tuple[str, ...] = tuple(_core.analytic_term_names())


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
    shape = _broadcast_shape("analytic", arrays)
    _check_range("visibility", arrays["visibility"], 0.0, 1.0)
    _check_range("n_dot_l", arrays["n_dot_l"], -1.0, 1.0)
    _check_range("n_dot_v", arrays["n_dot_v"], -1.0, 1.0)
    _check_range("roughness", arrays["roughness"], 0.0, 1.0, lo_open=True)
    rows = np.empty(shape + (4,))
    for k, a in enumerate(arrays.values()):
        rows[..., k] = a
    return _core.analytic_rows(name, np.ascontiguousarray(rows.reshape(-1, 4)), ao_weighting).reshape(shape)
