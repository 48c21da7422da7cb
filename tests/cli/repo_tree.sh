#!/usr/bin/env bash
# The repository tracks no stray output of a command: no file whose name starts with '-' (a command that took
# '-', standard output, or an option for a file name wrote it: a 393 KB BLF called '-', written by decode_fast.sh's
# 'convert ... - --format blf' run with a saulctl from before '-' meant standard output, was committed from the
# repository's root), and git ignores a file called '-' at the root. Skipped outside a git checkout.
set -uo pipefail
root=$2
source "$(dirname "$0")/check.bash"
if ! git -C "$root" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  echo "SKIP $root is not a git checkout"
  echo "0 failed"
  exit 0
fi
stray=$(git -C "$root" ls-files | grep -E '(^|/)-' || true)
[[ -n $stray ]] && echo "  tracked: $stray"
check "no tracked file's name starts with '-'" test -z "$stray"
check "a file called '-' at the root is ignored (.gitignore)" git -C "$root" check-ignore -q --no-index -- ./-
echo "$fails failed"
exit $((fails > 0))
