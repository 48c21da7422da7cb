#!/usr/bin/env bash
# The three-terminal scenario on the simulated robot: monitor holds its CANable, sniff and estop go through it
# (tests/cli/shared_link.py).
set -euo pipefail
exec python3 "$(dirname "$0")/shared_link.py" "$1" sim
