#!/usr/bin/env bash
# saulctl completion bash|zsh: the bash script is sourced and its function run as bash runs it (COMP_LINE,
# COMP_POINT, COMP_WORDS), and COMPREPLY compared with what a user expects, written by hand. The scripts ask
# saulctl itself (saulctl __complete WORD...) on every TAB. The serial ports come
# from a stand-in saulctl whose 'ports --json' lists two, the SocketCAN interfaces from a made-up /sys
# (SAUL_SYSFS). The zsh script is loaded the way a user does (compinit, then source), and its front end run with
# zsh's completion builtins replaced by ones that print what they were given.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# A saulctl that knows two serial ports; everything else goes to the real one.
cat >"$out/saulctl" <<EOF
#!/bin/sh
if [ "\$1" = ports ] && [ "\$2" = --json ]; then
  printf '[\n  {\n    "path": "/dev/ttyACM0",\n    "role": "CANable"\n  },\n  {\n    "path": "/dev/ttyUSB0",\n    "role": ""\n  }\n]\n'
  exit 0
fi
exec "$saulctl" "\$@"
EOF
chmod +x "$out/saulctl"
# /sys/class/net: two CAN interfaces (type 280, ARPHRD_CAN) and an Ethernet one (type 1).
for i in can0:280 vcan1:280 eth0:1; do
  mkdir -p "$out/sys/class/net/${i%%:*}"
  echo "${i#*:}" >"$out/sys/class/net/${i%%:*}/type"
done
export SAUL_SYSFS=$out/sys
# Files to complete: captures by extension (also compressed), a folder, and files that are no capture.
mkdir -p "$out/work/runs"
touch "$out/work/run.log" "$out/work/bench.pcapng.zst" "$out/work/uart.serial" "$out/work/notes.md" "$out/work/fw.elf"

"$saulctl" completion bash >"$out/saulctl.bash" || echo "FAIL saulctl completion bash exits non-zero"
check "the bash script is valid bash" bash -n "$out/saulctl.bash"

