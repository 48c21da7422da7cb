#!/usr/bin/env bash
# Sets up (installs missing Debian packages), builds, and runs every test: unit, host, firmware, saulctl end to end,
# bench suites on the simulator, the real-kernel harness, the arm-none-eabi build of the core and the fuzzers.
# This is exactly what CI runs (.ci/run).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
# What the build needs first; what only the tests need (the browser, QEMU, the cross compiler, lintian, ...) is
# installed while the build compiles: apt waits on the network and the disk, the compiler on the CPU. When sudo
# would ask for a password, everything is installed first (a prompt in the background would be lost).
if [[ $(id -u) == 0 ]] || sudo -n true 2>/dev/null; then
  scripts/setup.sh --build
  setup_log=$(mktemp)
  scripts/setup.sh --test >"$setup_log" 2>&1 &
  setup_pid=$!
else
  scripts/setup.sh
  setup_pid=""
fi
# The preset "test" (CMakePresets.json) builds everything in build-test/ with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer, so the whole suite runs once under them; the fuzz test adds libFuzzer runs. clang
# because it builds this code in two thirds of g++'s time (cold, on two cores: 520 s against 830 s); g++ -Werror
# still builds the libraries, saulctl and the Python module in the package test (tests/package), as users build them.
cmake --preset test >/dev/null
cmake --build --preset test
if [[ -n $setup_pid ]]; then
  if ! wait "$setup_pid"; then
    cat "$setup_log" >&2
    echo "test: installing the test packages failed (scripts/setup.sh --test; output above)" >&2
    exit 1
  fi
  cat "$setup_log"
  rm -f "$setup_log"
fi
ctest --preset test -j "$(nproc)"
