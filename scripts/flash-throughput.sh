#!/usr/bin/env bash
# Effective write throughput of `saulctl flash` against the ROM emulator (tests/cli/esp_rom_emulator.py) with
# --baud-pacing, which spends the time the bytes would take on a real UART at the current baud rate. The flash
# chip's own erase and program times are not modelled, so these are the line-rate-bound figures.
#
#   scripts/flash-throughput.sh build/saulctl/saulctl [IMAGE]
#
# IMAGE defaults to 1 MiB of machine code behind an ESP32-S3 image header: Debian's python3.11 executable, which
# deflates to about 53 % (close to ESP-IDF applications), else saulctl itself (about 44 %).
set -euo pipefail
saulctl=$1
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
image=${2:-}
if [ -z "$image" ]; then
  image=$out/app.bin
  python3 - "$image" "$saulctl" <<'EOF'
import os, struct, sys
h = struct.pack('<BBBBI', 0xE9, 1, 2, 0x2F, 0x40375A88) + struct.pack('<BBBBHBHH4BB', 0xEE, 0, 0, 0, 9, 0, 0, 99, 0, 0, 0, 0, 0)
source = '/usr/bin/python3.11' if os.path.exists('/usr/bin/python3.11') else sys.argv[2]
body = open(source, 'rb').read()[0x1000:0x1000 + 1024 * 1024 - 24]
open(sys.argv[1], 'wb').write(h + body)
EOF
fi
echo "image: $(stat -c %s "$image") bytes, deflates to $(python3 -c "import zlib,sys; print(len(zlib.compress(open(sys.argv[1],'rb').read(), 9)))" "$image") bytes"
printf '%-8s %-12s %10s %14s\n' baud mode seconds "KiB/s"
for baud in 460800 921600; do
  for mode in compressed plain; do
    mkfifo "$out/ctl" "$out/tty"
    python3 "$root/tests/cli/esp_rom_emulator.py" --baud-pacing <"$out/ctl" >"$out/tty" &
    pid=$!
    exec {ctl}>"$out/ctl"
    read -r tty <"$out/tty"
    extra=()
    [ "$mode" = plain ] && extra=(--no-compress)
    "$saulctl" flash --board balance --port "$tty" --baud "$baud" --force "${extra[@]}" "$image" >"$out/log" 2>&1 || {
      cat "$out/log"; exit 1; }
    echo quit >&"$ctl"
    exec {ctl}>&-
    wait "$pid"
    rm -f "$out/ctl" "$out/tty"
    line=$(grep 'written and verified' "$out/log")
    secs=$(sed -E 's/.*verified in ([0-9.]+) s.*/\1/' <<<"$line")
    rate=$(sed -E 's/.*\(([0-9.]+) KiB\/s effective.*/\1/' <<<"$line")
    printf '%-8s %-12s %10s %14s\n' "$baud" "$mode" "$secs" "$rate"
  done
done
