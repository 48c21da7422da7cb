#!/usr/bin/env bash
# `saulctl sim --no-imu`: the simulated robot powers on with its IMU pulled. BALANCE latches FAULT (watchdog_reset,
# 0x20 in the faults) and stays alive: no watchdog reset loop (resets=0 in the final status line). As fast as
# possible (--speed 0) for 5 simulated seconds.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$saulctl" sim --help >"$work/help" 2>&1
check "sim --help documents --no-imu" grep -q -- "--no-imu" "$work/help"
check "sim --help documents the control console's 'imu off'" grep -q "'imu off'" "$work/help"
"$saulctl" sim --no-imu --speed 0 --for 5s --quiet --paths-file "$work/paths" >"$work/out" 2>&1
check "sim --no-imu ran and stopped" grep -q "^sim: stopped at t=5.000 s" "$work/out"
check "BALANCE is in FAULT with watchdog_reset (faults 0x30: watchdog_reset + orin_timeout)" \
  grep -q "state=FAULT .*faults=0x30 " "$work/out"
check "no watchdog reset loop (resets=0)" grep -q "resets=0$" "$work/out"
"$saulctl" sim --speed 0 --for 5s --quiet --paths-file "$work/paths" >"$work/plain" 2>&1
check "with the IMU in, it powers on OFF" grep -q "state=OFF .*faults=0x10 " "$work/plain"
cat "$work/out"
echo "$fails failed"
exit $((fails > 0))
