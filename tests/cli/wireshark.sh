#!/usr/bin/env bash
# The Lua dissector of `saulctl wireshark` under tshark: the same values as `saulctl decode --json`
# (tests/cli/wireshark.py).
set -uo pipefail
exec python3 "$(dirname "$0")/wireshark.py" "$1" "$2"
