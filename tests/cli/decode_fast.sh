#!/usr/bin/env bash
# decode and stats on large candump files (issue 15), generated here and removed after:
# - a file with one 200 MB line: reported as corrupt at its line, the lines after it still decode, and the process
#   never holds the line (peak RSS far below 200 MB; the bound is loose for sanitizer builds);
# - stdin ('-') and a file give the same bytes; --format csv and --json the same as through the pcap reader
#   (another reader, the same emitter), and --json parses line by line;
# - a file above the two-thread threshold (--parallel-from 1) decodes to the same bytes as on
#   one thread; stats read ahead on a second thread gives the report of one, and so does decode of a pcapng;
# - a log through a pipe path (<(cat log), plain, gz, zst; a named pipe) gives the file's bytes and report, and
#   replay refuses it.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# Runs in its scratch directory: a saulctl that takes the '-' below for a file name (convert's OUT before it meant
# standard output) writes that file where it runs, and one was committed from the repository's root.
[[ $saulctl == */* ]] && saulctl=$(realpath "$saulctl")
set -- "$saulctl" "$(realpath "$2")"
cd "$out" || exit 1

python3 - "$out/long.log" <<'PY'
import sys
with open(sys.argv[1], "w") as f:
    f.write("(1700000000.000000) can0 300#E8030CFE\n(1700000000.100000) can0 300#")
    chunk = "A" * (1 << 20)
    for _ in range(200):
        f.write(chunk)
    f.write("\n(1700000000.200000) can0 400#06FFA4012C0101\n(1700000000.300000) can0 300#E8030CFE\n")
PY
# decode_long NAME FILE: decodes FILE into long.txt and long.err, exits 0, and (with GNU time) never holds the
# 200 MB line: peak RSS far below it; then the line's report and the three other frames.
decode_long() {
  local name=$1 file=$2
  if [[ -x /usr/bin/time ]]; then
    /usr/bin/time -f "%M" -o "$out/rss" "$saulctl" decode "$file" >"$out/long.txt" 2>"$out/long.err"
    check "$name: decode exits 0" test $? -eq 0
    rss=$(tail -1 "$out/rss")
    echo "     peak RSS ${rss} KiB"
    check "$name: peak RSS below 150 MiB" test "$rss" -lt 153600
  else
    "$saulctl" decode "$file" >"$out/long.txt" 2>"$out/long.err"
  fi
  check "$name: reported at its line" grep -q "${file##*/}:2:1: line longer than 65536 bytes (line skipped)" "$out/long.err"
  check "$name: the three other frames decode" test "$(wc -l <"$out/long.txt")" -eq 3
}
decode_long "a 200 MB line" "$out/long.log"
check "a 200 MB line: the summary counts it" grep -q "3 frames: 3 decoded.*; 1 corrupt lines" "$out/long.err"
"$saulctl" stats "$out/long.log" >"$out/stats.txt" 2>"$out/stats.err"
check "a 200 MB line: stats reports it too" grep -q "long.log:2:1: line longer than" "$out/stats.err"
# The same gzipped (0.2 MB), its text cut into blocks as it inflates: the line is cut short as it is read, never
# held.
gzip -1 "$out/long.log"
decode_long "a 200 MB line, gzipped" "$out/long.log.gz"
if [[ -x /usr/bin/time ]]; then
  /usr/bin/time -f "%M" -o "$out/rss" "$saulctl" stats "$out/long.log.gz" >"$out/stats.txt" 2>"$out/stats.err"
  echo "     stats: peak RSS $(tail -1 "$out/rss") KiB"
  check "a 200 MB line, gzipped: stats' peak RSS below 150 MiB" test "$(tail -1 "$out/rss")" -lt 153600
else
  "$saulctl" stats "$out/long.log.gz" >"$out/stats.txt" 2>"$out/stats.err"
fi
check "a 200 MB line, gzipped: stats reports it at its line" grep -q "long.log.gz:2:1: line longer than" "$out/stats.err"
check "a 200 MB line, gzipped: stats counts the three other frames" grep -q ": 3 frames from" "$out/stats.txt"
rm -f "$out/long.log" "$out/long.log.gz"

