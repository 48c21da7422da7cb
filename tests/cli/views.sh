#!/usr/bin/env bash
# monitor and sniff --top as full-screen views in tmux at 80x24 and 120x40: fit, colours, keys (tests/cli/views.py).
set -euo pipefail
exec python3 "$(dirname "$0")/views.py" "$1"
