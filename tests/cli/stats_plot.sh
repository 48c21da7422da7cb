#!/usr/bin/env bash
# saulctl stats and plot end to end. Expected numbers are worked out by hand from the story in
# captures/make_robot_bus.py (ids, periods, counts) and from hand-made logs here; none come from saulctl.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
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
# Static pictures are gnuplot's (SVG, PNG, PDF), the page is dygraphs' (its drawing is checked in a browser by
# plot_browser.sh): here the files, what they say, and the numbers.
export out
xml_ok() { python3 -c "import xml.etree.ElementTree as E, sys; E.parse(sys.argv[1])" "$1" 2>/dev/null; }
# texts FILE STRING: how many SVG text elements say exactly STRING
texts() { grep -o ">[^<>]*</text>" "$1" | grep -cxF ">$2</text>"; }
export -f xml_ok texts
"$saulctl" plot "$log" --id 0x400 --field pitch,pid_out -o "$out/p.svg" 2>"$out/plot.err"
check "plot -o .svg: an SVG drawn by gnuplot, one panel per field (30 points each)" \
  bash -c "test $? -eq 0 && xml_ok '$out/p.svg' && grep -q 'Produced by GNUPLOT' '$out/p.svg' && test \$(grep -c '(30 points)</text>' '$out/p.svg') -eq 2"
check "plot says what it drew: 30 telemetry frames over 2.9 s" grep -q '30 points of 0x400 (pitch, pid_out) over 2.900 s' "$out/plot.err"
"$saulctl" plot "$log" --id telemetry_a --field pitch,pitch_raw -o "$out/p.csv" 2>/dev/null
# pitch_raw = round(150 sin(3t)) once armed (t >= 0.5 s): at t = 1.0 s (telemetry at +0.9991 s) round(150 sin 3) = 21
check "plot -o .csv: a header and the 30 points; pitch 0.21 deg (pitch_raw 21) at 1.0 s" \
  bash -c "test \$(wc -l <'$out/p.csv') -eq 31 && head -n 1 '$out/p.csv' | grep -qx 'time_s,pitch,pitch_raw' && grep -qx '1.000000,0.21,21' '$out/p.csv'"
"$saulctl" plot "$log" --id 0x400 --field pitch_x100 -o "$out/x.svg" 2>"$out/field.err"
check "a struct's field name (pitch_x100) is no signal name: exit 2, a line listing the message's signals" \
  bash -c "test $? -eq 2 && grep -q \"has no signal 'pitch_x100'; its signals: pitch, pitch_raw, pid_out, speed_mmps, state\" '$out/field.err'"
"$saulctl" plot "$log" --id 0x400 --field pitch -o "$out/x.png" 2>/dev/null
# PNG: 8-byte signature, then IHDR with width and height (big-endian): 1600 x (110 + 300 per panel) = 1600 x 410.
check "plot -o .png: a PNG of 1600 x 410 px for one panel" \
  bash -c "test $? -eq 0 && python3 -c \"import struct,sys; d=open('$out/x.png','rb').read(24); sys.exit(0 if d[:8]==b'\x89PNG\r\n\x1a\n' and struct.unpack('>II', d[16:24])==(1600,410) else 1)\""
"$saulctl" plot "$log" -o "$out/run.pdf" 2>/dev/null
check "plot -o .pdf: a PDF" bash -c "test $? -eq 0 && head -c 5 '$out/run.pdf' | grep -q '%PDF-' && test \$(wc -c <'$out/run.pdf') -gt 5000"
PATH=/nonexistent "$saulctl" plot "$log" -o "$out/nognuplot.svg" 2>"$out/nognuplot.err"
check "without gnuplot: exit 1 saying which package draws SVG, PNG and PDF" \
  bash -c "test $? -eq 1 && grep -q 'apt install gnuplot-nox' '$out/nognuplot.err'"
