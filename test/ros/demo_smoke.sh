#!/usr/bin/env bash
# ctest ros_demo_headless: README command one's demo (launch/demo.launch headless, run as
# scripts/run_default.sh runs it: through scripts/run_launch.py) for 0.5 simulated seconds on its
# own master port. A normal run must print the node's final statistics with status ok, end by
# itself with exit code 0 and without roslaunch's "REQUIRED process has died" banner; a run whose
# scene is bad must end with a non-zero exit code and the node's error.
# Then the same for 0.3 s at real_time_factor 0 (as fast as it can) and 0.5: until 2026-12-02
# every factor but 1 took the paddle's newest pose in the first step, after it had moved on during
# the build, and the water went NaN in the second step.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# shellcheck source=../../scripts/ros_env.sh
source "$ROOT/scripts/ros_env.sh"
# A master port of its own, below the kernel's ephemeral range (scripts/free_port.py).
port="$(/usr/bin/python3 "$ROOT/scripts/free_port.py")" || exit 1
host="${ROS_HOSTNAME:-${ROS_IP:-localhost}}"
export ROS_MASTER_URI="http://$host:$port"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# A run's time limit, 120 s, times FLUID_SIM_TEST_TIME_SCALE (scripts/sanitize.sh: 10; an
# instrumented node runs 10-30 times slower): a limit on the wait, not on what is checked.
scale="${FLUID_SIM_TEST_TIME_SCALE:-1}"
[[ "$scale" =~ ^[1-9][0-9]*$ ]] || scale=1
limit=$((120 * scale))

demo() { # duration, extra roslaunch arguments...
  local duration="$1"
  shift
  timeout "$limit" /usr/bin/python3 "$ROOT/scripts/run_launch.py" -p "$port" --until /fluid_sim/fluid_sim \
    fluid_sim demo.launch required:=false headless:=true duration:="$duration" "$@"
}
fail() {
  echo "demo_smoke: $*" >&2
  exit 1
}

# Normal runs: factor 1 (the demo's), 0 and 0.5.
normal() { # duration, extra roslaunch arguments...
  local duration="$1"
  demo "$@" > "$work/ok.log" 2>&1
  rc=$?
  cat "$work/ok.log"
  ((rc == 0)) || fail "($*) exit code $rc"
  grep -q "fluid_sim: finished at t = $duration" "$work/ok.log" || fail "($*) no final statistics"
  grep -q "status ok" "$work/ok.log" || fail "($*) status not ok"
  grep -q "paddle: force" "$work/ok.log" || fail "($*) no paddle wrench"
  # The summary's wrenches are the last message's window means (one step's jitter by tens of %).
  grep -q "wrenches (the last message's, each the mean over ~wrench_window = 0.1 s)" "$work/ok.log" ||
    fail "($*) the summary's wrenches are not the windowed means"
  grep -q "not a closed surface" "$work/ok.log" && fail "($*) the demo's thin blade was warned about as an open mesh"
  grep -q "REQUIRED process" "$work/ok.log" && fail "($*) the normal end printed roslaunch's REQUIRED banner"
  return 0
}
normal 0.5
normal 0.3 real_time_factor:=0
normal 0.3 real_time_factor:=0.5

# A failing run: the demo's scene with a misspelt solver key.
sed 's/density_error:/density_eror:/' "$ROOT/config/demo_scene.yaml" > "$work/bad_scene.yaml"
grep -q "density_eror" "$work/bad_scene.yaml" || fail "could not make the bad scene"
demo 0.5 scene:="$work/bad_scene.yaml" > "$work/bad.log" 2>&1
rc=$?
cat "$work/bad.log"
((rc != 0 && rc != 124)) || fail "a bad scene ended with exit code $rc (expected the node's, non-zero)"
grep -q "solver.density_eror" "$work/bad.log" || fail "the node's error (naming solver.density_eror) is not in the output"
echo "demo_smoke: ok"
