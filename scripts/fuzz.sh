#!/usr/bin/env bash
# Builds the libFuzzer harnesses of the parsers (test/fuzz; clang, ASan + UBSan) in build-fuzz/
# and runs each for a while, seeded with the repository's own scenes, URDFs and meshes and with
# the saved regression inputs (test/fuzz/regressions/<harness>/). Exits non-zero if any harness
# found a crash, a hang (-timeout), or an allocation beyond -rss_limit_mb; the input that did it
# is saved in build-fuzz/fuzz/artifacts/<harness>/ (add it, minimised, to the regressions).
#
#   bash scripts/fuzz.sh [-t SECONDS] [HARNESS ...]
#
#   -t SECONDS  run time per harness (default 60)
#   HARNESS     some of: scene urdf mesh_stl mesh_obj mesh_dae mesh_ply ply_frame package_xml
#               (default: all)
# The grown corpora are kept in build-fuzz/fuzz/corpus/<harness>/ and reused by the next run.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

seconds=60
while getopts "t:h" opt; do
  case "$opt" in
    t) seconds="$OPTARG" ;;
    *)
      sed -n '2,14p' "$0"
      exit 2
      ;;
  esac
done
shift $((OPTIND - 1))
all=(scene urdf mesh_stl mesh_obj mesh_dae mesh_ply ply_frame package_xml)
harnesses=("$@")
((${#harnesses[@]} > 0)) || harnesses=("${all[@]}")

log() { printf '[fuzz] %s\n' "$*"; }
# Leaks inside libraries that are not ours (each with its reason in the file) do not stop a
# harness; any other leak does.
export LSAN_OPTIONS="suppressions=$ROOT/scripts/lsan.supp:print_suppressions=0"

BUILD="$ROOT/build-fuzz"
if [[ ! -f "$BUILD/CMakeCache.txt" ]]; then
  CXX=clang++ cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFLUID_SIM_BUILD_ROS=OFF -DFLUID_SIM_FUZZ=ON
fi
nice cmake --build "$BUILD" --target fluid_sim_fuzzers -j"$(nproc 2> /dev/null || echo 2)"

FUZZ="$BUILD/fuzz"
fixtures=test/fixtures/fluid_sim_test_pkg

# Seeds: copies of the repository's files of each kind (a corpus folder only grows; libFuzzer
# names its own additions by their hash, these keep their file names).
seed() {
  local harness="$1"
  shift
  mkdir -p "$FUZZ/corpus/$harness"
  local f
  # Named after their paths (package.xml is in several folders).
  for f in "$@"; do [[ -f "$f" ]] && cp "$f" "$FUZZ/corpus/$harness/${f//\//_}"; done
  if [[ -d "test/fuzz/regressions/$harness" ]]; then
    find "test/fuzz/regressions/$harness" -type f ! -name "*.expected" -exec cp {} "$FUZZ/corpus/$harness/" \;
  fi
}

seed_scene() {
  seed scene config/*.yaml config/validation/*.yaml test/ros/*.yaml test/fuzz/seeds/scene/*.yaml
  # The same scenes with --set overrides after the NUL that starts them (fuzz_targets.h).
  local f out
  for f in config/hydrostatic_tank.yaml config/paddle_robot.yaml config/mesh_tank.yaml; do
    out="$FUZZ/corpus/scene/set_$(basename "$f")"
    {
      cat "$f"
      printf '\0solver.boundary_pressure=sph\ngravity=[0, 0, -1]\ntime_step.fixed=0.001\nboundaries[0].pose.xyz=[0, 0, 0.1]\n'
    } > "$out"
  done
}

seed_ply_frame() {
  seed ply_frame
  local dir="$FUZZ/corpus/ply_frame"
  printf 'ply\nformat ascii 1.0\ncomment units m\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\nproperty float vz\nproperty float pressure\nend_header\n0 0 0 0 0 0 1\n0.02 0 0 0 0 -1 2\n' > "$dir/ascii.ply"
  {
    printf 'ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty double vx\nproperty float vy\nproperty float vz\nend_header\n'
    # two vertices: floats 0 / 0.02 and a double vx
    printf '\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00'
    printf '\x0a\xd7\xa3\x3c\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\xf0\x3f\x00\x00\x00\x00\x00\x00\x80\xbf'
  } > "$dir/binary.ply"
}

run_one() {
  local harness="$1" binary dict=()
  case "$harness" in
    scene) seed_scene ;;
    urdf) seed urdf urdf/*.urdf test/ros/*.urdf $fixtures/urdf/*.urdf ;;
    mesh_stl) seed mesh_stl meshes/*.stl meshes/validation/*.stl $fixtures/meshes/*.stl ;;
    mesh_obj) seed mesh_obj $fixtures/meshes/*.obj ;;
    mesh_dae) seed mesh_dae $fixtures/meshes/*.dae ;;
    mesh_ply) seed mesh_ply $fixtures/meshes/*.ply ;;
    ply_frame) seed_ply_frame ;;
    package_xml) seed package_xml package.xml fluid_msgs/package.xml $fixtures/package.xml ;;
    *)
      echo "unknown harness '$harness' (known: ${all[*]})" >&2
      exit 2
      ;;
  esac
  binary="$FUZZ/fuzz_$harness"
  local dict_name="${harness#mesh_}"
  [[ "$harness" == ply_frame ]] && dict_name=ply
  [[ -f "test/fuzz/dict/$dict_name.dict" ]] && dict=(-dict="test/fuzz/dict/$dict_name.dict")
  mkdir -p "$FUZZ/artifacts/$harness" "$FUZZ/logs"
  local logfile="$FUZZ/logs/$harness.log" start=$SECONDS status=0
  log "$harness: ${seconds} s (log $logfile)"
  # -rss_limit_mb: the parsers must refuse a size they cannot hold rather than allocate it;
  # -timeout: one input that takes longer than 10 s is a hang.
  nice "$binary" "$FUZZ/corpus/$harness" "${dict[@]}" -max_total_time="$seconds" -rss_limit_mb=2048 \
    -timeout=10 -print_final_stats=1 -artifact_prefix="$FUZZ/artifacts/$harness/" > "$logfile" 2>&1 || status=$?
  local last
  last="$(grep -E '^#[0-9]+' "$logfile" | tail -n 1 || true)"
  log "$harness: exit $status after $((SECONDS - start)) s; last status: ${last:-none}"
  if ((status != 0)); then
    grep -E 'ERROR: |SUMMARY: |Test unit written' "$logfile" | head -n 5 | sed 's/^/[fuzz]   /'
    failed+=("$harness")
  fi
}

failed=()
for h in "${harnesses[@]}"; do run_one "$h"; done
if ((${#failed[@]} > 0)); then
  log "FAILED: ${failed[*]} (inputs in $FUZZ/artifacts/)"
  exit 1
fi
log "no crash, hang or oversized allocation in ${harnesses[*]}"
