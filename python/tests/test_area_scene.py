"""area_eval and scene: bad input, and the same values as `microshadow area eval` and `microshadow scene`."""

import csv
import json

import numpy as np
import pytest

import microshadow as ms

from conftest import read_csv_columns, read_scanline_exr, write_grey_png

SPHERE_COLUMNS = ["visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z", "light_x", "light_y", "light_z",
                  "half_angle_deg"]
RECT_COLUMNS = SPHERE_COLUMNS[:6] + [f"p{k}_{a}" for k in range(4) for a in "xyz"]


def sphere_queries(n=6, seed=3):
    rng = np.random.default_rng(seed)
    v = rng.uniform(0.3, 0.95, n)
    ax = rng.uniform(0.1, 0.8, n)
    ay = rng.uniform(0.1, 0.8, n)
    wi = rng.normal(size=(n, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.2
    centre = rng.normal(size=(n, 3))
    centre[:, 2] = np.abs(centre[:, 2]) + 0.1
    half = rng.uniform(2, 30, n)
    return v, ax, ay, wi, centre, half


def rect_corners(n=4):
    # A rectangle tilted a little, above the point, its corners in order round it (c -/+ u -/+ v, u . v = 0).
    c, u, v = np.array([0.0, 0.0, 1.2]), np.array([0.5, 0.0, 0.1]), np.array([0.0, 0.4, 0.0])
    base = np.array([c - u - v, c + u - v, c + u + v, c - u + v])
    return np.stack([base + [0.1 * k, 0.0, 0.0] for k in range(n)])


def write_rows(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow([repr(float(x)) for x in r])


# --- area_eval ------------------------------------------------------------------------------------------


def test_area_sphere_matches_cli(cli, tmp_path):
    v, ax, ay, wi, centre, half = sphere_queries()
    write_rows(tmp_path / "q.csv", SPHERE_COLUMNS, np.column_stack([v, ax, ay, wi, centre, half]))
    cli("area", "eval", "--in", tmp_path / "q.csv", "--out", tmp_path / "r.csv", "--light", "sphere", "--lobe", "lambert",
        "--samples", "1024", "-q")
    got = ms.area_eval(v, ax, ay, wi, light_direction=centre, half_angle_deg=half, lobe="lambert", samples=1024)
    want = read_csv_columns(tmp_path / "r.csv")
    assert got.term.tolist() == [float(x) for x in want["term"]]
    assert got.std_error.tolist() == [float(x) for x in want["std_error"]]
    assert (got.inner_error == 0).all()


def test_area_rect_exact_matches_cli(cli, tmp_path):
    n = 3
    v, ax, ay, wi, _, _ = sphere_queries(n, seed=8)
    corners = rect_corners(n)
    write_rows(tmp_path / "q.csv", RECT_COLUMNS, np.column_stack([v, ax, ay, wi, corners.reshape(n, 12)]))
    cli("area", "eval", "--in", tmp_path / "q.csv", "--out", tmp_path / "r.csv", "--light", "rect", "--method", "exact",
        "--samples", "256", "-q")
    got = ms.area_eval(v, ax, ay, wi, light="rect", corners=corners, method="exact", samples=256)
    want = read_csv_columns(tmp_path / "r.csv")
    for name in ("term", "std_error", "inner_error"):
        assert getattr(got, name).tolist() == [float(x) for x in want[name]], name


def test_area_broadcasts_one_light_over_surfaces():
    v, ax, ay, wi, _, _ = sphere_queries(3)
    one = ms.area_eval(v, ax, ay, wi, light_direction=[0, 0.3, 1], half_angle_deg=10, samples=256)
    each = ms.area_eval(v, ax, ay, wi, light_direction=np.tile([0, 0.3, 1], (3, 1)), half_angle_deg=[10] * 3, samples=256)
    assert one.term.tolist() == each.term.tolist()
    assert one.term.shape == (3,)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"half_angle_deg": [5, 90, 10]}, r"half_angle_deg\[1\] = 90.0: outside \(0, 90\)"),
        ({"half_angle_deg": [5, np.nan, 10]}, r"half_angle_deg\[1\] = nan: not a finite number"),
        ({"light_direction": [[0, 0, 1], [0, 0, 0], [0, 0, 1]]}, r"light_direction\[1\] = .*zero-length"),
        ({"light_direction": [[0, 0, 1]] * 2}, r"do not broadcast"),
        ({"light_direction": [0, 1]}, r"light_direction: shape \(2,\)"),
        ({"visibility": [0.5, 1.5, 0.5]}, r"visibility\[1\] = 1.5: outside \[0, 1\]"),
        ({"lobe": "phong"}, r"lobe = 'phong'"),
        ({"tolerance": 1e-6}, r"tolerance applies to method='exact' only"),
        ({"method": "exact", "device": "0"}, r"device applies to method='sampled' only"),
        ({"samples": 8}, r"samples = 8"),
        ({"corners": rect_corners(3)}, r"corners are a rect light's"),
    ],
)
def test_area_bad_input(kwargs, message):
    args = {"visibility": [0.5, 0.6, 0.7], "light_direction": [0, 0, 1], "half_angle_deg": 10}
    args.update(kwargs)
    visibility = args.pop("visibility")
    with pytest.raises(ValueError, match=message):
        ms.area_eval(visibility, 0.3, 0.3, [0, 0, 1], **args)


