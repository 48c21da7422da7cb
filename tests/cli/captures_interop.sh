#!/usr/bin/env bash
# Capture formats against the tools people open them with: tshark (pcap, pcapng), python-can (ASC and candump
# log), can-utils log2asc/asc2log (ASC); plus saulctl convert/decode round trips that need no tool.
# Expected values are taken from captures/robot_bus.log with awk, never from saulctl. A check whose tool is
# missing is SKIPPED with the reason, not failed; scripts/setup.sh installs all three tools.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
skip() { echo "SKIP $1 ($2)"; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
log=$root/captures/robot_bus.log

# --- expected values, straight from the candump text -------------------------------------------------------
# "id_decimal<TAB>extended<TAB>length<TAB>data" (tshark's -e can.id -e can.flags.xtd -e can.len -e data.data)
awk '
  function hex(s,   i, v) { v = 0; s = tolower(s); for (i = 1; i <= length(s); i++) v = v * 16 + index("0123456789abcdef", substr(s, i, 1)) - 1; return v }
  /^\(/ { split($3, p, "#"); printf "%d\t%d\t%d\t%s\n", hex(p[1]), length(p[1]) == 8, length(p[2]) / 2, tolower(p[2]) }
' "$log" >"$out/expect.tshark"
# "id_hex extended length data", lower case, as the python snippet below prints python-can messages
awk '/^\(/ { split($3, p, "#"); id = tolower(p[1]); sub(/^0+/, "", id); if (id == "") id = "0"
             print id, length(p[1]) == 8, length(p[2]) / 2, tolower(p[2]) }' "$log" >"$out/expect.pycan"
# "ID#DATA microseconds-since-first-frame" of any candump log (the -x direction column is ignored)
rel() {
  awk '/^\(/ { t = substr($1, 2, length($1) - 2); split(t, s, ".")
               if (!n++) { s0 = s[1]; u0 = s[2] }
               printf "%s %d\n", toupper($3), (s[1] - s0) * 1000000 + (s[2] - u0) }' "$1"
}
rel "$log" >"$out/expect.rel"
frames=$(grep -c '^(' "$log")

# --- round trips through saulctl alone ---------------------------------------------------------------------
for fmt in pcap pcapng asc log; do
  "$saulctl" convert "$log" "$out/bus.$fmt" 2>"$out/convert.$fmt.err"
  check "convert to .$fmt exits 0 and reports $frames frames" \
    bash -c "test $? -eq 0 && grep -q ' $frames frames from ' '$out/convert.$fmt.err'"
  "$saulctl" convert "$out/bus.$fmt" "$out/back.$fmt.log" 2>/dev/null
  check ".$fmt converted back to candump is byte-identical to the sample" cmp -s "$log" "$out/back.$fmt.log"
done
"$saulctl" decode "$log" >"$out/decoded.log" 2>/dev/null
for fmt in pcap pcapng asc; do
  cp "$out/bus.$fmt" "$out/disguised.$fmt.log"  # a misleading extension: the content decides
  "$saulctl" decode "$out/disguised.$fmt.log" >"$out/decoded.$fmt" 2>/dev/null
  check "decode reads .$fmt by content and prints what it prints for the candump sample" \
    cmp -s "$out/decoded.log" "$out/decoded.$fmt"
done
check "the pcap has a 24-byte header and 32-byte records" test "$(stat -c %s "$out/bus.pcap")" -eq $((24 + 32 * frames))
check "the ASC ends with End TriggerBlock" bash -c "tail -n 1 '$out/bus.asc' | grep -qx 'End TriggerBlock'"
"$saulctl" convert "$log" "$out/bus.unknown" 2>"$out/unknown.err"
check "convert to an unknown extension without --format exits 1 and says why" \
  bash -c "test $? -eq 1 && grep -q 'cannot tell which format' '$out/unknown.err'"
"$saulctl" convert "$log" "$out/bus.unknown" --format pcapng 2>/dev/null
check "--format overrides the extension" cmp -s "$out/bus.unknown" "$out/bus.pcapng"
printf '(1.000000) vcan0 123#11\n(2.000000) can1 20000080#0000000000000000\n(3.0 can0 1#\n' >"$out/mixed.log"
"$saulctl" convert "$out/mixed.log" "$out/mixed.asc" 2>"$out/mixed.err"
check "convert reports a corrupt line with its position and goes on" \
  grep -q "mixed.log:3:1: timestamp has no closing ')' (line skipped)" "$out/mixed.err"
check "convert to ASC says what the format drops" grep -q 'note: asc keeps no interface names: vcan0 reads back as can0' "$out/mixed.err"

