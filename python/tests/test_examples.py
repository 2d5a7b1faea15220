"""The examples a new user runs: a missing optional dependency is said at once, with the way to get it."""

import os
import subprocess
import sys

from conftest import ROOT


def test_study_without_matplotlib_says_how_to_get_the_plot(tmp_path):
    # A matplotlib that cannot be imported, ahead of any installed one on the path.
    fake = tmp_path / "site" / "matplotlib"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('matplotlib hidden by the test')\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path / "site"), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / "study.py"), "--small", "--out",
                           str(tmp_path / "out")], capture_output=True, text=True, env=env, timeout=300)
    # Before: the whole study ran, then "matplotlib is not installed: no plot" and exit status 0.
    assert done.returncode == 2, done.stdout + done.stderr
    assert "pip install '.[plot]'" in done.stderr and "--no-plot" in done.stderr, done.stderr
    assert not (tmp_path / "out" / "seed_lut.exr").exists(), "the check comes before any work"
