#!/usr/bin/env bash
# Regenerates the logic-analyser fixtures of captures/: the VCDs and serial logs (make_uart_vcd.py), then what
# sigrok-cli's UART decoder prints for the VCDs. The committed outputs were made with sigrok-cli 0.7.2 and
# libsigrokdecode 0.5.3 (Debian 12's sigrok-cli package); tests/cli/uart_interop.sh runs the same commands live
# when sigrok-cli is installed and compares.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
python3 "$here/make_uart_vcd.py" "$here"
cd "$here"
# inter-board, 460800 8N1: data bytes with their sample numbers (10 MHz: the VCD's 100 ns timescale)
sigrok-cli -i interboard_uart.vcd -P uart:rx=rx:baudrate=460800 -A uart=rx-data --protocol-decoder-samplenum \
  >interboard_uart.sigrok.txt
# Pride, 38400 8E1: data bytes and parity errors (1 MHz: the VCD's 1 us timescale)
sigrok-cli -i pride_uart.vcd -P uart:rx=rx:baudrate=38400:parity=even -A uart=rx-data:rx-parity-err \
  --protocol-decoder-samplenum >pride_uart.sigrok.txt
# the same as Google Trace Event JSON, whose times are in microseconds already
sigrok-cli -i pride_uart.vcd -P uart:rx=rx:baudrate=38400:parity=even -A uart=rx-data:rx-parity-err \
  --protocol-decoder-jsontrace >pride_uart.sigrok.json
echo "wrote interboard_uart.sigrok.txt pride_uart.sigrok.txt pride_uart.sigrok.json"
