#!/usr/bin/env bash
# Cross-compiles microshadow for 64-bit Windows with MinGW-w64 on Debian 12, and leaves
#   build-windows/microshadow.exe and build-windows/tests/microshadow_tests.exe
# (both static: no DLL beside them; OpenCL is loaded at run time from OpenCL.dll when a driver has one).
#
#   bash scripts/build-windows.sh          # install what is missing, build the dependencies once, build
#   bash scripts/build-windows.sh test     # the same, then the unit and CLI tests under Wine
#   bash scripts/build-windows.sh deps     # only steps 1 to 3
# (WINDOWS_BUILD_DIR names another build folder than build-windows.)
#
# Steps, each skipped when already done:
#   1. Debian packages: the MinGW-w64 compilers (posix threads), Wine, zlib for MinGW, dpkg-dev;
#   2. a deb-src entry for the mirror the machine already uses (apt-get source needs one);
#   3. OpenEXR, Imath and libpng from Debian's source packages, cross-built as static libraries into
#      build-windows-deps/prefix (kept between runs; delete the folder to rebuild them), GoogleTest from
#      Debian's /usr/src/googletest (WINDOWS_DEPS_DIR names another folder for them, e.g. one that
#      outlives the clone); the header-only libraries (CLI11, toml++, nlohmann-json, the OpenCL
#      headers) are Debian's, seen through build-windows-deps/prefix/include;
#   4. the project, with warnings as errors (MICROSHADOW_WERROR) unless MICROSHADOW_CMAKE_ARGS says else.
# Builds run under nice with JOBS (default 2) compilers at once.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
jobs=${JOBS:-2}
deps=${WINDOWS_DEPS_DIR:-$root/build-windows-deps}
prefix=$deps/prefix
toolchain=$root/cmake/mingw-w64.cmake
# Its own variable, not BUILD_DIR: other scripts read BUILD_DIR for their native builds, and a native
# build folder reused here would keep its cached host compiler under the MinGW flags.
build=${WINDOWS_BUILD_DIR:-build-windows}
t_start=$SECONDS
log() { echo "build-windows: $* ($((SECONDS - t_start)) s)" >&2; }

as_root=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 || { echo "build-windows: needs root or sudo to install packages" >&2; exit 1; }
  as_root=(sudo)
fi

# --- 1. packages -------------------------------------------------------------------------------------
packages=(g++-mingw-w64-x86-64-posix wine64 wine libz-mingw-w64-dev dpkg-dev cmake
          libcli11-dev libtomlplusplus-dev nlohmann-json3-dev opencl-c-headers opencl-clhpp-headers googletest)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  log "installing ${missing[*]}"
  "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# --- 2. sources of the dependencies --------------------------------------------------------------------
# A deb-src twin of every deb entry, for the same mirror and suites (deb822 .sources files and the
# one-line format alike), added once.
ensure_deb_src() {
  if grep -rqsE '^(Types:.*deb-src|deb-src )' /etc/apt/sources.list /etc/apt/sources.list.d/; then return 0; fi
  log "adding deb-src entries for the configured mirrors"
  local tmp
  tmp=$(mktemp)
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    sed -E 's/^Types:[[:space:]]*deb([[:space:]]|$)/Types: deb-src\1/' "$f" >>"$tmp"
    echo >>"$tmp"
  done
  if [ -s "$tmp" ]; then
    "${as_root[@]}" install -m 644 "$tmp" /etc/apt/sources.list.d/microshadow-deb-src.sources
  fi
  : >"$tmp"
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [ -f "$f" ] || continue
    sed -nE 's/^deb[[:space:]]+/deb-src /p' "$f" >>"$tmp"
  done
  if [ -s "$tmp" ]; then
    "${as_root[@]}" install -m 644 "$tmp" /etc/apt/sources.list.d/microshadow-deb-src.list
  fi
  rm -f "$tmp"
  "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
}

mkdir -p "$deps/src" "$prefix"
source_dir() {  # the unpacked source folder of a Debian source package, fetched when absent
  local pkg=$1 dir
  dir=$(find "$deps/src" -mindepth 1 -maxdepth 1 -type d -name "$2-*" | head -n1)
  if [ -z "$dir" ]; then
    ensure_deb_src
    log "apt-get source $pkg"
    # The newest version may come from a suite whose source files the mirror lacks (security updates):
    # then the release's own suite.
    local codename
    codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
    (cd "$deps/src" && { apt-get source -qq "$pkg" >/dev/null 2>&1 || apt-get source -qq "$pkg/$codename" >/dev/null 2>&1; }) \
      || { echo "build-windows: apt-get source $pkg failed" >&2; return 1; }
    dir=$(find "$deps/src" -mindepth 1 -maxdepth 1 -type d -name "$2-*" | head -n1)
  fi
  echo "$dir"
}

