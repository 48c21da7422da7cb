#!/usr/bin/env bash
# MCAP (issue 37) against Foxglove's own library: every file saulctl writes is read by @mcap/core's indexed and
# streaming readers, each message validated against its channel's JSON Schema (ajv), counts per channel equal to
# saulctl stats, values equal to decode --json (tests/npm/mcap_check.mjs); a file written by @mcap/core's writer
# reads back in saulctl frame for frame; a file cut at every 4 KiB boundary reads, in saulctl and in the streaming
# reader, exactly the complete chunks before the cut; damaged files are reported with their byte offset.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
npm_dir=$root/tests/npm
if [[ ! -d $npm_dir/node_modules/@mcap/core || ! -d $npm_dir/node_modules/ajv ]]; then
  echo "FAIL @mcap/core or ajv missing in tests/npm (run scripts/setup.sh)"
  exit 1
fi
# --single-threaded: Node 20's process.exit deadlocks now and then (about 1 run in 8 here) when a V8 background
# thread compiling the decompressors' WebAssembly waits for a garbage collection while the main thread joins it.
node_check() { timeout 120 node --single-threaded "$npm_dir/mcap_check.mjs" "$@"; }  # a hang fails the check
verify() { node_check verify "$@" >/dev/null; }
frames_of() { "$saulctl" decode --json "$1" 2>/dev/null | jq -c '[.frame, .interface]'; }

# 1. Every input format (and every chunk compression) to MCAP, checked by the independent reader.
for src in robot_bus.log robot_bus.blf robot_bus.csv robot_bus.trc.zst robot_bus.log.gz glitches.log; do
  "$saulctl" decode --json "$root/captures/$src" >"$out/d.jsonl" 2>/dev/null
  "$saulctl" stats --json "$root/captures/$src" >"$out/s.json" 2>/dev/null
  for c in zstd lz4 none; do
    "$saulctl" convert --compression "$c" "$root/captures/$src" "$out/r.mcap" 2>"$out/e"
    check "convert $src (--compression $c): @mcap/core reads it, schemas, counts, values" \
      verify "$out/r.mcap" "$out/d.jsonl" "$out/s.json"
  done
  check "decode of $src's MCAP = decode of $src (frames, interfaces)" \
    cmp -s <(frames_of "$root/captures/$src") <(frames_of "$out/r.mcap")
done
# 1a. Converted in blocks on both cores (what a file of 4 MiB or more gets; here forced with blocks of 256 bytes): each
# block's chunks filled and compressed apart, written in file order, the channels the same ids and records. The
# same messages and corrupt-record reports as frame by frame; several chunks (the block path ran).
"$saulctl" convert "$root/captures/robot_bus.log" "$out/rb.pcap" 2>/dev/null
"$saulctl" convert "$root/captures/robot_bus.log" "$out/rb.pcapng" 2>/dev/null
for path in "$root"/captures/{robot_bus.log,robot_bus.log.gz,glitches.log} "$out"/rb.{pcap,pcapng}; do
  src=$(basename "$path")
  "$saulctl" decode --json "$path" >"$out/d.jsonl" 2>/dev/null
  "$saulctl" stats --json "$path" >"$out/s.json" 2>/dev/null
  "$saulctl" convert "$path" "$out/one.mcap" 2>"$out/e1"
  "$saulctl" convert --parallel-from 1 --block-size 256 "$path" "$out/blocks.mcap" 2>"$out/e2"
  check "convert $src in blocks of 256 bytes: @mcap/core reads it, schemas, counts, values" \
    verify "$out/blocks.mcap" "$out/d.jsonl" "$out/s.json"
  check "convert $src in blocks: the same frames and corrupt-record reports as frame by frame, in more chunks" \
    bash -c 'cmp -s "$0" "$1" && cmp -s <(sed "s/one.mcap/X/" "$2") <(sed "s/blocks.mcap/X/" "$3") &&
      test "$($4 chunks "$5" | wc -l)" -gt "$($4 chunks "$6" | wc -l)"' \
    <(frames_of "$out/one.mcap") <(frames_of "$out/blocks.mcap") "$out/e1" "$out/e2" \
    "timeout 120 node --single-threaded $npm_dir/mcap_check.mjs" "$out/blocks.mcap" "$out/one.mcap"
