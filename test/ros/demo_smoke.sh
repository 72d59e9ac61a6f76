#!/usr/bin/env bash
# ctest ros_demo_headless: launch/demo.launch headless for 0.5 simulated seconds on its own master
# port; it must print the node's final statistics with status ok and end by itself.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# shellcheck source=../../scripts/ros_env.sh
source "$ROOT/scripts/ros_env.sh"
port=$((20000 + RANDOM % 20000))
host="${ROS_HOSTNAME:-${ROS_IP:-localhost}}"
export ROS_MASTER_URI="http://$host:$port"
log="$(mktemp)"
timeout 120 roslaunch -p "$port" fluid_sim demo.launch headless:=true duration:=0.5 > "$log" 2>&1
rc=$?
cat "$log"
if ((rc != 0)); then
  echo "demo_smoke: roslaunch exit code $rc" >&2
  exit 1
fi
grep -q "fluid_sim: finished at t = 0.5" "$log" || { echo "demo_smoke: no final statistics" >&2; exit 1; }
grep -q "status ok" "$log" || { echo "demo_smoke: status not ok" >&2; exit 1; }
grep -q "paddle: force" "$log" || { echo "demo_smoke: no paddle wrench" >&2; exit 1; }
rm -f "$log"
echo "demo_smoke: ok"
