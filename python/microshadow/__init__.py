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

Where things are (each module one job, as the CLI's commands): _checks.py (the argument checks every job
shares), _options.py (each job's C++ options struct built from its keyword arguments, in one place),
_evaluate.py, _files.py (Lut, Representation, open), _bake.py (bake, repr_bake), _analytic.py, _sweep.py,
_ibl.py, _area.py, _scene.py, _design.py; the C++ bindings in python/src/, one file per job.
"""

from __future__ import annotations

from . import _microshadow as _core
from ._analytic import ANALYTIC_TERMS, analytic
from ._area import AreaResult, area_eval
from ._bake import REPR_PRESETS, bake, repr_bake
from ._checks import ArrayLike, PathArg, ProgressArg  # noqa: F401 - the type aliases of the signatures
from ._design import DesignTable, design
from ._evaluate import evaluate, evaluate_iso, lookup_inputs
from ._files import Lut, Representation, open  # noqa: A004 - the module's open, as in PIL / h5py
from ._ibl import (DfgLut, IrradianceMap, PrefilteredEnvironment, ShIrradiance, ibl_dfg, ibl_irradiance, ibl_prefilter,
                   ibl_sh)
from ._scene import SceneRun, scene
from ._sweep import SweepTable, sweep

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

# The public classes show as microshadow.X (in help() and reprs), wherever they are defined.
for _public in (Lut, Representation, SweepTable, DfgLut, AreaResult, SceneRun, PrefilteredEnvironment, IrradianceMap,
                ShIrradiance, DesignTable):
    _public.__module__ = __name__
del _public
