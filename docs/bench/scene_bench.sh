#!/usr/bin/env bash
# Benchmarks of scenes, run from the repository root after a Release build:
#     bash docs/bench/scene_bench.sh [scene] [bake]      (both by default)
# scene: the example scene at 1024 x 1024 (scripts/make_example_scene.py --size 1024), one directional
#        light, per-pixel bound 2e-3 at 99.9 %, `microshadow scene --no-seed-luts` with the defaults (tiles
#        of sampling.tile_pixels 65536, sample counts predicted from neighbours, predict_stride 8), the
#        whole image at once (tile_pixels 0), every query from min_samples (predict_stride 1), and
#        --no-skip, each under
#        /usr/bin/time -v: wall, user CPU seconds, peak RSS and the report's sample counts
#        -> docs/bench/scene.csv
# bake:  `microshadow bake --scene` on the 256 x 256 example scene and on its texture set on a flat plane
#        (the same AO and roughness, normal (0, 0, 1)), --scene-layout fit and layout: texels
#        baked of the full layout, the scene bake's time against the full bake of the same layout (same
#        run), and the error of the scene LUT, the default LUT and the azimuth-mean floor on sampled lookups
#        -> docs/bench/scene_bake.csv
# The machine is shared: compare CPU seconds and sample counts; wall times carry the load average, which
# the CSV records.
set -euo pipefail
BIN=${MICROSHADOW:-build/microshadow}
OUT=docs/bench
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-/tmp/pocl-cache}
parts=("$@")
[ ${#parts[@]} -gt 0 ] || parts=(scene bake)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
load() { cut -d' ' -f1 /proc/loadavg; }
field() { grep -F "$1" "$2" | sed 's/.*: //'; }
for part in "${parts[@]}"; do
  case $part in
  scene)
    /usr/bin/python3 scripts/make_example_scene.py --size 1024 "$tmp/s" > /dev/null
    echo "run,wall,user_s,peak_rss_kib,load_before,pixel_lights,sampled,samples_drawn,samples_final,skipped_fraction,sampling_s" > "$OUT/scene.csv"
    for run in tiles whole no-predict no-skip; do
      cp "$tmp/s/scene.toml" "$tmp/s/run.toml"
      flags=""
      case $run in
        whole) echo "tile_pixels = 0" >> "$tmp/s/run.toml" ;;
        no-predict) echo "predict_stride = 1" >> "$tmp/s/run.toml" ;;
        no-skip) flags="--no-skip" ;;
      esac
      l=$(load)
      /usr/bin/time -v "$BIN" scene "$tmp/s/run.toml" --out "$tmp/out-$run" --no-seed-luts --quiet $flags 2> "$tmp/time-$run"
      python3 - "$tmp/out-$run/report.json" "$run" "$(field 'Elapsed (wall' "$tmp/time-$run")" "$(field 'User time' "$tmp/time-$run")" \
          "$(field 'Maximum resident' "$tmp/time-$run")" "$l" >> "$OUT/scene.csv" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); w = j["work"]
print(",".join([sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], sys.argv[6], str(w["pixel_lights"]), str(w["sampled"]),
                str(w["samples_drawn"]), str(w.get("samples_final", "")), "%.4f" % w["skipped_fraction"],
                "%.1f" % j["seconds"]["sampling"]]))
PY
      echo "scene $run: $(tail -1 "$OUT/scene.csv")"
    done ;;
  bake)
    # The flat variant: the example's [normal] table replaced by a constant, its images by absolute paths.
    sed -e '/^file = "normal.png"/d' -e '/^space = "tangent"/d' -e '/^green = "+Y"/d' \
        -e 's|^\[normal\]|[normal]\nvalue = [0.0, 0.0, 1.0]|' -e "s|file = \"\([a-z]*\.png\)\"|file = \"$PWD/examples/scene/\1\"|" \
        examples/scene/scene.toml > "$tmp/flat.toml"
    echo "scene,layout,texels,baked_texels,touched_texels,baked_slices,slices,scene_bake_s,full_bake_s,ratio,scene_lut_weighted_max,scene_lut_weighted_rms,default_weighted_max,default_weighted_rms,reference_bound,default_serves,load_before,histogram_updates,full_histogram_updates,batches,full_batches,azimuth_floor_weighted_max,azimuth_floor_weighted_rms,azimuth_floor_bound" > "$OUT/scene_bake.csv"
    for scene in example flat; do
    toml=examples/scene/scene.toml
    [ $scene = flat ] && toml="$tmp/flat.toml"
    for layout in fit layout; do
      l=$(load)
      "$BIN" bake --scene "$toml" --scene-layout $layout --out "$tmp/$layout.exr" --scene-report "$tmp/rep-$layout" --quiet
      python3 - "$tmp/rep-$layout/report.json" $layout "$l" $scene >> "$OUT/scene_bake.csv" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); c = j["coverage"]; t = j["time"]; e = j["lights"][0]["errors"]
print(",".join(str(x) for x in [sys.argv[4], sys.argv[2], c["texels"], c["baked_texels"], c["touched_texels"], c["baked_slices"], c["slices"],
      "%.2f" % t["scene_bake_seconds"], "%.2f" % t["full_bake_seconds"], "%.3f" % t["ratio"],
      "%.4g" % e["scene_lut"]["weighted_max"], "%.4g" % e["scene_lut"]["weighted_rms"],
      "%.4g" % e["default_lut"]["weighted_max"], "%.4g" % e["default_lut"]["weighted_rms"], "%.3g" % e["reference_bound"],
      j["verdict"]["default_serves"], sys.argv[3], t["histogram_updates"], t["full_histogram_updates"], t["batches"], t["full_batches"],
      "%.4g" % e["azimuth_mean_floor"]["weighted_max"], "%.4g" % e["azimuth_mean_floor"]["weighted_rms"], "%.3g" % e["azimuth_mean_floor_bound"]]))
PY
      echo "bake $scene $layout: $(tail -1 "$OUT/scene_bake.csv")"
    done
    done ;;
  *) echo "unknown part $part (scene, bake)" >&2; exit 2 ;;
  esac
done
