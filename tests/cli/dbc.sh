#!/usr/bin/env bash
# saulctl dbc: the DBC it writes, checked line by line where the layout matters and by decoding docs/protocol.md's
# worked examples with a small DBC reader written in Python (tests/cli/dbc_check.py), independent of the C++ code.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

"$saulctl" dbc >"$out/stdout.dbc"
check "dbc exits 0" test $? -eq 0
"$saulctl" dbc -o "$out/saul.dbc"
check "dbc -o exits 0" test $? -eq 0
check "-o writes what stdout gets" cmp -s "$out/stdout.dbc" "$out/saul.dbc"
check "the seven SAUL frames and 2 x 7 VESC frames" test "$(grep -c '^BO_ ' "$out/saul.dbc")" -eq 21
check "0x300 is little-endian and signed" grep -q '^ SG_ speed_mmps : 0|16@1- (1,0) \[-32768|32767\] "mm/s" BALANCE$' "$out/saul.dbc"
check "pitch_x100 is pitch in 0.01 deg" grep -q '^ SG_ pitch : 0|16@1- (0.01,0) \[-327.68|327.67\] "deg" Orin$' "$out/saul.dbc"
check "comments name the wire integers as decode --json does (pitch_raw), not the structs' fields (pitch_x100)" \
  bash -c 'grep -q "^CM_ BO_ 1024 .*pitch_raw" "$0" && ! grep "^CM_" "$0" | grep -q -e _x100 -e battery_mv' "$out/saul.dbc"
check "0x301 multiplexer is the gain index" grep -q '^ SG_ gain M : 0|8@1+ ' "$out/saul.dbc"
check "0x301 kd is multiplexed on index 2" grep -q '^ SG_ kd m2 : 32|32@1- ' "$out/saul.dbc"
check "0x301 gains are IEEE floats" test "$(grep -c '^SIG_VALTYPE_ 769 k[pid] : 1;$' "$out/saul.dbc")" -eq 3
check "state value table" grep -q '^VAL_ 1024 state 5 "FAULT" 4 "TILT_CUTOFF" 3 "ESTOP" 2 "MANUAL" 1 "BALANCE" 0 "OFF" ;$' "$out/saul.dbc"
check "mode value table" grep -q '^VAL_ 770 mode 3 "estop" 2 "manual" 1 "balance" 0 "off" ;$' "$out/saul.dbc"
check "ack result value table" grep -q '^VAL_ 1026 result 3 "rejected_incomplete" .* 0 "applied" ;$' "$out/saul.dbc"
# 0x80000000 | 9 << 8 | 68 = 2147483648 + 2372 = 2147486020; big-endian fields start at bit 8 * byte + 7
check "VESC STATUS of 68: extended id with bit 31" grep -q '^BO_ 2147486020 vesc_status_1_68: 8 VESC_68$' "$out/saul.dbc"
check "VESC STATUS duty is Motorola from byte 6" grep -q '^ SG_ duty : 55|16@0- (0.001,0) ' "$out/saul.dbc"
check "VESC SET_RPM to 56 (0x80000338)" grep -q '^BO_ 2147484472 vesc_set_rpm_56: 4 BALANCE$' "$out/saul.dbc"
python3 "$root/tests/cli/dbc_check.py" "$out/saul.dbc" mini >"$out/mini" 2>&1
check "docs/protocol.md's worked examples decode through the DBC (own reader)" test $? -eq 0
grep -v '^ok' "$out/mini"
"$saulctl" dbc -o "$out/no/such/dir/x.dbc" 2>"$out/err"
check "an unwritable output exits 1 and says so" bash -c "test $? -eq 1 && grep -q 'cannot open' '$out/err'"
echo "$fails failed"
exit $((fails > 0))
