#!/usr/bin/env bash
# Builds the core, io and ROS-layer (node) tests with sanitizers, each flavour in its own build
# folder, runs them and exits non-zero on any failure or sanitizer report:
#   asan: AddressSanitizer + UndefinedBehaviorSanitizer (build-asan/)
#   tsan: ThreadSanitizer (build-tsan/), solver_loop_race_test included
# Tests run: ctest labels ros, io and core, in that order (the gtests, the rostests that start the
# node, the nodelet, the downstream package); not the validation cases (the runner on whole scenes,
# minutes each), nor the three runs paced by the wall clock (below).
#
#   bash scripts/sanitize.sh [--asan | --tsan] [--quick] [--no-rostest] [--label L]... [--tests RE]
#                            [--no-build]
#
#   --asan, --tsan  one flavour only (default: both)
#   --label L       run label L only (ros, io or core; repeatable; default: all three, in that order)
#   --tests RE      run only the tests whose name matches the regular expression RE (ctest -R)
#                   (a value-parameterized gtest's ctest name ends in "  # GetParam() = ..." with
#                   CMake 3.25, e.g. "AllMethods/WarmStart.DamBreakStaysStable/mls  # GetParam() = 4-byte
#                   object <03-00 00-00>": end RE with '/mls( |$)', not '/mls$', which matches nothing)
#   --no-build      run the tests of the existing build folder as it is (no configure, no build)
#   --quick         skip the long tests (the physical checks that run a scene for seconds: cube
#                   buoyancy, 3 s at rest, the dam breaks of WarmStart and Stability, the STL
#                   sphere's buoyancy, determinism at 195 k particles, the runner's whole scenes);
#                   they run the same solver code as the short tests, 10-70 times slower under a
#                   sanitizer
#   --no-rostest    skip the tests that start a ROS master (the rostests)
#
# Never run here: the demo (ros_demo_headless), the recording (ros_record_bag), the short soak
# (ros_soak_short) and the node's speed (ros_node_speed). They run the node paced by the wall clock (robot_state_publisher poses the
# paddle at ROS time, real-time factor 1, 0.5 or 0.25) and check that it keeps up; the
# instrumented node steps about 500 times slower than real time (ASan, 2026-12-02: the demo's
# first steps took 2 s each), falls 30 s behind, draws the paddle along and the water goes
# unstable, with no sanitizer report. No factor on a wait helps a check of keeping up; the same
# node code runs under the sanitizers in the rostests (simulated time or still links). The script
# prints this when it leaves them out.
#
# ThreadSanitizer needs every library whose threads touch our data instrumented; the core's
# threads are TBB's. An uninstrumented libtbb hides TBB's own synchronisation from TSan, which then
# reports races between a task and the code that spawned it (false reports in fluid_sim code, that
# no suppression may hide). The tsan flavour therefore builds oneTBB from source with
# -fsanitize=thread (once, into build-tsan-tbb/) and links the tests against it. Give the source of
# the version Debian ships (2021.8.0) in FLUID_SIM_TBB_SOURCE, e.g. from
#   git clone --branch v2021.8.0 --depth 1 https://github.com/oneapi-src/oneTBB
#   apt-get source tbb              (with a deb-src line in the apt sources)
# scripts/tsan.supp lists what TSan may ignore, each entry with its reason.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

