#!/usr/bin/env bash
# Benchmarks of image-based lighting, run from the repository root after a Release build:
#     bash docs/bench/ibl_bench.sh [dfg] [prefilter]      (both by default)
# dfg:       the 64 x 64 DFG LUT at several sample counts against the quadrature oracle's LUT
#            (docs/bench/ibl_dfg_quadrature64.exr, made by `microshadow ibl dfg --backend oracle --size 64`;
#            --remake-reference makes it again, ~3 minutes on 2 cores): bake seconds (kernel build excluded: a
#            warm-up run fills PoCL's cache) and max / RMS error -> docs/bench/ibl_dfg.csv
# prefilter: a 512^2-per-face cubemap of a blender-data environment (scripts/install-example-data.sh) to its
#            mip chain (8 levels, 512 .. 4, cmgen roughness), filtered importance sampling against brute-force
#            importance sampling of the full-resolution source, each at several sample counts: seconds and the
#            RMS / max error relative to the brute-force oracle on the same 48 random texels (--verify 48)
#            -> docs/bench/ibl_prefilter.csv; IBL_BENCH_OPENCL=1 IBL_BENCH_TAG=opencl runs the kernel instead
#            (kernels/prefilter/prefilter.cl), IBL_BENCH_ENV=... IBL_BENCH_TAG=name another environment
# bright:    the same chain and texels, in one run: filtered importance sampling with and without the
#            bright texels summed explicitly (--bright-threshold 64, on mips of roughness >= 0.2), against brute
#            force, with the replicate std error beside the error (variance vs bias)
#            -> docs/bench/ibl_prefilter_bright_<tag>.csv (IBL_BENCH_ENV, IBL_BENCH_TAG as above; tag forest by default)
#            IBL_BENCH_WIDE=1: both methods with 4x samples on the wide-lobe mips (--wide-samples-factor 4)
#            -> docs/bench/ibl_prefilter_bright_wide4_<tag>.csv
set -euo pipefail
BIN=${MICROSHADOW:-build/microshadow}
OUT=docs/bench
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-/tmp/pocl-cache-ibl}
parts=("$@")
[ ${#parts[@]} -gt 0 ] || parts=(dfg prefilter)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
json() { python3 -c "import json,sys; m=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

for part in "${parts[@]}"; do
case $part in
--remake-reference)
    "$BIN" ibl dfg --backend oracle --size 64 --out "$OUT/ibl_dfg_quadrature64.exr" --quiet ;;
dfg)
    ref="$OUT/ibl_dfg_quadrature64.exr"
    "$BIN" ibl dfg --size 64 --samples 4096 --out "$tmp/warm.exr" --quiet  # fills the kernel cache
    echo "samples_per_texel,warp,seconds,max_error_scale,max_error_bias,max_error_E,rms_error_E,max_std_error" > "$OUT/ibl_dfg.csv"
    for warp in 1 3; do
        "$BIN" ibl dfg --size 64 --samples 4096 --warp $warp --out "$tmp/warm.exr" --quiet
        for s in 4096 8192 16384 32768 65536 131072 262144; do
            "$BIN" ibl dfg --size 64 --samples $s --warp $warp --out "$tmp/d.exr" --compare "$ref" 2> "$tmp/log"
            line=$(grep '^compare:' "$tmp/log")
            secs=$(echo "$line" | sed -E 's/.*bake ([0-9.e+-]+) s.*/\1/')
            ms=$(echo "$line" | sed -E 's/.*scale ([0-9.e+-]+) bias ([0-9.e+-]+) E ([0-9.e+-]+) .*rms ([0-9.e+-]+) ([0-9.e+-]+) ([0-9.e+-]+);.*/\1,\2,\3,\6/')
            se=$(grep '^ibl dfg: [0-9]* x' "$tmp/log" | sed -E 's/.*max std error ([0-9.e+-]+),.*/\1/')
            echo "$s,$warp,$secs,$ms,$se" | tee -a "$OUT/ibl_dfg.csv"
        done
    done ;;
prefilter)
    env=${IBL_BENCH_ENV:-/usr/share/blender/datafiles/studiolights/world/forest.exr}
    [ -f "$env" ] || { echo "no $env: run scripts/install-example-data.sh" >&2; exit 2; }
    csv="$OUT/ibl_prefilter${IBL_BENCH_TAG:+_$IBL_BENCH_TAG}.csv"  # IBL_BENCH_ENV=... IBL_BENCH_TAG=studio: another environment
    echo "method,samples_per_texel,seconds,cpu_seconds,texels,rms_relative_error,max_relative_error,verified_texels" > "$csv"
    run() {  # method samples extra-args...
        local method=$1 samples=$2; shift 2
        "$BIN" ibl prefilter "$env" --out "$tmp/p" --size 512 --samples "$samples" --verify 48 --verify-report --tolerance 0 --bright off --replicates 4 --bright-min-roughness 0.2 --quiet "$@"
        local j="$tmp/p/ibl.json"
        echo "$method,$samples,$(json "$j" "m['specular']['seconds']"),$(json "$j" "m['specular']['cpu_seconds']"),$(json "$j" "sum(6*(512>>k)**2 for k in range(1,len(m['specular']['roughness'])))"),$(json "$j" "m['specular']['verify']['rms_relative']"),$(json "$j" "m['specular']['verify']['max_relative']"),48" | tee -a "$csv"
    }
    if [ -n "${IBL_BENCH_OPENCL:-}" ]; then  # the kernel on the default OpenCL device (wall seconds; no CPU time)
        "$BIN" ibl prefilter "$env" --out "$tmp/w" --size 16 --samples 64 --device default --quiet  # kernel cache
        for s in 64 256 1024; do run filtered-opencl $s --device default; done
        for s in 1024 4096; do run brute-force-opencl $s --no-fis --device default; done
    elif [ -n "${IBL_BENCH_QUICK:-}" ]; then
        for s in 64 256; do run filtered $s; done
        for s in 256 1024; do run brute-force $s --no-fis; done
    else
        for s in 64 256 1024; do run filtered $s; done
        run filtered-bias1 256 --lod-bias 1
        for s in 256 1024 4096; do run brute-force $s --no-fis; done
    fi ;;