"$saulctl" plot "$root/captures/interboard_uart.serial" --id state --field pitch -o "$out/s.csv" 2>/dev/null
check "plot reads serial captures by message name (pitch in deg)" grep -qx '0.000000,-12.34' "$out/s.csv"

# --- plot: the dashboard, state/fault markers, HTML ---------------------------------------------------------
# robot_bus.log (make_robot_bus.py) has every message the dashboard draws: 30 0x400 + 30 0x401 + 44 0x300 + 2 x 30
# VESC STATUS + 2 x 15 STATUS_5 = 194 messages, from the first 0x400 at +0.0009 s to the last STATUS_5 at
# step 295 + 0.8 ms = +2.9508 s: 2.9499 s. Its timestamps start at 1763800000.000900 = 2025-11-22 08:26:40.0009 UTC.
"$saulctl" plot "$log" -o "$out/run.svg" 2>"$out/dash.err"
check "plot without --id draws the dashboard: 6 panels of 194 messages over 2.950 s" \
  bash -c "test $? -eq 0 && grep -q 'saulctl plot: 194 messages over 2.950 s in 6 panels (pitch \[deg\], pid_out \[permille\], speed \[mm/s\], wheel speed \[rpm\] (0x401), VESC ERPM (STATUS), battery \[V\]) written to $out/run.svg' '$out/dash.err'"
check "the dashboard SVG: each panel titled with its points, the series in the keys" \
  bash -c "xml_ok '$out/run.svg' && test \$(texts '$out/run.svg' 'pitch [deg] (30 points)') -eq 1 && test \$(texts '$out/run.svg' 'VESC ERPM (STATUS) (60 points)') -eq 1 && test \$(texts '$out/run.svg' 'commanded (0x300)') -eq 1 && test \$(texts '$out/run.svg' 'right (56)') -eq 1"
check "the title has a date, not a raw epoch; the axis the time of day of 0" \
  bash -c "test \$(texts '$out/run.svg' 'robot_bus.log: telemetry (194 messages from 2025-11-22 08:26:40.001 UTC)') -eq 1 && test \$(texts '$out/run.svg' 'time since 08:26:40.001 UTC [s]') -eq 1 && ! grep -q 1763800000 '$out/run.svg'"
# The state goes OFF (first seen, t = 0) -> BALANCE at step 50 (t = 0.5 s); the faults stay 0: both labelled on all
# six panels.
check "state changes marked on every panel: OFF and BALANCE" \
  bash -c "test \$(texts '$out/run.svg' OFF) -eq 6 && test \$(texts '$out/run.svg' BALANCE) -eq 6 && grep -q 'saulctl plot: 2 state/fault changes marked' '$out/dash.err'"

"$saulctl" plot "$log" -o "$out/run.html" 2>/dev/null
check "plot -o .html: one page, its scripts inline (no src, no link), dygraphs from Debian" \
  bash -c "test $? -eq 0 && head -n 1 '$out/run.html' | grep -qx '<!DOCTYPE html>' && python3 '$root/tests/cli/plot_page.py' '$out/run.html' && grep -qF \"\$(head -c 200 /usr/share/javascript/dygraphs/dygraph.min.js)\" '$out/run.html'"
check "the page's table: OFF first seen at 0.000000 (08:26:40.001), BALANCE at 0.500000 (08:26:40.501)" \
  bash -c "grep -q '<td class=\"num\">0.000000</td><td class=\"num\">2025-11-22 08:26:40.001 UTC</td><td>state</td><td>OFF (first seen)</td>' '$out/run.html' && grep -q '<td class=\"num\">0.500000</td><td class=\"num\">2025-11-22 08:26:40.501 UTC</td><td>state</td><td>OFF -&gt; BALANCE</td>' '$out/run.html'"
check "the page's data: 6 panels from 0 to 2.9499 s, the day and the time of day of 0" \
  bash -c "python3 '$root/tests/cli/plot_page.py' '$out/run.html' --data | grep -qx '6 panels 0..2.9499 2025-11-22 30400.0009'"
