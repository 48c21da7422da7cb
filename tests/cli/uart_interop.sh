#!/usr/bin/env bash
# Serial byte captures end to end: our serial logs and the sigrok-cli UART outputs committed in captures/ decode
# to the same messages, with the decoder counters at the end; then, when sigrok-cli is installed, the fixtures
# are made again live (captures/make_uart_vcd.py, sigrok-cli 0.7.2 on its VCDs) and must come out identical.
# Expected messages are the story of captures/make_uart_vcd.py, written out by hand. A missing sigrok-cli is
# SKIPPED with the reason; scripts/setup.sh installs it.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
skip() { echo "SKIP $1 ($2)"; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
caps=$root/captures
messages() { cut -d' ' -f3- "$1"; }  # drop the time and link columns

"$saulctl" decode "$caps/interboard_uart.serial" >"$out/ib" 2>"$out/ib.err"
check "the inter-board serial log decodes (exit 0)" test $? -eq 0
cat >"$out/ib.expect" <<'TXT'
rc_cmd throttle=500 steer=-250 flags=1
state pitch=-12.34° pid_out=300 error_state=1
sensor tof_mm=1234 baro_delta_pa=-56 nfc_present=1
fault flags=5
led_cmd pattern=2 r=255 g=128 b=0
buzzer tone_id=3 duration_ms=500
TXT
check "its six messages, in order (the frame with the bad CRC is not one)" bash -c "$(declare -f messages); messages '$out/ib' | cmp -s - '$out/ib.expect'"
check "the link's counters at the end: 6 frames, 1 CRC error, 7 bytes skipped (2 noise + the bad frame's 5)" \
  grep -q 'serial:/dev/ttyUSB0@460800:8N1 (interboard): 6 frames, 1 crc errors, 0 length errors, 0 unknown types, 7 bytes skipped, 0 incomplete' "$out/ib.err"
check "a message's time is that of the chunk holding its last byte (frames 1 ms apart from 0.1 ms)" \
  bash -c "head -n 1 '$out/ib' | grep -q '^(0000000000.000100) serial:/dev/ttyUSB0@460800:8N1 rc_cmd'"

"$saulctl" decode --samplerate 10M "$caps/interboard_uart.sigrok.txt" >"$out/ib.sigrok" 2>"$out/ib.sigrok.err"
check "sigrok-cli's decode of the inter-board VCD gives the same messages" bash -c "$(declare -f messages); messages '$out/ib.sigrok' | cmp -s - '$out/ib.expect'"
check "its protocol is guessed from the bytes and said so" grep -q 'uart-1 (interboard, guessed from the bytes): 6 frames, 1 crc errors' "$out/ib.sigrok.err"
# rc_cmd's last byte (0x0F) is byte 9 of the frame sent from 0.1 ms at 460800 baud; with --samplerate its
# annotation's first data bit, 8 bytes x 10 bits + 1 bit = 81 bits = 175.8 us later, gives the time
check "--samplerate turns sample numbers into time" bash -c "head -n 1 '$out/ib.sigrok' | grep -q '^(0000000000.00027[56]) uart-1 rc_cmd'"

"$saulctl" decode "$caps/pride_uart.serial" >"$out/pr" 2>"$out/pr.err"
for f in pride_uart.sigrok.txt pride_uart.sigrok.json; do
  "$saulctl" decode --protocol pride --samplerate 1M "$caps/$f" >"$out/$f.out" 2>"$out/$f.err"
  check "$f decodes to the messages of pride_uart.serial" bash -c "$(declare -f messages); cmp -s <(messages '$out/pr') <(messages '$out/$f.out')"
  check "$f: 8 frames, and the parity error sigrok flagged is counted" grep -q '8 frames, 0 checksum errors, 0 out of range, 0 bytes skipped, 0 incomplete, 1 uart errors' "$out/$f.err"
done
check "the Pride log: 4 commands and 4 statuses" \
  bash -c "test \$(grep -c ' vcu_command ' '$out/pr') -eq 4 && test \$(grep -c ' controller_status error_byte=2 battery_charge=100 unknown=0' '$out/pr') -eq 4"
"$saulctl" decode --json --protocol pride --samplerate 1M "$caps/pride_uart.sigrok.json" >"$out/pr.json" 2>/dev/null
check "--json names link and protocol" grep -q '"link":"uart-1:RX","message":{"forward_back":50,"left_right":0,"speed_level":7,"type":"vcu_command"},"protocol":"pride","time":"0000000000.001658"' "$out/pr.json"
"$saulctl" decode --format csv "$caps/pride_uart.serial" >"$out/pr.csv" 2>/dev/null
check "--format csv has the message and its fields" grep -q ',serial:/dev/ttyUSB1@38400:8E1,,,,,,vcu_command,speed_level=7 forward_back=50 left_right=0$' "$out/pr.csv"
printf '(1.000000) uart0 pride FE5407320074\n(2.000000) uart0 modbus 01\n(3.0 uart0 pride 4A\n' >"$out/bad.serial"
"$saulctl" decode "$out/bad.serial" >"$out/bad" 2>"$out/bad.err"
check "corrupt serial lines are reported with their position; the rest decodes" \
  bash -c "grep -q 'bad.serial:2:18: unknown protocol' '$out/bad.err' && grep -q 'vcu_command speed_level=7' '$out/bad'"

# --- sigrok-cli, live --------------------------------------------------------------------------------------
if command -v sigrok-cli >/dev/null; then
  python3 "$caps/make_uart_vcd.py" "$out" >/dev/null
  for f in interboard_uart.vcd pride_uart.vcd interboard_uart.serial pride_uart.serial; do
    check "make_uart_vcd.py makes $f again byte for byte" cmp -s "$caps/$f" "$out/$f"
  done
  sigrok-cli -i "$out/interboard_uart.vcd" -P uart:rx=rx:baudrate=460800 -A uart=rx-data \
    --protocol-decoder-samplenum >"$out/ib.live.txt" 2>"$out/sigrok.err"
  check "sigrok-cli decodes the inter-board VCD (460800 8N1) exactly as committed" cmp -s "$caps/interboard_uart.sigrok.txt" "$out/ib.live.txt"
  sigrok-cli -i "$out/pride_uart.vcd" -P uart:rx=rx:baudrate=38400:parity=even -A uart=rx-data:rx-parity-err \
    --protocol-decoder-samplenum >"$out/pr.live.txt" 2>>"$out/sigrok.err"
  check "sigrok-cli decodes the Pride VCD (38400 8E1) exactly as committed, parity error included" \
    bash -c "cmp -s '$caps/pride_uart.sigrok.txt' '$out/pr.live.txt' && grep -q 'uart-1: Parity error' '$out/pr.live.txt'"
  sigrok-cli -i "$out/pride_uart.vcd" -P uart:rx=rx:baudrate=38400:parity=even -A uart=rx-data:rx-parity-err \
    --protocol-decoder-jsontrace >"$out/pr.live.json" 2>>"$out/sigrok.err"
  check "sigrok-cli's JSON trace of it is as committed" cmp -s "$caps/pride_uart.sigrok.json" "$out/pr.live.json"
  # sigrok-cli's full annotation output (every class, every bit) decodes to the same messages too
  sigrok-cli -i "$out/pride_uart.vcd" -P uart:rx=rx:baudrate=38400:parity=even -A uart >"$out/pr.all.txt" 2>>"$out/sigrok.err"
  "$saulctl" decode "$out/pr.all.txt" >"$out/pr.all" 2>"$out/pr.all.err"
  check "all of sigrok-cli's annotations (-A uart): same messages, bits and markers ignored" \
    bash -c "$(declare -f messages); cmp -s <(messages '$out/pr') <(messages '$out/pr.all') && grep -q '1 uart errors' '$out/pr.all.err'"
else
  skip "sigrok-cli decodes the VCDs as committed" "sigrok-cli not installed; scripts/setup.sh installs it"
fi

echo "$fails failed"
exit $((fails > 0))
