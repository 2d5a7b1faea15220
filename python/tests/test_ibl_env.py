"""ibl_prefilter, ibl_irradiance and ibl_sh: bad input, and the same values as `microshadow ibl prefilter |
irradiance | sh` on the same environment."""

import json

import numpy as np
import pytest

import microshadow as ms

from conftest import read_scanline_exr, write_hdr

# Horizontal cross: row 0 holds +Y above +Z, row 1 -X +Z +X -Z, row 2 -Y below +Z; faces +X -X +Y -Y +Z -Z.
CROSS_ORIGIN = [(2, 1), (0, 1), (1, 0), (1, 2), (1, 1), (3, 1)]


def cross_faces(path):
    """An EXR horizontal cross as (6, n, n, 3) faces."""
    planes = read_scanline_exr(path)
    rgb = np.stack([planes["R"], planes["G"], planes["B"]], axis=-1)
    n = rgb.shape[1] // 4
    return np.stack([rgb[y * n:(y + 1) * n, x * n:(x + 1) * n] for x, y in CROSS_ORIGIN])


@pytest.fixture(scope="module")
def environment(tmp_path_factory):
    """A 32 x 16 equirectangular sky: a smooth gradient and a small bright sun (8^2 cube faces)."""
    h, w = 16, 32
    y, x = np.mgrid[0:h, 0:w]
    rgb = np.stack([0.2 + 0.6 * (1 - y / h), 0.3 + 0.2 * x / w, 0.5 + 0.4 * (1 - y / h)], axis=-1)
    rgb[3, 20] = [40.0, 35.0, 30.0]
    path = tmp_path_factory.mktemp("env") / "sky.hdr"
    write_hdr(path, rgb)
    return path


def _without_run(meta):
    """Metadata without what depends on the run rather than the inputs (time, command line)."""
    if isinstance(meta, dict):
        return {k: _without_run(v) for k, v in meta.items()
                if k not in ("seconds", "cpu_seconds", "command_line", "samples_per_second")}
    if isinstance(meta, list):
        return [_without_run(v) for v in meta]
    return meta


def test_prefilter_matches_cli(cli, environment, tmp_path):
    cli("ibl", "prefilter", environment, "--out", tmp_path / "cli", "--samples", "64", "--irradiance-size", "4", "--format", "exr", "-q")
    env = ms.ibl_prefilter(environment, samples=64, irradiance_size=4)
    assert [m.shape for m in env.mips] == [(6, 8, 8, 3), (6, 4, 4, 3)]
    assert env.roughness.tolist() == [0.0, 1.0]
    for m, mip in enumerate(env.mips):
        assert np.array_equal(mip, cross_faces(tmp_path / "cli" / f"specular_m{m}.exr")), m
    assert np.array_equal(env.irradiance, cross_faces(tmp_path / "cli" / "irradiance.exr"))
    cli_meta = json.loads((tmp_path / "cli" / "ibl.json").read_text())
    assert _without_run(env.metadata) == _without_run(cli_meta)
    assert env.sh.tolist() == cli_meta["irradiance"]["radiance_sh"]
    env.save(tmp_path / "py")
    assert sorted(p.name for p in (tmp_path / "py").iterdir()) == sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert np.array_equal(cross_faces(tmp_path / "py" / "specular_m1.exr"), env.mips[1])


def test_prefilter_saves_ktx2(environment, tmp_path):
    env = ms.ibl_prefilter(environment, samples=16, levels=1, irradiance_size=2)
    env.save(tmp_path / "out", format="ktx2", encoding="float32")
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert "specular.ktx2" in names and "irradiance.ktx2" in names and "ibl.json" in names


def test_irradiance_matches_cli(cli, environment, tmp_path):
    cli("ibl", "irradiance", environment, "--out", tmp_path / "cli", "--face-size", "4", "--source-size", "8", "-q")
    irr = ms.ibl_irradiance(environment, face_size=4, source_size=8)
    assert irr.data.shape == (6, 4, 4, 3) and irr.bound.shape == (6, 4, 4, 3)
    assert np.array_equal(irr.data, cross_faces(tmp_path / "cli" / "irradiance.exr"))
    cli_meta = json.loads((tmp_path / "cli" / "irradiance.json").read_text())
    assert _without_run(irr.metadata) == _without_run(cli_meta)
    assert (irr.bound >= 0).all()
    irr.save(tmp_path / "py", format="dds")
    assert sorted(p.name for p in (tmp_path / "py").iterdir()) == [
        "irradiance.dds", "irradiance.dds.json", "irradiance.json", "irradiance_preview.png"]