# comp LINE: COMPREPLY (sorted, space separated) for LINE with the cursor at its end, as bash would call _saulctl.
comp() {
  (cd "$out/work" && bash -c '
    source "$1"
    COMP_LINE=$2; COMP_POINT=${#2}
    read -ra COMP_WORDS <<<"$2"; [[ $2 == *" " ]] && COMP_WORDS+=("")
    COMP_CWORD=$((${#COMP_WORDS[@]} - 1))
    _saulctl
    printf "%s\n" "${COMPREPLY[@]}" | sort | tr "\n" " " | sed "s/ $//"' _ "$out/saulctl.bash" "$1")
}
# expect LINE WANTED: COMPREPLY for LINE is exactly WANTED
expect() {
  local got; got=$(comp "$1")
  [[ $got == "$2" ]] || { echo "  '$1' gave: '$got'"; return 1; }
}
s=$out/saulctl
check "verbs: 'saulctl dec' -> decode" expect "$s dec" "decode"
check "modes: 'saulctl mode b' -> balance" expect "$s mode b" "balance"
check "modes: 'saulctl mode ' -> all four" expect "$s mode " "balance estop manual off"
check "formats: 'decode --format ' -> text, jsonl, csv, long" expect "$s decode --format " "csv jsonl long text"
check "formats: 'decode --format=j' -> jsonl (after the '=' bash splits at)" expect "$s decode --format=j" "jsonl"
check "input formats: 'convert --input-format pc' -> pcap, pcapng" expect "$s convert --input-format pc" "pcap pcapng"
check "boards: 'flash --board ' -> balance, io" expect "$s flash --board " "balance io"
check "shells: 'completion ' -> bash, zsh" expect "$s completion " "bash zsh"
check "a CAN link: SocketCAN interfaces (type 280 only) and slcan: on each serial port" \
  expect "$s monitor --link " "can0 slcan:/dev/ttyACM0 slcan:/dev/ttyUSB0 vcan1"
check "a link that may be serial (sniff's positional) offers serial: too" \
  expect "$s sniff " "can0 serial:/dev/ttyACM0 serial:/dev/ttyUSB0 slcan:/dev/ttyACM0 slcan:/dev/ttyUSB0 vcan1"
check "after an option's value the positional is completed ('sniff --id 400 c')" expect "$s sniff --id 400 c" "can0"
check "'--link slcan:/dev/ttyA': only what follows the ':' bash splits at" \
  expect "$s monitor --link slcan:/dev/ttyA" "/dev/ttyACM0"
check "serial ports: 'console ' -> the ports saulctl lists" expect "$s console " "/dev/ttyACM0 /dev/ttyUSB0"
check "capture files by extension (compressed too) and folders, not other files" \
  expect "$s decode " "bench.pcapng.zst run.log runs uart.serial"
check "capture files for a second capture too" expect "$s decode run.log u" "uart.serial"
check "any file where any file goes (convert's OUT)" \
  expect "$s convert run.log " "bench.pcapng.zst fw.elf notes.md run.log runs uart.serial"
check "folders only for --build-dir" expect "$s flash --build-dir " "runs"
check "nothing to offer for a number (--count), and no options instead" expect "$s sniff --count " ""
check "options: 'decode --js' -> --json" expect "$s decode --js" "--json"
check "subverbs: 'pride ' -> vcu" expect "$s pride " "vcu"
check "'help de' -> decode" expect "$s help de" "decode"
# (the script asks the saulctl the line names, here as a user has it: on PATH)
words=$(PATH=$out:$PATH bash -c 'source "$1"; COMP_WORDS=(saulctl dec); COMP_CWORD=1; _saulctl
                               echo "${COMPREPLY[*]}"' _ "$out/saulctl.bash")
check "without COMP_LINE (COMP_WORDS only) it still completes" test "$words" = "decode"
check "the verb the scripts ask (__complete) is not in saulctl's help" \
  bash -c "! '$saulctl' --help | grep -q __complete && ! '$saulctl' help | grep -q __complete"

# --- zsh --------------------------------------------------------------------------------------------------------
if command -v zsh >/dev/null; then
  "$saulctl" completion zsh >"$out/_saulctl"
  check "the zsh script starts with #compdef saulctl" test "$(head -n1 "$out/_saulctl")" = "#compdef saulctl"
  check "the zsh script is valid zsh" zsh -n "$out/_saulctl"
  loaded=$(HOME=$out zsh -c 'autoload -Uz compinit; compinit; source <(cat "$1"); print -r -- $_comps[saulctl]' _ \
           "$out/_saulctl" 2>"$out/zsh.err")
  check "zsh: compinit, then source <(saulctl completion zsh) binds _saulctl to saulctl, quietly" \
    bash -c "test '$loaded' = _saulctl && ! test -s '$out/zsh.err'"
  # zcomp LINE: what the zsh front end offers for LINE (cursor at its end), through stand-ins for the builtins.
  zcomp() {
    (cd "$out/work" && zsh -c '
      compdef() { : }
      compadd() { while [[ $1 == -* ]]; do [[ $1 == -- ]] && { shift; break }; shift; done; print -rl -- "$@" }
      _describe() { local a=$4; print -rl -- ${(P)a%%:*} }
      _files() { print -r -- "_files $*" }
      compset() { return 0 }
      source "$1"
      words=(${(z)2}); [[ $2 == *" " ]] && words+=("")
      CURRENT=$#words
      _saulctl | sort | tr "\n" " " | sed "s/ $//"' _ "$out/_saulctl" "$1")
  }
  zexpect() {
    local got; got=$(zcomp "$1")
    [[ $got == "$2" ]] || { echo "  zsh '$1' gave: '$got'"; return 1; }
  }
  check "zsh: 'mode ' -> all four modes" zexpect "$s mode " "balance estop manual off"
  check "zsh: 'decode --format ' -> the formats" zexpect "$s decode --format " "csv jsonl long text"
  check "zsh: 'monitor --link ' -> CAN interfaces and slcan: ports" \
    zexpect "$s monitor --link " "can0 slcan:/dev/ttyACM0 slcan:/dev/ttyUSB0 vcan1"
  check "zsh: 'decode ' -> capture files by extension" zexpect "$s decode " \
    "_files -g *.(log|candump|pcap|cap|pcapng|ntar|asc|blf|trc|csv|serial|txt|json)(|.gz|.zst)"
  check "zsh: 'flash --build-dir ' -> folders" zexpect "$s flash --build-dir " "_files -/"
  check "zsh: 'pride ' -> vcu" zexpect "$s pride " "vcu"
  check "zsh: nothing to offer for a number ('sniff --count ')" zexpect "$s sniff --count " ""
else
  echo "skip zsh checks: zsh is not installed (scripts/setup.sh installs it)"
fi

echo "$fails failed"
[ "$fails" -eq 0 ]
