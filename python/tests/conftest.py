"""Shared fixtures: the CLI to compare with, and small inputs.

The CLI is $MICROSHADOW_CLI, or build/microshadow of this checkout. Tests that compare with it are
skipped when neither exists, unless MICROSHADOW_REQUIRE_CLI=1 (scripts/ci-python.sh sets it): then its
absence fails them.
"""

import csv
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _cli_path():
    env = os.environ.get("MICROSHADOW_CLI")
    if env:
        return pathlib.Path(env)
    return ROOT / "build" / "microshadow"


@pytest.fixture(scope="session")
def cli():
    path = _cli_path()
    if not path.is_file():
        if os.environ.get("MICROSHADOW_REQUIRE_CLI") == "1":
            pytest.fail(f"the microshadow program is not at {path} (set MICROSHADOW_CLI)")
        pytest.skip(f"the microshadow program is not at {path} (set MICROSHADOW_CLI)")

    def run(*args, check=True):
        done = subprocess.run([str(path), *map(str, args)], capture_output=True, text=True)
        if check and done.returncode != 0:
            raise AssertionError(f"microshadow {' '.join(map(str, args))}: exit {done.returncode}\n{done.stderr}")
        return done

    return run


@pytest.fixture(autouse=True, scope="session")
def _pocl_cache(tmp_path_factory):
    # PoCL needs a writable kernel cache.
    os.environ.setdefault("POCL_CACHE_DIR", str(tmp_path_factory.mktemp("pocl")))


QUERY_COLUMNS = ["visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"]


def random_queries(n, seed=5):
    """n varied queries: anisotropic, every azimuth, lights above and below the horizon, v = 1 included."""
    rng = np.random.default_rng(seed)
    v = rng.uniform(0.2, 1.0, n)
    v[0] = 1.0
    ax = rng.uniform(0.05, 1.0, n)
    ay = rng.uniform(0.05, 1.0, n)
    wi = rng.normal(size=(n, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.05
    wo = rng.normal(size=(n, 3))
    return v, ax, ay, wi, wo


def write_queries(path, v, ax, ay, wi, wo):
    """The query CSV of `microshadow eval`, every number in round-trip precision (repr)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(QUERY_COLUMNS)
        for i in range(len(v)):
            w.writerow([repr(float(x)) for x in (v[i], ax[i], ay[i], *wi[i], *wo[i])])


def read_csv_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: [r[k] for r in body] for k, name in enumerate(header)}
