#!/usr/bin/env bash
# README command one: installs what is missing and builds (scripts/setup.sh), then runs the ROS
# demo (launch/demo.launch: the paddle robot stirring water, posed through tf). With a display
# it opens rviz and runs until Ctrl-C; without one it runs headless for `duration` simulated
# seconds (default 5) and prints the statistics. Extra arguments go to roslaunch, e.g.
#   bash scripts/run_default.sh duration:=10
#   bash scripts/run_default.sh headless:=true            # no rviz even with a display
# The headless runner on the default scene (no ROS): build/fluid_sim_run config/dam_break.yaml
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

bash scripts/setup.sh
# shellcheck source=ros_env.sh
source scripts/ros_env.sh

mode=(headless:=true)
if [[ -n "${DISPLAY:-}" ]] && command -v rviz > /dev/null; then
  mode=(rviz:=true)
fi
for arg in "$@"; do
  [[ "$arg" == headless:=* || "$arg" == rviz:=* ]] && mode=()
done
# Not `roslaunch`: headless, the run ends when the node has run `duration` seconds, and
# run_launch.py then ends the launch without roslaunch's red "REQUIRED process has died" banner
# and exits with the node's exit code (non-zero, with the node's error, when it fails).
# test/ros/demo_smoke.sh runs the same command.
exec /usr/bin/python3 scripts/run_launch.py --until /fluid_sim/fluid_sim fluid_sim demo.launch required:=false \
  "${mode[@]}" "$@"
