#!/usr/bin/env bash
# saulctl decode end to end. Expected values come from the story in captures/make_robot_bus.py and from
# captures/glitches.log, written by hand; none are produced by saulctl itself.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

"$saulctl" decode "$root/captures/robot_bus.log" >"$out/text" 2>"$out/err"
check "sample decodes with exit 0" test $? -eq 0
check "mode balance while OFF is acknowledged not_allowed" \
  grep -q '^(1763800000.100400) can0 402#020002 *command_ack command=2 sequence=0 result=rejected_not_allowed$' "$out/text"
check "PID gains decode to 1.5 0.25 0.05" \
  bash -c "grep -c 'pid_gain gain=kp sequence=1 kp=1.5\$\|pid_gain gain=ki sequence=1 ki=0.25\$\|pid_gain gain=kd sequence=1 kd=0.05\$' '$out/text' | grep -qx 3"
check "config 20.00 deg / 1200 mm/s" grep -q 'config_cmd tilt_limit=20.00° max_speed_mmps=1200$' "$out/text"
check "velocity reaches 400 mm/s" grep -q '300#90010000 *velocity_cmd speed_mmps=400 steer_mrad=0$' "$out/text"
check "telemetry shows BALANCE after arming" grep -q 'telemetry_a .* state=BALANCE$' "$out/text"
check "summary on stderr counts 452 frames" grep -q '^saulctl decode: 452 frames' "$out/err"
check "no SAUL frame of the sample is rejected" bash -c "! grep -E '^\\(.* (30[0-3]|40[0-2])#.*!' '$out/text'"
# VESC frames (29-bit ids, big-endian). At 1.50 s the Orin asks for 200 mm/s: round(0.2 / (pi x 0.2) x 60) = 19
# mechanical rpm x 7 pole pairs = 133 ERPM = 0x85. At 1.55 s: 220 mm/s -> 21 rpm -> 147 ERPM = 0x93, current
# 12 -> 1.2 A, duty int(220 / 20) = 11 -> 0.011; STATUS_5 tachometer 155 x 3 = 465 = 0x1D1, 396 -> 39.6 V.
check "VESC SET_RPM to 68 decodes to 133 ERPM" \
  grep -q '^(1763800001.500200) can0 00000344#00000085 *vesc_set_rpm controller_id=68 erpm=133$' "$out/text"
check "VESC STATUS from 68 decodes ERPM, current and duty" \
  grep -q '^(1763800001.550500) can0 00000944#00000093000C000B *vesc_status_1 controller_id=68 erpm=147 current=1.2 duty=0.011$' "$out/text"
check "VESC STATUS_5 from 56 decodes tachometer and voltage" \
  grep -q '00001B38#000001D1018C0000 *vesc_status_5 controller_id=56 tachometer=465 voltage_in=39.6$' "$out/text"
check "all 340 VESC frames decode (250 SET_RPM, 60 STATUS, 30 STATUS_5)" \
  test "$(grep -c ' vesc_\(set_rpm\|status_1\|status_5\) controller_id=' "$out/text")" -eq 340
check "the sample has 0 unknown ids and no rejected frame" \
  bash -c "grep -q '^saulctl decode: 452 frames: 452 decoded, 0 unknown id, 0 rejected' '$out/err' && ! grep -q '!' '$out/text'"

"$saulctl" decode --json "$root/captures/robot_bus.log" >"$out/json" 2>/dev/null
check "--json gives one object per frame" test "$(wc -l <"$out/json")" -eq 452
check "--json carries typed fields" grep -q '"message":{"max_speed_mmps":1200,"tilt_limit":20.0,"tilt_limit_raw":2000,"type":"config_cmd"}' "$out/json"
check "--json carries VESC values as plain decimals" \
  grep -q '"message":{"controller_id":68,"current":1.2,"duty":0.011,"erpm":147,"type":"vesc_status_1"}' "$out/json"

"$saulctl" decode --id 0x300 --time delta "$root/captures/robot_bus.log" >"$out/delta" 2>/dev/null
check "--id filters to 0x300 only" bash -c "! grep -v ' 300#' '$out/delta'"
check "--time delta shows the 50 ms period" grep -q '^(   0.050000) can0 300#' "$out/delta"

"$saulctl" decode "$root/captures/glitches.log" >"$out/g" 2>"$out/gerr"
check "a log with corrupt lines still exits 0" test $? -eq 0
"$saulctl" decode --strict "$root/captures/glitches.log" >/dev/null 2>"$out/gstrict"
check "--strict exits 1 on corrupt lines" test $? -eq 1
check "--strict says why" grep -q -- '--strict: 2 corrupt record(s)' "$out/gstrict"
"$saulctl" decode --strict "$root/captures/robot_bus.log" >/dev/null 2>&1
check "--strict on a clean log exits 0" test $? -eq 0
printf '(1.0) can0 3G0#01\nnot a frame but a comment\n(2.0 can0 300#00\n' >"$out/allbad.log"
"$saulctl" decode "$out/allbad.log" >/dev/null 2>"$out/allbad.err"
check "a log of only corrupt lines exits 1 (nothing could be read)" test $? -eq 1
check "... and says so" grep -q 'nothing could be read' "$out/allbad.err"
check "wrong DLC is named" grep -q '300#E8030C .*!wrong_dlc$' "$out/g"
check "unknown id is named" grep -q '123#0102 .*!unknown_id$' "$out/g"
check "remote frame is named" grep -q '400#R .*!remote_frame$' "$out/g"
check "error frame is named" grep -q '20000004#0000080000000000 .*!error_frame$' "$out/g"
check "mode 7 is out of range" grep -q '302#07 .*!out_of_range$' "$out/g"
check "bad hex id reported with file, line and column" \
  grep -q "glitches.log:8:27: id is not hexadecimal (line skipped)" "$out/gerr"
check "missing ')' reported with its line" grep -q "glitches.log:11:1: timestamp has no closing ')'" "$out/gerr"
check "frames after a corrupt line still decode" grep -q '402#010703 .*command_ack command=1 sequence=7 result=rejected_incomplete$' "$out/g"
# 29-bit 0x300 is VESC command 3 (SET_RPM) to controller 0; 0xE8030CFE big-endian = 3892514046 - 2^32.
check "29-bit id 0x300 is not taken for a SAUL frame" \
  grep -q '00000300#E8030CFE *vesc_set_rpm controller_id=0 erpm=-402453250$' "$out/g"

"$saulctl" decode "$out/does-not-exist.log" 2>"$out/nf"
check "missing file exits 1" test $? -eq 1
check "missing file error names the file" grep -q "cannot open '.*does-not-exist.log'" "$out/nf"
"$saulctl" decode --format xml "$root/captures/robot_bus.log" >/dev/null 2>&1
check "bad option value exits 2" test $? -eq 2
"$saulctl" >/dev/null 2>&1
check "no verb exits 2" test $? -eq 2
"$saulctl" decode --help >"$out/help"
check "decode --help exits 0 and shows examples" grep -q 'Examples:' "$out/help"

echo "$fails failed"
exit $((fails > 0))
