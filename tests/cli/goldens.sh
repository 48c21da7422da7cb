#!/usr/bin/env bash
# Golden decodes: every sample in captures/ decodes exactly as its committed captures/<name>.decoded.txt
# (stdout, stderr and exit status). After a deliberate change of the output, regenerate them with
# captures/make_goldens.sh and read the diff before committing.
set -uo pipefail
exec bash "$2/captures/make_goldens.sh" --check "$1"
