#!/usr/bin/env bash
# Writes the samples of the formats other tools write (captures/README.md), each from the first 40 frames of
# captures/robot_bus.log, by the tool that writes that format, not by saulctl:
#   robot_bus.blf        python-can's BLFWriter (zlib log containers), plus an error frame and a marker object
#   robot_bus.trc.zst    python-can's TRCWriter (PEAK TRC 2.1), zstd-compressed; python-can 4.1 puts the clock of the
#                        machine in $STARTTIME (a bug), so that line is set to the first frame's time here
#   robot_bus.csv        python-can's CSVWriter
#   robot_bus.gvret.csv  SavvyCAN's native CSV layout (its saveNativeCSVFile field order), written with awk
#   robot_bus.fd.asc     can-utils' log2asc -f: classic frames on CANFD lines
#   robot_bus.log.gz     gzip -n of the 40 candump lines
# Needs Debian's /usr/bin/python3 with python3-can, can-utils, gzip, zstd. Times are UTC (TZ=UTC for python-can).
set -euo pipefail
cd "$(dirname "$0")"
export TZ=UTC
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
head -n 40 robot_bus.log >"$tmp/head.log"

/usr/bin/python3 - "$tmp/head.log" "$tmp" <<'PY'
import can, sys
src, out = sys.argv[1], sys.argv[2]
msgs = list(can.LogReader(src))
for ext in ("blf", "trc", "csv"):
    w = can.Logger(f"{out}/robot_bus.{ext}")
    for m in msgs:
        w.on_message_received(m)
    if ext == "blf":  # a bus error and a global marker (an object type saulctl counts and skips)
        w.on_message_received(can.Message(timestamp=msgs[-1].timestamp + 0.001, is_error_frame=True, channel=0))
        w.log_event("end of the sample", msgs[-1].timestamp + 0.002)
    w.stop()
PY
cp "$tmp/robot_bus.blf" robot_bus.blf
cp "$tmp/robot_bus.csv" robot_bus.csv
# $STARTTIME: days since 1899-12-30 of the first frame, 14 decimals rounded up (a reader that truncates gets the
# first frame's microsecond back)
start=$(/usr/bin/python3 -c "
from decimal import Decimal, ROUND_CEILING
t = Decimal(open('$tmp/head.log').readline().split()[0][1:-1])
print((Decimal(25569) + t / 86400).quantize(Decimal('1e-14'), rounding=ROUND_CEILING))")
first=$(date -u -d "@$(head -n 1 "$tmp/head.log" | cut -d' ' -f1 | tr -d '()')" '+%Y-%m-%d %H:%M:%S.%6N')
sed "s/^;\$STARTTIME=.*/;\$STARTTIME=$start\r/; s|^;   $tmp/robot_bus.trc|;   robot_bus.trc|;
     s/^;   Start time: .*/;   Start time: $first\r/" "$tmp/robot_bus.trc" >"$tmp/fixed.trc"
zstd -q -f -19 "$tmp/fixed.trc" -o robot_bus.trc.zst
awk 'BEGIN { print "Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8" }
     /^\(/ { t = substr($1, 2, length($1) - 2); split(t, s, "."); split($3, p, "#")
             id = p[1]; n = length(p[2]) / 2; line = sprintf("%s%s,%08s,%s,Rx,0,%d,", s[1], s[2], id,
                                                              length(id) == 8 ? "true" : "false", n)
             gsub(/ /, "0", line)
             for (i = 0; i < 8; i++) line = line (i < n ? substr(p[2], 2 * i + 1, 2) : "00") ","
             print line }' "$tmp/head.log" >robot_bus.gvret.csv
log2asc -f -I "$tmp/head.log" can0 >robot_bus.fd.asc
gzip -n -9 -c "$tmp/head.log" >robot_bus.log.gz
echo "wrote robot_bus.blf robot_bus.trc.zst robot_bus.csv robot_bus.gvret.csv robot_bus.fd.asc robot_bus.log.gz"
