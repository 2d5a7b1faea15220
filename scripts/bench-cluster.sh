#!/usr/bin/env bash
# The distribution layer's cost (docs/cluster.md, "Scale"): items per second of one bake whose items are
# nearly free (tiny slices at few samples), run by one process and by MPI worlds of 1, 2 and 4 computing
# ranks (mpirun -np 2, 3, 5, oversubscribed on a small machine: this measures overhead, not speed-up),
# with and without rank 0 keeping a chunk store; then rank 0's write rate for items of a real bake's
# size (a 64 x 64 slice: 32 KiB).
#
#   scripts/bench-cluster.sh [BUILD_DIR] [SLICES]     (defaults: build, 256)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$(cd "${1:-$root/build}" && pwd)/microshadow
slices=${2:-256}
work=$(mktemp -d /tmp/microshadow-bench-cluster.XXXXXX)
trap 'rm -rf "$work"' EXIT
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$work/pocl}
mpirun=(mpirun --oversubscribe)
[ "$(id -u)" -eq 0 ] && mpirun+=(--allow-run-as-root)

# 2 channels x (slices / 2) NdotV values of 4 x 4 texels, 256 samples: each item is ~a millisecond of work.
args=(bake --layout custom --size 4 --size-n-dot-v $((slices / 2)) --roughness 0.3,0.8 --samples 256 --seed 1 --quiet)
seconds() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N); echo "$t1 - $t0" | bc -l; }
rate() { printf '%.0f' "$(echo "$slices / $1" | bc -l)"; }

"$bin" "${args[@]}" --out "$work/warm.exr"  # the kernels' program cache
# The fixed cost of starting a process (device discovery, program cache), run on a one-slice bake.
one=(bake --layout custom --size 4 --size-n-dot-v 1 --roughness 0.3 --samples 256 --seed 1 --quiet)
start_s=$(seconds "$bin" "${one[@]}" --out "$work/one.exr")
printf '| run | wall s | items/s | items/s after start-up |\n|---|---|---|---|\n'
t=$(seconds "$bin" "${args[@]}" --out "$work/plain.exr")
printf '| one process | %.2f | %s | %s |\n' "$t" "$(rate "$t")" "$(rate "$(echo "$t - $start_s" | bc -l)")"
for np in 2 3 5; do
  mpi_start=$(seconds "${mpirun[@]}" -np "$np" "$bin" "${one[@]}" --out "$work/one-$np.exr" --mpi)
  t=$(seconds "${mpirun[@]}" -np "$np" "$bin" "${args[@]}" --out "$work/mpi-$np.exr" --mpi)
  printf '| mpirun -np %d (%d computing) | %.2f | %s | %s |\n' "$np" $((np - 1)) "$t" "$(rate "$t")" \
    "$(rate "$(echo "$t - $mpi_start" | bc -l)")"
  rm -rf "$work/store-$np"
  t=$(seconds "${mpirun[@]}" -np "$np" "$bin" "${args[@]}" --out "$work/mpis-$np.exr" --mpi --store "$work/store-$np")
  printf '| mpirun -np %d, rank 0 keeps a store | %.2f | %s | %s |\n' "$np" "$t" "$(rate "$t")" \
    "$(rate "$(echo "$t - $mpi_start" | bc -l)")"
done

# Rank 0's write rate: a 64 x 64-texel slice is 32 KiB of payload; every item is written to a temporary,
# synced, renamed. Measured through a merge-free store fill: a bake of 64 such slices into a store, minus
# the same bake without one.
big=(bake --layout custom --size 64 --size-n-dot-v 32 --roughness 0.3,0.8 --samples 256 --seed 1 --quiet)
"$bin" "${big[@]}" --out "$work/big-warm.exr"
without=$(seconds "$bin" "${big[@]}" --out "$work/big.exr")
with=$(seconds "$bin" "${big[@]}" --out "$work/big-s.exr" --store "$work/big-store")
bytes=$(du -sb "$work/big-store/items" | cut -f1)
printf '\nstore writes: 64 items of %d bytes: %.3f s with the store, %.3f s without: %.1f ms an item, %.1f MB/s\n' \
  $((bytes / 64)) "$with" "$without" "$(echo "($with - $without) * 1000 / 64" | bc -l)" \
  "$(echo "$bytes / ($with - $without) / 1000000" | bc -l)"
