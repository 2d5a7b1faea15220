#!/usr/bin/env bash
# The exact method's OpenCL kernel (run on PoCL's CPU device with --exact-kernel) from two kernel source
# trees, one binary, in one run, interleaved (A B, then B A, ...) so that machine load falls on both alike:
# `eval --method exact` (default tolerance, double kernel) and `eval --exact-float` on the 20,000 stress
# queries of exact_bench.sh, and `bake --method exact --size SIZE --tolerance 1e-7` through the kernel.
# From the repository root, with the kernel tree of another revision unpacked beside it:
#     mkdir -p /tmp/before && git archive REV kernels | tar -x -C /tmp/before
#     bash docs/bench/exact_kernel_closed_form_bench.sh BINARY /tmp/before/kernels kernels [REPEATS] [SIZE]
# -> $OUT (docs/bench/exact_kernel_closed_form.csv unless set): one row per run (wall and user+sys CPU seconds, the job's own
#    seconds as its summary says, the load average), and on stdout the after/before ratios of every repeat
#    with their median, min and max, and the largest differences between the two kernels' outputs.
set -euo pipefail
BIN=$1 BEFORE=$(realpath "$2") AFTER=$(realpath "$3") REPEATS=${4:-3} SIZE=${5:-16}
OUT=${OUT:-docs/bench/exact_kernel_closed_form.csv}
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-/tmp/pocl-cache}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 docs/bench/exact_stress_queries.py "$tmp/q.csv"
echo "repeat,kernel,job,wall_s,cpu_s,own_s,load" > "$OUT"
# one REPEAT KERNEL JOB CMD...: time one command, append its row
one() {
  local rep=$1 kernel=$2 job=$3; shift 3
  local dir=$BEFORE; [ "$kernel" = after ] && dir=$AFTER
  local l; l=$(cut -d' ' -f1 /proc/loadavg)
  MICROSHADOW_KERNEL_DIR=$dir /usr/bin/time -f "%e %U %S" -o "$tmp/t" "$@" > /dev/null 2> "$tmp/err" || {
    local rc=$?; [ $rc -eq 3 ] || { cat "$tmp/err" >&2; exit 1; }  # 3: a float value above the tolerance
  }
  local secs; secs=$(grep -o 'computed in [0-9.e+-]* s' "$tmp/err" | tail -1 | cut -d' ' -f3 || true)
  echo "$rep,$kernel,$job,$(tail -1 "$tmp/t" | awk '{print $1 "," $2 + $3}'),$secs,$l" >> "$OUT"
}
# Build both kernel programs once (PoCL caches them), so that no timed run compiles.
for k in before after; do
  one 0 "$k" warm "$BIN" eval --in "$tmp/q.csv" --out "$tmp/warm.csv" --method exact --exact-kernel -q
  one 0 "$k" warm "$BIN" eval --in "$tmp/q.csv" --out "$tmp/warm.csv" --method exact --exact-float -q
done
for rep in $(seq 1 "$REPEATS"); do
  order=(before after); [ $((rep % 2)) -eq 0 ] && order=(after before)
  for k in "${order[@]}"; do
    one "$rep" "$k" eval "$BIN" eval --in "$tmp/q.csv" --out "$tmp/$k.csv" --method exact --exact-kernel
    one "$rep" "$k" eval-float "$BIN" eval --in "$tmp/q.csv" --out "$tmp/$k-float.csv" --method exact --exact-float
    one "$rep" "$k" bake-1e-7 "$BIN" bake --size "$SIZE" --method exact --exact-kernel --tolerance 1e-7 --out "$tmp/$k.exr"
  done
done
python3 - "$OUT" <<'PY'
import csv, statistics, sys
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r["repeat"] != "0"]
def col(kernel, job, key):
    return [float(r[key]) for r in rows if r["kernel"] == kernel and r["job"] == job]
for job in ("eval", "eval-float", "bake-1e-7"):
    for key in ("own_s", "cpu_s", "wall_s"):
        a, b = col("before", job, key), col("after", job, key)
        ratios = [y / x for x, y in zip(a, b)]
        print(f"{job} {key}: after/before {statistics.median(ratios):.3f} (min {min(ratios):.3f}, max {max(ratios):.3f});"
              f" before {statistics.median(a):.3g} s, after {statistics.median(b):.3g} s")
PY
python3 - "$tmp" <<'PY'
import csv, sys
t = sys.argv[1]
for name in ("", "-float"):
    a = list(csv.DictReader(open(f"{t}/after{name}.csv"))); b = list(csv.DictReader(open(f"{t}/before{name}.csv")))
    d = [abs(float(x["term"]) - float(y["term"])) for x, y in zip(a, b)]
    e = [abs(float(x["term"]) - float(y["term"])) / (float(x["std_error"]) + float(y["std_error"]) + 1e-300) for x, y in zip(a, b)]
    m = [float(x["std_error"]) for x in a]; n = [float(y["std_error"]) for y in b]
    print(f"eval{name}: max |after - before| {max(d):.3e}, max |after - before| / (sum of estimates) {max(e):.3f};"
          f" largest estimate after {max(m):.3e}, before {max(n):.3e}")
PY
/opt/microshadow-py/bin/python3 - "$tmp" <<'PY' 2>/dev/null || true
import sys, numpy as np, OpenImageIO as oiio
t = sys.argv[1]
rd = lambda p: np.asarray(oiio.ImageInput.open(p).read_image("float"))
print(f"bake 1e-7: max |after - before| {np.abs(rd(f'{t}/after.exr') - rd(f'{t}/before.exr')).max():.3e}")
PY
