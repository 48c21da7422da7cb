#!/usr/bin/env bash
# Sets up (installs missing Debian packages), builds, and runs every test: unit, host, saulctl end to end,
# and the arm-none-eabi build of the core. This is exactly what CI runs (.ci/run).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/setup.sh
cmake --preset default -DSAUL_BUILD_TESTS=ON -DSAUL_BUILD_BENCH=ON >/dev/null
cmake --build --preset default
ctest --preset default -j "$(nproc)"
