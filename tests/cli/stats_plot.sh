#!/usr/bin/env bash
# saulctl stats and plot end to end. Expected numbers are worked out by hand from the story in
# captures/make_robot_bus.py (ids, periods, counts) and from hand-made logs here; none come from saulctl.
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
log=$root/captures/robot_bus.log

"$saulctl" stats "$log" >"$out/stats" 2>"$out/stats.err"
check "stats exits 0" test $? -eq 0
# 452 frames from the first telemetry at 0.0009 s to the last SET_RPM (step 298 + 0.3 ms) at 2.9803 s
check "452 frames over 2.979 s" grep -q '^.*robot_bus.log: 452 frames from 1763800000.000900 to 1763800002.980300 (2.979 s); 0 corrupt records$' "$out/stats"
# worst-case bits: 0x300 95 x 44, 0x400/0x401 125 x 30 each, 0x302 65, 0x402 85 x 3, 0x301 135 x 3, 0x303 95,
# SET_RPM 120 x 250, STATUS/STATUS_5 160 x 90 = 56 900 bits / (2.9794 s x 500 kbit/s) = 3.82 %
check "bus load 3.82 % with worst-case stuffing at 500 kbit/s" grep -q 'at 500 kbit/s: 3.82 % (worst-case stuffing)' "$out/stats"
# 0x300 at 20 Hz from step 80 to step 295: (295 - 80) / 5 + 1 = 44 frames, 50 ms apart, never silent for 500 ms
check "0x300: longest silence 50 ms, never over the Orin timeout" \
  grep -q '^0x300 velocity_cmd: longest silence 50.000 ms from +0.799 s; 0 silences over the 500 ms Orin timeout$' "$out/stats"
row() { grep -E "^$1 +$2 +$3 +$4 " "$out/stats" >/dev/null; }  # id, type, count, rate
check "0x300 row: 44 frames at 20 Hz" row 300 velocity_cmd 44 20.00
check "0x400 and 0x401 rows: 30 frames at 10 Hz" bash -c "$(declare -f row); out=$out; row 400 telemetry_a 30 10.00 && row 401 telemetry_b 30 10.00"
# SET_RPM every other 10 ms step once armed (step 50 to 298): 125 per VESC at 50 Hz; STATUS at 10 Hz, STATUS_5 at 5 Hz
check "VESC rows: 125 SET_RPM at 50 Hz, 30 STATUS at 10 Hz, 15 STATUS_5 at 5 Hz per controller" \
  bash -c "$(declare -f row); out=$out; row 00000344 vesc_set_rpm 125 50.00 && row 00000938 vesc_status_1 30 10.00 && row 00001B44 vesc_status_5 15 5.00"
check "the three acks: longest gap 500.4 ms (0.1004 s to 0.6008 s)" grep -qE '^402 +command_ack +3 .* 500.400 ms ' "$out/stats"
check "no error frames, no decode errors" bash -c "grep -qx 'error frames: 0' '$out/stats' && grep -qx 'decode errors: 0' '$out/stats'"

"$saulctl" stats --json "$log" >"$out/json" 2>/dev/null
check "--json: one object with the same numbers" python3 - "$out/json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
v = [e for e in j["ids"] if e["id_hex"] == "300"][0]
load = j["load"]["can0"]
ok = (j["frames"] == 452 and v["count"] == 44 and abs(v["max_gap_s"] - 0.05) < 1e-9
      and v["silences_over_orin_timeout"] == 0 and load["bits_worst_case"] == 56900
      and abs(load["percent_worst_case"] - 3.8196) < 0.001 and j["decode_errors"] == 0)
sys.exit(0 if ok else 1)
PY

# A silence the BALANCE board would notice: 0x300 at 0, 0.1, 0.7 (600 ms later) and 0.75 s.
printf '(1.000000) can0 300#64000000\n(1.100000) can0 300#64000000\n(1.700000) can0 300#64000000\n(1.750000) can0 300#64000000\n' >"$out/silence.log"
"$saulctl" stats "$out/silence.log" >"$out/silence" 2>&1
check "a 600 ms gap in 0x300 is reported against the 500 ms Orin timeout" \
  grep -q '^0x300 velocity_cmd: longest silence 600.000 ms from +0.100 s; 1 silences over the 500 ms Orin timeout$' "$out/silence"

