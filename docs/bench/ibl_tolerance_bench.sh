#!/usr/bin/env bash
# The default prefilter (tolerance, automatic bright split) against brute-force importance sampling on every
# studio-light world blender-data ships (scripts/install-example-data.sh), 64^2 faces (5 mips), errors against
# the brute-force oracle on the same 48 random texels of mips 1-4 (--verify 48, seed 1), CPU seconds of the
# prefilter. Brute force: --no-fis --bright off --tolerance 0 at fixed sample counts. One CSV row per run.
# Usage: bash docs/bench/ibl_tolerance_bench.sh [OUT.csv]   (MICROSHADOW=path/to/microshadow, THREADS=1)
set -euo pipefail
ms=${MICROSHADOW:-build/microshadow}
threads=${THREADS:-1}
out=${1:-docs/bench/ibl_tolerance.csv}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
echo "world,method,samples_or_tolerance,cpu_s,wall_s,rms_relative,max_relative,worst_z,z_bound,mean_samples,bright_texels,bright_power" > "$out"
run() {  # world method param args...
    local world=$1 method=$2 param=$3; shift 3
    rm -rf "$dir/o"
    # --verify-report: brute force's bars are not honest (the rare sun), so its --verify would fail and write nothing.
    if "$ms" ibl prefilter "/usr/share/blender/datafiles/studiolights/world/$world.exr" --size 64 --out "$dir/o" --verify 48 \
        --threads "$threads" -q --irradiance-size 4 --verify-report "$@" 2> "$dir/err"; then
        python3 - "$dir/o/ibl.json" "$world" "$method" "$param" >> "$out" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))["specular"]; v = m["verify"]
print(",".join(str(x) for x in [sys.argv[2], sys.argv[3], sys.argv[4], round(m["cpu_seconds"], 2), round(m["seconds"], 2),
      v["rms_relative"], v["max_relative"], v["worst_z"], v["z_bound"], m["samples_total"] / sum(6 * (64 >> k) ** 2 for k in range(1, 5)),
      m["bright_texels"]["count"], m["bright_texels"].get("power_fraction", 0)]))
PY
    else
        echo "$world,$method,$param,failed: $(tr ',\n' ';;' < "$dir/err")" >> "$out"
    fi
}
for w in city courtyard forest interior night studio sunrise sunset; do
    run "$w" default 0.02
    for n in 1024 4096 16384; do run "$w" brute "$n" --no-fis --bright off --tolerance 0 --samples "$n"; done
done