bright)
    env=${IBL_BENCH_ENV:-/usr/share/blender/datafiles/studiolights/world/forest.exr}
    [ -f "$env" ] || { echo "no $env: run scripts/install-example-data.sh" >&2; exit 2; }
    csv="$OUT/ibl_prefilter_bright${IBL_BENCH_WIDE:+_wide4}_${IBL_BENCH_TAG:-forest}.csv"
    echo "method,samples_per_texel,bright_texels,bright_power_fraction,cpu_seconds,seconds,rms_relative_error,rms_relative_std_error,max_relative_error,verified_texels" > "$csv"
    brun() {  # method samples extra-args...
        local method=$1 samples=$2; shift 2
        "$BIN" ibl prefilter "$env" --out "$tmp/p" --size 512 --samples "$samples" --verify 48 --verify-report --tolerance 0 --replicates 4 --bright-min-roughness 0.2 $([[ " $* " == *" --bright-threshold "* ]] || echo --bright off) --quiet "$@"
        local j="$tmp/p/ibl.json"
        echo "$method,$samples,$(json "$j" "m['specular'].get('bright_texels',{}).get('count',0)"),$(json "$j" "m['specular'].get('bright_texels',{}).get('power_fraction',0)"),$(json "$j" "m['specular']['cpu_seconds']"),$(json "$j" "m['specular']['seconds']"),$(json "$j" "m['specular']['verify']['rms_relative']"),$(json "$j" "m['specular']['verify']['rms_relative_std_error']"),$(json "$j" "m['specular']['verify']['max_relative']"),48" | tee -a "$csv"
    }
    if [ -n "${IBL_BENCH_WIDE:-}" ]; then  # 4x samples on the wide-lobe mips, for both methods
        for s in 64 256; do brun filtered-bright64-wide4 $s --bright-threshold 64 --wide-samples-factor 4; done
        for s in 1024 4096; do brun brute-force-wide4 $s --no-fis --wide-samples-factor 4; done
    else
        for s in 64 256; do brun filtered $s; brun filtered-bright64 $s --bright-threshold 64; done
        for s in 256 1024 4096; do brun brute-force $s --no-fis; done
    fi ;;
*) echo "unknown part $part" >&2; exit 2 ;;
esac
done
