#!/usr/bin/env bash
# The DBC of `saulctl dbc` read by cantools: docs/protocol.md's worked examples decode to the values read off by
# hand (tests/cli/dbc_check.py). SKIP with the reason when cantools is not installed: Debian 12 has no
# python3-cantools package, so scripts/setup.sh cannot install it (pip install cantools does).
set -uo pipefail
saulctl=$1
root=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
if ! python3 -c 'import cantools' 2>/dev/null; then
  echo "SKIP cantools is not installed (Debian 12 does not package python3-cantools; pip install cantools)"
  exit 0
fi
"$saulctl" dbc -o "$out/saul.dbc" || { echo "FAIL saulctl dbc"; exit 1; }
python3 "$root/tests/cli/dbc_check.py" "$out/saul.dbc" cantools
