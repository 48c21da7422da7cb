#!/usr/bin/env bash
# Writes the golden decodes of the samples in captures/: captures/<name>.decoded.txt is what `saulctl decode`
# prints for captures/<name> (run from the repository root, so the file names in messages are captures/<name>),
# then a line "# stderr:" and what it printed on stderr (corrupt lines with their positions, decoder counters,
# the summary), then "# exit: N".
#   captures/make_goldens.sh build/saulctl/saulctl            regenerate them (read the diff before committing)
#   captures/make_goldens.sh --check build/saulctl/saulctl    compare instead (tests/cli/goldens.sh)
# The VCDs are not decoded by saulctl (they are logic levels): their goldens are those of the sigrok-cli outputs
# made from them (make_sigrok_fixtures.sh) and of the serial logs holding the same bytes.
set -uo pipefail
check=0
if [[ ${1:-} == --check ]]; then check=1; shift; fi
saulctl=${1:?usage: make_goldens.sh [--check] PATH/TO/saulctl}
saulctl=$(cd "$(dirname "$saulctl")" && pwd)/$(basename "$saulctl")
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

# sample    decode options (the sigrok sample numbers need the capture's sample rate: 10 MHz for the inter-board VCD's
# 100 ns timescale, 1 MHz for the Pride VCD's 1 us; the Pride logic exports name no protocol)
samples=(
  "robot_bus.log|"
  "glitches.log|"
  "interboard_uart.serial|"
  "interboard_uart.sigrok.txt|--samplerate 10M"
  "pride_uart.serial|"
  "pride_uart.sigrok.txt|--protocol pride --samplerate 1M"
  "pride_uart.sigrok.json|--protocol pride"
  "robot_bus.blf|"
  "robot_bus.trc.zst|"
  "robot_bus.csv|"
  "robot_bus.gvret.csv|"
  "robot_bus.fd.asc|"
  "robot_bus.log.gz|"
)

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
for entry in "${samples[@]}"; do
  name=${entry%%|*}
  read -r -a opts <<<"${entry#*|}"
  out="$tmp/$name.decoded.txt"
  "$saulctl" decode "${opts[@]}" "captures/$name" >"$out" 2>"$tmp/err"
  status=$?
  { echo "# stderr:"; cat "$tmp/err"; echo "# exit: $status"; } >>"$out"
  golden="captures/$name.decoded.txt"
  if ((check)); then
    if diff -u "$golden" "$out" >"$tmp/diff" 2>&1; then
      echo "ok   $name decodes as $golden"
    else
      echo "FAIL $name differs from $golden:"
      head -40 "$tmp/diff"
      fails=$((fails + 1))
    fi
  else
    cp "$out" "$golden"
    echo "wrote $golden ($(wc -l <"$golden") lines, exit $status)"
  fi
done
((check)) && echo "$fails failed"
exit $((fails > 0))
