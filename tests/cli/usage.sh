#!/usr/bin/env bash
# Usage errors as a new user meets them: typos of verbs and options get the nearest name, "saulctl help [VERB]"
# works, and every usage error names the verb's own --help and exits 2. The expected lines are written by hand.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# run NAME ARGS...: stdout, stderr and exit code of one saulctl run
run() {
  local name=$1; shift
  "$saulctl" "$@" >"$out/$name.out" 2>"$out/$name.err"
  echo $? >"$out/$name.rc"
}
rc() { cat "$out/$1.rc"; }
err_is() { [ "$(cat "$out/$1.err")" = "$2" ] || { echo "  got: $(cat "$out/$1.err")"; return 1; }; }

run verb decod x
check "a mistyped verb exits 2" test "$(rc verb)" -eq 2
check "... and names the nearest verb" \
  err_is verb "saulctl: unknown verb 'decod'; did you mean 'decode'? ('saulctl help' lists the verbs)"
run swapped stast x
check "two letters swapped are one typo" grep -q "did you mean 'stats'?" "$out/swapped.err"
run far frobnicate
check "a word near no verb gets no guess" \
  err_is far "saulctl: unknown verb 'frobnicate' ('saulctl help' lists the verbs)"
run none
check "no verb at all exits 2 saying so" \
  bash -c "test $(rc none) -eq 2 && grep -qx \"saulctl: no verb given ('saulctl help' lists the verbs)\" '$out/none.err'"

run help help
check "'saulctl help' prints the help and exits 0" \
  bash -c "test $(rc help) -eq 0 && grep -q '^saulctl - bench tool' '$out/help.out' && grep -q '^  decode' '$out/help.out'"
run helpverb help decode
check "'saulctl help decode' is decode's help" \
  bash -c "test $(rc helpverb) -eq 0 && grep -q '^Usage: saulctl decode' '$out/helpverb.out'"
run helpsub help pride vcu
check "'saulctl help pride vcu' is that subverb's help" grep -q '^Usage: saulctl pride vcu' "$out/helpsub.out"
run helptypo help decod
check "'saulctl help decod' suggests decode and exits 2" \
  bash -c "test $(rc helptypo) -eq 2 && grep -q \"did you mean 'decode'?\" '$out/helptypo.err'"

run opt decode --jsn x.log
check "a mistyped option exits 2" test "$(rc opt)" -eq 2
check "... naming the verb, the nearest option and the verb's help" \
  err_is opt "saulctl decode: unknown option --jsn; did you mean --json? (see 'saulctl decode --help')"
run optval decode --jsn=1 x.log
check "--jsn=VALUE is the same typo" grep -q "unknown option --jsn; did you mean --json?" "$out/optval.err"
run abbrev sniff --dur 1
check "an abbreviation of one option is completed" grep -q "did you mean --duration?" "$out/abbrev.err"
run subtypo pride vcx
check "a mistyped subverb names its parent and the nearest" \
  err_is subtypo "saulctl pride: unknown verb 'vcx'; did you mean 'vcu'? (see 'saulctl pride --help')"
run required decode
check "a missing argument points to the verb's help, exit 2" \
  bash -c "test $(rc required) -eq 2 && grep -q \"^saulctl decode: .*(see 'saulctl decode --help')$\" '$out/required.err'"
run value completion fish
check "a value out of its set points to the verb's help, exit 2" \
  bash -c "test $(rc value) -eq 2 && grep -q \"^saulctl completion: .*fish.*(see 'saulctl completion --help')$\" '$out/value.err'"
run late flash --board balance --port /dev/null
check "a usage error found by the verb itself points to its help too, exit 2" \
  bash -c "test $(rc late) -eq 2 && tail -n1 '$out/late.err' | grep -qx \"saulctl flash: see 'saulctl flash --help'\""
run filecheck convert "$(dirname "$0")/../../captures/robot_bus.log" "$out/x.log" --parallel-from 3q
check "a file verb's own check after parsing is a usage error too, exit 2" \
  bash -c "test $(rc filecheck) -eq 2 && tail -n1 '$out/filecheck.err' | grep -qx \"saulctl convert: see 'saulctl convert --help'\""

echo "$fails failed"
[ "$fails" -eq 0 ]
