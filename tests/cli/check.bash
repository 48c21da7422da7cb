# Sourced by the tests/cli/*.sh scripts (not a test itself: ctest runs only *.sh):
#   check DESCRIPTION COMMAND...   runs COMMAND, prints "ok   DESCRIPTION" or "FAIL DESCRIPTION", counts failures
# A script ends with: echo "$fails failed"; exit $((fails > 0))
fails=0
check() {
  local what=$1; shift
  if "$@"; then echo "ok   $what"; else echo "FAIL $what"; fails=$((fails + 1)); fi
}
