#!/usr/bin/env bash
# CI stage for the Python package: a fresh virtual environment, `pip install .`, the pytest suite
# (python/tests, which compares with the program built by the Release stage) and the study example at
# small sizes. Run after `scripts/quickstart.sh test` (it needs build/microshadow).
#   PYTHON        the interpreter (default /usr/bin/python3: Debian's, with python3-numpy and matplotlib)
#   VENV          the environment's folder (default build-python-venv; made afresh)
#   MICROSHADOW_CMAKE_ARGS  extra configure flags, as quickstart.sh takes them (CI: -DMICROSHADOW_WERROR=ON);
#                 the same flags as the Release build let ccache serve its objects to the pip build
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
python=${PYTHON:-/usr/bin/python3}
venv=${VENV:-build-python-venv}
export MICROSHADOW_CLI=${MICROSHADOW_CLI:-$root/build/microshadow}
[ -x "$MICROSHADOW_CLI" ] || { echo "ci-python: $MICROSHADOW_CLI is missing (run scripts/quickstart.sh test first)" >&2; exit 1; }
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$root/build-python-venv.pocl}
mkdir -p "$POCL_CACHE_DIR"

t0=$SECONDS
rm -rf "$venv"
# --system-site-packages: Debian's numpy (and matplotlib for the example's plot) serve the venv.
"$python" -m venv --system-site-packages "$venv"
venv=$(cd "$venv" && pwd)
# scikit-build-core reads CMAKE_ARGS; the Makefile generator and the core count as the Release build's.
CMAKE_ARGS="${MICROSHADOW_CMAKE_ARGS:-}" CMAKE_GENERATOR="Unix Makefiles" CMAKE_BUILD_PARALLEL_LEVEL="$(nproc)" \
  "$venv/bin/python" -m pip install -q .
"$venv/bin/python" -c "import pytest" 2>/dev/null || "$venv/bin/python" -m pip install -q pytest
echo "ci-python: venv and pip install . in $((SECONDS - t0)) s"

t0=$SECONDS
# From outside the checkout, so that `import microshadow` is the installed package.
(cd "$venv" && MICROSHADOW_REQUIRE_CLI=1 "$venv/bin/python" -m pytest -q -p no:cacheprovider "$root/python/tests")
echo "ci-python: pytest in $((SECONDS - t0)) s"

t0=$SECONDS
"$venv/bin/python" examples/python/study.py --small --out "$venv/study-out"
echo "ci-python: examples/python/study.py --small in $((SECONDS - t0)) s"
