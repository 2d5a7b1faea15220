#!/usr/bin/env bash
# Two builds of the exact method compared in one run, interleaved (A B, then B A, ...), so that machine load
# falls on both alike: `eval --method exact` (default tolerance, host evaluator) on the 20,000 stress
# queries of exact_bench.sh, and `bake --method exact --size 32` at --tolerance 1e-7 and 1e-6, beside the
# sampled default bake of the same size (run with the second build). From the repository root:
#     bash docs/bench/exact_closed_form_bench.sh BEFORE_BINARY AFTER_BINARY [REPEATS]   (3 by default)
# -> docs/bench/exact_closed_form.csv: one row per run (wall and user+sys CPU seconds, eval's own seconds
#    and microseconds per query per core for eval, the load average), and on stdout the after/before ratios
#    of every repeat with their median, min and max, and the max |difference| between the two builds' bakes.
set -euo pipefail
BEFORE=$1 AFTER=$2 REPEATS=${3:-3}
OUT=docs/bench/exact_closed_form.csv
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-/tmp/pocl-cache}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 docs/bench/exact_stress_queries.py "$tmp/q.csv"
echo "repeat,build,job,wall_s,cpu_s,eval_s,us_per_query_core,load" > "$OUT"
# one REPEAT BUILD JOB CMD...: time one command, append its row
one() {
  local rep=$1 build=$2 job=$3; shift 3
  local l; l=$(cut -d' ' -f1 /proc/loadavg)
  /usr/bin/time -f "%e %U %S" -o "$tmp/t" "$@" > /dev/null 2> "$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
  local secs="" us=""
  if [ "$job" = eval ]; then
    secs=$(grep -o '[0-9.e+-]* s on' "$tmp/err" | tail -1 | cut -d' ' -f1)
    us=$(awk -v s="$secs" 'BEGIN{printf "%.2f", s * 2 * 1e6 / 20000}')  # 2 cores
  fi
  echo "$rep,$build,$job,$(awk '{print $1}' "$tmp/t"),$(awk '{print $2 + $3}' "$tmp/t"),$secs,$us,$l" >> "$OUT"
}
"$AFTER" eval --in "$tmp/q.csv" --out "$tmp/warm.csv" --method sampled -q  # warm PoCL's kernel cache
for rep in $(seq 1 "$REPEATS"); do
  order=(before after); [ $((rep % 2)) -eq 0 ] && order=(after before)
  for build in "${order[@]}"; do
    bin=$BEFORE; [ "$build" = after ] && bin=$AFTER
    one "$rep" "$build" eval "$bin" eval --in "$tmp/q.csv" --out "$tmp/$build.csv" --method exact
    one "$rep" "$build" bake-1e-7 "$bin" bake --size 32 --method exact --tolerance 1e-7 --out "$tmp/$build-e7.exr" -q
    one "$rep" "$build" bake-1e-6 "$bin" bake --size 32 --method exact --tolerance 1e-6 --out "$tmp/$build-e6.exr" -q
  done
  one "$rep" after bake-sampled "$AFTER" bake --size 32 --method sampled --out "$tmp/sampled.exr" -q
done
python3 - "$OUT" "$tmp" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
def col(build, job, key):
    return [float(r[key]) for r in rows if r["build"] == build and r["job"] == job]
def show(name, a, b):
    ratios = [y / x for x, y in zip(a, b)]
    print(f"{name}: after/before {statistics.median(ratios):.3f} (min {min(ratios):.3f}, max {max(ratios):.3f});"
          f" before {statistics.median(a):.3g} s, after {statistics.median(b):.3g} s")
show("eval exact, eval seconds", col("before", "eval", "eval_s"), col("after", "eval", "eval_s"))
print(f"eval exact, us per query per core: before {statistics.median(col('before', 'eval', 'us_per_query_core')):.2f},"
      f" after {statistics.median(col('after', 'eval', 'us_per_query_core')):.2f}")
for job in ("bake-1e-7", "bake-1e-6"):
    show(job + " wall", col("before", job, "wall_s"), col("after", job, "wall_s"))
    show(job + " cpu", col("before", job, "cpu_s"), col("after", job, "cpu_s"))
    s = col("after", "bake-sampled", "wall_s")
    ratios = [y / x for x, y in zip(s, col("after", job, "wall_s"))]
    print(f"{job} after / sampled default bake, wall: {statistics.median(ratios):.2f} (min {min(ratios):.2f}, max {max(ratios):.2f})")
PY
/opt/microshadow-py/bin/python3 - "$tmp" <<'PY' 2>/dev/null || true
import sys, numpy as np, OpenImageIO as oiio
t = sys.argv[1]
rd = lambda p: np.asarray(oiio.ImageInput.open(p).read_image("float"))
for tol in ("e7", "e6"):
    print(f"bake 1e-{tol[1]}: max |after - before| {np.abs(rd(f'{t}/after-{tol}.exr') - rd(f'{t}/before-{tol}.exr')).max():.3e}")
PY
python3 - "$tmp" <<'PY'
import csv, sys
t = sys.argv[1]
a = list(csv.DictReader(open(f"{t}/after.csv"))); b = list(csv.DictReader(open(f"{t}/before.csv")))
d = [abs(float(x["term"]) - float(y["term"])) for x, y in zip(a, b)]
e = [abs(float(x["term"]) - float(y["term"])) / (float(x["std_error"]) + float(y["std_error"]) + 1e-300) for x, y in zip(a, b)]
print(f"eval: max |after - before| {max(d):.3e}, max |after - before| / (sum of estimates) {max(e):.3f}")
PY
