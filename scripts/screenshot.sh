#!/usr/bin/env bash
# Renders rviz showing the ROS demo under a virtual display (Xvfb, software OpenGL) and saves a
# screenshot: docs/demo_rviz.png (or the path given). Installs what it needs when missing
# (rviz, xvfb, imagemagick, Mesa's software renderer), like scripts/setup.sh.
#
#   bash scripts/screenshot.sh [OUTPUT.png] [SECONDS of demo before the shot, default 8]
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
out="${1:-docs/demo_rviz.png}"
wait_s="${2:-8}"

FLUID_SIM_WITH_RVIZ=1 bash scripts/setup.sh
extra=()
for pkg in xvfb imagemagick xauth libgl1-mesa-dri; do
  [[ "$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2> /dev/null || true)" == installed ]] || extra+=("$pkg")
done
if ((${#extra[@]})); then
  sudo=()
  ((EUID == 0)) || sudo=(sudo)
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${extra[@]}"
fi
# shellcheck source=ros_env.sh
source scripts/ros_env.sh

display=":$((90 + RANDOM % 9))"
Xvfb "$display" -screen 0 1280x800x24 -nolisten tcp > /tmp/fluid_sim_xvfb.log 2>&1 &
xvfb_pid=$!
launch_pid=""
cleanup() {
  [[ -n "$launch_pid" ]] && kill -INT "$launch_pid" 2> /dev/null && wait "$launch_pid" 2> /dev/null || true
  kill "$xvfb_pid" 2> /dev/null || true
}
trap cleanup EXIT
sleep 1
export DISPLAY="$display" LIBGL_ALWAYS_SOFTWARE=1
roslaunch fluid_sim demo.launch rviz:=true > /tmp/fluid_sim_screenshot_launch.log 2>&1 &
launch_pid=$!
# rviz needs a few seconds to come up; the demo runs meanwhile.
sleep "$wait_s"
mkdir -p "$(dirname "$out")"
import -display "$display" -window root "$out"
echo "[screenshot] wrote $out"
