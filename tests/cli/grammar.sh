#!/usr/bin/env bash
# One grammar across saulctl's verbs: every verb's --help against a table written by hand, the README's --json
# list, and the link, id and duration words driven (tests/cli/grammar.py).
set -euo pipefail
exec python3 "$(dirname "$0")/grammar.py" "$1" "$2"