done
"$saulctl" convert "$root/captures/robot_bus.log" "$out/run.mcap" 2>/dev/null
topics=$(node_check verify "$out/run.mcap" <("$saulctl" decode --json "$root/captures/robot_bus.log" 2>/dev/null) \
  <("$saulctl" stats --json "$root/captures/robot_bus.log" 2>/dev/null))
check "robot_bus.log: one channel per message kind (/saul/telemetry_a, /vesc/68/status_1, ...)" \
  bash -c '[[ $0 == *\"/saul/telemetry_a\":30* && $0 == *\"/vesc/68/status_1\":30* && $0 == *\"/can/frames\":452* ]]' "$topics"
"$saulctl" convert --zstd-level -2 "$root/captures/robot_bus.log" "$out/fast.mcap" 2>/dev/null
"$saulctl" convert --zstd-level 1 "$root/captures/robot_bus.log" "$out/l1.mcap" 2>/dev/null
check "convert's chunks are zstd at level -2 by default (the same bytes as --zstd-level -2, not level 1's)" \
  bash -c 'cmp -s "$0" "$1" && ! cmp -s "$0" "$2"' "$out/run.mcap" "$out/fast.mcap" "$out/l1.mcap"
"$saulctl" convert "$root/captures/robot_bus.log" "$out/f.x" --format mcap 2>/dev/null
check "--format mcap whatever the name" cmp -s <(frames_of "$out/f.x") <(frames_of "$root/captures/robot_bus.log")
check "stats reads MCAP: the same counts as from the log" \
  cmp -s <("$saulctl" stats --json "$out/run.mcap" | jq -c '.ids') <("$saulctl" stats --json "$root/captures/robot_bus.log" | jq -c '.ids')

# 1b. A loop trace (saulctl tune record) to MCAP: its records on /saul/loop_trace, as decode --json prints them.
"$saulctl" tune record --sim --seed 1 --duration 2s -o "$out/t.trace" >/dev/null 2>&1
"$saulctl" decode --json "$out/t.trace" >"$out/t.jsonl" 2>/dev/null
for c in zstd lz4 none; do
  "$saulctl" convert --compression "$c" "$out/t.trace" "$out/t.mcap" 2>/dev/null
  check "convert run.trace (--compression $c): /saul/loop_trace = decode --json's $(wc -l <"$out/t.jsonl") records" \
    test "$(node_check trace "$out/t.mcap" "$out/t.jsonl")" = "$(wc -l <"$out/t.jsonl")" -a -s "$out/t.jsonl"
done
# A corrupt record (the middle byte of the file flipped): reported as for CSV, the rest converted.
python3 -c "import sys; d=bytearray(open(sys.argv[1],'rb').read()); d[len(d)//2]^=0xFF; open(sys.argv[2],'wb').write(d)" \
  "$out/t.trace" "$out/bad.trace"
"$saulctl" decode --json "$out/bad.trace" >"$out/t.jsonl" 2>/dev/null
"$saulctl" convert "$out/bad.trace" "$out/t.mcap" 2>"$out/e"
check "convert of a trace with a corrupt record: reported with its byte, the rest on /saul/loop_trace" \
  bash -c 'grep -q "corrupt record at byte" "$0" && test "$(timeout 120 node --single-threaded "$1" trace "$2" "$3")" = "$(wc -l <"$3")"' \
  "$out/e" "$npm_dir/mcap_check.mjs" "$out/t.mcap" "$out/t.jsonl"

