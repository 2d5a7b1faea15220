"""The image-based lighting integrals: ibl_dfg(), ibl_prefilter(), ibl_irradiance(), ibl_sh()
(``microshadow ibl dfg | prefilter | irradiance | sh``)."""

from __future__ import annotations

import json
import os
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import _microshadow as _core
from . import _options
from ._checks import _BACKENDS, _choice, _count, _deprecated_alias, PathArg, _progress, ProgressArg, _real, _shown


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
    n_dot_v_count: int = 0,
    roughness_count: int = 0,
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
    size_n_dot_v: Optional[int] = None,
    size_roughness: Optional[int] = None,
) -> DfgLut:
    """Bakes the DFG LUT: ``microshadow ibl dfg`` without its file (call ``.save(path)``).

    size: texels on both axes (n_dot_v_count, roughness_count: one axis's own, 0: size; the names of
    DfgOptions and of the command's --n-dot-v-count, --roughness-count; size_n_dot_v, size_roughness: the
    same, deprecated); texel: "centres" or
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
    counts = {"n_dot_v_count": n_dot_v_count, "roughness_count": roughness_count}
    for old, new, value in (("size_n_dot_v", "n_dot_v_count", size_n_dot_v),
                            ("size_roughness", "roughness_count", size_roughness)):
        counts[new] = _deprecated_alias("ibl_dfg", old, new, value, counts[new])
    for name, value in counts.items():
        _count(name, value, 0, 4096)
    _count("replicates", replicates, 2, 64)
    _count("samples", samples, 1, (1 << 24) * 64)
    _count("seed", seed, 0, 2**64 - 1)
    _count("threads", threads, 0, 1024)
    options = _options.build(
        "DfgOptions", size=int(size), n_dot_v_count=int(counts["n_dot_v_count"]),
        roughness_count=int(counts["roughness_count"]), texel=texel, method=method, channels=channels,
        parameterization=parameterization, samples=int(samples), replicates=int(replicates), seed=int(seed),
        threads=int(threads), fast_math=bool(fast_math), **_options.where(backend, device))
    native = _core.bake_dfg(options, _progress("ibl dfg", progress))
    return DfgLut(native)


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
    fis: bool = True,
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
    no_fis: Optional[bool] = None,
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
        fis: filtered importance sampling; False reads every sample from the full-resolution source
            (``--no-fis``; no_fis=True is the deprecated spelling of fis=False).
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
    if no_fis is not None:
        if fis is not True:
            raise TypeError("ibl_prefilter() got both no_fis= and fis= (give fis= only)")
        fis = not _deprecated_alias("ibl_prefilter", "no_fis", "fis", bool(no_fis), None)
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
    options = _options.build(
        "PrefilterOptions", environment=_options.environment(image, files), size=int(size), levels=int(levels),
        mapping=mapping, tolerance=_real("tolerance", tolerance, 0, 1), samples=int(samples),
        max_samples=int(max_samples), replicates=int(replicates), seed=int(seed), fis=bool(fis),
        lod_bias=_real("lod_bias", lod_bias, -16, 16), bright=bright,
        bright_threshold=_real("bright_threshold", bright_threshold, 0, 1e12),
        bright_min_roughness=_real("bright_min_roughness", bright_min_roughness, 0, 1),
        wide_samples_factor=int(wide_samples_factor), bright_max=int(bright_max),
        # No device: the C++ path on CPU threads (the struct's empty device).
        device=device or "", threads=int(threads), verify=int(verify), irradiance_size=int(irradiance_size))
    native = _core.prefilter(options, _progress("ibl prefilter", progress))
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
    options = _options.build(
        "IrradianceOptions", environment=_options.environment(image, files), face_size=int(face_size),
        source_size=int(source_size), threads=int(threads), verify=int(verify), **_options.where(backend, device))
    native = _core.irradiance(options, _progress("ibl irradiance", progress))
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
    return ShIrradiance(_core.spherical_harmonics(_options.environment(image, files), int(face_size)))
