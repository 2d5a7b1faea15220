#!/usr/bin/env bash
# The README test: runs every ```sh block of README.md and of the docs' quick examples exactly as written,
# in order, as a user following them would, so that an example can no longer drift from the program.
#
# Usage: bash scripts/check-readme.sh [--build DIR] [--python] [--list] [--keep]
#
# Each block runs under `bash -euo pipefail` in one scratch folder (outputs land there), where `examples/`,
# `docs/` and `scripts/` are the checkout's and `microshadow` is BUILD/microshadow (a folder on PATH, so
# mpirun finds it too; `build/microshadow` works as well). A block's sizes are the ones it shows: nothing is
# scaled down here, so the examples themselves are kept small where they would take long.
#
# The line before a block's fence may say where it runs instead:
#   <!-- example: python -->     the Python package's blocks: run with --python from the checkout's root
#                                (scripts/ci-python.sh does, after the Release build)
#   <!-- example: checkout -->   run from the checkout's root rather than the scratch folder (the quick start)
#   <!-- example: skip REASON --> not run; REASON says what runs it instead (CI's Release stage, say)
# --list prints every block with its kind and runs nothing; --keep keeps the scratch folder.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=build
mode=default
list=0
keep=0
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2; shift 2 ;;
    --python) mode=python; shift ;;
    --list) list=1; shift ;;
    --keep) keep=1; shift ;;
    -h|--help) sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "check-readme: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
build=$(cd "$build" 2>/dev/null && pwd) || { echo "check-readme: no build folder '$build' (run scripts/quickstart.sh first)" >&2; exit 2; }

# The files whose blocks are examples a user copies: the README and the docs' quick examples. (The
# docs' study and benchmark reproductions take minutes to hours and are not part of this test.)
files=(README.md docs/engine.md docs/python.md docs/cli.md)

scratch=$(mktemp -d /tmp/microshadow-readme.XXXXXX)
cleanup() { if [ "$keep" = 1 ]; then echo "check-readme: scratch folder kept: $scratch"; else rm -rf "$scratch"; fi; }
trap cleanup EXIT
mkdir -p "$scratch/blocks" "$scratch/bin" "$scratch/work"

# Splits the files into one script per block: blocks/NN.sh, with NN.kind and NN.where beside it.
n=0
for f in "${files[@]}"; do
  awk -v file="$f" -v dir="$scratch/blocks" -v start="$n" '
    function flush() { }
    /^```sh[[:space:]]*$/ { inblock = 1; n++; id = sprintf("%s/%02d", dir, start + n);
                            kind = "default"; if (match(prev, /<!-- example: [a-z]+/)) kind = substr(prev, RSTART + 14, RLENGTH - 14)
                            print kind > (id ".kind"); print file ":" NR + 1 > (id ".where"); printf "" > (id ".sh"); next }
    /^```/ && inblock { inblock = 0; next }
    inblock { print >> (id ".sh"); next }
    NF { prev = $0 }
  ' "$f"
  n=$(ls "$scratch/blocks"/*.sh 2>/dev/null | wc -l)
done

ln -s "$build/microshadow" "$scratch/bin/microshadow"
for d in examples docs scripts; do ln -s "$root/$d" "$scratch/work/$d"; done
ln -s "$build" "$scratch/work/build"
export PATH="$scratch/bin:$PATH"
# A cold kernel cache for this run alone (as on a fresh machine), kept out of the user's.
export POCL_CACHE_DIR="$scratch/pocl-cache"

ran=0 skipped=0 failed=0
t_all=$SECONDS
# The scripts a reader is pointed to answer --help with their usage and do nothing else (apt-get and
# sudo are stand-ins here that fail loudly).
if [ "$list" = 0 ] && [ "$mode" = default ]; then
  mkdir -p "$scratch/no-install"
  for tool in apt-get sudo; do printf '#!/bin/sh\necho "check-readme: --help ran %s" >&2; exit 97\n' "$tool" >"$scratch/no-install/$tool"; chmod +x "$scratch/no-install/$tool"; done
  for s in scripts/quickstart.sh scripts/install-example-data.sh scripts/check-readme.sh; do
    if ! out=$(PATH="$scratch/no-install:$PATH" bash "$s" --help 2>&1) || ! grep -qi "usage" <<<"$out"; then
      echo "check-readme: '$s --help' did not print its usage and exit 0:" >&2
      echo "$out" >&2
      exit 1
    fi
  done
  echo "check-readme: --help of quickstart.sh, install-example-data.sh, check-readme.sh: usage printed, nothing run"
fi
for script in "$scratch"/blocks/*.sh; do
  id=${script%.sh}
  kind=$(cat "$id.kind") where=$(cat "$id.where")
  if [ "$list" = 1 ]; then printf '%-9s %s\n' "$kind" "$where"; sed 's/^/    /' "$script"; continue; fi
  case "$mode:$kind" in
    default:default) dir=$scratch/work ;;
    default:checkout|python:python) dir=$root ;;
    *) skipped=$((skipped + 1)); echo "check-readme: $where: $kind (not run here)"; continue ;;
  esac
  echo "check-readme: $where: running"
  t0=$SECONDS
  # Each command is echoed with the block's elapsed seconds before it runs; TIMEFORMAT gives the
  # block's wall and CPU time (the kernels' threads and mpirun's ranks included).
  TIMEFORMAT="check-readme: $where: %R s wall, %U s user + %S s system CPU"
  # (PS4 is set inside: bash running as root ignores one from the environment.)
  if time (cd "$dir" && bash -euo pipefail -c 'PS4="+ [\${SECONDS} s] "; set -x; source "$0"' "$script"); then
    echo "check-readme: $where: passed in $((SECONDS - t0)) s"
    ran=$((ran + 1))
  else
    echo "check-readme: $where: FAILED (exit status $?) after $((SECONDS - t0)) s; the block:" >&2
    sed 's/^/    /' "$script" >&2
    failed=$((failed + 1))
    break  # later blocks may build on this one's outputs
  fi
done
[ "$list" = 1 ] && exit 0
echo "check-readme: $ran passed, $failed failed, $skipped skipped (their kind is run elsewhere) in $((SECONDS - t_all)) s"
[ "$failed" = 0 ]
