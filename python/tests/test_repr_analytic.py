"""repr_bake() and representation lookups, and the analytic terms: the CLI's values on the same inputs."""

import numpy as np
import pytest

import microshadow as ms
from conftest import random_queries, read_csv_columns, write_queries

REPR = dict(kind="azimuth-harmonics", visibility_count=4, n_dot_l_count=4, n_dot_v_count=3, azimuth_nodes=7,
            roughness=[0.3, 0.9], tolerance=1e-6, backend="oracle")
REPR_CLI = ["--kind", "azimuth-harmonics", "--visibility-count", "4", "--n-dot-l-count", "4", "--n-dot-v-count", "3",
            "--azimuth-nodes", "7", "--roughness", "0.3,0.9", "--tolerance", "1e-6", "--backend", "oracle", "-q"]


@pytest.fixture(scope="module")
def representation():
    return ms.repr_bake(**REPR)


def _compare_columns(cli, tmp_path, queries, *compare):
    write_queries(tmp_path / "q.csv", *queries)
    args = []
    for c in compare:
        args += ["--compare", c]
    cli("eval", "--in", tmp_path / "q.csv", "--out", tmp_path / "r.csv", *args, "--backend", "oracle",
        "--tolerance", "1e-4", "-q")
    return read_csv_columns(tmp_path / "r.csv")


def test_lookup_inputs_are_the_normalised_directions_and_their_azimuth():
    got = ms.lookup_inputs([0.5, 0.7], [0.09, 0.04], [0.09, 0.36], [[0, 0, 2], [3, 0, 4]], [[0, 0.6, 0.8], [0, -3, 4]])
    np.testing.assert_allclose(got["n_dot_v"], [1.0, 0.8])
    np.testing.assert_allclose(got["n_dot_l"], [0.8, 0.8])
    np.testing.assert_allclose(got["roughness"], [0.3, np.sqrt(0.12)])
    np.testing.assert_allclose(got["relative_azimuth_deg"], [0.0, 90.0])  # wi along the normal: 0
    np.testing.assert_array_equal(got["visibility"], [0.5, 0.7])


def test_repr_bake_gives_the_clis_file(cli, representation, tmp_path):
    cli("repr", "bake", "--out", tmp_path / "cli.exr", *REPR_CLI)
    back = ms.open(tmp_path / "cli.exr")
    assert isinstance(back, ms.Representation) and back.kind == "azimuth-harmonics"
    np.testing.assert_array_equal(representation.data, back.data)
    representation.save(tmp_path / "py.exr")
    again = ms.open(tmp_path / "py.exr")
    np.testing.assert_array_equal(again.data, back.data)
    assert again.metadata["kind"] == "representation"


def test_representation_lookup_is_the_clis_compare_column(cli, representation, tmp_path):
    representation.save(tmp_path / "h.exr")
    queries = random_queries(20, seed=4)
    cols = _compare_columns(cli, tmp_path, queries, f"h={tmp_path / 'h.exr'}")
    want = np.array([float(x) for x in cols["h"]])
    got = ms.open(tmp_path / "h.exr").lookup(**ms.lookup_inputs(*queries))
    # The CLI reads the azimuth in radians from atan2; here it goes through degrees and back.
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="relative_azimuth_deg: required"):
        representation.lookup(0.5, 0.5, 0.5, roughness=0.5)


def test_repr_formats_and_bad_options(representation, tmp_path):
    for name in ("r.ktx2", "r.dds"):
        representation.save(tmp_path / name)
        np.testing.assert_array_equal(ms.open(tmp_path / name).data, representation.data)
    with pytest.raises(ValueError, match="written as .exr, .ktx2 or .dds"):
        representation.save(tmp_path / "r.png")
    with pytest.raises(ValueError, match="kind = 'azimuth-table'"):
        ms.repr_bake(kind="azimuth-table")
    with pytest.raises(ValueError, match=r"roughness\[1\] = 0.3: the nodes must increase"):
        ms.repr_bake(kind="azimuth-axis", roughness=[0.5, 0.3])


def test_repr_bake_preset_gives_the_clis_preset_file(cli, tmp_path):
    # The default preset, as `repr bake --preset full-range` bakes it (the exact term at its 512 KiB grid).
    cli("repr", "bake", "--preset", "full-range", "--backend", "oracle", "--out", tmp_path / "cli.exr", "-q")
    back = ms.open(tmp_path / "cli.exr")
    rep = ms.repr_bake(preset="full-range", backend="oracle")
    assert rep.kind == back.kind == "azimuth-harmonics"
    assert rep.metadata["preset"] == "full-range"
    np.testing.assert_array_equal(rep.data, back.data)
    with pytest.raises(ValueError, match="preset = 'full-range' sets the whole layout: kind, visibility_count"):
        ms.repr_bake(preset="full-range", kind="azimuth-axis", visibility_count=8)
    with pytest.raises(ValueError, match="preset = 'fullrange': one of"):
        ms.repr_bake(preset="fullrange")
    with pytest.raises(ValueError, match="kind: required for a custom layout"):
        ms.repr_bake()


def test_analytic_terms_are_the_clis_compare_columns(cli, tmp_path):
    queries = random_queries(20, seed=9)
    cols = _compare_columns(cli, tmp_path, queries, *ms.ANALYTIC_TERMS)
    inputs = ms.lookup_inputs(*queries)
    v, nl, nv, r = inputs["visibility"], inputs["n_dot_l"], inputs["n_dot_v"], inputs["roughness"]
    for name in ms.ANALYTIC_TERMS:
        want = np.array([float(x) for x in cols[name]])
        np.testing.assert_array_equal(ms.analytic(name, v, nl, nv, roughness=r), want, err_msg=name)


def test_analytic_terms_broadcast_and_refuse_bad_input():
    grid = ms.analytic("naughty-dog", np.linspace(0, 1, 4)[:, None], np.linspace(0, 1, 3))
    assert grid.shape == (4, 3)
    np.testing.assert_allclose(grid, np.clip(np.linspace(0, 1, 3) + 2 * np.linspace(0, 1, 4)[:, None] ** 2 - 1, 0, 1))
    uniform = ms.analytic("reference-step", 0.5, 0.45, ao_weighting="uniform")
    assert uniform == 0.0  # cone cos 1 - v = 0.5 > NdotL
    assert ms.analytic("reference-step", 0.5, 0.45) == 0.0  # cosine cone sqrt(0.5) = 0.707
    assert ms.analytic("reference-step", 0.5, 0.75) == 1.0
    with pytest.raises(ValueError, match="name = 'naughty-cat': one of reference-step"):
        ms.analytic("naughty-cat", 0.5, 0.5)
    with pytest.raises(ValueError, match=r"visibility\[1\] = -0.5: outside \[0, 1\]"):
        ms.analytic("naughty-dog", [0.5, -0.5], 0.5)
