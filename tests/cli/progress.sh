#!/usr/bin/env bash
# Progress lines of decode, stats and convert on long files: drawn on stderr in place (\r ... erase to end of line),
# only on a terminal or with SAUL_PROGRESS=1 (forced here: a test has no terminal), never mixed into stdout, and
# cleared at the end; off without a terminal.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# 20 000 frames (progress is looked at every 4096 records), one corrupt line in the middle.
awk 'BEGIN { for (i = 0; i < 20000; i++) { printf "(%d.%06d) can0 300#E8030CFE\n", 1700000000 + int(i / 1000), (i % 1000) * 1000;
             if (i == 10000) print "(1700000010.500000) can0 30G#00" } }' >"$out/big.log"

SAUL_PROGRESS=1 "$saulctl" decode "$out/big.log" >"$out/forced.txt" 2>"$out/forced.err"
check "decode with progress exits 0" test $? -eq 0
"$saulctl" decode "$out/big.log" >"$out/plain.txt" 2>"$out/plain.err"
check "stdout is the same with and without progress" cmp -s "$out/forced.txt" "$out/plain.txt"
check "progress lines are drawn in place: \\r, verb, share of the file, records" \
  grep -qaP '\rdecode: \d+% of [0-9.]+ MB, \d+ records, [0-9.]+ s\x1b\[K' "$out/forced.err"
check "the progress line is cleared before a corrupt line is reported, which ends with its own newline" \
  grep -qaP '\r\x1b\[Ksaulctl decode: .*big.log:10002:.*id is not hexadecimal \(line skipped\)$' "$out/forced.err"
check "the line is cleared before the summary" grep -qaP '\r\x1b\[Ksaulctl decode: 20000 frames' "$out/forced.err"
check "without a terminal (and SAUL_PROGRESS unset) nothing is drawn" bash -c "! grep -qa \$'\\r' '$out/plain.err'"
SAUL_PROGRESS=1 "$saulctl" stats "$out/big.log" >"$out/stats.txt" 2>"$out/stats.err"
check "stats draws its progress too" grep -qaP '\rstats: \d+% of' "$out/stats.err"
SAUL_PROGRESS=1 "$saulctl" convert "$out/big.log" "$out/big.pcapng" >/dev/null 2>"$out/conv.err"
check "convert draws its progress too" grep -qaP '\rconvert: \d+% of' "$out/conv.err"
SAUL_PROGRESS=0 "$saulctl" decode "$out/big.log" >/dev/null 2>"$out/off.err"
check "SAUL_PROGRESS=0 turns it off" bash -c "! grep -qa \$'\\r' '$out/off.err'"
echo "$fails failed"
exit $((fails > 0))