"$saulctl" plot "$log" --format html -o - 2>/dev/null | cmp -s - "$out/run.html"
check "--format html -o - writes the same page to stdout" test $? -eq 0
(cd "$out" && "$saulctl" plot "$log" 2>/dev/null)
check "without -o: the page, named after the capture (robot_bus.html)" cmp -s "$out/robot_bus.html" "$out/run.html"

"$saulctl" plot "$log" -o "$out/run.csv" 2>/dev/null
# At t = 1.0 s (0x400 at +1.0009 s): pitch round(150 sin 3) = 21 -> 0.21 deg, pid_out int(21 x 0.8) = 16,
# speed 0 (the ramp starts at 1.0 s), state 1; one row per message that gives a column: 194 + the header.
check "plot -o .csv without --id: the dashboard's columns, one row per message, 0.21 deg at 1.0 s" \
  bash -c "head -n 1 '$out/run.csv' | grep -qx 'time_s,pitch,pid_out,speed_mmps,speed_cmd_mmps,wheel_l_rpm,wheel_r_rpm,vesc_l_erpm,vesc_r_erpm,battery,vesc_l_v,vesc_r_v,state,faults' && test \$(wc -l <'$out/run.csv') -eq 195 && grep -qx '1.000000,0.21,16,0,,,,,,,,,1,' '$out/run.csv'"

# glitches.log has no valid 0x400 and no VESC STATUS: pitch, pid_out and ERPM are left out, and said so; its 0x401
# (+0.070 s) sets faults 0x11 = rc_loss + orin_timeout, 70 ms after the first plotted message (0x300 at +0.000 s).
"$saulctl" plot "$root/captures/glitches.log" -o "$out/g.html" 2>"$out/g.err"
check "a capture lacking frames: the panels without data are left out, on stderr" \
  bash -c "test $? -eq 0 && test \$(grep -c ': left out, ' '$out/g.err') -eq 3 && grep -q '^saulctl plot: pitch \[deg\]: left out, no 0x400 telemetry_a' '$out/g.err' && grep -q '^saulctl plot: VESC ERPM (STATUS): left out' '$out/g.err' && grep -q 'in 3 panels (speed \[mm/s\], wheel speed \[rpm\] (0x401), battery \[V\])' '$out/g.err'"
check "the fault change marked and listed: +rc_loss +orin_timeout at 0.070 s" \
  bash -c "grep -qF '\"label\":\"+rc_loss +orin_timeout\",\"t\":0.07' '$out/g.html' && grep -q '<td class=\"num\">0.070000</td><td class=\"num\">2025-11-22 08:26:40.070 UTC</td><td>faults</td><td>none -&gt; rc_loss+orin_timeout</td>' '$out/g.html'"

# Marker cap: 12 telemetry frames alternating OFF/BALANCE, 100 ms apart = 12 changes; --max-markers 5 draws the
# first 5 (OFF, BALANCE, OFF, BALANCE, OFF) on each of the 3 panels 0x400 fills (pitch, pid_out, speed).
awk 'BEGIN { for (i = 0; i < 12; i++) printf "(%d.%06d) can0 400#0000000000000%d\n", 1 + int(i / 10), (i % 10) * 100000, i % 2 }' \
  >"$out/toggle.log"
"$saulctl" plot "$out/toggle.log" --max-markers 5 -o "$out/t.svg" 2>"$out/t.err"
check "--max-markers 5: 5 of 12 changes drawn on each panel, the other 7 counted in the picture and on stderr" \
  bash -c "test $? -eq 0 && test \$(texts '$out/t.svg' OFF) -eq 9 && test \$(texts '$out/t.svg' BALANCE) -eq 6 && grep -q '12 state/fault changes: the first 5 are marked, 7 more are not' '$out/t.svg' && grep -q '12 state/fault changes, the first 5 marked' '$out/t.err'"

