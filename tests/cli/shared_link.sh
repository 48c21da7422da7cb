#!/usr/bin/env bash
# Two and three saulctl processes on one fake CANable (and a serial port): one owner, the others through it
# (tests/cli/shared_link.py).
set -euo pipefail
exec python3 "$(dirname "$0")/shared_link.py" "$1" fake
