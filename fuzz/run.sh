#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) and runs each for a bounded time.
#   fuzz/run.sh [SECONDS_PER_TARGET]      (default 25; env BUILD_DIR, default build-fuzz; JOBS, default 2:
#                                          the build's jobs and how many targets fuzz at once, each a
#                                          single-threaded libFuzzer process on a core of its own;
#                                          FUZZ_SEED: libFuzzer's -seed, default random)
# CI sets FUZZ_SEED so a run explores the same inputs on every machine: a red CI is then a finding that
# reproduces, not a lucky draw; exploration with fresh seeds is a developer's longer run.
# Seeds: the hand-made corpus in tests/data/hostile, fuzz/{csv,spec,cli,env,...}-seeds (encodings, control
# bytes, huge counts and integers) plus examples/. New inputs found go to
# $BUILD_DIR/fuzz-corpus/<target> (kept between runs); crashes to $BUILD_DIR/fuzz-artifacts/.
# Exit status: non-zero if any target crashed, leaked, timed out on one input or ran out of memory.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET="${1:-25}"
BUILD_DIR="${BUILD_DIR:-build-fuzz}"
JOBS="${JOBS:-2}"

if [[ ! -f "$BUILD_DIR/CMakeCache.txt" ]]; then
  cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DMICROSHADOW_FUZZ=ON -DMICROSHADOW_SANITIZE=ON \
    -DMICROSHADOW_BUILD_TESTS=OFF -DMICROSHADOW_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$BUILD_DIR" -j"$JOBS" --target fuzz_csv fuzz_spec fuzz_cli fuzz_text fuzz_sweep_files fuzz_lut_file fuzz_repr_file fuzz_scene fuzz_area_csv fuzz_environment

seed_dirs() {  # the seeds of one target, as directories libFuzzer reads (read-only; never written)
  case "$1" in
    fuzz_csv) echo tests/data/hostile tests/data/hostile/valid fuzz/csv-seeds ;;
    fuzz_spec) echo tests/data/hostile/spec fuzz/spec-seeds ;;
    fuzz_cli) echo fuzz/cli-seeds ;;
    fuzz_text) echo fuzz/cli-seeds fuzz/csv-seeds ;;
    fuzz_sweep_files) echo fuzz/sweep-seeds ;;
    fuzz_lut_file) echo fuzz/lut-seeds tests/data/hostile/exr ;;
    fuzz_repr_file) echo fuzz/repr-seeds ;;
    fuzz_scene) echo fuzz/scene-seeds ;;
    fuzz_area_csv) echo fuzz/area-seeds ;;
    fuzz_environment) echo fuzz/env-seeds tests/data/hostile/exr ;;
  esac
}

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
seed_option=()
[[ -n "${FUZZ_SEED:-}" ]] && seed_option=(-seed="$FUZZ_SEED")
targets=(fuzz_csv fuzz_spec fuzz_cli fuzz_text fuzz_sweep_files fuzz_lut_file fuzz_repr_file fuzz_scene fuzz_area_csv fuzz_environment)
fuzz_one() {  # runs one target for its time; its exit status goes to $BUILD_DIR/fuzz-<target>.status
  local target=$1 corpus="$BUILD_DIR/fuzz-corpus/$1" artifacts="$BUILD_DIR/fuzz-artifacts/$1/"
  mkdir -p "$corpus" "$artifacts"
  # -rss_limit_mb: "allocates without bound" is a finding; -timeout: one input may not take > 10 s.
  local rc=0
  # shellcheck disable=SC2046
  "$BUILD_DIR/fuzz/$target" "$corpus" $(seed_dirs "$target") \
    -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=2048 -max_len=4096 \
    -dict=fuzz/"${target#fuzz_}".dict -artifact_prefix="$artifacts" -print_final_stats=1 "${seed_option[@]}" \
    >"$BUILD_DIR/fuzz-$target.log" 2>&1 || rc=$?
  echo "$rc" >"$BUILD_DIR/fuzz-$target.status"
}
# JOBS targets at a time (every target still runs its full SECONDS_PER_TARGET), reported in order.
running=0
for target in "${targets[@]}"; do
  rm -f "$BUILD_DIR/fuzz-$target.status"
  fuzz_one "$target" &
  running=$((running + 1))
  if (( running >= JOBS )); then wait -n || true; running=$((running - 1)); fi
done
wait
status=0
for target in "${targets[@]}"; do
  log="$BUILD_DIR/fuzz-$target.log"
  artifacts="$BUILD_DIR/fuzz-artifacts/$target/"
  if [[ "$(cat "$BUILD_DIR/fuzz-$target.status" 2>/dev/null)" == 0 ]]; then
    result=ok
  else
    result=FAILED
    status=1
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  crashes=$(find "$artifacts" -type f | wc -l)
  echo "fuzz: $target: $result, $runs inputs in ${SECONDS_PER_TARGET}s, $crashes crash artifacts (log: $log)"
  [[ "$result" == ok ]] || tail -30 "$log"
done
exit "$status"
