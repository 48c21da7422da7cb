#!/usr/bin/env bash
# saulctl doctor's ModemManager check on a fake system root (--sysroot: its proc/ and udev rule folders):
# ModemManager running without the CANable2 rule -> a warning with the fix; with the package's rule (in either
# rules folder) -> ok; not running -> ok. Doctor's other checks run on the real machine and are not looked at.
#   doctor_modemmanager.sh SAULCTL RULES_FILE
set -euo pipefail
saulctl=$1 rule=$2
root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
fails=0
expect() {  # expect NAME PATTERN: doctor's ModemManager lines must match PATTERN (grep -E)
  local name=$1 pattern=$2 out
  out=$("$saulctl" doctor --sysroot "$root" 2>&1) || true
  local lines
  lines=$(grep -A1 'ModemManager:' <<<"$out" || true)
  if grep -Eq "$pattern" <<<"$lines"; then
    echo "ok   $name"
  else
    echo "FAIL $name: expected /$pattern/, got:"; echo "$out" | sed 's/^/     /'; fails=$((fails + 1))
  fi
}

mkdir -p "$root/proc/1" "$root/proc/731" "$root/proc/self"
echo systemd >"$root/proc/1/comm"
echo ModemManager >"$root/proc/731/comm"
expect "running, no rule: warning" '^WARN ModemManager: running, and no udev rule'
expect "running, no rule: the fix names the rule" 'fix: .*60-saulctl-canable.rules'

mkdir -p "$root/etc/udev/rules.d"
echo 'SUBSYSTEM=="tty", ATTRS{idVendor}=="16d0", ENV{ID_MM_DEVICE_IGNORE}="1"' >"$root/etc/udev/rules.d/70-other.rules"
expect "a rule for another product does not count" '^WARN ModemManager'
rm "$root/etc/udev/rules.d/70-other.rules"

mkdir -p "$root/usr/lib/udev/rules.d"
cp "$rule" "$root/usr/lib/udev/rules.d/"
expect "running, package rule installed: ok" '^ok   ModemManager: running; .*usr/lib/udev/rules.d/60-saulctl-canable.rules'
rm "$root/usr/lib/udev/rules.d/60-saulctl-canable.rules"
cp "$rule" "$root/etc/udev/rules.d/99-canable.rules"
expect "running, rule copied to /etc: ok" '^ok   ModemManager: running; .*etc/udev/rules.d/99-canable.rules'

echo bash >"$root/proc/731/comm"
rm "$root/etc/udev/rules.d/99-canable.rules"
expect "not running: ok" '^ok   ModemManager: not running'

((fails == 0)) || { echo "$fails check(s) failed"; exit 1; }
echo "all ModemManager checks passed"
