#!/usr/bin/env bash
# README command two: installs what is missing and builds (scripts/setup.sh), runs every test of
# build/ (float, ROS on) with ctest, then builds the core and its tests in build-double/
# (Real = double, ROS off) and runs them there, since both precisions must build and pass.
# Exits non-zero on any failure.
#
#   bash scripts/test.sh
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

jobs="$(nproc 2> /dev/null || echo 2)"
total_start=$SECONDS

log() { printf '[test] %s\n' "$*"; }

# ---------------------------------------------------------------- float, with ROS (build/)
bash scripts/setup.sh
# rostest's helpers run `#!/usr/bin/env python3`; ROS needs a host name or address it can reach.
# shellcheck source=ros_env.sh
source scripts/ros_env.sh
if grep -q '^FLUID_SIM_BUILD_ROS:BOOL=ON' build/CMakeCache.txt; then
  # catkin's test targets (catkin_add_gtest, rostest dependencies) are not part of `all`.
  cmake --build build --target tests -j"$jobs"
fi
start=$SECONDS
ctest --test-dir build --output-on-failure --no-tests=error
log "build/ (float): tests $((SECONDS - start)) s"

# ---------------------------------------------------------------- double, ROS-free (build-double/)
start=$SECONDS
cmake -S . -B build-double -DCMAKE_BUILD_TYPE=Release -DFLUID_SIM_USE_DOUBLE=ON -DFLUID_SIM_BUILD_ROS=OFF
# Only the core and its tests: the io layer and the tools are checked in build/.
cmake --build build-double --target fluid_sim_core_tests -j"$jobs"
log "build-double/: configure + build $((SECONDS - start)) s"
start=$SECONDS
# The two longest physical checks (cube buoyancy, 3 s at rest: about 2 minutes in double) run in
# float only; every other core test, the hydrostatic column included, runs in double too.
ctest --test-dir build-double --output-on-failure --no-tests=error -L core -E 'Buoyancy|Rest\.'
log "build-double/ (double): core tests $((SECONDS - start)) s"

log "all passed in $((SECONDS - total_start)) s"
