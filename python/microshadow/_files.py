"""LUT and representation files: :class:`Lut`, :class:`Representation` and :func:`open`."""

from __future__ import annotations

import json
import os
from typing import Optional, Tuple, Union

import numpy as np

from . import _microshadow as _core
from ._checks import _broadcast_shape, _array, ArrayLike, _choice, _index, PathArg, _renamed_keyword


def _lookup_rows(name_prefix: str, visibility, n_dot_l, n_dot_v, roughness, relative_azimuth_deg) -> Tuple[np.ndarray, Tuple[int, ...]]:
    """The (N, 5) rows of a lookup and the broadcast shape of its arguments (any shapes that broadcast)."""
    arrays = {
        "visibility": _array("visibility", visibility),
        "n_dot_l": _array("n_dot_l", n_dot_l),
        "n_dot_v": _array("n_dot_v", n_dot_v),
        "roughness": _array("roughness", roughness),
        "relative_azimuth_deg": _array("relative_azimuth_deg", 0.0 if relative_azimuth_deg is None else relative_azimuth_deg),
    }
    shape = _broadcast_shape(name_prefix, arrays)
    for name, a in arrays.items():
        # NaN would make every blend weight NaN; the renderer's clamps cover the rest.
        if np.isnan(a).any():
            i = int(np.flatnonzero(np.isnan(a))[0])
            raise ValueError(f"{name}{_index(i, a.shape)} = nan: not a number")
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
               relative_azimuth_deg: Optional[ArrayLike] = None,
               relative_azimuth: Optional[ArrayLike] = None) -> np.ndarray:
        """The renderer's lookup: linear filtering, clamp to edge, linear blend between roughness channels.

        The arguments broadcast against each other (any shapes); roughness (keyword only, so that an
        alpha is never passed for it by position) is the perceptual roughness, alpha = roughness^2 (an
        anisotropic surface uses (alpha_x alpha_y)^(1/4)). A LUT stores the azimuth's mean, so
        relative_azimuth_deg is accepted and ignored (relative_azimuth: its older name, DeprecationWarning).
        Returns float64 of the broadcast shape.
        """
        relative_azimuth_deg = _renamed_keyword("Lut.lookup", "relative_azimuth", "relative_azimuth_deg", relative_azimuth,
                                                relative_azimuth_deg)
        rows, shape = _lookup_rows("Lut.lookup", visibility, n_dot_l, n_dot_v, roughness, relative_azimuth_deg)
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
               relative_azimuth_deg: Optional[ArrayLike] = None,
               relative_azimuth: Optional[ArrayLike] = None) -> np.ndarray:
        """The renderer's lookup (the generated shader's arithmetic, in double) at the relative azimuth in
        degrees (0: light on the view's side, 180: opposite). The arguments broadcast; roughness (the
        perceptual roughness) and relative_azimuth_deg are keywords, relative_azimuth_deg required (this
        file keeps the azimuth; relative_azimuth: its older name, DeprecationWarning)."""
        relative_azimuth_deg = _renamed_keyword("Representation.lookup", "relative_azimuth", "relative_azimuth_deg",
                                                relative_azimuth, relative_azimuth_deg)
        if relative_azimuth_deg is None:
            raise ValueError(f"relative_azimuth_deg: required by a {self.kind} representation (it keeps the azimuth)")
        rows, shape = _lookup_rows("Representation.lookup", visibility, n_dot_l, n_dot_v, roughness, relative_azimuth_deg)
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
