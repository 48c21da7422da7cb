#!/usr/bin/env bash
# Memory does not grow with the capture (issue 15): decode (text and JSON) and stats of the same robot bus repeated
# to 16 MB and to 128 MB (both above the two-thread threshold, forced low, so both take the same path) peak within
# 8 MiB of each other. The 10 GB figure is bench/memory's (not CI: minutes of disk writing).
# Under AddressSanitizer, freed memory waits in a quarantine that grows with the bytes churned, so it is kept small.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
if [[ ! -x /usr/bin/time ]]; then
  echo "SKIP GNU time is not installed (scripts/setup.sh installs it)"
  exit 0
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=4"
export SAUL_DECODE_PARALLEL_FROM=1

python3 "$root/bench/make_bus.py" 50000 "$out/block.log" >/dev/null 2>&1
block=$(stat -c %s "$out/block.log")
for ((i = 0; i < 16 * 1024 * 1024 / block + 1; i++)); do cat "$out/block.log"; done >"$out/small.log"
for ((i = 0; i < 128 * 1024 * 1024 / block + 1; i++)); do cat "$out/block.log"; done >"$out/big.log"
echo "     files: $(du -m "$out/small.log" | cut -f1) MB and $(du -m "$out/big.log" | cut -f1) MB"

peak() {  # FILE ARGS...: peak RSS in KiB of saulctl ARGS FILE
  local file=$1; shift
  /usr/bin/time -f "%M" -o "$out/rss" "$saulctl" "$@" "$file" >/dev/null 2>"$out/err" || { echo 0; return; }
  tail -1 "$out/rss"
}
for verb in "decode" "decode --json" "stats"; do
  # shellcheck disable=SC2086
  small=$(peak "$out/small.log" $verb)
  # shellcheck disable=SC2086
  big=$(peak "$out/big.log" $verb)
  echo "     $verb: peak RSS $((small / 1024)) MiB on 16 MB, $((big / 1024)) MiB on 128 MB"
  check "$verb: runs" test "$small" -gt 0 -a "$big" -gt 0
  check "$verb: peak memory does not grow with the file (128 MB within 8 MiB of 16 MB)" \
    test "$big" -le $((small + 8 * 1024))
done
echo "$fails failed"
exit $((fails > 0))
