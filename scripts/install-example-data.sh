#!/usr/bin/env bash
# The real environments of the IBL example and benchmark: Debian's blender-data package ships
# HDR studio-light worlds (equirectangular OpenEXR, 2:1) under
#   /usr/share/blender/datafiles/studiolights/world/*.exr (license.txt beside them)
# Only the example (README, docs/ibl.md) and the benchmark use them; the tests generate their own small
# environments and never need this package.
set -euo pipefail
if ! ls /usr/share/blender/datafiles/studiolights/world/*.exr >/dev/null 2>&1; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends blender-data
fi
ls /usr/share/blender/datafiles/studiolights/world/*.exr
