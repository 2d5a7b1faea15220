#!/usr/bin/env bash
# Installs the Debian 12 packages microshadow needs, only those that are missing.
# Runs as root, or through sudo when it is present.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-c-headers opencl-clhpp-headers clinfo
  libopenexr-dev libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libpng-dev
  googletest libgtest-dev libbenchmark-dev
  python3 python3-dev python3-matplotlib python3-numpy python3-venv
  glslang-tools mesa-vulkan-drivers libvulkan-dev openimageio-tools
  clang libclang-rt-14-dev ccache
  openmpi-bin libopenmpi-dev
)

# OpenImageIO with DX10 DDS support (3.x; Debian 12 ships 2.4, which reads no DX10 DDS) for the LUT
# format tests, from PyPI into its own virtual environment (tests/lut/lut_formats_test.cpp looks there).
oiio_venv=/opt/microshadow-py
oiio_version=3.2.2.0
install_oiio_python() {
  if [ -x "$oiio_venv/bin/python3" ] && "$oiio_venv/bin/python3" -c 'import OpenImageIO' 2>/dev/null; then return 0; fi
  local as=()
  [ "$(id -u)" -eq 0 ] || as=(sudo)
  echo "install-deps: OpenImageIO $oiio_version (PyPI) into $oiio_venv"
  if ! { "${as[@]}" python3 -m venv "$oiio_venv" && "${as[@]}" "$oiio_venv/bin/pip" install -q "OpenImageIO==$oiio_version"; }; then
    echo "install-deps: warning: could not install OpenImageIO from PyPI; the DDS-through-OpenImageIO test will skip" >&2
  fi
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  install_oiio_python
  exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "install-deps: missing packages (${missing[*]}) and neither root nor sudo; install them and rerun" >&2
  exit 1
fi
echo "install-deps: installing ${missing[*]}"
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_oiio_python