# --- 3. dependencies, static, into the prefix ----------------------------------------------------------
cross_build() {  # name source-dir cmake-args...
  local name=$1 src=$2; shift 2
  [ -f "$prefix/.$name.done" ] && return 0
  log "cross-building $name"
  rm -rf "$deps/build/$name"
  nice -n 5 cmake -S "$src" -B "$deps/build/$name" -G "Unix Makefiles" -DCMAKE_TOOLCHAIN_FILE="$toolchain" \
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$prefix" -DCMAKE_PREFIX_PATH="$prefix" \
    -DBUILD_SHARED_LIBS=OFF -DBUILD_TESTING=OFF "$@" >"$deps/build-$name.log" 2>&1 \
    || { tail -30 "$deps/build-$name.log"; exit 1; }
  nice -n 5 cmake --build "$deps/build/$name" -j"$jobs" >>"$deps/build-$name.log" 2>&1 \
    || { tail -30 "$deps/build-$name.log"; exit 1; }
  cmake --install "$deps/build/$name" >>"$deps/build-$name.log" 2>&1
  rm -rf "$deps/build/$name"
  touch "$prefix/.$name.done"
}
zlib_static=/usr/x86_64-w64-mingw32/lib/libz.a
src=$(source_dir imath imath)
cross_build imath "$src" -DIMATH_INSTALL_PKG_CONFIG=OFF
src=$(source_dir openexr openexr)
cross_build openexr "$src" -DOPENEXR_BUILD_TOOLS=OFF -DOPENEXR_INSTALL_EXAMPLES=OFF \
  -DOPENEXR_INSTALL_PKG_CONFIG=OFF -DZLIB_LIBRARY="$zlib_static" -DZLIB_INCLUDE_DIR=/usr/x86_64-w64-mingw32/include
src=$(source_dir libpng1.6 libpng1.6)
cross_build libpng "$src" -DPNG_SHARED=OFF -DPNG_STATIC=ON -DPNG_TESTS=OFF \
  -DPNG_EXECUTABLES=OFF -DZLIB_LIBRARY="$zlib_static" -DZLIB_INCLUDE_DIR=/usr/x86_64-w64-mingw32/include
cross_build googletest /usr/src/googletest -DBUILD_GMOCK=OFF -DINSTALL_GTEST=ON

# Header-only libraries: Debian's headers, through the prefix (never /usr/include itself, which holds the
# Linux C library's headers), with package files that name the same targets Debian's do.
mkdir -p "$prefix/include"
for h in CL CLI toml++ nlohmann; do
  [ -e "$prefix/include/$h" ] || ln -s "/usr/include/$h" "$prefix/include/$h"
done
header_package() {  # package target [compile definitions]
  mkdir -p "$prefix/lib/cmake/$1"
  cat >"$prefix/lib/cmake/$1/$1Config.cmake" <<EOF
# Written by scripts/build-windows.sh: Debian's header-only $1 for the MinGW build.
if(NOT TARGET $2)
  add_library($2 INTERFACE IMPORTED)
  set_target_properties($2 PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "$prefix/include"
                        INTERFACE_COMPILE_DEFINITIONS "${3:-}")
endif()
EOF
}
header_package CLI11 CLI11::CLI11
# toml++ as a header-only library (Debian's package links a Linux shared library instead).
header_package tomlplusplus tomlplusplus::tomlplusplus TOML_HEADER_ONLY=1
header_package nlohmann_json nlohmann_json::nlohmann_json

[ "${1:-}" = deps ] && { log "dependencies ready in $prefix"; exit 0; }

# --- 4. the project ------------------------------------------------------------------------------------
log "configuring $build"
# A folder first configured without the MinGW toolchain keeps its host compiler in CMakeCache.txt, which
# a toolchain file given later does not replace: refuse it rather than mix the two.
if [ -f "$build/CMakeCache.txt" ] && ! grep -q "^CMAKE_TOOLCHAIN_FILE:.*mingw-w64.cmake" "$build/CMakeCache.txt"; then
  echo "build-windows: $build was configured for another compiler; give another WINDOWS_BUILD_DIR or delete it" >&2
  exit 2
fi
# shellcheck disable=SC2086  # MICROSHADOW_CMAKE_ARGS is a list of arguments
nice -n 5 cmake -S . -B "$build" -DCMAKE_TOOLCHAIN_FILE="$toolchain" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" -DZLIB_LIBRARY="$zlib_static" -DZLIB_INCLUDE_DIR=/usr/x86_64-w64-mingw32/include \
  -DMICROSHADOW_BUILD_BENCH=OFF -DMICROSHADOW_MPI=OFF -DMICROSHADOW_WERROR=ON ${MICROSHADOW_CMAKE_ARGS:-} >/dev/null
log "building $build"
nice -n 5 cmake --build "$build" -j"$jobs" --target microshadow microshadow_tests -- ${KEEP_GOING:+-k}
log "built $build/microshadow.exe and $build/tests/microshadow_tests.exe"

if [ "${1:-}" = test ]; then
  bash scripts/test-windows.sh "$build"
fi
