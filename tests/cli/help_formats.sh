#!/usr/bin/env bash
# The verbs' help names every format they read: each sample in captures/ (and a pcap, a pcapng and a PulseView CSV
# made here) is read by decode, and the name of its format, written out by hand below, is on decode's line of
# 'saulctl --help' and in 'decode --help' (replay's too; convert's for the CAN ones). The help once listed
# candump, pcap, pcapng, ASC and the serial ones for decode, which read BLF, TRC, CSV, GVRET and compressed files too.
set -uo pipefail
saulctl=$1 root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

"$saulctl" convert "$root/captures/robot_bus.log" "$out/bus.pcap" 2>/dev/null
"$saulctl" convert "$root/captures/robot_bus.log" "$out/bus.pcapng" 2>/dev/null
printf '"Sample","Time","Decoder","Ann Row","Ann Class","Value"\n' >"$out/pv.csv"
printf '"100","0.000010000","UART","RX data","RX data","AA"\n' >>"$out/pv.csv"
overview=$("$saulctl" --help | grep -E '^ +decode ')
decode_help=$("$saulctl" decode --help)
replay_help=$("$saulctl" replay --help)
convert_help=$("$saulctl" convert --help)
# FILE|NAME[|can]: decode reads FILE; NAME is in each help (convert's too when the third word is "can")
while IFS='|' read -r file name kind; do
  [[ $file == /* ]] || file=$root/captures/$file
  "$saulctl" decode "$file" >/dev/null 2>&1
  check "decode reads ${file##*/}" test $? -eq 0
  check "... and '$name' is on decode's line of saulctl --help, in decode --help and replay --help" \
    bash -c 'grep -qF -- "$1" <<<"$2" && grep -qF -- "$1" <<<"$3" && grep -qF -- "$1" <<<"$4"' _ "$name" \
    "$overview" "$decode_help" "$replay_help"
  [[ ${kind:-} == can ]] && check "... and in convert --help" grep -qF -- "$name" <<<"$convert_help"
done <<EOF2
robot_bus.log|candump|can
$out/bus.pcap|pcap|can
$out/bus.pcapng|pcapng|can
robot_bus.fd.asc|ASC|can
robot_bus.blf|BLF|can
robot_bus.trc.zst|TRC|can
robot_bus.trc.zst|.zst|can
robot_bus.csv|CSV|can
robot_bus.gvret.csv|GVRET|can
robot_bus.log.gz|.gz|can
pride_uart.serial|serial
pride_uart.sigrok.txt|sigrok
pride_uart.sigrok.json|sigrok JSON
$out/pv.csv|PulseView
EOF2
echo "$fails failed"
exit $((fails > 0))
