#!/usr/bin/env bash
# The exact references of the jobs, two builds interleaved (BEFORE and AFTER: two microshadow binaries),
# REPEATS times (default 3), from the repository root:
#     bash docs/bench/exact_jobs_bench.sh BEFORE AFTER [REPEATS]
# Jobs, each at its defaults except where said:
#   repr-full-range   repr bake --preset full-range (589,824 isotropic queries: 9 azimuth nodes a texel)
#   repr-realistic    repr bake --preset realistic (294,912 isotropic queries: 8 NdotV x 9 nodes a row)
#   repr-anisotropic  repr bake --preset anisotropic (the same bake, then 2,000,000 anisotropic queries)
#   design-reference  the reference set of docs/study/design-realistic.toml by the exact method (16,384
#                     Halton points; a fresh cache each run; design's default candidates)
#   design-reference-262k  the same region with 262,144 points (the per-point cost without start-up)
#   sweep-isotropic   sweep of docs/study/azimuth.toml's isotropic grid by the exact method (53,248 points,
#                     chunks of 4,096) with its analytic comparators only (stage: its progress line's seconds)
#   scene-1024        scene of the 1024 x 1024 example (scripts/make_example_scene.py --size 1024), one light,
#                     its default method (exact)
# For each run: wall and user+sys CPU seconds of the command, and the seconds the job records for its exact
# stage (the bake's, the correction's, the reference set's, the sweep's, the scene's sampling), with the
# load average at its start -> docs/bench/exact_jobs_grid.csv. max_abs_difference: the largest difference
# of AFTER's output values from BEFORE's in the same repeat (representation coefficients, reference and
# sweep terms, scene pixels' terms).
set -euo pipefail
BEFORE=$(realpath "$1") AFTER=$(realpath "$2") REPEATS=${3:-3}
OUT=${OUT:-docs/bench/exact_jobs_grid.csv}
PY=${PY:-/opt/microshadow-py/bin/python3}
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-/tmp/pocl-cache}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
root=$PWD
load() { cut -d' ' -f1 /proc/loadavg; }
/usr/bin/python3 scripts/make_example_scene.py --size 1024 "$tmp/scene" > /dev/null
# The design spec by the exact method (its default): the shipped spec less its sampling table.
sed '/^\[sampling\]/,$d' docs/study/design-realistic.toml > "$tmp/design-exact.toml"
sed -e '/^\[sampling\]/,$d' -e 's/^count = 16384/count = 262144/' -e 's/^name = .*/name = "realistic-262k"/' \
  docs/study/design-realistic.toml > "$tmp/design-exact-262k.toml"
# The sweep spec by the exact method, analytic comparators only (no LUT files needed).
sed -e '/^\[sampling\]/,/^seed/d' -e '/^\[\[comparators.lut\]\]/,$d' docs/study/azimuth.toml > "$tmp/sweep-exact.toml"

