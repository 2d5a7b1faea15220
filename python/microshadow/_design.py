"""design(): every candidate representation against a reference set (``microshadow design``)."""

from __future__ import annotations

import os
from typing import Dict, List, Optional, Sequence

import numpy as np

from . import _microshadow as _core
from . import _options
from ._checks import _BACKENDS, _choice, _count, PathArg, _progress, ProgressArg, _shown


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
    options = _options.build(
        "DesignOptions", reference=spec, fit_reference=fit, cache=os.fspath(cache), luts=_files("luts", luts),
        reprs=_files("reprs", reprs), closed_forms=_files("closed_forms", closed_forms), fit_orders=orders,
        max_bytes=budget["max_bytes"], max_fetches=budget["max_fetches"], max_alu=budget["max_alu"],
        choose=choose or "", analytic=bool(analytic), strict_domain=bool(strict_domain),
        **_options.where(backend, device))
    table, by_roughness, chosen, ref = _core.design(options, _progress("design", progress))
    return DesignTable(table, by_roughness, chosen, ref)
