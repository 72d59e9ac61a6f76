# Sourced by the scripts that start ROS (run_default.sh, test.sh, screenshot.sh): the devel
# space of build/ and a network setup that works on a machine without a resolvable host name.
# shellcheck shell=bash

# A pyenv python3 first on PATH cannot import Debian's ROS Python modules (ROS_ON_DEBIAN.md).
export PYENV_VERSION=system
if [[ -z "${ROS_HOSTNAME:-}" && -z "${ROS_IP:-}" ]]; then
  if getent hosts localhost > /dev/null 2>&1; then
    export ROS_HOSTNAME=localhost
  else
    # No /etc/hosts (a bare chroot or container): talk over the loopback address instead.
    export ROS_IP=127.0.0.1
    export ROS_MASTER_URI="${ROS_MASTER_URI:-http://127.0.0.1:11311}"
  fi
fi
# catkin's setup scripts read unset variables: source them without `set -u`.
_fluid_nounset=0
[[ $- == *u* ]] && _fluid_nounset=1
set +u
# FLUID_SIM_BUILD_DIR: another build folder of the repository (scripts/sanitize.sh's).
# shellcheck disable=SC1091
source "$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/${FLUID_SIM_BUILD_DIR:-build}/devel/setup.bash"
((_fluid_nounset)) && set -u
unset _fluid_nounset
