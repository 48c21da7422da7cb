#!/usr/bin/env bash
# saulctl record -o x.mcap on a serial link (a pseudo-terminal), Ctrl-C and kill -9, read by @mcap/core
# (tests/cli/mcap_record_serial.py).
set -euo pipefail
exec python3 "$(dirname "$0")/mcap_record_serial.py" "$1" "$2"
