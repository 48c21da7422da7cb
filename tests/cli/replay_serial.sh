#!/usr/bin/env bash
# saulctl replay of serial captures (inter-board, Pride, CRSF, a sigrok export) onto a pseudo-terminal: the bytes
# received byte for byte against an independent Python reading of the frames, the motion rule, --allow-motion,
# timing, and the usage errors of a capture onto a link of the other kind (tests/cli/replay_serial_peer.py).
set -euo pipefail
exec python3 "$(dirname "$0")/replay_serial_peer.py" "$1" "$2"
