#!/usr/bin/env bash
# CI stage for the Python package: the README's Python blocks exactly as written (a venv `.venv` in the
# checkout, `pip install .`, the study example at small sizes; scripts/check-readme.sh --python), then
# the pytest suite (python/tests, which compares with the program built by the Release stage and, in
# test_frontends.py, with the C++ API's front end build/tests/microshadow_api_jobs) in that venv. Run after `scripts/quickstart.sh test` (it needs build/microshadow).
#   PYTHON        the interpreter the README's `python3` names (default /usr/bin/python3: Debian's, with
#                 python3-numpy and matplotlib)
#   MICROSHADOW_CMAKE_ARGS  extra configure flags, as quickstart.sh takes them (CI: -DMICROSHADOW_WERROR=ON);
#                 the same flags as the Release build let ccache serve its objects to the pip build
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
python=${PYTHON:-/usr/bin/python3}
export MICROSHADOW_CLI=${MICROSHADOW_CLI:-$root/build/microshadow}
# The C++ API's front end of the front-end test (python/tests/test_frontends.py), built by the Release stage.
export MICROSHADOW_API_JOBS=${MICROSHADOW_API_JOBS:-$root/build/tests/microshadow_api_jobs}
[ -x "$MICROSHADOW_CLI" ] || { echo "ci-python: $MICROSHADOW_CLI is missing (run scripts/quickstart.sh test first)" >&2; exit 1; }
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$root/build-python-venv.pocl}
mkdir -p "$POCL_CACHE_DIR"

# A fresh venv, as on a first run of the README; `python3` is the chosen interpreter. The venv's own
# python links to the `python3` it was made with, so that link stays (in an ignored build folder): the
# Python fuzz stage runs in this venv after the others.
rm -rf .venv
bin=$root/build-python-venv.bin
rm -rf "$bin" && mkdir -p "$bin"
ln -s "$python" "$bin/python3"
# scikit-build-core reads CMAKE_ARGS: the Release build's flags, so that ccache serves its objects.
PATH="$bin:$PATH" CMAKE_ARGS="${MICROSHADOW_CMAKE_ARGS:-}" bash scripts/check-readme.sh --python

venv=$root/.venv
"$venv/bin/python" -c "import pytest" 2>/dev/null || "$venv/bin/python" -m pip install -q pytest
t0=$SECONDS
# From outside the checkout, so that `import microshadow` is the installed package.
(cd "$venv" && MICROSHADOW_REQUIRE_CLI=1 "$venv/bin/python" -m pytest -q -p no:cacheprovider "$root/python/tests")
echo "ci-python: pytest in $((SECONDS - t0)) s"
