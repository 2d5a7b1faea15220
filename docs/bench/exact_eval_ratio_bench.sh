#!/usr/bin/env bash
# `eval --method exact` at its default tolerance (1e-10, host evaluator) against the sampled kernel at 4,096
# samples, on the 20,000 stress queries of exact_bench.sh, two builds of the exact method in one run,
# interleaved (the order alternates every repeat), so that machine load falls on all of them alike. From the
# repository root after a Release build:
#     bash docs/bench/exact_eval_ratio_bench.sh BEFORE_BINARY AFTER_BINARY [REPEATS]   (5 by default)
# Each repeat also runs both methods on the first query alone, whose CPU seconds are the program's start-up
# (process, OpenCL platform, CSV and provenance), so that the evaluation's own CPU is the difference.
# -> docs/bench/exact_eval_ratio.csv: one row per run (eval's own seconds, user+sys CPU seconds, the load
#    average), and on stdout the ratios exact / sampled of every repeat with their median, min and max, and
#    how far the after build's values are from the before build's at tolerance 1e-13 compared with their
#    estimates (every |after - reference| within the after value's estimated error).
set -euo pipefail
BEFORE=$1 AFTER=$2 REPEATS=${3:-5}
OUT=docs/bench/exact_eval_ratio.csv
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-/tmp/pocl-cache}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 docs/bench/exact_stress_queries.py "$tmp/q.csv"
head -2 "$tmp/q.csv" > "$tmp/q1.csv"
"$BEFORE" eval --in "$tmp/q.csv" --out "$tmp/reference.csv" --method exact --tolerance 1e-13 --allow-tolerance-miss -q
"$AFTER" eval --in "$tmp/q.csv" --out "$tmp/warm.csv" --method sampled --samples 4096 -q  # warm PoCL's kernel cache
echo "repeat,run,queries,eval_s,cpu_s,load" > "$OUT"
# one REPEAT RUN QUERIES CMD...: time one command, append its row
one() {
  local rep=$1 run=$2 queries=$3; shift 3
  local l; l=$(cut -d' ' -f1 /proc/loadavg)
  # CPU seconds of the process and its threads to the millisecond by perf's task clock where perf runs
  # (/usr/bin/time's user + sys, rounded to 10 ms, elsewhere)
  if perf stat -x, -e task-clock -o "$tmp/t" "$@" > /dev/null 2> "$tmp/err"; then
    awk -F, '/task-clock/ {printf "%.4f\n", $1 / 1000}' "$tmp/t" > "$tmp/cpu"
  else
    /usr/bin/time -f "%U %S" -o "$tmp/t" "$@" > /dev/null 2> "$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
    awk '{print $1 + $2}' "$tmp/t" > "$tmp/cpu"
  fi
  local secs; secs=$(grep -o '[0-9.e+-]* s on' "$tmp/err" | tail -1 | cut -d' ' -f1)
  echo "$rep,$run,$queries,$secs,$(cat "$tmp/cpu"),$l" >> "$OUT"
}
for rep in $(seq 1 "$REPEATS"); do
  runs=(exact-before exact-after sampled-4096)
  [ $((rep % 2)) -eq 0 ] && runs=(sampled-4096 exact-after exact-before)
  for run in "${runs[@]}"; do
    case $run in
      exact-before) cmd=("$BEFORE" eval --method exact) ;;
      exact-after) cmd=("$AFTER" eval --method exact) ;;
      sampled-4096) cmd=("$AFTER" eval --method sampled --samples 4096) ;;
    esac
    one "$rep" "$run" 20000 "${cmd[@]}" --in "$tmp/q.csv" --out "$tmp/$run.csv"
    one "$rep" "$run" 1 "${cmd[@]}" --in "$tmp/q1.csv" --out "$tmp/$run-1.csv"
  done
done
python3 - "$OUT" "$tmp" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
def col(run, queries, key):
    return [float(r[key]) for r in rows if r["run"] == run and r["queries"] == str(queries)]
def show(name, a, b):
    ratios = [x / y for x, y in zip(a, b)]
    print(f"{name}: {statistics.median(ratios):.3f} (min {min(ratios):.3f}, max {max(ratios):.3f})")
sampled_own = [c - s for c, s in zip(col("sampled-4096", 20000, "cpu_s"), col("sampled-4096", 1, "cpu_s"))]
for build in ("before", "after"):
    run = "exact-" + build
    show(f"exact {build} / sampled 4096, eval's own seconds", col(run, 20000, "eval_s"), col("sampled-4096", 20000, "eval_s"))
    show(f"exact {build} / sampled 4096, process CPU seconds", col(run, 20000, "cpu_s"), col("sampled-4096", 20000, "cpu_s"))
    own = [c - s for c, s in zip(col(run, 20000, "cpu_s"), col(run, 1, "cpu_s"))]
    show(f"exact {build} / sampled 4096, CPU seconds less start-up", own, sampled_own)
    print(f"exact {build}: eval's own seconds median {statistics.median(col(run, 20000, 'eval_s')):.3g},"
          f" CPU less start-up median {statistics.median(own):.3g} s"
          f" ({statistics.median(own) * 1e6 / 20000:.2f} core-us a query)")
print(f"sampled 4096: eval's own seconds median {statistics.median(col('sampled-4096', 20000, 'eval_s')):.3g},"
      f" CPU less start-up median {statistics.median(sampled_own):.3g} s"
      f" ({statistics.median(sampled_own) * 1e6 / 20000:.2f} core-us a query)")
tmp = sys.argv[2]
ref = list(csv.DictReader(open(f"{tmp}/reference.csv")))
new = list(csv.DictReader(open(f"{tmp}/exact-after.csv")))
old = list(csv.DictReader(open(f"{tmp}/exact-before.csv")))
outside = sum(abs(float(n["term"]) - float(r["term"])) > float(n["std_error"]) for n, r in zip(new, ref))
moved = max(abs(float(n["term"]) - float(o["term"])) for n, o in zip(new, old))
worst = max(abs(float(n["term"]) - float(r["term"])) / float(n["std_error"]) for n, r in zip(new, ref) if float(n["std_error"]) > 0)
print(f"after against the before build at 1e-13: {outside} of {len(new)} values outside their estimate,"
      f" largest |difference| / estimate {worst:.3g}; largest |after - before| at 1e-10 {moved:.3g}")
PY
