#!/usr/bin/env bash
# The real environments of the IBL example and benchmark: Debian's blender-data package ships
# HDR studio-light worlds (equirectangular OpenEXR, 2:1) under
#   /usr/share/blender/datafiles/studiolights/world/*.exr (license.txt beside them)
# Only the example (README, docs/ibl.md) and the benchmark use them; the tests generate their own small
# environments and never need this package.
#
# Usage: bash scripts/install-example-data.sh   (installs blender-data with apt-get when the worlds are
# missing, as root or through sudo; prints the worlds' paths)
set -euo pipefail
case "${1:-}" in
  "") ;;
  -h|--help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "install-example-data: takes no arguments, not '$1' (--help says what it does)" >&2; exit 2 ;;
esac
if ! ls /usr/share/blender/datafiles/studiolights/world/*.exr >/dev/null 2>&1; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends blender-data
fi
ls /usr/share/blender/datafiles/studiolights/world/*.exr
