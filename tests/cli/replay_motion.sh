#!/usr/bin/env bash
# saulctl replay's motion rule, checked before any link opens (the link named here does not exist).
# captures/robot_bus.log has 44 x 0x300, one 0x302 balance and 250 VESC SET_RPM (make_robot_bus.py): 295 motion frames.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
link=slcan:$out/no-such-tty
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" </dev/null 2>"$out/none"
check "by default motion frames are dropped and counted before the link opens (exit 1: no such link)" test $? -eq 1
check "... the count is said: 295 frames, 0x300/0x302/VESC named" \
  grep -q 'replay: dropping 295 frame(s) that can move motors (295 per pass: 0x300, 0x302 balance/manual, VESC set commands); --allow-motion sends them' "$out/none"
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" --loop 2 --no-motion </dev/null 2>"$out/nm"
check "--no-motion says the same, counted over the passes" grep -q 'dropping 590 frame(s) that can move motors (295 per pass' "$out/nm"
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" --allow-motion </dev/null 2>"$out/allow"
check "--allow-motion: the run gets as far as opening the link (exit 1)" test $? -eq 1
check "... and drops nothing" bash -c "! grep -q 'dropping' '$out/allow'"
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" --allow-motion --no-motion </dev/null 2>/dev/null
check "--allow-motion with --no-motion is a usage error" test $? -eq 2
echo "$fails failed"
exit $((fails > 0))
