#!/usr/bin/env bash
# ctest ros_downstream_package (issue 12): what fluid_sim exports to code that uses it.
#   1. no -march=native in the interface of its libraries (it is a property of this build's own
#      targets: a dependant built for another CPU must not inherit it);
#   2. a downstream catkin package (test/fixtures/downstream) configures against this build's
#      devel space: it finds the three libraries, the headers and the definitions they need.
#      FLUID_SIM_DOWNSTREAM_BUILD=1 also builds and runs its program (about a minute).
#   downstream_test.sh BUILD_DIR
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
BUILD="$1"
fail() {
  echo "downstream_test: $*" >&2
  exit 1
}

cat "$BUILD/fluid_sim_interface_options.txt"
grep -q "march" "$BUILD/fluid_sim_interface_options.txt" && fail "-march in a library's interface (above)"

export PYENV_VERSION=system
set +u
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
set -u
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cmake -S "$ROOT/test/fixtures/downstream" -B "$work" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCATKIN_DEVEL_PREFIX="$work/devel" || fail "the downstream package does not configure"
if [[ "${FLUID_SIM_DOWNSTREAM_BUILD:-0}" == 1 ]]; then
  cmake --build "$work" -j2 || fail "the downstream package does not build"
  "$work/downstream" || fail "the downstream program failed"
fi
echo "downstream_test: ok"
