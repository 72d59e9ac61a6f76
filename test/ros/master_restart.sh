#!/usr/bin/env bash
# ctest ros_master_restart_connected / ros_master_restart_startup: the node lives through a
# restart of its master (test/ros/master_restart.py; argument: the scenario).
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# shellcheck source=../../scripts/ros_env.sh
source "$ROOT/scripts/ros_env.sh"
out="$(mktemp -d)"
/usr/bin/python3 "$ROOT/test/ros/master_restart.py" "$1" --out "$out"
rc=$?
rm -rf "$out"
exit $rc