# 1c. Serial byte captures to MCAP: each link's decoded messages on /serial/<protocol>/<message>, as decode --json
# prints them (value, link, log time = its time), the chunks on /serial/bytes, a Metadata record per link; decoder
# counters and corrupt lines reported as decode reports them. sigrok exports in sample numbers at 10 MHz carry
# times decode prints to the microsecond: their log times are checked to within 1 us.
serial_check() {  # serial_check NAME TOLERANCE_NS COMPRESSION ARGS...: the MCAP of `convert ARGS` against `decode ARGS`
  local name=$1 tolerance=$2 compression=$3; shift 3
  "$saulctl" decode --json "$@" >"$out/s.jsonl" 2>"$out/de"
  "$saulctl" convert --compression "$compression" "$@" "$out/s.mcap" 2>"$out/ce"
  check "convert $name: @mcap/core reads it, schemas, each message = decode --json's ($(wc -l <"$out/s.jsonl"))" \
    bash -c 'timeout 120 node --single-threaded "$0" serial "$1" "$2" "$3" >"$4" && test -s "$2"' \
    "$npm_dir/mcap_check.mjs" "$out/s.mcap" "$out/s.jsonl" "$tolerance" "$out/topics"
  check "convert $name: each link's decoder counters reported as decode reports them" \
    cmp -s <(grep -E '\((interboard|crsf|pride|raw)' "$out/de" | sed 's/^saulctl decode/saulctl convert/') \
           <(grep -E '\((interboard|crsf|pride|raw)' "$out/ce")
}
for c in zstd lz4 none; do
  serial_check "interboard_uart.serial (--compression $c)" 0 "$c" "$root/captures/interboard_uart.serial"
done
check "interboard_uart.serial: a channel per message kind, every chunk on /serial/bytes" \
  bash -c '[[ $(cat "$0") == *\"/serial/interboard/state\":1[,}]* && $(cat "$0") == *\"/serial/bytes\":$1,* ]]' \
  "$out/topics" "$(grep -c '^(' "$root/captures/interboard_uart.serial")"
serial_check pride_uart.serial 0 zstd "$root/captures/pride_uart.serial"
serial_check "interboard_uart.sigrok.txt (sigrok-cli, 10 MHz)" 999 lz4 --samplerate 10M "$root/captures/interboard_uart.sigrok.txt"
serial_check "pride_uart.sigrok.txt (sigrok-cli, 1 MHz)" 999 none --protocol pride --samplerate 1M "$root/captures/pride_uart.sigrok.txt"
serial_check "pride_uart.sigrok.json (sigrok-cli JSON trace)" 0 zstd --protocol pride "$root/captures/pride_uart.sigrok.json"
# Four links in one log: two inter-board links (the second gets /serial/interboard_2/...), Pride, and CRSF with
# protocols.md's test frames (T1 RC channels, T3 link statistics, T5 attitude, a 0x32 command frame that does not
# decode, on /serial/crsf/undecoded, T8 device ping), plus a corrupt line.
{
  cat "$root/captures/interboard_uart.serial"
  sed 's#/dev/ttyUSB0#/dev/ttyUSB2#' "$root/captures/interboard_uart.serial"
  cat "$root/captures/pride_uart.serial"
  crsf="serial:/dev/ttyACM0@420000:8N1 crsf"
  echo "(1763800000.000100) $crsf C81816E0031FF8C0073EF0810F7CE0031FF8C0073EF0810F7CAD"
  echo "(1763800000.002150) $crsf C80C143C3E640900040337620895"
  echo "(1763800000.004000) $crsf C8081E03E8F8303D5C0AC80C32C8EC0A7001001E84802272"
  echo "(1763800000.006001) $crsf C8042800EA54"
  echo "(1763800000.0070 $crsf C8"
} >"$out/multi.serial"
serial_check "four links in one serial log" 0 zstd "$out/multi.serial"
for topic in /serial/interboard/state /serial/interboard_2/state /serial/pride/vcu_command /serial/crsf/rc_channels \
  /serial/crsf/link_statistics /serial/crsf/undecoded; do
  check "four links: $topic" grep -q "\"$topic\":" "$out/topics"
done
check "four links: the corrupt line reported with its line and column, as decode does" \
  bash -c 'grep -q "1 corrupt lines skipped" "$0" && grep -q "multi.serial:[0-9]*:[0-9]*: .*(line skipped)" "$0" &&
           cmp -s <(grep "(line skipped)" "$1" | sed "s/^saulctl decode/saulctl convert/") <(grep "(line skipped)" "$0")' \
  "$out/ce" "$out/de"
check "a serial capture to a CAN format: refused, exit 1, no file" \
  bash -c '! "$0" convert "$1" "$2" 2>/dev/null && test ! -e "$2"' "$saulctl" "$out/multi.serial" "$out/multi.log"

