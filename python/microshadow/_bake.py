"""bake() and repr_bake(): a LUT (``microshadow bake``) or a representation (``microshadow repr bake``)."""

from __future__ import annotations

from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _microshadow as _core
from . import _options
from ._files import Lut, Representation
from ._checks import (_array, _check_range, _choice, _count, _deprecated_alias, _MAX_SAMPLES, _progress, ProgressArg,
                     _sampling, _scalar_or_vector, _shown)


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
        counts[new] = _deprecated_alias("bake", old, new, value, counts[new])
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
    options = _options.build(
        "BakeOptions", layout=layout, size=int(size), visibility_count=int(counts["visibility_count"]),
        n_dot_l_count=int(counts["n_dot_l_count"]), n_dot_v_count=int(counts["n_dot_v_count"]), roughness=rough,
        visibility_range=ranges["visibility_range"], n_dot_l_range=ranges["n_dot_l_range"],
        n_dot_v_range=ranges["n_dot_v_range"], texel=texel, azimuth=azimuth_text, tolerance=tolerance,
        max_batches=int(max_batches),
        # The bake's own tolerance is BakeOptions.tolerance (its sampled batches); the struct's sampling
        # tolerance stays 0 as the command leaves it.
        sampling=_options.sampling(method=method, tolerance=0.0, samples=samples, replicates=replicates, seed=seed,
                                   sequence=sequence, form=form, ao_weighting=ao_weighting, backend=backend,
                                   device=device, fast_math=fast_math, exact_float=exact_float))
    native = _core.bake(options, _progress("bake", progress))
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
    if not 1 <= r.size <= 64:  # the representation grid's limit, checked before any element is read
        raise ValueError(f"roughness: {r.size} values; 1 to 64 nodes")
    _check_range("roughness", r, 0.0, 1.0, lo_open=True)
    if (np.diff(r) <= 0).any():
        i = int(np.flatnonzero(np.diff(r) <= 0)[0]) + 1
        raise ValueError(f"roughness[{i}] = {float(r[i])!r}: the nodes must increase")
    tolerance = _sampling(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device)
    options = _options.build(
        "ReprBakeOptions", preset=preset, kind=kind, visibility_count=int(visibility_count),
        n_dot_l_count=int(n_dot_l_count), n_dot_v_count=int(n_dot_v_count), azimuth_nodes=int(azimuth_nodes),
        roughness=[float(x) for x in r], roughness_count=int(roughness_count), n_dot_v_warp=n_dot_v_warp,
        n_dot_l_warp=n_dot_l_warp, visibility_warp=visibility_warp,
        sampling=_options.sampling(method=method, tolerance=tolerance, samples=samples, replicates=replicates, seed=seed,
                                   sequence=sequence, form=form, ao_weighting=ao_weighting, backend=backend,
                                   device=device, fast_math=fast_math, exact_float=exact_float))
    native = _core.repr_bake(options, _progress("repr bake", progress))
    return Representation(native)
