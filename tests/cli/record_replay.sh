#!/usr/bin/env bash
# saulctl record and replay against a fake CANable and a fake serial link on pseudo-terminals
# (tests/cli/fake_recording.py).
set -euo pipefail
exec python3 "$(dirname "$0")/fake_recording.py" "$1"
