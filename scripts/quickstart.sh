#!/usr/bin/env bash
# Usage: bash scripts/quickstart.sh main|test
# The README's quick start: installs what is missing, builds in Release, then
#   main: runs the main job: the default seed-3d LUT bake (32^3 x 4 roughness) and its preview, into out/
#   test: runs the whole test suite through ctest
# The build goes through ccache, which serves `pip install .` (README) the same objects.
set -euo pipefail
cd "$(dirname "$0")/.."
job=${1:-main}
case "$job" in
  main|test) ;;
  -h|--help) sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "usage: $0 main|test (--help says what each does)" >&2; exit 2 ;;
esac

bash scripts/install-deps.sh
build=${MICROSHADOW_BUILD_DIR:-build}
# MICROSHADOW_CMAKE_ARGS: extra configure flags (CI passes -DMICROSHADOW_WERROR=ON).
# MICROSHADOW_CCACHE: compiled through ccache, so that `pip install .` afterwards takes these objects
# from the cache instead of compiling the library again (about 5 minutes on 2 cores).
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DMICROSHADOW_CCACHE=ON ${MICROSHADOW_CMAKE_ARGS:-} >/dev/null
if [ "$job" = main ]; then
  cmake --build "$build" -j"$(nproc)" --target microshadow  # the main job needs only the program
else
  cmake --build "$build" -j"$(nproc)"
fi

if [ "$job" = main ]; then
  mkdir -p out
  "$build/microshadow" devices
  "$build/microshadow" bake --out out/microshadow_lut.exr --preview out/microshadow_lut.png --verify 64
  echo "wrote out/microshadow_lut.exr and out/microshadow_lut.png"
  echo "next: '$build/microshadow help' lists the commands; docs/engine.md puts the LUT and its shader in an engine;"
  echo "      '$build/microshadow bake --out lut.ktx2 --shader-glsl lut.glsl' bakes a KTX2 with matching GLSL;"
  echo "      'bash scripts/quickstart.sh test' runs the test suite"
else
  cd "$build"
  ctest --output-on-failure -j"$(nproc)"
fi
