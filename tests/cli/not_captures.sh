#!/usr/bin/env bash
# Files that are not captures are refused, named, with what they look like (issue 14): random bytes named .log,
# candump's default output (without -L) in a file or on standard input, a directory. Each input is made here.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# 2000 bytes of a fixed pseudo-random sequence: binary junk, the same on every run.
python3 -c "import random,sys; r=random.Random(14); sys.stdout.buffer.write(bytes(r.randrange(256) for _ in range(2000)))" \
  >"$out/junk.log"
cp "$out/junk.log" "$out/junk.dat"
# What 'candump can0' prints (no -L): interface, id, [dlc], bytes, no timestamps.
printf '  can0  400   [7]  96 00 78 00 00 00 01\n  can0  401   [7]  00 00 00 00 B0 9A 00\n  can0  00000944   [8]  00 00 00 93 00 0C 00 0B\n' \
  >"$out/candump.log"
cp "$out/candump.log" "$out/candump.txt"
mkdir "$out/runs"

for verb in "decode" "decode --strict" "stats" "plot -o $out/p.html" "convert IN $out/x.pcap" "replay IN --link slcan:/dev/null"; do
  read -r -a args <<<"$verb"
  if [[ " $verb " == *" IN "* ]]; then
    args=("${args[@]/IN/$out/junk.log}")
  else
    args+=("$out/junk.log")
  fi
  "$saulctl" "${args[@]}" >"$out/o" 2>"$out/e"
  code=$?
  check "${verb%% IN*}: random bytes named .log: exit 1, 'FILE: not a capture (… binary data …)'" \
    bash -c "test $code -eq 1 && grep -qF '$out/junk.log: not a capture (' '$out/e' && grep -q 'binary data of no format saulctl knows, starting' '$out/e'"
done
"$saulctl" decode "$out/junk.log" >"$out/o" 2>"$out/e"
check "decode of junk prints no frame" test ! -s "$out/o"

"$saulctl" decode "$out/junk.dat" >/dev/null 2>"$out/e"
check "random bytes with an unknown extension: exit 1, not a capture (binary data …)" \
  bash -c "test $? -eq 1 && grep -qF '$out/junk.dat: not a capture (binary data' '$out/e'"

for f in candump.log candump.txt; do
  "$saulctl" decode "$out/$f" >"$out/o" 2>"$out/e"
  check "candump's default output in $f: exit 1 and the hint 'candump -L'" \
    bash -c "test $? -eq 1 && grep -qF '$out/$f: not a capture (' '$out/e' && grep -q \"candump's default output\" '$out/e' && grep -q 'candump -L can0' '$out/e'"
done
"$saulctl" decode - <"$out/candump.log" >"$out/o" 2>"$out/e"
check "candump's default output on standard input (candump can0 | saulctl decode -): exit 1 and the hint" \
  bash -c "test $? -eq 1 && grep -q '^saulctl decode: -: not a capture (candump.s default output' '$out/e' && grep -q 'candump -L' '$out/e'"
"$saulctl" decode - </dev/null >"$out/o" 2>"$out/e"
check "empty standard input is no error (exit 0, 0 frames)" bash -c "test $? -eq 0 && grep -q '^saulctl decode: 0 frames' '$out/e'"
"$saulctl" decode - <"$root/captures/robot_bus.log" >"$out/o" 2>"$out/e"
check "a candump -L log on standard input still decodes (452 frames, exit 0)" \
  bash -c "test $? -eq 0 && test \$(wc -l <'$out/o') -eq 452"
printf '# a comment\n(1763800000.000900) can0 400#96007800000001\n' | "$saulctl" decode - >"$out/o" 2>"$out/e"
check "a comment line before candump -L lines is skipped as canplayer does (exit 0)" \
  bash -c "test $? -eq 0 && grep -q 'telemetry_a pitch=1.50' '$out/o'"

for verb in decode stats plot; do
  "$saulctl" "$verb" "$out/runs" >/dev/null 2>"$out/e"
  check "$verb of a directory: exit 1, 'DIR: is a directory', no C++ stream error" \
    bash -c "test $? -eq 1 && grep -qF '$out/runs: is a directory' '$out/e' && ! grep -q 'basic_filebuf' '$out/e'"
done
"$saulctl" decode "$out/runs" "$root/captures/robot_bus.log" >"$out/o" 2>"$out/e"
check "a directory among files: named, the files still decode, exit 1" \
  bash -c "test $? -eq 1 && grep -qF '$out/runs: is a directory' '$out/e' && test \$(wc -l <'$out/o') -eq 452"
: | "$saulctl" stats - >/dev/null 2>"$out/e"
check "an empty standard input (stats -): exit 1, 'not a capture (empty: not one byte)'" \
  bash -c "test $? -eq 1 && grep -q '^saulctl stats: -: not a capture (empty: not one byte)' '$out/e'"
"$saulctl" decode "$root/captures/robot_bus.log" >/dev/null 2>"$out/e"
check "a real capture is no error (exit 0)" test $? -eq 0

# The other way round: CAN frames written to a format of serial bytes are refused before a file is made.
"$saulctl" convert "$root/captures/robot_bus.log" "$out/bus.serial" >/dev/null 2>"$out/e"
check "convert CAN frames to .serial: exit 1, one line naming the file and why, no file made" \
  bash -c "test $? -eq 1 && test \$(wc -l <'$out/e') -eq 1 && test ! -e '$out/bus.serial' && grep -qF \"cannot write CAN frames to '$out/bus.serial' as serial: that format holds serial bytes\" '$out/e'"

echo "$fails failed"
exit $((fails > 0))
