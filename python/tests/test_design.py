"""design: bad input, and the same table as `microshadow design` on the same reference spec."""

import csv
import json

import numpy as np
import pytest

import microshadow as ms

REFERENCE = """
name = "tiny"
[points]
count = 96
seed = 2
visibility = [0.3, 1.0]
roughness = [0.2, 1.0]
n_dot_v = [0.2, 1.0]
[sampling]
method = "exact"
tolerance = 1e-6
"""

FIT = REFERENCE.replace('name = "tiny"', 'name = "tiny-fit"').replace("seed = 2", "seed = 5")


@pytest.fixture
def specs(tmp_path):
    (tmp_path / "ref.toml").write_text(REFERENCE)
    (tmp_path / "fit.toml").write_text(FIT)
    return tmp_path / "ref.toml", tmp_path / "fit.toml"


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_design_matches_cli(cli, specs, tmp_path):
    ref, fit = specs
    lut = ms.bake(layout="custom", size=4, roughness=[0.3, 0.8], samples=256)
    lut.save(tmp_path / "small.exr")
    cli("design", "--reference", ref, "--fit-reference", fit, "--fit-orders", "1", "--lut", f"small={tmp_path / 'small.exr'}",
        "--max-bytes", "1024", "--cache", tmp_path / "cli-cache", "--out", tmp_path / "cli", "-q")
    # Another cache: the reference sets are computed again, to the same bits.
    table = ms.design(ref, fit_reference=fit, fit_orders=[1], luts=[f"small={tmp_path / 'small.exr'}"], max_bytes=1024,
                      cache=tmp_path / "py-cache")
    rows = read_rows(tmp_path / "cli" / "pareto.csv")
    assert table["name"].tolist() == [r["name"] for r in rows]
    assert "small" in table["name"] and "closed-form-1" in table["name"]
    for column in ("kind", "storage"):
        assert table[column].tolist() == [r[column] for r in rows], column
    for column in ("bytes", "fetches_per_light", "alu_per_light", "outside_domain"):
        assert table[column].tolist() == [int(r[column]) for r in rows], column
    for column in ("weighted_rms", "weighted_p99", "max_abs"):
        assert table[column].tolist() == [float(r[column]) for r in rows], column
    for column in ("pareto", "chosen", "within_budget"):
        assert table[column].tolist() == [r[column] == "1" for r in rows], column
    meta = json.loads((tmp_path / "cli" / "design.json").read_text())
    assert table.chosen == meta["chosen"]
    assert table.by_roughness["edges"].tolist() == meta["by_roughness"]["edges"]
    for k, name in enumerate(table["name"]):
        bands = meta["by_roughness"]["candidates"][name]
        assert table.by_roughness["weighted_rms"][k].tolist() == [b["weighted_rms"] for b in bands]
        assert table.by_roughness["points"][k].tolist() == [b["points"] for b in bands]
    assert table.reference["points"] == 96
    assert table.reference["max_std_error"] == meta["reference"]["max_std_error"]


def test_design_reads_its_cache_and_reports_progress(specs, tmp_path):
    ref, _ = specs
    seen = []
    first = ms.design(ref, cache=tmp_path / "cache", progress=lambda d, t: seen.append((d, t)))
    assert seen and seen[-1] == (96, 96)
    again = ms.design(ref, cache=tmp_path / "cache", max_bytes=0)
    assert again["weighted_rms"].tolist() == first["weighted_rms"].tolist()
    assert again.reference["file"] == first.reference["file"]
    # A budget of no bytes: the chosen candidate is one of part 1's formulas (no texture).
    assert again["bytes"][again["chosen"]].tolist() == [0]


def test_design_bad_input(specs, tmp_path):
    ref, fit = specs
    cache = tmp_path / "cache"
    with pytest.raises(ValueError, match=r"fit_orders\[1\] = 7"):
        ms.design(ref, fit_reference=fit, fit_orders=[1, 7], cache=cache)
    with pytest.raises(ValueError, match=r"max_bytes = -1"):
        ms.design(ref, max_bytes=-1, cache=cache)
    with pytest.raises(ValueError, match=r"choose = 'nothing': no such candidate"):
        ms.design(ref, choose="nothing", cache=cache)
    with pytest.raises(ValueError, match=r"no candidates"):
        ms.design(ref, analytic=False, cache=cache)
    with pytest.raises(ValueError, match=r"luts: a list"):
        ms.design(ref, luts=str(tmp_path / "x.exr"), cache=cache)
    with pytest.raises(ValueError, match=r"candidate name"):
        ms.design(ref, luts=["a,b=x.exr"], cache=cache)
    (tmp_path / "bad.toml").write_text(REFERENCE.replace("count = 96", "count = -3"))
    with pytest.raises(ValueError, match=r"bad\.toml"):
        ms.design(tmp_path / "bad.toml", cache=cache)
    with pytest.raises(FileNotFoundError):
        ms.design(tmp_path / "missing.toml", cache=cache)
    # Every refusal came before any work: nothing was computed or cached.
    assert not cache.exists() or not any(cache.iterdir())


def test_design_interrupt_keeps_no_finished_set(specs, tmp_path):
    ref, _ = specs

    def stop(done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        ms.design(ref, cache=tmp_path / "cache", progress=stop)
    assert not list((tmp_path / "cache").glob("reference-*.csv"))