# run NAME DIR CMD...: the command in DIR, its wall and CPU seconds into $tmp/NAME.time
run() {
  local name=$1 dir=$2; shift 2
  (cd "$dir" && /usr/bin/time -f "%e %U %S" -o "$tmp/$name.time" "$@" > /dev/null 2> "$tmp/$name.err") ||
    { cat "$tmp/$name.err" >&2; exit 1; }
}
# stage JOB DIR ERR: the seconds the job recorded for its exact stage (ERR: its standard error)
stage() {
  "$PY" - "$1" "$2" "$3" <<'PY'
import glob, json, re, sys
job, d, err = sys.argv[1], sys.argv[2], sys.argv[3]
if job.startswith("repr"):
    import OpenImageIO as oiio
    i = oiio.ImageInput.open(f"{d}/r.exr"); m = json.loads(i.spec().getattribute("microshadow")); i.close()
    s = m["bake"]["seconds"] + (m.get("correction", {}).get("seconds", 0) if isinstance(m.get("correction"), dict) else 0)
elif job.startswith("design-reference"):
    s = json.load(open(glob.glob(f"{d}/cache/reference-*.json")[0]))["seconds"]
elif job == "sweep-isotropic":
    s = float(re.findall(r"sweep: 100% \(\d+/\d+\) ([0-9.]+) s", open(err).read())[-1])
else:
    s = json.load(open(f"{d}/out/report.json"))["seconds"]["sampling"]
print(f"{s:.3f}")
PY
}
# values JOB DIR: the job's output values, one a line
values() {
  "$PY" - "$1" "$2" <<'PY'
import csv, glob, sys
job, d = sys.argv[1], sys.argv[2]
if job.startswith("repr"):
    import OpenImageIO as oiio, numpy as np
    i = oiio.ImageInput.open(f"{d}/r.exr"); x = np.asarray(i.read_image("float")).ravel(); i.close()
    print("\n".join(repr(float(v)) for v in x))
elif job.startswith("design-reference"):
    for r in csv.DictReader(open(glob.glob(f"{d}/cache/reference-*.csv")[0])): print(r["term"])
elif job == "sweep-isotropic":
    for r in csv.DictReader(open(f"{d}/out/sweep.csv")): print(r["term"])
else:
    import OpenImageIO as oiio, numpy as np
    # The scene's term per pixel: the exact reference's channel of the light.
    i = oiio.ImageInput.open(f"{d}/out/scene.exr"); names = list(i.spec().channelnames)
    x = np.asarray(i.read_image("float"))[..., names.index("sun.reference")].ravel(); i.close()
    print("\n".join(repr(float(v)) for v in x))
PY
}
job_cmd() {  # job_cmd JOB BIN: the command line of JOB with binary BIN
  case $1 in
  repr-full-range)  echo "$2 repr bake --preset full-range --out r.exr -q" ;;
  repr-realistic)   echo "$2 repr bake --preset realistic --out r.exr -q" ;;
  repr-anisotropic) echo "$2 repr bake --preset anisotropic --out r.exr -q" ;;
  design-reference) echo "$2 design --reference $tmp/design-exact.toml --cache cache --out design -q" ;;
  design-reference-262k) echo "$2 design --reference $tmp/design-exact-262k.toml --cache cache --out design -q" ;;
  sweep-isotropic)  echo "$2 sweep $tmp/sweep-exact.toml --out out" ;;
  scene-1024)       echo "$2 scene $tmp/scene/scene.toml --out out --no-seed-luts -q" ;;
  esac
}

echo "job,repeat,build,wall_s,cpu_s,stage_s,max_abs_difference,load" > "$OUT"
for r in $(seq "$REPEATS"); do
  for job in ${JOBS:-repr-full-range repr-realistic repr-anisotropic design-reference design-reference-262k sweep-isotropic scene-1024}; do
    # Alternate which build goes first, so that neither always meets the other's cache or load.
    builds="before after"; [ $((r % 2)) -eq 0 ] && builds="after before"
    for b in $builds; do
      bin=$BEFORE; [ "$b" = after ] && bin=$AFTER
      d="$tmp/$job-$b"; rm -rf "$d"; mkdir -p "$d"
      l=$(load)
      # shellcheck disable=SC2046
      run "$job-$b" "$d" $(job_cmd "$job" "$bin")
      echo "$(cut -d' ' -f1 "$tmp/$job-$b.time") $(awk '{print $2 + $3}' "$tmp/$job-$b.time") $(stage "$job" "$d" "$tmp/$job-$b.err") $l" > "$tmp/$job-$b.row"
    done
    values "$job" "$tmp/$job-before" > "$tmp/vb"; values "$job" "$tmp/$job-after" > "$tmp/va"
    diff=$(paste -d' ' "$tmp/vb" "$tmp/va" | awk '{d = $1 - $2; if (d < 0) d = -d; if (d > m) m = d} END {printf "%.3e", m}')
    for b in before after; do
      read -r w c s l < "$tmp/$job-$b.row"
      echo "$job,$r,$b,$w,$c,$s,$([ "$b" = after ] && echo "$diff" || echo 0),$l" >> "$OUT"
    done
  done
done
cd "$root"
echo "wrote $OUT"
