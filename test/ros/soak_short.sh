#!/usr/bin/env bash
# ctest ros_soak_short: two minutes of scripts/soak.py (the hour-long soak's short version): the
# demo's node lives through its tf publisher killed and restarted, the master restarted, pause,
# step and reset, with a verdict on the way. At a spacing of 3 cm and real-time factor 0.5 (the
# robot moves at half the demo's speed, so the water sees the demo's motion) it keeps up on a
# loaded 2-core machine.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# shellcheck source=../../scripts/ros_env.sh
source "$ROOT/scripts/ros_env.sh"
out="$(mktemp -d)"
# The node's time to start (120 s) and to publish again after a fault (60 s) are limits on waits:
# times FLUID_SIM_TEST_TIME_SCALE (scripts/sanitize.sh: 10; an instrumented node runs 10-30 times
# slower). The soak's length and its checks stay as they are.
scale="${FLUID_SIM_TEST_TIME_SCALE:-1}"
[[ "$scale" =~ ^[1-9][0-9]*$ ]] || scale=1
/usr/bin/python3 "$ROOT/scripts/soak.py" --duration 120 --event-period 12 --spacing 0.03 --real-time-factor 0.5 \
  --seed 2 --start-limit $((120 * scale)) --resume-limit $((60 * scale)) --out "$out"
rc=$?
((rc == 0)) && rm -rf "$out"
exit $rc
