#!/usr/bin/env bash
# ctest ros_demo_headless: launch/demo.launch headless for 0.5 simulated seconds on its own master
# port; it must print the node's final statistics with status ok and end by itself. Then the same
# for 0.3 s with real_time_factor 0 (as fast as it can) and 0.5: until 2026-12-02 every factor but
# 1 took the paddle's newest pose in the first step, after it had moved on during the build, and
# the water went NaN in the second step.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# shellcheck source=../../scripts/ros_env.sh
source "$ROOT/scripts/ros_env.sh"
port=$((20000 + RANDOM % 20000))
host="${ROS_HOSTNAME:-${ROS_IP:-localhost}}"
export ROS_MASTER_URI="http://$host:$port"
run_demo() { # duration, extra roslaunch arguments...
  local duration="$1" log rc
  shift
  log="$(mktemp)"
  timeout 120 roslaunch -p "$port" fluid_sim demo.launch headless:=true duration:="$duration" "$@" > "$log" 2>&1
  rc=$?
  cat "$log"
  if ((rc != 0)); then
    echo "demo_smoke ($*): roslaunch exit code $rc" >&2
    exit 1
  fi
  grep -q "fluid_sim: finished at t = $duration" "$log" || { echo "demo_smoke ($*): no final statistics" >&2; exit 1; }
  grep -q "status ok" "$log" || { echo "demo_smoke ($*): status not ok" >&2; exit 1; }
  grep -q "paddle: force" "$log" || { echo "demo_smoke ($*): no paddle wrench" >&2; exit 1; }
  rm -f "$log"
}
run_demo 0.5
run_demo 0.3 real_time_factor:=0
run_demo 0.3 real_time_factor:=0.5
echo "demo_smoke: ok"