# --- tshark ------------------------------------------------------------------------------------------------
if command -v tshark >/dev/null; then
  for fmt in pcap pcapng; do
    tshark -r "$out/bus.$fmt" -T fields -e can.id -e can.flags.xtd -e can.len -e data.data >"$out/tshark.$fmt" 2>/dev/null
    check "tshark reads our .$fmt: ids, extended flags, lengths and data of all $frames frames" \
      cmp -s "$out/expect.tshark" "$out/tshark.$fmt"
    check "tshark shows the first frame of our .$fmt at 1763800000.000900" \
      bash -c "tshark -r '$out/bus.$fmt' -c 1 -T fields -e frame.time_epoch 2>/dev/null | grep -qx '1763800000.000900000'"
  done
  check "tshark sees interface can0 in our .pcapng" \
    bash -c "tshark -r '$out/bus.pcapng' -T fields -e frame.interface_name 2>/dev/null | sort -u | grep -qx can0"
else
  skip "tshark reads our .pcap and .pcapng" "tshark not installed; scripts/setup.sh installs it"
fi

# --- python-can --------------------------------------------------------------------------------------------
if [[ -x /usr/bin/python3 ]] && /usr/bin/python3 -c 'import can' 2>/dev/null; then
  pycan_dump() {  # pycan_dump FILE: python-can's LogReader, one line per message
    /usr/bin/python3 - "$1" <<'EOF'
import sys, can
for m in can.LogReader(sys.argv[1]):
    print(f"{m.arbitration_id:x} {int(m.is_extended_id)} {m.dlc} {m.data.hex()}")
EOF
  }
  for fmt in asc log; do
    pycan_dump "$out/bus.$fmt" >"$out/pycan.$fmt" 2>"$out/pycan.$fmt.err"
    check "python-can's LogReader reads our .$fmt: same ids, lengths and data" cmp -s "$out/expect.pycan" "$out/pycan.$fmt"
  done
  # and the other way: python-can writes an ASC, we read it
  TZ=UTC /usr/bin/python3 - "$log" "$out/pycan_written.asc" <<'EOF'
import sys, can
with can.ASCWriter(sys.argv[2]) as w:
    for m in can.LogReader(sys.argv[1]):
        w.on_message_received(m)
EOF
  "$saulctl" convert "$out/pycan_written.asc" "$out/pycan_written.log" 2>"$out/pycan_written.err"
  check "we read python-can's ASC without a corrupt line" grep -q ' 0 corrupt records' "$out/pycan_written.err"
  rel "$out/pycan_written.log" >"$out/pycan_written.rel"
  # python-can formats float seconds: allow 1 us of rounding in relative times
  check "python-can's ASC gives the same ids/data and relative times (within 1 us)" \
    awk 'NR == FNR { a[FNR] = $0; n = FNR; next }
         { split(a[FNR], e, " "); if (e[1] != $1 || e[2] - $2 > 1 || $2 - e[2] > 1) bad++; m = FNR }
         END { exit !(m == n && !bad) }' "$out/expect.rel" "$out/pycan_written.rel"
else
  skip "python-can reads our .asc and .log" "python3-can not importable by /usr/bin/python3; scripts/setup.sh installs it"
fi

# --- can-utils log2asc / asc2log ---------------------------------------------------------------------------
if command -v log2asc >/dev/null; then
  log2asc -I "$log" can0 >"$out/log2asc.asc"
  "$saulctl" convert "$out/log2asc.asc" "$out/log2asc.log" 2>"$out/log2asc.err"
  check "we read log2asc's ASC without a corrupt line" grep -q " $frames frames from .* 0 corrupt records" "$out/log2asc.err"
  rel "$out/log2asc.log" >"$out/log2asc.rel"
  check "log2asc's ASC gives the same ids, data and relative times" cmp -s "$out/expect.rel" "$out/log2asc.rel"
  # log2asc's date is the first frame's whole second: the absolute times lose the sub-second of the first frame
  check "log2asc's date line anchors the times (first frame at 1763800000.000000)" \
    bash -c "head -n 1 '$out/log2asc.log' | grep -q '^(1763800000.000000) can0 400#'"
else
  skip "our ASC reader reads log2asc's output" "log2asc (can-utils) not installed; scripts/setup.sh installs it"
fi
if command -v asc2log >/dev/null; then
  # asc2log's absolute times are unreliable (it needs an am/pm date and a locale): ids, data, relative times only
  asc2log -I "$out/bus.asc" -O "$out/asc2log.log" 2>/dev/null
  rel "$out/asc2log.log" >"$out/asc2log.rel"
  check "asc2log reads our ASC: same ids, data and relative times" cmp -s "$out/expect.rel" "$out/asc2log.rel"
else
  skip "asc2log reads our ASC" "asc2log (can-utils) not installed; scripts/setup.sh installs it"
fi

echo "$fails failed"
exit $((fails > 0))
