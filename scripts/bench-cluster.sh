#!/usr/bin/env bash
# The distribution layer's cost (docs/cluster.md, "Scale"): items per second of one bake whose items are
# nearly free (tiny slices at few samples), run by one process and by MPI worlds of 1, 2 and 4 computing
# ranks (mpirun -np 2, 3, 5, oversubscribed on a small machine: this measures overhead, not speed-up),
# with and without rank 0 keeping a chunk store; then rank 0's write rate for items of a real bake's
# size (a 64 x 64 slice: 32 KiB), and the bytes of a scene's item (a tile) per pixel.
#
#   scripts/bench-cluster.sh [BUILD_DIR] [SLICES] [REPEATS]     (defaults: build, 1024, 3)
#
# Every run gives its wall time and its CPU time (user + system of the process and all its children:
# every rank), and the load average before it: on a shared machine, wall times alone mislead. Each is
# the run of median wall time of REPEATS.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$(cd "${1:-$root/build}" && pwd)/microshadow
slices=${2:-1024}
repeats=${3:-3}
work=$(mktemp -d /tmp/microshadow-bench-cluster.XXXXXX)
trap 'rm -rf "$work"' EXIT
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$work/pocl}
mpirun=(mpirun --oversubscribe)
[ "$(id -u)" -eq 0 ] && mpirun+=(--allow-run-as-root)

# 2 channels x (slices / 2) NdotV values of 4 x 4 texels, 256 samples: each item is ~a millisecond of work.
args=(bake --layout custom --size 4 --n-dot-v-count $((slices / 2)) --roughness 0.3,0.8 --samples 256 --seed 1 --quiet)
# "WALL CPU" of a command (bash's time: real, and user + sys of the shell's children).
measure() {
  local TIMEFORMAT='%R %U %S' out
  out=$( { time "$@" >/dev/null 2>&1; } 2>&1 | tail -1)
  echo "$out" | awk '{printf "%.3f %.3f\n", $1, $2 + $3}'
}
# The median run (by wall time) of `repeats` runs: "WALL CPU".
median() {
  local runs=() i
  for ((i = 0; i < repeats; i++)); do runs+=("$(measure "$@")"); done
  printf '%s\n' "${runs[@]}" | sort -n | sed -n "$(((repeats + 1) / 2))p"
}
rate() { printf '%.0f' "$(echo "$slices / $1" | bc -l)"; }
load() { cut -d' ' -f1 /proc/loadavg; }

echo "machine: $(nproc) cores; $(uptime)"
"$bin" "${args[@]}" --out "$work/warm.exr"  # the kernels' program cache
# The fixed cost of starting a process (device discovery, program cache), run on a one-slice bake.
one=(bake --layout custom --size 4 --n-dot-v-count 1 --roughness 0.3 --samples 256 --seed 1 --quiet)
read -r start_s _ < <(median "$bin" "${one[@]}" --out "$work/one.exr")
printf '| run | load before | wall s | CPU s | items/s | items/s after start-up |\n|---|---|---|---|---|---|\n'
row() {  # label, start-up wall s, command...
  local label=$1 startup=$2 l w c
  shift 2
  l=$(load)
  read -r w c < <(median "$@")
  printf '| %s | %s | %.2f | %.2f | %s | %s |\n' "$label" "$l" "$w" "$c" "$(rate "$w")" "$(rate "$(echo "$w - $startup" | bc -l)")"
}
row "one process" "$start_s" "$bin" "${args[@]}" --out "$work/plain.exr"
for np in 2 3 5; do
  read -r mpi_start _ < <(median "${mpirun[@]}" -np "$np" "$bin" "${one[@]}" --out "$work/one-$np.exr" --mpi)
  row "mpirun -np $np ($((np - 1)) computing)" "$mpi_start" "${mpirun[@]}" -np "$np" "$bin" "${args[@]}" --out "$work/mpi-$np.exr" --mpi
  # A fresh store each run (a kept one would be resumed from): the folder is removed inside the timed command.
  row "mpirun -np $np, rank 0 keeps a store" "$mpi_start" \
    sh -c 'rm -rf "$1" && shift && exec "$@"' sh "$work/store-$np" "${mpirun[@]}" -np "$np" "$bin" "${args[@]}" \
    --out "$work/mpis-$np.exr" --mpi --store "$work/store-$np"