def test_area_rect_bad_corners():
    with pytest.raises(ValueError, match=r"corners: shape \(3, 3\)"):
        ms.area_eval(0.5, 0.3, 0.3, [0, 0, 1], light="rect", corners=np.ones((3, 3)))
    bad = rect_corners(2)
    bad[1, 2, 0] = np.inf
    with pytest.raises(ValueError, match=r"corners\[1, 2, 0\] = inf"):
        ms.area_eval(0.5, 0.3, 0.3, [0, 0, 1], light="rect", corners=bad)
    # Corners that are no rectangle: the library's own check, naming the query.
    skew = rect_corners(2)
    skew[1, 2] = [3.0, 3.0, 0.2]
    with pytest.raises(ValueError, match=r"query 1: "):
        ms.area_eval(0.5, 0.3, 0.3, [0, 0, 1], light="rect", corners=skew)


# --- scene ----------------------------------------------------------------------------------------------


SCENE = """
[normal]
value = [0.1, 0.0, 1.0]
[visibility]
file = "ao.png"
[roughness]
value = 0.45
[view]
direction = [0.3, 0.2, 0.9]
[[light]]
name = "key"
direction = [0.5, -0.3, 0.8]
[[light]]
name = "low"
direction = [-0.7, 0.2, 0.3]
intensity = 2.0
[comparators]
analytic = ["pz-analytic", "naughty-dog"]
[sampling]
tolerance = 1e-4
"""


@pytest.fixture
def scene_file(tmp_path):
    ao = np.linspace(0.25, 1.0, 6 * 4).reshape(4, 6)
    write_grey_png(tmp_path / "ao.png", ao)
    (tmp_path / "s.toml").write_text(SCENE)
    return tmp_path / "s.toml"


def _without_timings(report):
    report = json.loads(json.dumps(report))
    report.pop("provenance")
    report.pop("seconds")
    for light in report["lights"]:
        light.pop("seconds")
    return report


def test_scene_matches_cli(cli, scene_file, tmp_path):
    cli("scene", scene_file, "--out", tmp_path / "cli", "--no-seed-luts", "-q")
    run = ms.scene(scene_file, seed_luts=False)
    assert (run.width, run.height) == (6, 4)
    assert run.lights == ["key", "low"]
    assert run.comparators == ["pz-analytic", "naughty-dog"]
    cli_layers = read_scanline_exr(tmp_path / "cli" / "scene.exr")
    assert sorted(cli_layers) == sorted(run.layers)
    for name, plane in run.layers.items():
        assert plane.shape == (4, 6) and plane.dtype == np.float32
        assert np.array_equal(plane, cli_layers[name], equal_nan=True), name
    cli_report = json.loads((tmp_path / "cli" / "report.json").read_text())
    assert _without_timings(run.report) == _without_timings(cli_report)
    # save() writes what the command writes: the same images and layers.
    run.save(tmp_path / "py")
    for png in ("key_reference.png", "low_naughty-dog.png"):
        assert (tmp_path / "py" / png).read_bytes() == (tmp_path / "cli" / png).read_bytes()
    saved = read_scanline_exr(tmp_path / "py" / "scene.exr")
    assert all(np.array_equal(saved[k], cli_layers[k], equal_nan=True) for k in cli_layers)


def test_scene_options(scene_file):
    run = ms.scene(scene_file, seed_luts=False, method="sampled", tolerance=0.01)
    assert run.report["method"] == "sampled" and run.report["tolerance"] == 0.01
    assert run.report["provenance"]["skip"] is True


def test_scene_bad_input(scene_file, tmp_path):
    with pytest.raises(ValueError, match=r"tolerance = 0.9: 1e-12 to 0.5"):
        ms.scene(scene_file, tolerance=0.9)
    with pytest.raises(ValueError, match=r"method = 'fast'"):
        ms.scene(scene_file, method="fast")
    with pytest.raises(FileNotFoundError, match=r"luts\[0\] = .*no such file"):
        ms.scene(scene_file, luts=[tmp_path / "missing.exr"])
    with pytest.raises(FileNotFoundError):
        ms.scene(tmp_path / "missing.toml")
    (tmp_path / "bad.toml").write_text(SCENE.replace("value = 0.45", "value = 1.5"))
    with pytest.raises(ValueError, match=r"bad.toml: roughness"):
        ms.scene(tmp_path / "bad.toml", seed_luts=False)


def test_scene_stops_on_request_and_save_refuses_a_file(scene_file, tmp_path):
    def stop(done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        ms.scene(scene_file, seed_luts=False, progress=stop)
    run = ms.scene(scene_file, seed_luts=False, tolerance=0.01)
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="exists and is not a folder"):
        run.save(tmp_path / "file")
    assert (tmp_path / "file").read_text() == "x"
