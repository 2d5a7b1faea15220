"""The CLI, the C++ API and Python give identical bytes for the same job (frontends.py has the jobs)."""

import os
import pathlib

import pytest

import microshadow as ms
from conftest import ROOT, _cli_path
import frontends


@pytest.fixture(scope="module")
def programs():
    """The CLI and the C++ API's front end (microshadow_api_jobs, $MICROSHADOW_API_JOBS or the build's)."""
    api = pathlib.Path(os.environ.get("MICROSHADOW_API_JOBS") or ROOT / "build" / "tests" / "microshadow_api_jobs")
    cli = _cli_path()
    for path in (cli, api):
        if not path.is_file():
            if os.environ.get("MICROSHADOW_REQUIRE_CLI") == "1":
                pytest.fail(f"{path} is missing (set MICROSHADOW_CLI and MICROSHADOW_API_JOBS)")
            pytest.skip(f"{path} is missing (set MICROSHADOW_CLI and MICROSHADOW_API_JOBS)")
    return cli, api


@pytest.mark.parametrize("options, tag", [(frontends.EVAL_EXACT, "exact"), (frontends.EVAL_SAMPLED, "sampled")])
def test_eval_is_the_same_in_every_front_end(programs, tmp_path, options, tag):
    frontends.check_eval(*programs, ms, tmp_path, options, tag)


def test_bake_writes_the_same_bytes_in_every_front_end(programs, tmp_path):
    frontends.check_bake(*programs, ms, tmp_path)


def test_repr_bake_writes_the_same_bytes_in_every_front_end(programs, tmp_path):
    frontends.check_repr(*programs, ms, tmp_path)


def test_area_eval_is_the_same_in_every_front_end(programs, tmp_path):
    frontends.check_area(*programs, ms, tmp_path)
