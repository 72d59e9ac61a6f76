#!/usr/bin/env bash
# Installs the Debian 12 packages fluid_sim needs (only those missing), then configures and
# builds build/ (Release) with all cores.
#
#   bash scripts/setup.sh [extra cmake configure arguments, e.g. -DFLUID_SIM_NATIVE=OFF]
#
# Works as root or as a user with sudo, on a full machine or a minimal Debian 12
# (debootstrap --variant=minbase). Set FLUID_SIM_SKIP_APT=1 to skip the package step;
# FLUID_SIM_WITH_RVIZ=1 adds rviz (added anyway when DISPLAY is set).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

export DEBIAN_FRONTEND=noninteractive
# A pyenv python3 first on PATH cannot import Debian's ROS Python modules.
export PYENV_VERSION=system

# ROS 1 from Debian's own packages (shared ROS_ON_DEBIAN.md), plus the project's own tools.
PACKAGES=(
  build-essential cmake zlib1g-dev catkin ros-message-generation ros-message-runtime
  libroscpp-dev libroslib-dev librostest-dev
  libstd-msgs-dev libgeometry-msgs-dev libsensor-msgs-dev libvisualization-msgs-dev
  ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-visualization-msgs
  python3-geometry-msgs python3-sensor-msgs python3-visualization-msgs python3-tf2-msgs
  libtf2-ros-dev tf2-tools ros-robot-state-publisher
  liburdfdom-dev libassimp-dev libeigen3-dev libtbb-dev libgtest-dev libyaml-cpp-dev libtinyxml2-dev
  libbullet-dev
  # The free surface as a mesh (core surface.cpp). Debian's FindOpenVDB.cmake needs Boost's
  # iostreams CMake config too, which libopenvdb-dev does not depend on.
  libopenvdb-dev libboost-iostreams-dev
  python3-roslaunch python3-rostopic python3-rosnode python3-rosparam python3-rosmsg
  python3-rostest rosbash python3-rosbag
  libnodeletlib-dev libnodeletlib-tools libnodelet-dev python3-nodelet pluginlib-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libstd-srvs-dev ros-std-srvs python3-std-srvs
  libcli11-dev nlohmann-json3-dev clang-format python3-matplotlib
  # scripts/yardstick.py (and its ctest self-test) reads scene YAML; the ROS Python packages pull it in too.
  python3-yaml
)

# rviz (launch/demo.launch rviz:=true) only where there is a display to show it, or when asked.
if [[ -n "${DISPLAY:-}" || "${FLUID_SIM_WITH_RVIZ:-0}" == 1 ]]; then
  PACKAGES+=(rviz libgl1-mesa-dri)
fi

log() { printf '[setup] %s\n' "$*"; }

install_missing() {
  if ! command -v dpkg-query > /dev/null || ! command -v apt-get > /dev/null; then
    echo "[setup] error: dpkg-query/apt-get not found; this script targets Debian 12 (bookworm)." >&2
    exit 1
  fi
  local missing=() pkg status
  for pkg in "${PACKAGES[@]}"; do
    status="$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2> /dev/null || true)"
    [[ "$status" == installed ]] || missing+=("$pkg")
  done
  if ((${#missing[@]} == 0)); then
    log "all ${#PACKAGES[@]} Debian packages present"
    return
  fi

  local sudo=()
  if ((EUID != 0)); then
    if command -v sudo > /dev/null; then
      sudo=(sudo)
    else
      echo "[setup] error: ${#missing[@]} Debian packages are missing (${missing[*]})" >&2
      echo "[setup]        and this user is neither root nor has sudo. Install them as root:" >&2
      echo "[setup]        apt-get update && apt-get install -y --no-install-recommends ${missing[*]}" >&2
      exit 1
    fi
  fi
  log "installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  # `env` so that DEBIAN_FRONTEND reaches apt-get through sudo's environment reset.
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
}

# ROS (roslaunch, rostest, the master) resolves `localhost`. A bare system made with debootstrap
# has no /etc/hosts at all; add the standard loopback lines that any installed Debian has.
ensure_localhost() {
  getent hosts localhost > /dev/null 2>&1 && return
  local sudo=()
  ((EUID == 0)) || sudo=(sudo)
  log "localhost does not resolve (no entry in /etc/hosts): adding the standard loopback lines, which ROS needs"
  printf '127.0.0.1\tlocalhost\n::1\tlocalhost ip6-localhost ip6-loopback\n' | "${sudo[@]}" tee -a /etc/hosts > /dev/null
}

if [[ "${FLUID_SIM_SKIP_APT:-0}" != 1 ]]; then
  start=$SECONDS
  ensure_localhost
  install_missing
  log "packages: $((SECONDS - start)) s"
fi

start=$SECONDS
jobs="$(nproc 2> /dev/null || echo 2)"
# The canonical configuration (float, with ROS), also when build/ was configured otherwise before;
# arguments given to this script come last and win.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DFLUID_SIM_USE_DOUBLE=OFF -DFLUID_SIM_BUILD_ROS=ON \
  -DPYTHON_EXECUTABLE=/usr/bin/python3 "$@"
cmake --build build -j"$jobs"
log "configure + build: $((SECONDS - start)) s (build/)"
