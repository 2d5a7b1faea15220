"""bake(), Lut, open() and lookup: the CLI's texels and lookups on the same options, every file format."""

import numpy as np
import pytest

import microshadow as ms
from conftest import random_queries, read_csv_columns, write_queries

BAKE = dict(layout="custom", size=4, n_dot_v_count=3, roughness=[0.3, 0.8], backend="oracle", samples=256, seed=5)
BAKE_CLI = ["--layout", "custom", "--size", "4", "--size-n-dot-v", "3", "--roughness", "0.3,0.8", "--backend", "oracle",
            "--samples", "256", "--seed", "5", "-q"]


@pytest.fixture(scope="module")
def lut():
    return ms.bake(**BAKE)


def test_bake_gives_the_clis_texels(cli, lut, tmp_path):
    cli("bake", "--out", tmp_path / "cli.exr", *BAKE_CLI)
    back = ms.open(tmp_path / "cli.exr")
    assert isinstance(back, ms.Lut)
    np.testing.assert_array_equal(lut.data, back.data)
    assert lut.data.shape == (3, 4, 4, 2) and lut.data.dtype == np.float32
    np.testing.assert_array_equal(lut.roughness, [0.3, 0.8])
    np.testing.assert_allclose(lut.n_dot_l, [0.125, 0.375, 0.625, 0.875])
    assert lut.metadata["layout"] == back.metadata["layout"] == "custom"
    assert lut.metadata["samples"] == back.metadata["samples"]
    assert 0 < lut.max_total_error < 0.5


@pytest.mark.parametrize("name, tolerance", [("l.exr", 0), ("l.ktx2", 0), ("l.dds", 0), ("l.h", 0),
                                             ("l16.exr", 2.0**-12), ("l.png", 0.5 / 255)])
def test_every_format_opens_again(lut, tmp_path, name, tolerance):
    encoding = "float16" if name.startswith("l16") else None
    lut.save(tmp_path / name, encoding=encoding)
    back = ms.open(tmp_path / name)
    np.testing.assert_allclose(back.data, lut.data, rtol=0, atol=tolerance + 1e-7)


def test_lookup_is_the_clis_compare_column(cli, lut, tmp_path):
    lut.save(tmp_path / "l.exr")
    v, ax, ay, wi, wo = random_queries(25, seed=11)
    write_queries(tmp_path / "q.csv", v, ax, ay, wi, wo)
    cli("eval", "--in", tmp_path / "q.csv", "--out", tmp_path / "r.csv", "--compare", f"lut={tmp_path / 'l.exr'}",
        "--backend", "oracle", "--tolerance", "1e-4", "-q")
    want = np.array([float(x) for x in read_csv_columns(tmp_path / "r.csv")["lut"]])
    got = lut.lookup(**ms.lookup_inputs(v, ax, ay, wi, wo))
    np.testing.assert_array_equal(got, want)


def test_lookup_broadcasts_and_refuses_nan(lut):
    grid = lut.lookup(np.linspace(0, 1, 5)[:, None], np.linspace(0, 1, 3)[None, :], 0.8, roughness=0.5)
    assert grid.shape == (5, 3)
    assert grid[0, 0] == lut.lookup(0.0, 0.0, 0.8, roughness=0.5)
    assert lut.lookup(0.5, 0.5, 0.5, roughness=0.5, relative_azimuth_deg=30.0) == lut.lookup(0.5, 0.5, 0.5, roughness=0.5)
    with pytest.raises(ValueError, match=r"n_dot_v\[2\] = nan"):
        lut.lookup(0.5, 0.5, [0.5, 0.6, np.nan], roughness=0.5)
    with pytest.raises(ValueError, match="do not broadcast"):
        lut.lookup([0.5, 0.6], [0.5, 0.6, 0.7], 0.5, roughness=0.5)
    with pytest.raises(TypeError):
        lut.lookup(0.5, 0.5, 0.5, 0.5)  # roughness by name only


def test_bake_refuses_bad_options():
    with pytest.raises(ValueError, match="roughness needs layout='custom'"):
        ms.bake(roughness=[0.5])
    with pytest.raises(ValueError, match=r"roughness\[1\] = 1.5: outside \(0, 1\]"):
        ms.bake(layout="custom", roughness=[0.5, 1.5])
    with pytest.raises(ValueError, match="layout = 'seed-4d'"):
        ms.bake(layout="seed-4d")
    with pytest.raises(ValueError, match="size = 0"):
        ms.bake(size=0)
    with pytest.raises(ValueError, match="azimuth = 200"):
        ms.bake(azimuth=200)
    with pytest.raises(ValueError, match="not both"):
        ms.bake(samples=1024, tolerance=1e-3)
    with pytest.raises(ValueError, match="encoding = 'float8'"):
        ms.bake(**BAKE).save("x.exr", encoding="float8")


def test_a_fixed_azimuth_bake_gives_the_clis_texels(cli, tmp_path):
    got = ms.bake(layout="custom", size=3, n_dot_v_count=2, roughness=[0.6], azimuth=45.0, method="exact",
                  tolerance=1e-5, backend="oracle")
    cli("bake", "--out", tmp_path / "a.exr", "--layout", "custom", "--size", "3", "--size-n-dot-v", "2", "--roughness",
        "0.6", "--azimuth", "45", "--method", "exact", "--tolerance", "1e-5", "--backend", "oracle", "-q")
    np.testing.assert_array_equal(got.data, ms.open(tmp_path / "a.exr").data)


def test_open_names_a_missing_or_foreign_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.exr"):
        ms.open(tmp_path / "nope.exr")
    (tmp_path / "junk.exr").write_bytes(b"not an image")
    with pytest.raises(RuntimeError, match="junk.exr"):
        ms.open(tmp_path / "junk.exr")
