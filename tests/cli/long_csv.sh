#!/usr/bin/env bash
# decode --format long: one row per signal, aggregated in an SQL engine per signal (tests/cli/long_csv.py).
set -euo pipefail
exec python3 "$(dirname "$0")/long_csv.py" "$1" "$2"
