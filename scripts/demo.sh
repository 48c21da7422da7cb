#!/usr/bin/env bash
# Sets up, builds saulctl, and runs the main job on the bundled capture: every frame of three seconds of
# the robot's CAN bus, decoded. Pass other saulctl arguments to run something else, e.g.
#   scripts/demo.sh decode --json captures/robot_bus.log
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
SAUL_SKIP_EMBEDDED=1 scripts/setup.sh
cmake --preset default -DSAUL_BUILD_TESTS=OFF -DSAUL_BUILD_BENCH=OFF >/dev/null
cmake --build --preset default --target saulctl
if (($# == 0)); then
  set -- decode captures/robot_bus.log
fi
exec build/saulctl/saulctl "$@"
