#!/usr/bin/env bash
# CANFD lines of Vector ASC read by one rule (docs/captures.md): see tests/cli/asc_canfd.py.
# Debian's /usr/bin/python3 runs it (python3-can).
exec /usr/bin/python3 "$(dirname "$0")/asc_canfd.py" "$1"
