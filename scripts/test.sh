#!/usr/bin/env bash
# Sets up (installs missing Debian packages), builds, and runs every test: unit, host, firmware, saulctl end to end,
# bench suites on the simulator, the real-kernel harness, the arm-none-eabi build of the core and the fuzzers.
# This is exactly what CI runs (.ci/run).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/setup.sh
# The preset "test" (CMakePresets.json) builds everything in build-test/ with AddressSanitizer and
# UndefinedBehaviorSanitizer, so the whole suite runs once under them; the fuzz test adds libFuzzer runs.
cmake --preset test >/dev/null
cmake --build --preset test
ctest --preset test -j "$(nproc)"
