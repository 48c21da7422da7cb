#!/usr/bin/env bash
# saulctl's live verbs against a fake CANable on a pseudo-terminal (tests/cli/fake_canable.py).
set -euo pipefail
exec python3 "$(dirname "$0")/fake_canable.py" "$1"
