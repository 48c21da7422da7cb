#!/usr/bin/env bash
# saulctl replay's motion rule, checked before any link opens (the link named here does not exist).
# captures/robot_bus.log has 44 x 0x300, one 0x302 balance and 250 VESC SET_RPM (make_robot_bus.py): 295 motion frames.
set -uo pipefail
saulctl=$1
root=$2
fails=0
check() {  # check DESCRIPTION COMMAND...
  local what=$1; shift
  if "$@"; then echo "ok   $what"; else echo "FAIL $what"; fails=$((fails + 1)); fi
}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
link=slcan:$out/no-such-tty
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" --no-motion </dev/null 2>"$out/nm"
check "--no-motion tells how many frames it drops" grep -q -- '--no-motion: dropping 295 frame(s) that can move motors' "$out/nm"
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" </dev/null 2>"$out/none"
check "without confirmation and no terminal: exit 2" test $? -eq 2
check "... and the hint names --allow-motion" grep -q 'add --allow-motion' "$out/none"
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" --allow-motion </dev/null 2>"$out/allow"
check "--allow-motion confirms (the run gets as far as opening the link: exit 1)" test $? -eq 1
check "... without asking" bash -c "! grep -q 'refusing' '$out/allow'"
"$saulctl" replay "$root/captures/robot_bus.log" --to "$link" --allow-motion --no-motion </dev/null 2>/dev/null
check "--allow-motion with --no-motion is a usage error" test $? -eq 2
echo "$fails failed"
exit $((fails > 0))
