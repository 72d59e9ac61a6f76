#!/usr/bin/env bash
# Renders rviz showing the ROS demo under a virtual display (Xvfb, software OpenGL) and saves a
# screenshot: docs/demo_rviz.png (or the path given). Installs what it needs when missing
# (rviz, xvfb, imagemagick, Mesa's software renderer), like scripts/setup.sh.
#
#   bash scripts/screenshot.sh [--surface] [OUTPUT.png] [SECONDS of demo before the shot, default 8]
#
# --surface: the water as its free surface (the node's `surface` topic, ~surface_rate 5 Hz; the
# particle display unticked) instead of particles coloured by speed; default output
# docs/demo_surface.png.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
surface=0
if [[ "${1:-}" == --surface ]]; then
  surface=1
  shift
fi
if ((surface)); then
  out="${1:-docs/demo_surface.png}"
else
  out="${1:-docs/demo_rviz.png}"
fi
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
config_dir="$(mktemp -d)"
cleanup() {
  [[ -n "$launch_pid" ]] && kill -INT "$launch_pid" 2> /dev/null && wait "$launch_pid" 2> /dev/null || true
  kill "$xvfb_pid" 2> /dev/null || true
  rm -rf "$config_dir"
}
trap cleanup EXIT
sleep 1
export DISPLAY="$display" LIBGL_ALWAYS_SOFTWARE=1
args=(rviz:=true)
if ((surface)); then
  # The shipped config with the particle display ("Water (speed)") unticked: the surface alone.
  awk '/Name: Water \(speed\)/ { water = 1 }
       water && /Enabled: true/ { sub(/Enabled: true/, "Enabled: false"); water = 0 }
       { print }' config/fluid_sim.rviz > "$config_dir/surface.rviz"
  args+=(surface_rate:=5 "rviz_config:=$config_dir/surface.rviz")
fi
roslaunch fluid_sim demo.launch "${args[@]}" > /tmp/fluid_sim_screenshot_launch.log 2>&1 &
launch_pid=$!
# rviz needs a few seconds to come up; the demo runs meanwhile.
sleep "$wait_s"
mkdir -p "$(dirname "$out")"
import -display "$display" -window root "$out"
echo "[screenshot] wrote $out"
