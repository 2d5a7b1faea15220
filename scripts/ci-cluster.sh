#!/usr/bin/env bash
# The cluster stage of CI: microshadow on the engines clusters already run, on this one machine.
#
#   scripts/ci-cluster.sh [BUILD_DIR]      (default: build; needs BUILD_DIR/microshadow)
#
#   1. MPI (Open MPI, when the program was built with it): `mpirun --oversubscribe -np 3` sweep, bake,
#      repr bake, bake --scene, scene and design against one process, byte for byte (a LUT: texels and
#      metadata apart from the command line; a representation: its texture; a design: its Pareto tables;
#      a scene: its images, scene.exr's layers and its report apart from the run's provenance and times);
#      --mpi without mpirun and mpirun -np 1 refused with exit status 2.
#   2. Slurm: munged, slurmctld and slurmd started on localhost under a temporary folder (a generated
#      slurm.conf on ports of their own), a 4-task array of a sweep, of a bake, of a scene and of a design, each
#      followed by its merge job (--dependency=afterok), checked against one process; an array task
#      killed mid-run (SIGKILL) and requeued with scontrol, which resumes from the chunk store; then
#      everything is stopped.
#
# Packages (slurm-wlm, munge, openmpi-bin) are installed when missing and this runs as root; where they
# cannot be, that part is SKIPPED with a message (never counted as passed). Exit status 0 when every part
# that ran passed, 1 otherwise. CI_CLUSTER_REQUIRE=1 turns a skip into a failure.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
bin=$(cd "$build" && pwd)/microshadow
[ -x "$bin" ] || { echo "ci-cluster: no $bin (build the microshadow target first)" >&2; exit 1; }
start=$(date +%s)
failures=0
skips=0
say() { echo "ci-cluster: [$(($(date +%s) - start)) s] $*"; }
fail() { say "FAILED: $*"; failures=$((failures + 1)); }
skip() { say "SKIPPED: $*"; skips=$((skips + 1)); }

