"""The argument checks every job shares: arrays of numbers, ranges, broadcasting, choices, counts and the
progress argument. Each raises ValueError naming the argument and the index of the first bad element."""

from __future__ import annotations

import os
import sys
import time
import warnings
from typing import Callable, Dict, Sequence, Tuple, Union

import numpy as np

ArrayLike = Union[float, Sequence[float], np.ndarray]
ProgressArg = Union[bool, Callable[[int, int], object], None]
PathArg = Union[str, "os.PathLike[str]"]


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
        if np.ma.isMaskedArray(value) and np.ma.getmaskarray(value).any():
            # np.asarray would hand over the values under the mask as if they were given.
            raise ValueError("masked values: give plain numbers")
        a = np.asarray(value)
        # Converting complex numbers to float64 would drop their imaginary parts with only a warning; dates,
        # durations, records and text would convert to numbers that mean nothing here.
        if np.iscomplexobj(a):
            raise ValueError("complex numbers: give real ones")
        if a.dtype.kind in "MmVUS":
            raise ValueError(f"{a.dtype} values: give real numbers")
        a = a.astype(np.float64, copy=False)
    except (TypeError, ValueError, OverflowError) as e:
        raise ValueError(f"{name}: not an array of numbers ({e})") from None
    return a


# Bytes a query needs while it is evaluated: its 9 input and 2 output float64 columns, the rows handed to
# the library and the library's own copies of both, with room to spare.
_BYTES_PER_QUERY = 512


# Bytes a lookup or an analytic value needs: its 5 input columns, the output and the engine's copy.
_BYTES_PER_LOOKUP = 128


def _check_memory(what: str, count: int, bytes_each: int = _BYTES_PER_QUERY) -> None:
    """MemoryError at once, before any work, for a call whose queries cannot fit in this machine's memory."""
    try:
        physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return  # no figure on this platform: numpy's own MemoryError is the answer
    needed = count * bytes_each
    if needed > physical:
        raise MemoryError(f"{count} {what} need about {needed / 2**30:.0f} GiB, more than this machine's "
                          f"{physical / 2**30:.0f} GiB of memory: split the call")


def _broadcast_shape(what: str, arrays: Dict[str, np.ndarray], bytes_each: int = _BYTES_PER_LOOKUP) -> Tuple[int, ...]:
    """The shape `arrays` broadcast to, from their shapes alone: ValueError when they do not broadcast,
    MemoryError when the result cannot fit in memory (at once: before a check reads any element of a
    broadcast view of a billion values)."""
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in arrays.items())
        raise ValueError(f"{what}: the arguments do not broadcast ({shapes})") from None
    _check_memory("values", int(np.prod(shape, dtype=np.float64)), bytes_each)
    return shape


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

def _real(name: str, value: float, lo: float, hi: float) -> float:
    v = float(value)
    if not (np.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} = {_shown(value)!r}: a number from {lo:g} to {hi:g}")
    return v


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


def _renamed_keyword(function: str, old: str, new: str, old_value, new_value):
    """The value of keyword `new` (None: not given) when its deprecated spelling `old` may have been given
    instead: DeprecationWarning for `old`, TypeError when both are. For array arguments, whose truth is
    not a test of being given."""
    if old_value is None:
        return new_value
    warnings.warn(f"{function}({old}=) is deprecated: use {new}=", DeprecationWarning, stacklevel=3)
    if new_value is not None:
        raise TypeError(f"{function}() got both {old}= and {new}= (give {new}= only)")
    return old_value


def _deprecated_alias(function: str, old: str, new: str, old_value, new_value):
    """The value of keyword `new` when its deprecated spelling `old` may have been given instead:
    DeprecationWarning for `old`, TypeError when both are."""
    if old_value is None:
        return new_value
    warnings.warn(f"{function}({old}=) is deprecated: use {new}=", DeprecationWarning, stacklevel=3)
    if new_value:
        raise TypeError(f"{function}() got both {old}= and {new}= (the same count; give {new}= only)")
    return old_value