"$saulctl" stats "$root/captures/glitches.log" >"$out/g" 2>"$out/gerr"
check "glitches.log: exit 0, the error frame and 4 decode errors by reason" \
  bash -c "grep -qx 'error frames: 1 (1 controller)' '$out/g' && grep -qx 'decode errors: 4 (1 out_of_range, 1 remote_frame, 1 unknown_id, 1 wrong_dlc)' '$out/g'"
check "glitches.log: corrupt lines reported with their position and counted" \
  bash -c "grep -q 'glitches.log:8:27: id is not hexadecimal' '$out/gerr' && grep -q '9 frames .* 2 corrupt records' '$out/g'"

"$saulctl" stats "$root/captures/pride_uart.serial" >"$out/pride" 2>&1
check "serial stats: 4 vcu_command and 4 controller_status, 5 ms apart, line load at 38400 baud 8E1" \
  bash -c "grep -qE '^  vcu_command +4 +200.00 +5.000 ms +5.000 ms' '$out/pride' && grep -qE '^  controller_status +4 ' '$out/pride' && grep -q 'at 38400 baud (11 bits per byte)' '$out/pride'"
"$saulctl" stats --samplerate 1M "$root/captures/pride_uart.sigrok.txt" >"$out/sigrok" 2>&1
check "stats of a sigrok export guesses pride and counts the parity error" \
  bash -c "grep -q 'uart-1 (pride, guessed)' '$out/sigrok' && grep -q '8 frames, 0 checksum errors, 0 out of range, 0 bytes skipped, 0 incomplete, 1 uart errors' '$out/sigrok'"

"$saulctl" stats "$out/nope.log" 2>"$out/nope"
check "stats of a missing file exits 1" test $? -eq 1
"$saulctl" stats --bitrate fast "$log" >/dev/null 2>&1
check "a bad --bitrate is a usage error (exit 2)" test $? -eq 2

# --- plot ---------------------------------------------------------------------------------------------------
"$saulctl" plot "$log" --id 0x400 --field pitch_x100,pid_out -o "$out/p.svg" 2>"$out/plot.err"
check "plot writes an SVG with one line per field" \
  bash -c "test $? -eq 0 && head -c 5 '$out/p.svg' | grep -q '<?xml' && test \$(grep -c '<polyline' '$out/p.svg') -eq 2"
check "plot says what it drew: 30 telemetry frames over 2.9 s" grep -q '30 points of 0x400 (pitch_x100, pid_out) over 2.900 s' "$out/plot.err"
"$saulctl" plot "$log" --id telemetry_a --field pitch_x100 -o "$out/p.csv" 2>/dev/null
# pitch = round(150 sin(3t)) once armed (t >= 0.5 s): at t = 1.0 s (telemetry at +0.9991 s) round(150 sin 3) = 21
check "plot -o .csv: a header and the 30 points; pitch 21 at 1.0 s" \
  bash -c "test \$(wc -l <'$out/p.csv') -eq 31 && head -n 1 '$out/p.csv' | grep -qx 'time_s,pitch_x100' && grep -qx '1.000000,21' '$out/p.csv'"
"$saulctl" plot "$log" --id 0x400 --field pitch -o "$out/x.svg" 2>"$out/field.err"
check "an unknown field exits 2 and lists the message's fields" \
  bash -c "test $? -eq 2 && grep -q 'it has pitch_x100, pid_out, speed_mmps, state' '$out/field.err'"
"$saulctl" plot "$log" --id 0x400 --field pitch_x100 -o "$out/x.png" 2>"$out/png.err"
check "PNG is refused with a hint (exit 2)" bash -c "test $? -eq 2 && grep -q 'rsvg-convert' '$out/png.err'"
"$saulctl" plot "$root/captures/interboard_uart.serial" --id state --field pitch_x100 -o "$out/s.csv" 2>/dev/null
check "plot reads serial captures by message name" grep -qx '0.000000,-1234' "$out/s.csv"

echo "$fails failed"
exit $((fails > 0))