flavours=(asan tsan)
quick=0
rostest=1
build=1
labels=()
tests_re=""
usage() {
  sed -n '2,34p' "$0"
  exit 2
}
while (($# > 0)); do
  case "$1" in
    --asan) flavours=(asan) ;;
    --tsan) flavours=(tsan) ;;
    --quick) quick=1 ;;
    --no-rostest) rostest=0 ;;
    --no-build) build=0 ;;
    --label)
      if (($# < 2)) || [[ ! $2 =~ ^(ros|io|core)$ ]]; then usage; fi
      labels+=("$2")
      shift
      ;;
    --tests)
      (($# >= 2)) || usage
      tests_re="$2"
      shift
      ;;
    *) usage ;;
  esac
  shift
done
((${#labels[@]} > 0)) || labels=(ros io core)

jobs="$(nproc 2> /dev/null || echo 2)"
# An instrumented process runs 10-30 times slower: the ROS tests' limits on waiting for the node
# (never what they check) are multiplied by this factor, at configure time (the ctest TIMEOUTs
# of the demo, the soak and solver_loop_race_test) and at run time (FLUID_SIM_TEST_TIME_SCALE:
# node_rostest.cpp's waits, demo_smoke.sh, soak_short.sh).
time_scale=10
log() { printf '[sanitize] %s\n' "$*"; }
export PYENV_VERSION=system

# Tests left out by --quick (minutes under a sanitizer): the two long physical checks (as
# scripts/test.sh leaves them out of the double build) and the runner's whole-scene tests.
long_tests='Buoyancy|Rest\.|WarmStart|Stability\.|StlSphereFeels'
# Tests that start a ROS master.
ros_master_tests='rostest|ros_demo_headless|ros_soak_short|ros_record_bag|ros_node_speed'
# Tests paced by the wall clock, never run here (see the top of this file).
wall_clock_tests='ros_demo_headless|ros_soak_short|ros_record_bag|ros_node_speed'

# The instrumented oneTBB for the tsan flavour; prints its CMake package folder.
tsan_tbb() {
  local prefix="$ROOT/build-tsan-tbb/install"
  if [[ ! -f "$prefix/lib/cmake/TBB/TBBConfig.cmake" ]]; then
    local src="${FLUID_SIM_TBB_SOURCE:-}"
    if [[ -z "$src" || ! -f "$src/CMakeLists.txt" ]]; then
      echo "[sanitize] error: the tsan flavour needs oneTBB's source (FLUID_SIM_TBB_SOURCE=<folder>, version" >&2
      echo "[sanitize]        2021.8.0 as in Debian 12) to build it with ThreadSanitizer; see the top of $0" >&2
      exit 2
    fi
    log "building oneTBB from $src with -fsanitize=thread (build-tsan-tbb/)" >&2
    cmake -S "$src" -B "$ROOT/build-tsan-tbb" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTBB_SANITIZE=thread \
      -DTBB_TEST=OFF -DTBB_EXAMPLES=OFF -DTBB_STRICT=OFF -DCMAKE_INSTALL_PREFIX="$prefix" > /dev/null
    nice cmake --build "$ROOT/build-tsan-tbb" -j"$jobs" > /dev/null
    cmake --install "$ROOT/build-tsan-tbb" > /dev/null
  fi
  echo "$prefix/lib/cmake/TBB"
}

declare -A summary
status=0
for flavour in "${flavours[@]}"; do
  dir="build-$flavour"
  extra=()
  case "$flavour" in
    asan)
      flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
      extra+=(-DFLUID_SIM_TSAN_TESTS=OFF)
      ;;
    tsan)
      flags="-fsanitize=thread"
      # solver_loop_race_test: the solver loop's threads, in a build where everything is instrumented.
      extra+=(-DFLUID_SIM_TSAN_TESTS=ON "-DTBB_DIR=$(tsan_tbb)")
      ;;
  esac
  start=$SECONDS
  if ((build)); then
    log "$flavour: configure and build $dir/"
    mkdir -p "$dir"
    cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS=$flags" -DFLUID_SIM_TEST_TIME_SCALE=$time_scale \
      "-DCMAKE_EXE_LINKER_FLAGS=$flags" "-DCMAKE_SHARED_LINKER_FLAGS=$flags" "${extra[@]}" > "$dir/configure.log" 2>&1 ||
      {
        cat "$dir/configure.log"
        exit 1
      }
    # `all` (the tools and the node the tests run) and catkin's test targets.
    nice cmake --build "$dir" -j"$jobs"
    nice cmake --build "$dir" --target tests -j"$jobs"
  else
    [[ -f "$dir/CTestTestfile.cmake" ]] || {
      echo "[sanitize] error: --no-build, but $dir/ has no build" >&2
      exit 2
    }
    log "$flavour: --no-build, the tests of $dir/ as built"
  fi
  build_time=$((SECONDS - start))

  exclude="validation_|$wall_clock_tests"
  log "$flavour: not run: ros_demo_headless, ros_record_bag, ros_soak_short, ros_node_speed (paced by the wall clock;" \
    "the instrumented node is about 500 times slower than real time; see the top of $0)"
  ((quick)) && exclude+="|$long_tests|Runner\\.|Determinism\\."
  ((rostest)) || exclude+="|$ros_master_tests"
  # Any report ends the process with a failure. Every instrumented process also writes its
  # reports to files of its own (<flavour>.<pid> in $dir/sanitizer_reports/): a node that rostest
  # starts logs to ~/.ros/log, not to ctest, and a leak is found only as a process exits, after its
  # test may have passed; each such file counts as a report.
  reports_dir="$ROOT/$dir/sanitizer_reports"
  rm -rf "$reports_dir"
  mkdir -p "$reports_dir"
  export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1:log_path=$reports_dir/asan"
  export LSAN_OPTIONS="suppressions=$ROOT/scripts/lsan.supp:print_suppressions=0"
  export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:log_path=$reports_dir/ubsan"
  export TSAN_OPTIONS="halt_on_error=1:exitcode=66:second_deadlock_stack=1:suppressions=$ROOT/scripts/tsan.supp:log_path=$reports_dir/tsan"
  # nodelet.test loads the node into ROS's own nodelet manager, an uninstrumented program: the
  # sanitizer's runtime has to be loaded before the instrumented plugin, so the manager starts with
  # it preloaded (the test passes FLUID_SIM_LAUNCH_PREFIX to roslaunch as its launch-prefix).
  # The instrumented node runs 10-30 times slower: the rostests' waits for it and their time limits
  # grow accordingly (limits on waiting for a condition, never the condition itself).
  # A rostest's own limit (300 s times the factor) comes before ctest's (360 s times the factor,
  # for the tests without a limit of their own: catkin's rostests), so that rostest ends the test
  # and says so; pusher.test under TSan on a loaded machine took 821 s, and more than 1200.
  export FLUID_SIM_TEST_TIME_SCALE=$time_scale FLUID_SIM_ROSTEST_TIME_LIMIT=$((300 * time_scale))
  runtime="$([[ $flavour == tsan ]] && echo libtsan.so || echo libasan.so)"
  export FLUID_SIM_LAUNCH_PREFIX="env LD_PRELOAD=$(readlink -f "$(gcc -print-file-name="$runtime")")"
  # One ctest per label, the ROS layer first: its tests (the node under rostest, the nodelet, the
  # demo, the soak) take minutes and are the likeliest to find something, while the core's long
  # physical checks take most of the run. Each label's output is in $dir/sanitize_ctest_<label>.log,
  # all of them in $dir/sanitize_ctest.log.
  start=$SECONDS
  result=0
  ran=0
  failed=0
  : > "$dir/sanitize_ctest.log"
  for label in "${labels[@]}"; do
    label_start=$SECONDS
    rc=0
    # shellcheck source=ros_env.sh
    (export FLUID_SIM_BUILD_DIR="$dir" && source scripts/ros_env.sh && cd "$dir" &&
      nice ctest --output-on-failure --no-tests=error -L "^$label\$" -E "$exclude" ${tests_re:+-R "$tests_re"} \
        --timeout $((360 * time_scale))) \
      > "$dir/sanitize_ctest_$label.log" 2>&1 || rc=$?
    cat "$dir/sanitize_ctest_$label.log" >> "$dir/sanitize_ctest.log"
    ((rc == 0)) || result=$rc
    # "100% tests passed, 0 tests failed out of 26"
    counts="$(grep -E 'tests passed, [0-9]+ tests failed out of [0-9]+' "$dir/sanitize_ctest_$label.log" | tail -n 1 || true)"
    if [[ $counts =~ ([0-9]+)\ tests\ failed\ out\ of\ ([0-9]+) ]]; then
      failed=$((failed + BASH_REMATCH[1]))
      ran=$((ran + BASH_REMATCH[2]))
    else
      counts="no ctest summary"
      result=1
    fi
    log "$flavour $label: $counts ($((SECONDS - label_start)) s)"
  done
  test_time=$((SECONDS - start))
  line="$((ran - failed)) of $ran tests passed, $failed failed"
  in_log="$(grep -cE 'ERROR: AddressSanitizer|ERROR: LeakSanitizer|runtime error:|WARNING: ThreadSanitizer' \
    "$dir/sanitize_ctest.log" || true)"
  in_files="$(find "$reports_dir" -type f | wc -l)"
  reports=$((in_log + in_files))
  for f in $(find "$reports_dir" -type f | head -n 5); do
    log "report $f:"
    grep -m 3 -E 'ERROR|WARNING|runtime error|SUMMARY' "$f" | sed 's/^/[sanitize]   /' || true
  done
  summary[$flavour]="${line:-no ctest summary} | sanitizer reports: $reports | build ${build_time} s, tests ${test_time} s"
  if ((result != 0 || reports > 0)); then
    status=1
    grep -E 'Failed|\*\*\*|SUMMARY: ' "$dir/sanitize_ctest.log" | head -n 20 | sed 's/^/[sanitize]   /'
  fi
  log "$flavour: ${summary[$flavour]} (log $dir/sanitize_ctest.log)"
done

for flavour in "${flavours[@]}"; do log "summary $flavour: ${summary[$flavour]}"; done
((status == 0)) && log "clean" || log "FAILED"
exit "$status"
