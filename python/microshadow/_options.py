"""Each job's C++ options struct (include/microshadow/*.hpp), built from the keyword arguments of its
Python function in one place. The structs are bound field by field (python/src/options.cpp) under the
fields' own names, which are also the Python keywords and, with dashes, the CLI's flags; a name that is not
a field raises AttributeError here, so a keyword and its field cannot drift apart silently."""

from __future__ import annotations

from . import _microshadow as _core


def build(struct: str, **fields):
    """The options struct `struct` (a class of the C++ module) with `fields` set; the rest keep the C++
    defaults."""
    options = getattr(_core, struct)()
    for name, value in fields.items():
        setattr(options, name, value)
    return options


def where(backend, device) -> dict:
    """Where a job runs, as the fields of its struct: every job's backend and device pass through here."""
    return {"backend": backend, "device": device}


def sampling(*, method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend, device,
             fast_math=False, exact_float=False):
    """SamplingOptions: how a job evaluates the term (evaluate, bake, repr_bake, area_eval)."""
    return build("SamplingOptions", method=method, tolerance=float(tolerance), samples=int(samples),
                 replicates=int(replicates), seed=int(seed), sequence=sequence, form=form, ao_weighting=ao_weighting,
                 fast_math=bool(fast_math), exact_float=bool(exact_float), **where(backend, device))


def environment(image: str, faces) -> object:
    """EnvironmentSource: one image, or six face files."""
    return build("EnvironmentSource", image=image, faces=list(faces))