# 2. A file written by @mcap/core's McapWriter (frames in our schema, plus a channel saulctl must pass over).
"$saulctl" decode --json "$root/captures/robot_bus.log" >"$out/d.jsonl" 2>/dev/null
node_check write "$out/theirs.mcap" "$out/d.jsonl"
check "@mcap/core's writer: saulctl decode reads it frame for frame" \
  cmp -s <(frames_of "$out/theirs.mcap") <(frames_of "$root/captures/robot_bus.log")
check "@mcap/core's writer: the same timestamps" \
  cmp -s <("$saulctl" decode "$out/theirs.mcap" 2>/dev/null) <("$saulctl" decode "$root/captures/robot_bus.log" 2>/dev/null)

# 3. Live: record -o x.mcap from the simulated robot. Ctrl-C writes the summary (checked like the converted
# files); kill -9 leaves a file that reads up to its last closed chunk, in saulctl as in @mcap/core. The simulator runs
# at 3x real time: its bus fills the 60 kB each recording waits for three times sooner.
"$saulctl" sim --quiet --speed 3 --paths-file "$out/sim.paths" --for 360s >"$out/sim.out" 2>&1 &
sim=$!
wait_for() {  # wait_for SECONDS COMMAND...: polls a condition (not a fixed sleep), false on timeout
  local until=$((SECONDS + $1)); shift
  until "$@"; do ((SECONDS < until)) || return 1; sleep 0.1; done
}
wait_for 20 test -s "$out/sim.paths"
can=$(sed -n 's/^can=//p' "$out/sim.paths")
size_over() { [[ -f $1 && $(stat -c %s "$1") -gt $2 ]]; }
"$saulctl" record "slcan:$can" -o "$out/rec.mcap" -q 2>"$out/rec.err" &
rec=$!
wait_for 30 size_over "$out/rec.mcap" 60000
kill -INT "$rec"
wait "$rec"
check "record -o x.mcap, Ctrl-C: exit 0" test $? = 0
"$saulctl" decode --json "$out/rec.mcap" >"$out/d.jsonl" 2>/dev/null
"$saulctl" stats --json "$out/rec.mcap" >"$out/s.json" 2>/dev/null
check "record -o x.mcap, Ctrl-C: @mcap/core reads it whole (summary, indexes), schemas, counts, values" \
  verify "$out/rec.mcap" "$out/d.jsonl" "$out/s.json"
"$saulctl" record "slcan:$can" -o "$out/killed.mcap" -q 2>/dev/null &
rec=$!
wait_for 30 size_over "$out/killed.mcap" 60000
kill -9 "$rec"
wait "$rec" 2>/dev/null
ours=$("$saulctl" decode "$out/killed.mcap" 2>"$out/e" | wc -l)
theirs=$(node_check stream "$out/killed.mcap" | jq .frames)
check "record killed (kill -9): saulctl and @mcap/core's streaming reader read the same $ours frames (> 100)" \
  test "$ours" = "$theirs" -a "$ours" -gt 100
check "record killed: decode says the file ends without its footer" grep -q "ends without its footer" "$out/e"
kill "$sim" 2>/dev/null
wait "$sim" 2>/dev/null

# 4. The recording cut at every 4 KiB boundary: both read exactly the frames of the chunks complete before the cut.
node_check chunks "$out/rec.mcap" >"$out/chunks"
size=$(stat -c %s "$out/rec.mcap")
node_check stream_cuts "$out/rec.mcap" 4096 >"$out/theirs_cut"  # the streaming reader on every cut, one process
check "the streaming reader read every cut" test "$(wc -l <"$out/theirs_cut")" = "$(((size - 1) / 4096))"
cut_fails=0
for ((at = 4096; at < size; at += 4096)); do
  head -c "$at" "$out/rec.mcap" >"$out/part.mcap"
  want=$(awk -v at="$at" '$1 <= at { n += $2 } END { print n + 0 }' "$out/chunks")
  ours=$("$saulctl" decode "$out/part.mcap" 2>/dev/null | wc -l)
  theirs=$(awk -v at="$at" '$1 == at { print $2 }' "$out/theirs_cut")
  if [[ $ours != "$want" || $theirs != "$want" ]]; then
    echo "  cut at $at: saulctl $ours, @mcap/core $theirs, complete chunks hold $want"
    cut_fails=$((cut_fails + 1))
  fi