# --- packages ---------------------------------------------------------------------------------------
have_package() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }
install_packages() {
  local missing=()
  for p in "$@"; do have_package "$p" || missing+=("$p"); done
  [ ${#missing[@]} -eq 0 ] && return 0
  [ "$(id -u)" -eq 0 ] || return 1
  say "installing ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null 2>&1 ||
    { DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null 2>&1 &&
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null 2>&1; }
}

work=$(mktemp -d /tmp/microshadow-cluster.XXXXXX)
daemons=()
cleanup() {
  # Stop what this script started, by the pids it recorded (read first: munged removes its pid file as it
  # exits), wait for them, then remove the folder.
  local pids=() pid
  for pidfile in "${daemons[@]}"; do pid=$(cat "$pidfile" 2>/dev/null) && pids+=("$pid"); done
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  done
  rm -rf "$work"
}
trap cleanup EXIT
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$work/pocl}

# --- the jobs: a small sweep (exact method) and a small bake (sampled, OpenCL default device) ----------
cat > "$work/sweep.toml" <<'EOF'
[sweep]
name = "cluster"
chunk_size = 6
[parameters]
roughness = [0.2, 0.5, 0.9]
visibility = [0.3, 0.6, 0.9]
n_dot_l = [0.3, 0.7]
n_dot_v = [0.4, 0.9]
[comparators]
analytic = ["naughty-dog"]
EOF
sweep_args=(sweep "$work/sweep.toml" --quiet --tolerance 1e-6)
bake_args=(bake --layout custom --size 8 --roughness 0.3,0.8 --samples 4096 --seed 5 --quiet)

# Two LUT files hold the same bake: equal texels (printed with 9 significant digits: every float exactly)
# and equal metadata apart from the command line (`lut info --metadata` prints one key a line).
lut_digest() {
  local d=$work/cmp; rm -rf "$d"; mkdir -p "$d"
  "$bin" lut info --metadata "$1" | sed -n '/^{/,$p' | grep -v '^  "command_line": ' > "$d/meta.json"
  "$bin" lut export "$1" --out "$d/lut.h" >/dev/null
  sed -n '/_data\[/,$p' "$d/lut.h" > "$d/data.txt"
  cat "$d/meta.json" "$d/data.txt" | cksum
}
same_lut() {
  local a b
  a=$(lut_digest "$1") && b=$(lut_digest "$2") && [ "$a" = "$b" ]
}

# The other jobs that spread: a representation bake (its roughness nodes), a scene bake (its slices) and a
# design (its reference set's chunks: 2100 points are three of 1024).
repr_args=(repr bake --kind azimuth-harmonics --visibility-count 4 --n-dot-l-count 4 --n-dot-v-count 3 --azimuth-nodes 7
           --roughness 0.2,0.5,0.8 --samples 1024 --seed 3 --quiet)
scene_args=(bake --scene "$root/examples/scene/scene.toml" --scene-layout layout --size 8 --samples 4096 --no-scene-compare --quiet)
printf 'name = "cluster"\n[points]\ncount = 2100\n[sampling]\nmethod = "sampled"\nsamples = 256\n' > "$work/ref.toml"
design_args=(design --reference "$work/ref.toml" --quiet)

# A representation's texture as an engine loads it (the DDS: header and texels; its metadata, which holds
# the run's time, goes beside it).
same_repr() {
  "$bin" repr export "$1" --out "$work/a.dds" >/dev/null && "$bin" repr export "$2" --out "$work/b.dds" >/dev/null &&
    cmp -s "$work/a.dds" "$work/b.dds"
}
# Two LUT files with the same texels (a scene bake's metadata records its time, and a scene bake is
# partial: its unbaked texels are NaN, which a DDS holds and a C header does not). The DDS's metadata
# goes beside it, so the .dds itself is header and texels only.
same_texels() {
  "$bin" lut export "$1" --out "$work/a.dds" >/dev/null && "$bin" lut export "$2" --out "$work/b.dds" >/dev/null &&
    cmp -s "$work/a.dds" "$work/b.dds"
}
same_design() { cmp -s "$1/pareto.csv" "$2/pareto.csv" && cmp -s "$1/pareto.md" "$2/pareto.md"; }

# A small scene (16 x 16 pixels: an AO gradient written here as a PNG, two lights) in tiles of 64 pixels:
# 2 lights x 4 tiles = 8 work items.
python3 - "$work/scene-ao.png" <<'PY'
import struct, sys, zlib
w = h = 16
rows = b"".join(b"\0" + bytes(60 + (x * 11 + y * 7) % 190 for x in range(w)) for y in range(h))
chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
open(sys.argv[1], "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) +
                              chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
PY
cat > "$work/scene.toml" <<'EOF'
[normal]
value = [0, 0, 1]
[visibility]
file = "scene-ao.png"
channel = "Y"
[roughness]
value = 0.4
[view]
direction = [0.5, 0, 0.866]
[[light]]
name = "sun"
direction = [0.3, 0.5, 0.81]
[[light]]
name = "lamp"
type = "point"
position = [0.2, -0.3, 1.2]
intensity = 2
[comparators]
analytic = ["naughty-dog", "pz-analytic"]
seed_3d = false
seed_2d = false
[sampling]
tolerance = 1e-4
tile_pixels = 64
EOF
view_args=(scene "$work/scene.toml" --quiet)
pixel_hash=$build/tests/exr_pixel_hash
# Two scene folders hold the same run: every PNG byte for byte, scene.exr's layers bit for bit (its header
# holds the report with the run's command line), report.json apart from its provenance and times, and
# report.md's tables (its first paragraph gives the times).
same_scene() {
  [ -x "$pixel_hash" ] || { say "no $pixel_hash (build the exr_pixel_hash target)"; return 1; }
  local f
  for f in "$1"/*.png; do cmp -s "$f" "$2/$(basename "$f")" || return 1; done
  local ha hb
  ha=$("$pixel_hash" "$1/scene.exr") && hb=$("$pixel_hash" "$2/scene.exr") && [ -n "$ha" ] && [ "$ha" = "$hb" ] || return 1
  python3 - "$1/report.json" "$2/report.json" <<'PY' || return 1
import json, sys
def run_free(path):
    j = json.load(open(path))
    for key in ("provenance", "seconds"): j.pop(key)
    for light in j["lights"]: light.pop("seconds")
    return j
sys.exit(0 if run_free(sys.argv[1]) == run_free(sys.argv[2]) else 1)
PY
  cmp -s <(sed -n '/^| pixel x light/,$p' "$1/report.md") <(sed -n '/^| pixel x light/,$p' "$2/report.md")
}

"$bin" "${sweep_args[@]}" --out "$work/one.sweep" >/dev/null
"$bin" "${bake_args[@]}" --out "$work/one.exr"
"$bin" "${repr_args[@]}" --out "$work/one-repr.exr"
"$bin" "${scene_args[@]}" --out "$work/one-scene.exr" --scene-report "$work/one-scene"
"$bin" "${design_args[@]}" --cache "$work/one-cache" --out "$work/one-design"
"$bin" "${view_args[@]}" --out "$work/one-view"

# --- 1. MPI -------------------------------------------------------------------------------------------
mpi_part() {
  if ! install_packages openmpi-bin || ! command -v mpirun >/dev/null; then
    skip "MPI: openmpi-bin is not installed and cannot be installed here"; return
  fi
  local probe
  probe=$(OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 "$bin" "${bake_args[@]}" --out "$work/x.exr" --mpi 2>&1 || true)
  if echo "$probe" | grep -q "built without MPI"; then
    skip "MPI: $bin was built without MPI (install libopenmpi-dev and configure again)"; return
  fi
  echo "$probe" | grep -q "needs at least 2 ranks" || fail "MPI: --mpi outside mpirun was not refused: $probe"
  local mpirun=(mpirun --oversubscribe)
  [ "$(id -u)" -eq 0 ] && mpirun+=(--allow-run-as-root)
  local status=0
  "${mpirun[@]}" -np 1 "$bin" "${bake_args[@]}" --out "$work/x.exr" --mpi >"$work/np1.log" 2>&1 || status=$?
  { [ "$status" -eq 2 ] && [ ! -e "$work/x.exr" ]; } || fail "MPI: -np 1 gave status $status (expected 2, nothing written)"
  "${mpirun[@]}" -np 3 "$bin" "${sweep_args[@]}" --out "$work/mpi.sweep" --mpi >"$work/mpi-sweep.log" 2>&1 ||
    { fail "MPI: sweep on 3 ranks failed"; cat "$work/mpi-sweep.log"; }
  cmp -s "$work/one.sweep/sweep.csv" "$work/mpi.sweep/sweep.csv" && say "MPI: sweep on 3 ranks = one process" ||
    fail "MPI: sweep.csv on 3 ranks differs from one process"
  "${mpirun[@]}" -np 3 "$bin" "${bake_args[@]}" --out "$work/mpi.exr" --mpi >"$work/mpi-bake.log" 2>&1 ||
    { fail "MPI: bake on 3 ranks failed"; cat "$work/mpi-bake.log"; }
  same_lut "$work/one.exr" "$work/mpi.exr" && say "MPI: bake on 3 ranks = one process" ||
    fail "MPI: the LUT baked on 3 ranks differs from one process"
  "${mpirun[@]}" -np 3 "$bin" "${repr_args[@]}" --out "$work/mpi-repr.exr" --mpi >"$work/mpi-repr.log" 2>&1 ||
    { fail "MPI: repr bake on 3 ranks failed"; cat "$work/mpi-repr.log"; }
  same_repr "$work/one-repr.exr" "$work/mpi-repr.exr" && say "MPI: repr bake on 3 ranks = one process" ||
    fail "MPI: the representation baked on 3 ranks differs from one process"
  "${mpirun[@]}" -np 3 "$bin" "${scene_args[@]}" --out "$work/mpi-scene.exr" --scene-report "$work/mpi-scene" --mpi \
    >"$work/mpi-scene.log" 2>&1 || { fail "MPI: bake --scene on 3 ranks failed"; cat "$work/mpi-scene.log"; }
  same_texels "$work/one-scene.exr" "$work/mpi-scene.exr" && say "MPI: bake --scene on 3 ranks = one process" ||
    fail "MPI: the scene LUT baked on 3 ranks differs from one process"
  "${mpirun[@]}" -np 3 "$bin" "${view_args[@]}" --out "$work/mpi-view" --mpi >"$work/mpi-view.log" 2>&1 ||
    { fail "MPI: scene on 3 ranks failed"; cat "$work/mpi-view.log"; }
  same_scene "$work/one-view" "$work/mpi-view" && say "MPI: scene on 3 ranks = one process" ||
    fail "MPI: the scene on 3 ranks differs from one process"
  "${mpirun[@]}" -np 3 "$bin" "${design_args[@]}" --cache "$work/mpi-cache" --out "$work/mpi-design" --mpi \
    >"$work/mpi-design.log" 2>&1 || { fail "MPI: design on 3 ranks failed"; cat "$work/mpi-design.log"; }
  same_design "$work/one-design" "$work/mpi-design" && say "MPI: design on 3 ranks = one process" ||
    fail "MPI: the design on 3 ranks differs from one process"
  # Ranks whose device fails after one slice (the test hook): the job stops naming a rank and its item,
  # writes no LUT, keeps what it gathered; the same command without the fault resumes to the same bytes.
  status=0
  "${mpirun[@]}" -np 3 -x MICROSHADOW_FAIL_DEVICE=0:1 "$bin" "${bake_args[@]}" --out "$work/fail.exr" --mpi \
    --store "$work/fail.chunks" >"$work/mpi-fail.log" 2>&1 || status=$?
  if [ "$status" -eq 0 ] || [ -e "$work/fail.exr" ] || ! grep -q "MPI: rank [12] failed on item [0-9]" "$work/mpi-fail.log"; then
    fail "MPI: a failing rank was not reported (status $status)"; cat "$work/mpi-fail.log"
  fi
  "${mpirun[@]}" -np 3 "$bin" "${bake_args[@]}" --out "$work/fail.exr" --mpi --store "$work/fail.chunks" >>"$work/mpi-fail.log" 2>&1 &&
    same_lut "$work/one.exr" "$work/fail.exr" && say "MPI: a failed rank named, the rerun resumed to one process's LUT" ||
    fail "MPI: the rerun after a failed rank did not give one process's LUT"
}
mpi_part

# --- 2. Slurm -----------------------------------------------------------------------------------------
wait_for_queue() {  # up to 5 minutes: CI runs this stage beside a compiler on both cores
  local until=$(($(date +%s) + 300))
  while [ "$(date +%s)" -lt "$until" ]; do [ -z "$(squeue -h 2>/dev/null)" ] && return 0; sleep 0.1; done
  fail "Slurm: jobs still queued after 300 s"; squeue; return 1
}

# A task killed mid-run (SIGKILL once two of its slices are in the store) and requeued resumes: the rerun
# finds those slices, computes the rest, and the merge equals one process.
requeue_part() {
  local s=$1 args=(bake --layout custom --size 6 --n-dot-v-count 8 --roughness 0.3,0.8 --samples 131072 --seed 9 --quiet)
  local out=$work/requeue.exr store=$work/requeue.exr.chunks array
  "$bin" "${args[@]}" --out "$work/requeue-one.exr"
  # The first run of task 1 starts the bake, waits for two of its slices (odd ids) and kills it.
  {
    echo '#!/bin/bash'
    echo "if [ \"\$SLURM_ARRAY_TASK_ID\" = 1 ] && [ ! -e $s/jobs/killed-once ]; then"
    echo "  touch $s/jobs/killed-once"
    echo "  $(printf '%q ' "$bin" "${args[@]}" --out "$out") &"
    echo '  pid=$!'
    echo "  until [ \"\$(ls $store/items 2>/dev/null | grep -c '[13579]\\.bin\$')\" -ge 2 ] || ! kill -0 \$pid 2>/dev/null; do sleep 0.02; done"
    echo '  kill -KILL $pid'
    echo '  exit 137'
    echo 'fi'
    echo "exec $(printf '%q ' "$bin" "${args[@]}" --out "$out")"
  } > "$s/jobs/requeue.sh"
  chmod +x "$s/jobs/requeue.sh"
  array=$(sbatch --parsable --array=0-1 -c1 -o "$s/jobs/requeue-%a.out" "$s/jobs/requeue.sh")
  wait_for_queue || return
  scontrol -o show job "${array}_1" | grep -q 'JobState=FAILED' ||
    { fail "Slurm requeue: the killed task did not fail: $(scontrol -o show job "${array}_1" | grep -o 'JobState=[A-Z]*')"; return; }
  # The slices kept, by inode: a rerun that computed them again would have replaced the files.
  local before kept
  before=$(ls "$store/items" | grep -c '[13579]\.bin$')
  kept=$(cd "$store/items" && ls -i $(ls | grep '[13579]\.bin$'))
  # Slurm holds a requeued job back for a while (its begin time moves on); a CI run has no reason to wait.
  scontrol requeue "${array}_1"
  scontrol update JobId="${array}_1" StartTime=now
  wait_for_queue || return
  scontrol -o show job "${array}_1" | grep -q 'JobState=COMPLETED' || { fail "Slurm requeue: the requeued task did not complete"; return; }
  [ "$(cd "$store/items" && ls -i $(echo "$kept" | awk '{print $2}'))" = "$kept" ] ||
    fail "Slurm requeue: the rerun computed again slices the killed run had kept"
  "$bin" "${args[@]}" --out "$out" --merge
  same_lut "$work/requeue-one.exr" "$out" &&
    say "Slurm: a task killed mid-run ($before of its 8 slices kept) and requeued resumed; the merge = one process" ||
    fail "Slurm requeue: the merged LUT differs from one process"
}

slurm_part() {
  if ! install_packages slurm-wlm munge || ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    skip "Slurm: slurm-wlm and munge are not installed and cannot be installed here"; return
  fi
  if [ "$(id -u)" -ne 0 ]; then skip "Slurm: slurmd must run as root to start jobs"; return; fi
  local s=$work/slurm host
  host=$(hostname -s)
  mkdir -p "$s"/{munge,state,spool,log,jobs}
  chmod 700 "$s/munge"
  dd if=/dev/urandom of="$s/munge/munge.key" bs=1024 count=1 2>/dev/null
  chmod 400 "$s/munge/munge.key"
  munged --key-file="$s/munge/munge.key" --socket="$s/munge/munge.socket" --pid-file="$s/munge/munged.pid" \
    --log-file="$s/log/munged.log" --seed-file="$s/munge/seed" --force
  daemons+=("$s/munge/munged.pid")
  # Ports of its own (a real cluster's slurmctld may listen on the defaults), from this process's pid.
  local port=$((20000 + ($$ % 20000)))
  cat > "$s/slurm.conf" <<EOF
ClusterName=microshadow-ci
SlurmctldHost=$host
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
AuthInfo=socket=$s/munge/munge.socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$s/state
SlurmdSpoolDir=$s/spool
SlurmctldPidFile=$s/slurmctld.pid
SlurmdPidFile=$s/slurmd.pid
SlurmctldLogFile=$s/log/slurmctld.log
SlurmdLogFile=$s/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/builtin
InactiveLimit=0
MinJobAge=600
KillWait=5
NodeName=$host CPUs=$(nproc) RealMemory=1000 State=UNKNOWN
PartitionName=ci Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF=$s/slurm.conf
  slurmctld -f "$s/slurm.conf" -i && daemons+=("$s/slurmctld.pid")
  slurmd -f "$s/slurm.conf" && daemons+=("$s/slurmd.pid")
  local ready=0
  for _ in $(seq 300); do sinfo -h -o %T 2>/dev/null | grep -qx idle && { ready=1; break; }; sleep 0.1; done
  [ "$ready" -eq 1 ] || { fail "Slurm: the node did not come up"; tail -5 "$s"/log/*.log; return; }
  say "Slurm: $(slurmctld -V) up on $host (port $port)"

  # A 4-task array per job, each task one shard (from SLURM_ARRAY_TASK_ID/COUNT), then the dependent merge.
  local sweep_array bake_array sweep_merge bake_merge design_array design_merge view_array view_merge
  sweep_array=$(sbatch --parsable --array=0-3 -c1 -o "$s/jobs/sweep-%a.out" --wrap "$(printf '%q ' "$bin" "${sweep_args[@]}" --out "$work/slurm.sweep")")
  sweep_merge=$(sbatch --parsable --dependency=afterok:$sweep_array -c1 -o "$s/jobs/sweep-merge.out" \
    --wrap "$(printf '%q ' "$bin" merge --quiet --out "$work/slurm-merged.sweep" "$work/slurm.sweep")")
  bake_array=$(sbatch --parsable --array=0-3 -c1 -o "$s/jobs/bake-%a.out" --wrap "$(printf '%q ' "$bin" "${bake_args[@]}" --out "$work/slurm.exr")")
  bake_merge=$(sbatch --parsable --dependency=afterok:$bake_array -c1 -o "$s/jobs/bake-merge.out" \
    --wrap "$(printf '%q ' "$bin" "${bake_args[@]}" --out "$work/slurm.exr" --merge)")
  design_array=$(sbatch --parsable --array=0-3 -c1 -o "$s/jobs/design-%a.out" \
    --wrap "$(printf '%q ' "$bin" "${design_args[@]}" --cache "$work/slurm-cache")")
  design_merge=$(sbatch --parsable --dependency=afterok:$design_array -c1 -o "$s/jobs/design-merge.out" \
    --wrap "$(printf '%q ' "$bin" "${design_args[@]}" --cache "$work/slurm-cache" --out "$work/slurm-design" --merge)")
  view_array=$(sbatch --parsable --array=0-3 -c1 -o "$s/jobs/scene-%a.out" --wrap "$(printf '%q ' "$bin" "${view_args[@]}" --out "$work/slurm-view")")
  view_merge=$(sbatch --parsable --dependency=afterok:$view_array -c1 -o "$s/jobs/scene-merge.out" \
    --wrap "$(printf '%q ' "$bin" "${view_args[@]}" --out "$work/slurm-view" --merge)")
  local jobs=("$sweep_array" "$bake_array" "$sweep_merge" "$bake_merge" "$design_array" "$design_merge" "$view_array" "$view_merge")
  wait_for_queue || scancel "${jobs[@]}"
  for j in "${jobs[@]}"; do
    local states
    states=$(scontrol -o show job "$j" | grep -o 'JobState=[A-Z_]*' | sort -u | tr '\n' ' ')
    [ "$states" = "JobState=COMPLETED " ] || { fail "Slurm: job $j ended $states"; cat "$s"/jobs/*.out; }
  done
  ls "$work/slurm.sweep"/manifest.shard-*-of-4.json >/dev/null 2>&1 || fail "Slurm: the sweep's array tasks were not 4 shards"
  ls "$work/slurm.exr.chunks"/manifest.shard-*-of-4.json >/dev/null 2>&1 || fail "Slurm: the bake's array tasks were not 4 shards"
  requeue_part "$s"
  cmp -s "$work/one.sweep/sweep.csv" "$work/slurm-merged.sweep/sweep.csv" &&
    say "Slurm: sweep as a 4-task array + merge = one process" || fail "Slurm: the merged sweep.csv differs from one process"
  same_lut "$work/one.exr" "$work/slurm.exr" &&
    say "Slurm: bake as a 4-task array + merge = one process" || fail "Slurm: the merged LUT differs from one process"
  same_design "$work/one-design" "$work/slurm-design" &&
    say "Slurm: design as a 4-task array + merge = one process" || fail "Slurm: the merged design differs from one process"
  ls "$work/slurm-view/chunks"/manifest.shard-*-of-4.json >/dev/null 2>&1 || fail "Slurm: the scene's array tasks were not 4 shards"
  same_scene "$work/one-view" "$work/slurm-view" &&
    say "Slurm: scene as a 4-task array + merge = one process" || fail "Slurm: the merged scene differs from one process"
}
slurm_part

say "done in $(($(date +%s) - start)) s: $failures failed, $skips skipped"
[ "$failures" -eq 0 ] || exit 1
[ "$skips" -eq 0 ] || [ "${CI_CLUSTER_REQUIRE:-0}" != 1 ] || exit 1
exit 0