python3 "$2/bench/make_bus.py" 60000 "$out/bus.log" 2>/dev/null
frames=$(wc -l <"$out/bus.log")
printf '(1763800000.5) can0 30G#00\n' >>"$out/bus.log"
"$saulctl" convert "$out/bus.log" "$out/bus.pcap" >/dev/null 2>&1
for fmt in text csv jsonl; do
  "$saulctl" decode --format $fmt "$out/bus.log" >"$out/file.$fmt" 2>/dev/null
  "$saulctl" decode --format $fmt - <"$out/bus.log" >"$out/stdin.$fmt" 2>/dev/null
  check "$fmt: stdin and file give the same bytes" cmp -s "$out/file.$fmt" "$out/stdin.$fmt"
  "$saulctl" decode --parallel-from 1 --format $fmt "$out/bus.log" >"$out/two.$fmt" 2>"$out/two.err"
  check "$fmt: two threads give the bytes of one" cmp -s "$out/file.$fmt" "$out/two.$fmt"
  check "$fmt: two threads report the corrupt line at its line" grep -q "bus.log:$((frames + 1)):" "$out/two.err"
done
# Compressed logs in blocks on both cores as they inflate: the bytes of the plain file, the corrupt line at its
# line. (zstd only where its command is installed.)
gzip -1 -c "$out/bus.log" >"$out/bus.log.gz"
command -v zstd >/dev/null && zstd -q -c "$out/bus.log" >"$out/bus.log.zst"
for packed in "$out"/bus.log.gz "$out"/bus.log.zst; do
  [[ -f $packed ]] || { echo "SKIP $packed: no zstd command"; continue; }
  "$saulctl" decode "$packed" >"$out/packed.text" 2>"$out/packed.err"
  check "${packed##*.}: in blocks as it inflates, the bytes of the plain file" cmp -s "$out/file.text" "$out/packed.text"
  check "${packed##*.}: the corrupt line at its line" grep -q "${packed##*/}:$((frames + 1)):" "$out/packed.err"
  for json in "" --json; do  # stats counts it in blocks as it inflates too: the plain file's report but the name
    "$saulctl" stats $json "$out/bus.log" 2>"$out/plain.err" | sed "s|bus\.log|NAME|g" >"$out/plain$json.stats"
    "$saulctl" stats $json "$packed" 2>"$out/packed.err" | sed "s|${packed##*/}|NAME|g" >"$out/packed$json.stats"
    check "${packed##*.}: stats$json gives the plain file's report" cmp -s "$out/plain$json.stats" "$out/packed$json.stats"
    check "${packed##*.}: stats$json reports the corrupt line at its line" \
      grep -q "${packed##*/}:$((frames + 1)):" "$out/packed.err"
  done
