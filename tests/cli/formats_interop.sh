#!/usr/bin/env bash
# BLF, TRC, python-can and SavvyCAN CSV, gzip and zstd against python-can's own writers and readers, can-utils,
# text2pcap, tshark and the compressors; the bugs of issue 16 found with other tools' files; record --compress.
# Debian's /usr/bin/python3 runs it (python3-can); see tests/cli/formats_interop.py.
set -uo pipefail
exec /usr/bin/python3 "$(dirname "$0")/formats_interop.py" "$1" "$2"
