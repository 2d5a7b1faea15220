#!/usr/bin/env bash
# The golden set: outputs whose exact bits a refactor must keep (or change on purpose, with
# the reason in tests/golden/README.md). Prints "name hash" lines, one per output.
#   make_golden.sh MICROSHADOW_BIN EXR_PIXEL_HASH_BIN WORK_DIR
# LUT files are hashed by their pixels (exr_pixel_hash: channel names and float bits), not their bytes,
# because the header records the command line and the device; CSVs are hashed as bytes.
set -euo pipefail
bin=$1 exrhash=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$work"
cd "$work"
q() { "$bin" "$@" --quiet; }
q bake --size 16 --out b16.exr
q bake --out b32.exr
q bake --layout seed-2d --out b2d.exr
q bake --layout custom --texel endpoints --azimuth 60 --size 9 --roughness 0.3 0.8 \
  --visibility-range 0.05 0.95 --n-dot-v-range 0.1 1 --samples 16384 --out custom.exr
q eval --in "$here/bench_queries.csv" --out eval_opencl.csv --method sampled
q eval --in "$here/bench_queries.csv" --out eval_oracle.csv --method sampled --backend oracle --samples 16384
cp "$here/sweep.toml" sweep.toml
q sweep sweep.toml --out sweep --method sampled --samples 16384
for f in b16.exr b32.exr b2d.exr custom.exr; do echo "$f $("$exrhash" "$f")"; done
for f in eval_opencl.csv eval_oracle.csv sweep/sweep.csv sweep/summary.csv; do echo "$f $(sha256sum < "$f" | cut -c1-16)"; done
# The term column alone: the estimates, apart from their error bars.
for f in eval_opencl eval_oracle; do echo "$f.term $(cut -d, -f10 "$f.csv" | sha256sum | cut -c1-16)"; done