def test_sh_matches_cli(cli, environment, tmp_path):
    cli("ibl", "sh", environment, "--out", tmp_path / "sh.json", "--irradiance", tmp_path / "irr.exr", "--face-size", "4",
        "-q")
    sh = ms.ibl_sh(environment, face_size=4)
    cli_meta = json.loads((tmp_path / "sh.json").read_text())
    assert sh.coefficients.tolist() == cli_meta["radiance_sh"]
    assert _without_run(sh.metadata) == _without_run(cli_meta)
    assert np.array_equal(sh.irradiance, cross_faces(tmp_path / "irr.exr"))
    sh.save(tmp_path / "py.json", shader=tmp_path / "sh.glsl", symbol="sky")
    assert "sky_irradiance" in (tmp_path / "sh.glsl").read_text()
    assert json.loads((tmp_path / "py.json").read_text())["radiance_sh"] == cli_meta["radiance_sh"]


def test_sh_save_is_all_or_nothing(environment, tmp_path):
    sh = ms.ibl_sh(environment, face_size=2)
    with pytest.raises(ValueError, match=r"sky\.txt"):
        sh.save(tmp_path / "sh.json", shader=tmp_path / "sky.txt")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "call, kwargs, message",
    [
        (ms.ibl_prefilter, {"size": 12}, r"size = 12: a power of two"),
        (ms.ibl_prefilter, {"samples": 8}, r"samples = 8: an integer from 16"),
        (ms.ibl_prefilter, {"mapping": "log"}, r"mapping = 'log'"),
        (ms.ibl_prefilter, {"lod_bias": float("nan")}, r"lod_bias = nan"),
        (ms.ibl_prefilter, {"bright_min_roughness": 2.0}, r"bright_min_roughness = 2.0"),
        (ms.ibl_prefilter, {"levels": 9}, r"levels 9 is too many for faces of 8"),
        (ms.ibl_irradiance, {"face_size": 0}, r"face_size = 0"),
        (ms.ibl_irradiance, {"backend": "gpu"}, r"backend = 'gpu'"),
        (ms.ibl_sh, {"face_size": 2000}, r"face_size = 2000"),
    ],
)
def test_bad_input(environment, call, kwargs, message):
    with pytest.raises(ValueError, match=message):
        call(environment, **kwargs)


def test_environment_arguments(environment, tmp_path):
    with pytest.raises(ValueError, match="one of them"):
        ms.ibl_sh()
    with pytest.raises(ValueError, match="one of them"):
        ms.ibl_sh(environment, faces=[environment] * 6)
    with pytest.raises(ValueError, match=r"faces: 5 files"):
        ms.ibl_irradiance(faces=[environment] * 5)
    with pytest.raises(FileNotFoundError, match=r"faces\[2\]"):
        ms.ibl_prefilter(faces=[environment, environment, tmp_path / "no.hdr"] + [environment] * 3)
    with pytest.raises(FileNotFoundError):
        ms.ibl_irradiance(tmp_path / "no.hdr")
    (tmp_path / "bad.hdr").write_bytes(b"not an image")
    with pytest.raises(ValueError, match=r"bad\.hdr"):
        ms.ibl_sh(tmp_path / "bad.hdr")
    env = ms.ibl_irradiance(environment, face_size=2, source_size=4)
    with pytest.raises(ValueError, match=r"format = 'png'"):
        env.save(tmp_path / "out", format="png")
    assert not (tmp_path / "out").exists()


def test_prefilter_progress_and_interrupt(environment, tmp_path):
    def stop(done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        ms.ibl_prefilter(environment, samples=16, progress=stop)
    seen = []
    ms.ibl_prefilter(environment, samples=16, progress=lambda d, t: seen.append((d, t)))
    assert seen and seen[-1][0] == seen[-1][1]


def test_prefilter_fis_is_the_cli_no_fis_and_no_fis_still_works_with_a_warning(cli, environment, tmp_path):
    cli("ibl", "prefilter", environment, "--out", tmp_path / "cli", "--samples", "16", "--levels", "2", "--irradiance-size", "2",
        "--format", "exr", "--no-fis", "-q")
    unfiltered = ms.ibl_prefilter(environment, samples=16, levels=2, irradiance_size=2, fis=False)
    assert np.array_equal(unfiltered.mips[1], cross_faces(tmp_path / "cli" / "specular_m1.exr"))
    assert not np.array_equal(unfiltered.mips[1], ms.ibl_prefilter(environment, samples=16, levels=2, irradiance_size=2).mips[1])
    with pytest.warns(DeprecationWarning, match=r"ibl_prefilter\(no_fis=\) is deprecated: use fis="):
        old = ms.ibl_prefilter(environment, samples=16, levels=2, irradiance_size=2, no_fis=True)
    assert np.array_equal(old.mips[1], unfiltered.mips[1])
    with pytest.raises(TypeError, match="both no_fis= and fis="):
        ms.ibl_prefilter(environment, fis=False, no_fis=True)
    with pytest.raises(ValueError, match="bright"):
        ms.ibl_prefilter(environment, bright="Auto")
