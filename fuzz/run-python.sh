#!/usr/bin/env bash
# Runs the Python API fuzzer (fuzz/python_api_fuzz.py) for a bounded time in the venv that
# scripts/ci-python.sh made (.venv, with the installed package).
#   fuzz/run-python.sh [SECONDS]     (default 40; env FUZZ_SEED: the generator's seed, default random;
#                                     VENV: the venv, default .venv)
# Its log ($BUILD_DIR or build/, fuzz-python.log) lists every case before it runs: after a crash its
# last line is the case that crashed. Exit status: non-zero on any finding, crash or hang.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
seconds="${1:-40}"
venv="${VENV:-$root/.venv}"
log="$root/${BUILD_DIR:-build}/fuzz-python.log"
mkdir -p "$(dirname "$log")"
seed_option=()
[[ -n "${FUZZ_SEED:-}" ]] && seed_option=(--seed "$FUZZ_SEED")
[[ -x "$venv/bin/python" ]] || { echo "fuzz/run-python.sh: no venv at $venv (run scripts/ci-python.sh first)" >&2; exit 1; }
status=0
# From outside the checkout, so that `import microshadow` is the installed package.
(cd "$venv" && "$venv/bin/python" "$root/fuzz/python_api_fuzz.py" --seconds "$seconds" --log "$log" "${seed_option[@]}") || status=$?
if [[ $status -ne 0 && $status -ne 1 ]]; then
  echo "fuzz: python: the interpreter died (exit status $status); the case it ran:"
  tail -1 "$log"
fi
exit "$status"
