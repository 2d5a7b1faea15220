"""sweep() and ibl_dfg(): the CLI's tables and texels on the same inputs."""

import numpy as np
import pytest

import microshadow as ms
from conftest import read_csv_columns

SPEC = """
[sweep]
name = "python test"
chunk_size = 7

[parameters]
visibility = [0.3, 0.8]
n_dot_l = { start = 0.1, stop = 0.9, count = 3 }
n_dot_v = [0.5, 1.0]
roughness = [0.4, 0.9]
delta_phi = [0.0, 120.0]

[comparators]
analytic = ["naughty-dog", "activision-adjusted"]
"""


def test_sweep_gives_the_clis_table(cli, tmp_path):
    (tmp_path / "s.toml").write_text(SPEC)
    table = ms.sweep(tmp_path / "s.toml", tolerance=1e-6, backend="oracle")
    cli("sweep", tmp_path / "s.toml", "--out", tmp_path / "cli", "--tolerance", "1e-6", "--backend", "oracle", "-q")
    want = read_csv_columns(tmp_path / "cli" / "sweep.csv")
    assert list(table) == list(want)
    assert len(table["term"]) == 2 * 3 * 2 * 2 * 2
    for name, column in want.items():
        if name in ("form", "ao_weighting"):
            assert list(table[name]) == column, name
        else:
            np.testing.assert_array_equal(table[name], np.array([float(x) for x in column]), err_msg=name)
    assert "naughty-dog" in table.summary


def test_sweep_terms_are_evaluate_iso_at_the_same_points():
    table = ms.sweep(toml=SPEC, tolerance=1e-6, backend="oracle")
    term, err = ms.evaluate_iso(table["visibility"], table["n_dot_l"], table["n_dot_v"], roughness=table["roughness"],
                                relative_azimuth_deg=table["delta_phi"], backend="oracle", tolerance=1e-6)
    np.testing.assert_array_equal(term, table["term"])
    np.testing.assert_array_equal(err, table["std_error"])


def test_sweep_keeps_its_outputs_in_out_and_refuses_bad_specs(tmp_path):
    ms.sweep(toml=SPEC, out=tmp_path / "kept", tolerance=1e-6, backend="oracle")
    assert (tmp_path / "kept" / "sweep.csv").is_file()
    with pytest.raises(ValueError, match="parameters.n_dot_v"):
        ms.sweep(toml=SPEC.replace("n_dot_v = [0.5, 1.0]", "n_dot_v = [0.0]"), backend="oracle")
    with pytest.raises(ValueError, match="give spec"):
        ms.sweep()
    with pytest.raises(ValueError, match="method = 'quadrature'"):
        ms.sweep(toml=SPEC, method="quadrature")


def _header_array(path):
    text = path.read_text()
    return text[text.index("static const float"):]


def test_ibl_dfg_gives_the_clis_lut(cli, tmp_path):
    dfg = ms.ibl_dfg(size=4, samples=512, replicates=4, seed=2)
    assert dfg.data.shape == dfg.std_error.shape == (4, 4, 3)
    np.testing.assert_allclose(dfg.data[..., 2], dfg.data[..., 0] + dfg.data[..., 1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(dfg.n_dot_v, [0.125, 0.375, 0.625, 0.875])
    dfg.save(tmp_path / "py.h")
    cli("ibl", "dfg", "--out", tmp_path / "cli.h", "--size", "4", "--samples", "512", "--replicates", "4", "--seed", "2",
        "-q")
    assert _header_array(tmp_path / "py.h") == _header_array(tmp_path / "cli.h")
    assert dfg.metadata["samples"] == 512
    with pytest.raises(ValueError, match="replicates = 1"):
        ms.ibl_dfg(replicates=1)
    with pytest.raises(ValueError, match="extension picks the format"):
        dfg.save(tmp_path / "d.tga")


def test_ibl_dfg_takes_the_clis_method_channels_axis_and_symbol(cli, tmp_path):
    # The exact method with the cloth channel, Filament's channel order and HDRP's sqrt(NdotV) axis: the
    # same texels as the CLI's, and the header under the chosen name.
    dfg = ms.ibl_dfg(size=4, method="exact", channels=["bias", "E", "sheen"], parameterization="sqrt-n-dot-v")
    assert dfg.channels == ["bias", "E", "sheen"]
    assert dfg.data.shape == dfg.std_error.shape == (4, 4, 3)
    np.testing.assert_allclose(dfg.n_dot_v, np.array([0.125, 0.375, 0.625, 0.875]) ** 2, rtol=0, atol=1e-15)
    # The exact method's estimates stay at its ~1e-12 (kDfgExactTolerance = 1e-10 bounds them).
    assert float(dfg.std_error.max()) <= 1e-10
    dfg.save(tmp_path / "py.h", symbol="cloth_dfg")
    cli("ibl", "dfg", "--out", tmp_path / "cli.h", "--size", "4", "--method", "exact", "--channels", "bias,E,sheen",
        "--parameterization", "sqrt-n-dot-v", "--symbol", "cloth_dfg", "-q")
    assert "static const float cloth_dfg_data[CLOTH_DFG_DEPTH * CLOTH_DFG_HEIGHT * CLOTH_DFG_WIDTH * 3u]" in (tmp_path / "py.h").read_text()
    assert _header_array(tmp_path / "py.h") == _header_array(tmp_path / "cli.h")
    # Bad values are refused with the option's name, before any work.
    with pytest.raises(ValueError, match="method"):
        ms.ibl_dfg(method="monte-carlo")
    with pytest.raises(ValueError, match="parameterization"):
        ms.ibl_dfg(parameterization="log")
    with pytest.raises(ValueError, match="sheen|channel"):
        ms.ibl_dfg(size=2, method="exact", channels="scale,gloss")
    with pytest.raises(ValueError, match="contradicts"):
        ms.ibl_dfg(size=2, method="exact", backend="oracle")
    with pytest.raises(ValueError, match="symbol"):
        dfg.save(tmp_path / "bad.h", symbol="2bad")
    assert not (tmp_path / "bad.h").exists()