done
# A log through a path that can be read only once (a process substitution, a named pipe): the look at its first
# bytes that tells the format must not cost them, and the text must not be opened a second time (that lost the
# 8 KiB after the first look, and refused a compressed log read this way as "not a capture"). Plain, gzip and zstd:
# the file's bytes and corrupt line for decode, the file's report for stats; replay, which must read twice, refuses.
"$saulctl" stats --json "$out/bus.log" 2>/dev/null | sed -E 's|"file":"[^"]*"|"file":"NAME"|' >"$out/file.stats"
for packed in "$out/bus.log" "$out/bus.log.gz" "$out/bus.log.zst"; do
  [[ -f $packed ]] || continue
  kind=${packed##*/}
  "$saulctl" decode <(cat "$packed") >"$out/piped.text" 2>"$out/piped.err"
  check "$kind through a pipe path: decode gives the file's bytes" cmp -s "$out/file.text" "$out/piped.text"
  check "$kind through a pipe path: the corrupt line at its line" grep -q ":$((frames + 1)):" "$out/piped.err"
  "$saulctl" stats --json <(cat "$packed") 2>/dev/null | sed -E 's|"file":"[^"]*"|"file":"NAME"|' >"$out/piped.stats"
  check "$kind through a pipe path: stats gives the file's report" cmp -s "$out/file.stats" "$out/piped.stats"
done
mkfifo "$out/fifo"
cat "$out/bus.log" >"$out/fifo" &
"$saulctl" decode "$out/fifo" >"$out/fifo.text" 2>/dev/null
wait
check "a named pipe: decode gives the file's bytes" cmp -s "$out/file.text" "$out/fifo.text"
# '-' is standard input for every verb that reads a capture (decode's own '-' above), and standard output for
# convert's OUT (with --format; BLF still seeks back to its header when that is a file).
for packed in "$out/bus.log" "$out/bus.log.gz"; do
  "$saulctl" stats --json - <"$packed" 2>/dev/null | sed -E 's|"file":"[^"]*"|"file":"NAME"|' >"$out/stdin.stats"
  check "stats - (${packed##*/} redirected): the file's report" cmp -s "$out/file.stats" "$out/stdin.stats"
  cat "$packed" | "$saulctl" stats --json - 2>/dev/null | sed -E 's|"file":"[^"]*"|"file":"NAME"|' >"$out/stdin.stats"
  check "stats - (${packed##*/} through a pipe): the file's report" cmp -s "$out/file.stats" "$out/stdin.stats"
done
cat "$out/bus.log" | "$saulctl" convert - - --format pcap 2>/dev/null >"$out/stdout.pcap"
check "convert - - --format pcap: the bytes of convert to a file" cmp -s "$out/bus.pcap" "$out/stdout.pcap"
"$saulctl" convert "$out/bus.log" "$out/file.blf" 2>/dev/null
"$saulctl" convert "$out/bus.log" - --format blf 2>/dev/null >"$out/stdout.blf"
check "convert to - --format blf redirected to a file: the bytes of convert to a file" \
  cmp -s "$out/file.blf" "$out/stdout.blf"
( cd "$out" && "$saulctl" convert bus.log - >/dev/null 2>"$out/convert.err" )
check "convert to - without --format: exit 1" test $? -eq 1
check "convert to - without --format: says to give it, and writes no file called -" \
  bash -c "grep -q 'give the format' '$out/convert.err' && ! test -e '$out/-'"
saulctl_status() { "$saulctl" "$@" >/dev/null 2>"$out/status.err"; echo $?; }
check "record -o -: refused as usage (exit 2) before opening the link, no file called -" \
  bash -c "test $(saulctl_status record slcan:/dev/null -o - --format blf) -eq 2 && ! test -e '$out/-' &&
           grep -q 'record writes files' '$out/status.err'"
"$saulctl" plot - -o "$out/stdin.csv" <"$out/bus.log" 2>/dev/null
check "plot - from a redirected file: writes the plot" test -s "$out/stdin.csv"
"$saulctl" plot <(cat "$out/bus.log") -o "$out/piped.csv" >/dev/null 2>"$out/plot.err"
check "plot of a pipe path: refused as usage (exit 2), nothing written" \
  bash -c "test $? -eq 2 && ! test -e '$out/piped.csv' && grep -q 'save it to a file' '$out/plot.err'"
"$saulctl" replay <(cat "$out/bus.log") --link slcan:/dev/null >/dev/null 2>"$out/replay.err"
check "replay of a pipe path: refused as usage (exit 2), nothing opened" test $? -eq 2
check "replay of a pipe path: says to save it to a file" grep -q "not a regular file (a pipe?).*save it to a file" \
  "$out/replay.err"
"$saulctl" decode --format csv "$out/bus.pcap" >"$out/pcap.csv" 2>/dev/null
check "csv: the pcap of the log decodes to the same lines but the interface" \
  cmp -s <(cut -d, -f1,3- "$out/file.csv") <(cut -d, -f1,3- "$out/pcap.csv")
check "jsonl: every line parses as JSON" python3 -c '
import json, sys
n = 0
for line in open(sys.argv[1]):
    json.loads(line)
    n += 1
assert n == int(sys.argv[2]), n' "$out/file.jsonl" "$frames"

# pcapng (a reader of its own, in batches through the same emitter): read ahead on a second thread or not, the
# bytes of the candump log's decode, the corrupt line of the log excepted (convert skips it).
"$saulctl" convert "$out/bus.log" "$out/bus.pcapng" >/dev/null 2>&1
head -n "$frames" "$out/file.text" >"$out/frames.text"
for ahead in 1 999999999999; do
  "$saulctl" decode --parallel-from $ahead "$out/bus.pcapng" >"$out/pcapng.$ahead" 2>/dev/null
  check "pcapng (read ahead from $ahead bytes): the bytes of the candump log" cmp -s "$out/frames.text" "$out/pcapng.$ahead"
done

# The checks above that two threads give one thread's bytes pass as well when --parallel-from is ignored: here the
# threads are counted (strace: clones of `saulctl VERB --parallel-from 1` above those of a size larger than the file;
# LeakSanitizer refuses to run under a tracer, so it is off here). Skipped where strace is missing or ptrace is not
# allowed.
if command -v strace >/dev/null && strace -f -o /dev/null true 2>/dev/null; then
  clones() {
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0" strace -f -e trace=clone,clone3 -o "$out/strace" \
      "$saulctl" "$@" >/dev/null 2>&1
    grep -c 'clone' "$out/strace"
  }
  # the one read path's ways: blocks of a file (candump, pcap), a reader read ahead (pcapng of one block, ASC
  # through the batch interface's default, stats --signals in order)
  "$saulctl" convert "$out/bus.log" "$out/bus.asc" >/dev/null 2>&1
  for verb in "decode $out/bus.log" "decode $out/bus.pcapng" "decode $out/bus.asc" \
      "stats $out/bus.log" "stats $out/bus.pcap" "stats --signals $out/bus.log"; do
    # shellcheck disable=SC2086
    few=$(clones ${verb% *} --parallel-from 999999999999 "${verb##* }") more=$(clones ${verb% *} --parallel-from 1 "${verb##* }")
    check "${verb% *} $(basename "${verb##* }") --parallel-from 1 starts a thread ($more clones, $few with one core)" test "$more" -gt "$few"
  done
else
  echo "SKIP the threads counted: strace is missing or may not trace here"
fi

# stats on both cores (--parallel-from 1; --block-size 64k: the file counted in ~40 blocks
# appended in order) gives one thread's report and the same corrupt lines, with a corrupt line in the middle, one
# at the end and a frame on a second interface; so does --signals (parsing on a second thread).
{
  head -n 30000 "$out/bus.log"
  printf '(1763800030.5) can1 300#E8030CFE\n(17638x) can0 300#00\n'
  tail -n +30001 "$out/bus.log"
} >"$out/mixed.log"
for json in "" --json; do
  "$saulctl" stats --parallel-from 999999999999 $json "$out/mixed.log" >"$out/one$json.stats" 2>"$out/one.err"
  "$saulctl" stats --parallel-from 1 --block-size 64k $json "$out/mixed.log" >"$out/ahead$json.stats" 2>"$out/ahead.err"
  check "stats$json: both cores give one thread's report" cmp -s "$out/one$json.stats" "$out/ahead$json.stats"
  check "stats$json: both cores report the same corrupt lines" cmp -s "$out/one.err" "$out/ahead.err"
  "$saulctl" stats --parallel-from 999999999999 --signals $json "$out/mixed.log" >"$out/one$json.signals" 2>/dev/null
  "$saulctl" stats --parallel-from 1 --signals $json "$out/mixed.log" >"$out/ahead$json.signals" 2>/dev/null
  check "stats --signals$json: read ahead gives one thread's report" cmp -s "$out/one$json.signals" "$out/ahead$json.signals"
done
# pcap and pcapng in blocks on both cores: one thread's report
for f in bus.pcap bus.pcapng; do
  "$saulctl" stats --parallel-from 999999999999 --json "$out/$f" >"$out/$f.one" 2>/dev/null
  "$saulctl" stats --parallel-from 1 --block-size 64k --json "$out/$f" >"$out/$f.blocks" 2>/dev/null
  check "stats of $f: blocks on both cores give one thread's report" cmp -s "$out/$f.one" "$out/$f.blocks"
done
check "stats: both corrupt lines reported at their lines" \
  test "$(grep -cE "mixed.log:(30002|$((frames + 3))):" "$out/ahead.err")" -eq 2
check "stats: every frame counted, the one on can1 too" grep -q "^$out/mixed.log: $((frames + 1)) frames" "$out/ahead.stats"
check "stats: can1 has its own load line" grep -q "bus load on can1 " "$out/ahead.stats"
# Standard input stays live (candump -L can0 | saulctl decode -): a line written to the pipe comes out decoded
# while the pipe is still open, not at its end.
check "stdin is live: a frame on an open pipe is decoded before the pipe ends" python3 - "$saulctl" <<'PY'
import select, subprocess, sys
p = subprocess.Popen([sys.argv[1], "decode", "-"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                     stderr=subprocess.DEVNULL)
p.stdin.write(b"(1763800000.000000) can0 300#E8030CFE\n")
p.stdin.flush()
ready, _, _ = select.select([p.stdout], [], [], 20)
line = p.stdout.readline() if ready else b""
p.stdin.close()
p.wait(timeout=20)
sys.exit(0 if b"velocity_cmd speed_mmps=1000 steer_mrad=-500" in line else 1)
PY
echo "$fails failed"
exit $((fails > 0))
