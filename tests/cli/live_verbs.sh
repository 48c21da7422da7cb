#!/usr/bin/env bash
# saulctl console, pride vcu, doctor and sniff --top against fakes on pseudo-terminals (tests/cli/fake_live.py).
set -euo pipefail
exec python3 "$(dirname "$0")/fake_live.py" "$1"