"$saulctl" plot "$log" --id 0x400 --field pitch -o "$out/id.svg" 2>/dev/null
check "--id plots keep the markers: OFF and BALANCE on the one panel" \
  bash -c "test \$(texts '$out/id.svg' OFF) -eq 1 && test \$(texts '$out/id.svg' BALANCE) -eq 1"
"$saulctl" plot "$log" --format csv -o "$out/p.dat" 2>/dev/null
check "--format csv whatever the extension" bash -c "test $? -eq 0 && head -n 1 '$out/p.dat' | grep -q '^time_s,pitch,'"
"$saulctl" plot "$log" -o "$out/p.txt" 2>"$out/ext.err"
check "an unknown extension without --format is a usage error (exit 2)" \
  bash -c "test $? -eq 2 && grep -q 'html|svg|png|pdf|csv' '$out/ext.err'"
"$saulctl" plot "$log" --field pitch -o "$out/x.svg" 2>"$out/f.err"
check "--field without --id is a usage error (exit 2)" bash -c "test $? -eq 2 && grep -q 'needs --id' '$out/f.err'"
"$saulctl" plot "$root/captures/pride_uart.serial" -o "$out/pride.svg" 2>"$out/pride.err"
check "nothing the dashboard draws (a Pride capture): exit 1 and a hint to use --id" \
  bash -c "test $? -eq 1 && grep -q 'name a message with --id and --field' '$out/pride.err' && test ! -e '$out/pride.svg'"
# Pride's signals (core/signals_pride.hpp) are its unscaled fields, by the manual's names (docs/cli.md); the values
# written out by hand from captures/pride_uart.serial's four vcu_command frames.
"$saulctl" plot "$root/captures/pride_uart.serial" --id vcu_command --field forward_back --field left_right \
  --format csv -o "$out/pride.csv" 2>/dev/null
check "plot --id vcu_command --field forward_back: a Pride capture's fields by their names" \
  bash -c "test $? -eq 0 && head -n 1 '$out/pride.csv' | grep -q '^time_s,forward_back,left_right' && test \"\$(tail -n +2 '$out/pride.csv' | cut -d, -f2,3 | tr '\n' ' ')\" = '50,0 -100,-50 100,-100 0,0 '"
"$saulctl" plot "$root/captures/pride_uart.serial" --id vcu_command --field throttle -o "$out/p2.svg" 2>"$out/p2.err"
check "... a signal Pride's message has not: exit 2, listing its signals" \
  bash -c "test $? -eq 2 && grep -q \"has no signal 'throttle'; its signals: speed_level, forward_back, left_right\" '$out/p2.err'"
# The same error from a CRSF capture, whose frames come out of the core's noexcept decoder (it ended saulctl with
# "terminate called"): protocols.md's T1 RC frame, all channels 992 ticks.
echo "(1763800000.000100) serial:/dev/ttyACM0@420000:8N1 crsf C81816E0031FF8C0073EF0810F7CE0031FF8C0073EF0810F7CAD" \
  >"$out/crsf.serial"
"$saulctl" plot "$out/crsf.serial" --id rc_channels --field throttle -o "$out/c.svg" 2>"$out/c.err"
check "... and a CRSF message's: exit 2, one line listing its signals" \
  bash -c "test $? -eq 2 && grep -q \"^saulctl plot: 'rc_channels' (rc_channels) has no signal 'throttle'; its signals: ch1, \" '$out/c.err'"
"$saulctl" plot --help >"$out/help" 2>&1
check "plot --help explains the dashboard, the markers and the formats with examples" \
  bash -c "grep -q 'Without --id, draws the telemetry dashboard' '$out/help' && grep -q 'saulctl plot run.log -o run.pdf' '$out/help' && grep -q -- '--max-markers' '$out/help' && grep -q 'drag to zoom' '$out/help'"

echo "$fails failed"
exit $((fails > 0))