done
check "the recording cut at every 4 KiB of $size bytes: saulctl and the streaming reader read the complete chunks" \
  test "$cut_fails" = 0

# 5. Damaged files: reported with the byte offset, the rest read. With chunks closed at 1 MiB of records, the log
# 15 times over (1.6 MB of records) makes two.
for _ in {1..15}; do cat "$root/captures/robot_bus.log"; done >"$out/15.log"
"$saulctl" convert "$out/15.log" "$out/cut.mcap" --compression none --chunk-size 1M 2>/dev/null
node_check chunks "$out/cut.mcap" >"$out/chunks"
first_chunk_end=$(head -1 "$out/chunks" | cut -d' ' -f1)
first_chunk_frames=$(head -1 "$out/chunks" | cut -d' ' -f2)
total=$(awk '{ n += $2 } END { print n }' "$out/chunks")
check "convert of 1.6 MB of records in 1 MiB chunks: two chunks" test "$(wc -l <"$out/chunks")" = 2
"$saulctl" convert "$out/15.log" "$out/small.mcap" --chunk-size 1K 2>"$out/small.err"
check "--chunk-size under 4K: a usage error (exit 2) naming the option" \
  bash -c 'test "$0" = 2 && grep -q -- "--chunk-size" "$1"' "$?" "$out/small.err"
head -c "$((first_chunk_end - 1000))" "$out/cut.mcap" >"$out/part.mcap"  # inside the first chunk
check "a cut file: decode says where it ends" \
  bash -c '"$0" decode "$1" 2>&1 >/dev/null | grep -Eq "byte [0-9]+: a record \(opcode 0x06\) of [0-9]+ bytes is longer than the rest of the file \([0-9]+ bytes\): the file is cut short"' "$saulctl" "$out/part.mcap"
# A byte of the first chunk's records flipped (uncompressed, so only its CRC can tell).
python3 - "$out/cut.mcap" "$out/crc.mcap" "$first_chunk_end" <<'EOF'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
data[int(sys.argv[3]) - 100] ^= 0x01
open(sys.argv[2], "wb").write(data)
EOF
"$saulctl" decode "$out/crc.mcap" >"$out/o" 2>"$out/e"
check "a flipped byte in a chunk: 'byte N: chunk: CRC-32 ... does not match', the other chunks read" \
  bash -c 'grep -Eq "crc.mcap: byte [0-9]+: chunk: CRC-32 of its records is [0-9A-F]{8}, the chunk says" "$0" &&
           test "$(wc -l <"$1")" = "$2"' "$out/e" "$out/o" "$((total - first_chunk_frames))"
python3 -c "import sys; d=open(sys.argv[1],'rb').read(); open(sys.argv[2],'wb').write(b'\x89MCAQ0\r\n'+d[8:])" \
  "$out/cut.mcap" "$out/badmagic.mcap"
"$saulctl" decode --input-format mcap "$out/badmagic.mcap" >/dev/null 2>"$out/e"
check "wrong magic (forced as mcap): refused at byte 0, exit 1" \
  bash -c 'grep -q "byte 0: not an MCAP file" "$0"' "$out/e"
# A record whose length is larger than the file: reported, with the frames before it.
python3 - "$out/cut.mcap" "$out/long.mcap" "$first_chunk_end" <<'EOF'
import struct, sys
data = bytearray(open(sys.argv[1], "rb").read())
at = int(sys.argv[3])
while data[at] == 0x07:  # past the first chunk's message indexes, to the second chunk
    at += 9 + struct.unpack_from("<Q", data, at + 1)[0]
assert data[at] == 0x06, data[at]
struct.pack_into("<Q", data, at + 1, 1 << 40)
open(sys.argv[2], "wb").write(data)
EOF
"$saulctl" decode "$out/long.mcap" >"$out/o" 2>"$out/e"
check "a record longer than the file: 'byte N: ... longer than the rest of the file', the chunk before read" \
  bash -c 'grep -Eq "byte [0-9]+: a record \(opcode 0x06\) of 1099511627776 bytes is longer than the rest" "$0" &&
           test "$(wc -l <"$1")" = "$2"' "$out/e" "$out/o" "$first_chunk_frames"

echo "$fails failed"
exit $((fails > 0))