done

# Rank 0's write rate: a 64 x 64-texel slice is 32 KiB of payload; every item is written to a temporary
# and renamed, and the items are synced in groups (64 items or 1 s, chunk_store.hpp). Measured through a
# store fill: a bake of 256 such slices into a store, minus the same bake without one.
big_items=256
big=(bake --layout custom --size 64 --n-dot-v-count $((big_items / 2)) --roughness 0.3,0.8 --samples 64 --seed 1 --quiet)
"$bin" "${big[@]}" --out "$work/big-warm.exr"
read -r without without_cpu < <(median "$bin" "${big[@]}" --out "$work/big.exr")
read -r with with_cpu < <(median sh -c 'rm -rf "$1" && shift && exec "$@"' sh "$work/big-store" "$bin" "${big[@]}" --out "$work/big-s.exr" --store "$work/big-store")
item_bytes() { find "$1" -maxdepth 1 -name '*.bin' -printf '%s\n' | awk '{s += $1} END {print s}'; }
bytes=$(item_bytes "$work/big-store/items")
printf '\nstore writes (load %s): %d items of %d bytes: %.3f s (CPU %.3f) with the store, %.3f s (CPU %.3f) without: %.2f ms (CPU %.2f ms) an item\n' \
  "$(load)" "$big_items" $((bytes / big_items)) "$with" "$with_cpu" "$without" "$without_cpu" \
  "$(echo "($with - $without) * 1000 / $big_items" | bc -l)" "$(echo "($with_cpu - $without_cpu) * 1000 / $big_items" | bc -l)"

# Where that time goes: the fsync calls of one store fill, timed one by one (strace -T), and the disk's
# streaming write rate (128 MiB, synced), which bounds rank 0 for large items (a scene's tiles).
if command -v strace >/dev/null; then
  rm -rf "$work/big-store"
  strace -o "$work/trace.txt" -f -T -e trace=fsync "$bin" "${big[@]}" --out "$work/big-t.exr" --store "$work/big-store" >/dev/null 2>&1
  awk -F'<' '/fsync/ {split($NF, a, ">"); s += a[1]; n++} END {printf "fsync: %d calls for %d items, %.3f s in all, %.2f ms a call\n", n, items, s, 1000 * s / n}' \
    items="$big_items" "$work/trace.txt"
else
  echo "fsync: strace is not installed; the per-call time was not measured"
fi
dd if=/dev/zero of="$work/stream" bs=1M count=128 conv=fsync 2>&1 | tail -1 | sed 's/^/disk stream (dd, 128 MiB, synced): /'
rm -f "$work/stream"

# A scene's item is a tile of one light: its layers (3 floats a pixel), a byte a pixel, and for every
# compared pixel its irradiance and one double per comparator. Measured on a 64 x 64 scene in tiles of
# 1024 pixels, two comparators.
python3 - "$work/ao.png" <<'PY'
import struct, sys, zlib
w = h = 64
rows = b"".join(b"\0" + bytes(60 + (x * 11 + y * 7) % 190 for x in range(w)) for y in range(h))
chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
open(sys.argv[1], "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) +
                              chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
PY
printf '[normal]\nvalue = [0, 0, 1]\n[visibility]\nfile = "ao.png"\nchannel = "Y"\n[roughness]\nvalue = 0.4\n[view]\ndirection = [0.5, 0, 0.866]\n[[light]]\nname = "sun"\ndirection = [0.3, 0.5, 0.81]\n[comparators]\nanalytic = ["naughty-dog", "pz-analytic"]\nseed_3d = false\nseed_2d = false\n[sampling]\ntolerance = 1e-3\ntile_pixels = 1024\n' > "$work/scene.toml"
read -r scene_wall scene_cpu < <(measure "$bin" scene "$work/scene.toml" --quiet --out "$work/scene" --store "$work/scene-store")
items=$(ls "$work/scene-store/items" | grep -c '\.bin$')
bytes=$(item_bytes "$work/scene-store/items")
printf 'scene items: %d tiles of 1024 pixels (2 comparators), %d bytes each: %.1f bytes a pixel (%.2f s, CPU %.2f)\n' \
  "$items" $((bytes / items)) "$(echo "$bytes / $items / 1024" | bc -l)" "$scene_wall" "$scene_cpu"
