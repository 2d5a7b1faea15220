#!/usr/bin/env bash
# Benchmarks of the exact method against the sampled one, in one run, from the repository root after a
# Release build:
#     bash docs/bench/exact_bench.sh [eval] [bake] [scene] [grid]      (all by default)
# eval:  20,000 stress queries (alpha 0.002-1 log-uniform, anisotropy up to 1:50, view z 0.01-1, any
#        light): a reference by the exact method at tolerance 1e-13 (C++), then the exact method at 1e-6
#        and 1e-10 (C++ on 2 threads, OpenCL double and float kernels on PoCL) and the sampled kernel at
#        4096, 65536 and 1048576 samples: wall, microseconds per query per core, max and RMS error
#        -> docs/bench/exact_eval.csv
# bake:  the 64^3 x 4 seed-3d azimuth-mean LUT: sampled with the defaults, exact at --tolerance 1e-4 and
#        1e-6 (C++ threads and OpenCL double): wall and CPU, and max |difference| to the exact 1e-6 bake
#        (whose own estimated error is <= 1e-6) -> docs/bench/exact_bake.csv
# grid:  the 32^3 and 64^3 x 4 seed-3d LUT, sampled with the defaults against exact at --tolerance 1e-7,
#        interleaved, 3 repeats -> docs/bench/exact_grid_bake.csv
# scene: the 1024 x 1024 example scene (scripts/make_example_scene.py --size 1024), one light: sampled to
#        2e-3 and exact to 1e-6 (both defaults of their method) -> docs/bench/exact_scene.csv
# The machine may be shared: the CSVs record CPU seconds and the load average beside the wall times.
set -euo pipefail
BIN=${MICROSHADOW:-build/microshadow}
OUT=docs/bench
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-/tmp/pocl-cache}
parts=("$@")
[ ${#parts[@]} -gt 0 ] || parts=(eval bake scene grid)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
load() { cut -d' ' -f1 /proc/loadavg; }
# run NAME CMD...: wall and user+sys CPU seconds of one command into $tmp/NAME.time
run() {
  local name=$1; shift
  /usr/bin/time -f "%e %U %S" -o "$tmp/$name.time" "$@" > /dev/null 2> "$tmp/$name.err" || { cat "$tmp/$name.err" >&2; exit 1; }
}
wall() { cut -d' ' -f1 "$tmp/$1.time"; }
cpu() { awk '{print $2 + $3}' "$tmp/$1.time"; }

for part in "${parts[@]}"; do
  case $part in
  eval)
    python3 docs/bench/exact_stress_queries.py "$tmp/q.csv"
    run ref "$BIN" eval --in "$tmp/q.csv" --out "$tmp/ref.csv" --method exact --tolerance 1e-13 --backend oracle --allow-tolerance-miss -q
    # Each configuration twice: the first run warms PoCL's kernel cache; the second is recorded, with the
    # evaluation's own seconds (eval's summary line: no start-up, CSV or kernel build).
    echo "method,setting,wall_s,cpu_s,eval_s,us_per_query_core,max_error,rms_error,load" > "$OUT/exact_eval.csv"
    for cfg in "exact-cpp|1e-6|--method exact --tolerance 1e-6 --backend oracle" \
               "exact-cpp|1e-10|--method exact --tolerance 1e-10 --backend oracle" \
               "exact-opencl-double|1e-6|--method exact --tolerance 1e-6 --exact-kernel" \
               "exact-opencl-double|1e-10|--method exact --tolerance 1e-10 --exact-kernel" \
               "exact-opencl-float|1e-6|--method exact --tolerance 1e-6 --exact-float --allow-tolerance-miss" \
               "sampled-opencl|4096|--method sampled --samples 4096" \
               "sampled-opencl|65536|--method sampled --samples 65536" \
               "sampled-opencl|1048576|--method sampled --samples 1048576"; do
      method=${cfg%%|*}; rest=${cfg#*|}; setting=${rest%%|*}; flags=${rest#*|}; name="$method-$setting"
      # shellcheck disable=SC2086
      "$BIN" eval --in "$tmp/q.csv" --out "$tmp/$name.csv" $flags -q
      l=$(load)
      # shellcheck disable=SC2086
      run "$name" "$BIN" eval --in "$tmp/q.csv" --out "$tmp/$name.csv" $flags
      stats=$(python3 - "$tmp/ref.csv" "$tmp/$name.csv" <<'PY'
import csv, math, sys
ref = [float(r["term"]) for r in csv.DictReader(open(sys.argv[1]))]
got = [float(r["term"]) for r in csv.DictReader(open(sys.argv[2]))]
d = [abs(a - b) for a, b in zip(ref, got)]
print(f"{max(d):.3e},{math.sqrt(sum(x*x for x in d)/len(d)):.3e}")
PY
)
      secs=$(grep -o '[0-9.e+-]* s on' "$tmp/$name.err" | tail -1 | cut -d' ' -f1)
      us=$(awk -v s="$secs" 'BEGIN{printf "%.2f", s * 2 * 1e6 / 20000}')  # 2 cores
      echo "$method,$setting,$(wall "$name"),$(cpu "$name"),$secs,$us,$stats,$l" >> "$OUT/exact_eval.csv"
    done
    ;;
  bake)
    echo "method,setting,wall_s,cpu_s,max_error_vs_exact_1e-6,load" > "$OUT/exact_bake.csv"
    l=$(load); run exact-cpp-1e-6 "$BIN" bake --size 64 --method exact --tolerance 1e-6 --backend oracle --out "$tmp/e6.exr" -q
    echo "exact-cpp,1e-6,$(wall exact-cpp-1e-6),$(cpu exact-cpp-1e-6),0,$l" >> "$OUT/exact_bake.csv"
    for cfg in "sampled-opencl|default|--method sampled" \
               "exact-cpp|1e-4|--method exact --tolerance 1e-4 --backend oracle" \
               "exact-opencl-double|1e-6|--method exact --tolerance 1e-6 --exact-kernel"; do
      method=${cfg%%|*}; rest=${cfg#*|}; setting=${rest%%|*}; flags=${rest#*|}; name="$method-$setting"
      l=$(load)
      # shellcheck disable=SC2086
      run "$name" "$BIN" bake --size 64 $flags --out "$tmp/$name.exr" -q
      diff=$(/opt/microshadow-py/bin/python3 - "$tmp/e6.exr" "$tmp/$name.exr" <<'PY' 2>/dev/null || echo nan
import sys, numpy as np, OpenImageIO as oiio
a = oiio.ImageInput.open(sys.argv[1]).read_image("float"); b = oiio.ImageInput.open(sys.argv[2]).read_image("float")
print(f"{np.abs(np.asarray(a) - np.asarray(b)).max():.3e}")
PY
)
      echo "$method,$setting,$(wall "$name"),$(cpu "$name"),$diff,$l" >> "$OUT/exact_bake.csv"
    done
    ;;
  scene)
    /usr/bin/python3 scripts/make_example_scene.py --size 1024 "$tmp/s" > /dev/null
    echo "method,tolerance,wall_s,cpu_s,max_bound,load" > "$OUT/exact_scene.csv"
    for cfg in "sampled|2e-3" "exact|1e-6"; do
      m=${cfg%%|*}; t=${cfg#*|}
      l=$(load)
      run "scene-$m" "$BIN" scene "$tmp/s/scene.toml" --out "$tmp/out-$m" --no-seed-luts --method "$m" --tolerance "$t" -q
      bound=$(python3 -c "import json; r=json.load(open('$tmp/out-$m/report.json')); print(max(l.get('max_error_bound', 0) for l in r.get('lights', [{}])))" 2>/dev/null || echo nan)
      echo "$m,$t,$(wall "scene-$m"),$(cpu "scene-$m"),$bound,$l" >> "$OUT/exact_scene.csv"
    done
    ;;
  grid)
    # The exact bake at the float floor against the sampled default, interleaved, REPEATS times per size
    # (SIZES, default "32 64"; REPEATS default 3): wall and CPU of each run, and the largest difference
    # of the sampled bake from the exact one of the same repeat.
    echo "size,repeat,method,setting,wall_s,cpu_s,max_abs_difference_to_exact,load" > "$OUT/exact_grid_bake.csv"
    for size in ${SIZES:-32 64}; do
      for r in $(seq "${REPEATS:-3}"); do
        for cfg in "sampled|default|--method sampled" "exact|1e-7|--method exact --tolerance 1e-7"; do
          m=${cfg%%|*}; rest=${cfg#*|}; setting=${rest%%|*}; flags=${rest#*|}
          l=$(load)
          # shellcheck disable=SC2086
          run "grid-$m" "$BIN" bake --size "$size" $flags --out "$tmp/grid-$m.exr" -q
          diff=0
          if [ "$m" = exact ]; then
            diff=$(/opt/microshadow-py/bin/python3 - "$tmp/grid-exact.exr" "$tmp/grid-sampled.exr" <<'PY' 2>/dev/null || echo nan
import sys, numpy as np, OpenImageIO as oiio
a = oiio.ImageInput.open(sys.argv[1]); x = a.read_image("float"); a.close()
b = oiio.ImageInput.open(sys.argv[2]); y = b.read_image("float"); b.close()
n = min(x.shape[2], 4)
print(f"{float(np.nanmax(np.abs(x[..., :n] - y[..., :n]))):.3e}")
PY
)
          fi
          echo "$size,$r,$m,$setting,$(wall "grid-$m"),$(cpu "grid-$m"),$diff,$l" >> "$OUT/exact_grid_bake.csv"
        done
      done
    done
    ;;
  *) echo "unknown part '$part' (eval, bake, scene, grid)" >&2; exit 2 ;;
  esac
done
