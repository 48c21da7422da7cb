#!/usr/bin/env bash
# The .deb files packaging/build.sh made, checked as a bench laptop would meet them:
#  - Depends (dpkg-shlibdeps through CPack) names only installed Debian packages, and covers every shared
#    library saulctl and the Python module need (each NEEDED soname's package is in Depends), and saulctl loads
#    Debian's zlib and ncurses rather than copies of them;
#  - dpkg-deb -x into a temporary root: saulctl --version tells the package's version, man -l reads its page,
#    saulctl decodes captures/robot_bus.log exactly as the golden says, the bash completion completes a verb,
#    the Python module imports from the unpacked dist-packages, and the dev package's pkg-config file builds a
#    program from the unpacked tree;
#  - lintian, Debian's checker, finds no error in any of the three.
#   deb.sh SOURCE_DIR PACKAGE_BUILD_DIR
set -euo pipefail
src=$1 pkg=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
fail() { echo "FAIL $*"; fails=$((fails + 1)); }
ok() { echo "ok   $*"; }

deb_of() { local f; for f in "$pkg"/deb/"$1"_*.deb; do echo "$f"; return; done; }
saulctl_deb=$(deb_of saulctl) dev_deb=$(deb_of libsaulproto-dev) py_deb=$(deb_of python3-saulproto)
for d in "$saulctl_deb" "$dev_deb" "$py_deb"; do [[ -f $d ]] || { echo "FAIL missing package in $pkg/deb"; exit 1; }; done
root=$tmp/root
for d in "$saulctl_deb" "$dev_deb" "$py_deb"; do dpkg-deb -x "$d" "$root"; done

# ---- dependencies ---------------------------------------------------------------------------------------------
dep_names() {  # the package names of a Depends field (alternatives and versions dropped)
  { dpkg-deb -f "$1" Depends || true; } | tr ',|' '\n\n' | sed -E 's/\(.*\)//; s/:.*//; s/^ +//; s/ +$//' |
    { grep -v '^$' || true; } | sort -u
}
check_depends() {  # check_depends DEB ELF: Depends are Debian's packages and cover ELF's NEEDED libraries
  local deb=$1 elf=$2 name deps
  deps=$(dep_names "$deb")
  [[ -n $deps ]] || { fail "$(basename "$deb"): no Depends (dpkg-shlibdeps did not run?)"; return; }
  for name in $deps; do
    local status maint
    status=$(dpkg-query -W -f='${db:Status-Status}' "$name" 2>/dev/null || true)
    maint=$(dpkg-query -W -f='${Maintainer}' "$name" 2>/dev/null || true)
    if [[ $status != installed ]]; then
      fail "$(basename "$deb") depends on $name, which is not an installed package"
    elif ! grep -Eq '@([a-z.-]+\.)?debian\.(org|net)>' <<<"$maint"; then
      fail "$(basename "$deb") depends on $name, maintained by '$maint': not a Debian package"
    fi
  done
  local soname path owner
  for soname in $(readelf -d "$elf" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    # (awk reads to the end: an early exit would kill ldconfig with SIGPIPE)
    path=$(ldconfig -p | awk -v s="$soname" '$1 == s && /x86-64/ && !p {p = $NF} END {print p}')
    [[ -n $path ]] || path=$(ldconfig -p | awk -v s="$soname" '$1 == s && !p {p = $NF} END {print p}')
    owner=$(dpkg -S "$(readlink -f "$path")" 2>/dev/null | sed -n '1s/:.*//p' || true)
    [[ -n $owner ]] || owner=$(dpkg -S "$path" 2>/dev/null | sed -n '1s/:.*//p' || true)
    if [[ -z $owner ]]; then
      fail "$(basename "$elf") needs $soname ($path), which no package owns"
    elif ! grep -qx "$owner" <<<"$deps"; then
      fail "$(basename "$elf") needs $soname from $owner, not in Depends: $(tr '\n' ' ' <<<"$deps")"
    fi
  done
  ok "$(basename "$deb") Depends: $(dpkg-deb -f "$deb" Depends)"
}
check_depends "$saulctl_deb" "$root/usr/bin/saulctl"
# A packaged saulctl links Debian's shared libraries (packaging/build.sh turns SAUL_LEAN_LINK off): a copy of zlib
# or ncurses linked into it would never get Debian's security updates.
needed=$(readelf -d "$root/usr/bin/saulctl" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p' | tr '\n' ' ')
[[ " $needed" == *" libz.so.1 "* && " $needed" == *" libncursesw.so.6 "* ]] &&
  ok "saulctl loads Debian's zlib and ncurses: $needed" || fail "saulctl does not load libz and libncursesw (embedded?): $needed"
check_depends "$py_deb" "$(compgen -G "$root/usr/lib/python3/dist-packages/saulproto/_saulproto*.so")"
grep -q 'libserialport-dev' <<<"$(dpkg-deb -f "$dev_deb" Depends)" || fail "libsaulproto-dev does not depend on libserialport-dev"

# ---- files in their standard places ---------------------------------------------------------------------------
for f in usr/bin/saulctl usr/share/man/man1/saulctl.1.gz usr/share/bash-completion/completions/saulctl \
         usr/share/zsh/vendor-completions/_saulctl usr/lib/udev/rules.d/60-saulctl-canable.rules \
         usr/include/saulproto/core/saul_can.hpp usr/lib/python3/dist-packages/saulproto/__init__.py; do
  [[ -e $root/$f ]] || fail "$f not in the packages"
done

# ---- saulctl from the unpacked root ----------------------------------------------------------------------------
version=$(dpkg-deb -f "$saulctl_deb" Version)
got=$("$root/usr/bin/saulctl" --version)
[[ $got == "saulctl $version" ]] && ok "saulctl --version: $got" || fail "saulctl --version says '$got', package $version"

page=$(MANWIDTH=100 man -P cat -l "$root/usr/share/man/man1/saulctl.1.gz" 2>&1)
if grep -q '^NAME' <<<"$page" && grep -q 'saulctl - bench tool for the SAUL-TEE robot' <<<"$page" &&
   grep -Eq '^ +decode +Decode every frame' <<<"$page" && grep -q "saulctl $version" <<<"$page"; then
  ok "man -l saulctl.1.gz: NAME, the verbs and version $version"
else
  fail "man page:"; head -30 <<<"$page"
fi

(cd "$src" && "$root/usr/bin/saulctl" decode captures/robot_bus.log >"$tmp/decode.out" 2>"$tmp/decode.err") || true
golden=$src/captures/robot_bus.log.decoded.txt
if diff <(sed '/^# stderr:$/,$d' "$golden") "$tmp/decode.out" >/dev/null; then
  ok "saulctl decode captures/robot_bus.log matches the golden ($(wc -l <"$tmp/decode.out") lines)"
else
  fail "saulctl decode differs from $golden:"; diff <(sed '/^# stderr:$/,$d' "$golden") "$tmp/decode.out" | head
fi

# (the script asks the saulctl on PATH: saulctl __complete)
words=$(PATH=$root/usr/bin:$PATH bash -c 'source "$1"; COMP_WORDS=(saulctl dec); COMP_CWORD=1; _saulctl
  echo "${COMPREPLY[*]}"' _ "$root/usr/share/bash-completion/completions/saulctl")
[[ " $words " == *" decode "* ]] && ok "bash completion: 'saulctl dec<TAB>' offers decode" || fail "bash completion offers '$words'"
zsh_file=$root/usr/share/zsh/vendor-completions/_saulctl
if [[ $(head -1 "$zsh_file") != "#compdef saulctl" ]]; then
  fail "zsh completion does not start with #compdef saulctl"
elif command -v zsh >/dev/null && ! zsh -n "$zsh_file"; then
  fail "zsh completion: zsh -n finds a syntax error"
else
  ok "zsh completion: saulctl completion zsh"
fi

# ---- the Python module and the dev files from the unpacked root ------------------------------------------------
py=$(PYTHONPATH=$root/usr/lib/python3/dist-packages /usr/bin/python3 -c '
import saulproto
print(saulproto.__file__.split("/dist-packages/")[1], saulproto.decode(0x300, bytes.fromhex("E8030CFE")))')
[[ $py == "saulproto/__init__.py {'type': 'velocity_cmd', 'speed_mmps': 1000, 'steer_mrad': -500}" ]] &&
  ok "python3-saulproto imports from the unpacked root" || fail "python module from the package: $py"

export PKG_CONFIG_PATH=$(dirname "$(compgen -G "$root/usr/lib/*/pkgconfig/saulproto-core.pc")")
# shellcheck disable=SC2046
if c++ -std=c++20 "$src/tests/package/consumer/orin_node.cpp" $(pkg-config --cflags --libs saulproto-core) \
     -o "$tmp/orin_node" && "$tmp/orin_node" >/dev/null; then
  ok "libsaulproto-dev: a program builds from the unpacked tree with pkg-config"
else
  fail "libsaulproto-dev: build against the unpacked tree"
fi

# ---- Debian's own checker ---------------------------------------------------------------------------------------
# lintian (Debian's package checker): no error in any of the three (copyright, changelog, stripped binaries, no
# embedded copy of a Debian library, ...). Its warnings are printed, not failed on.
if command -v lintian >/dev/null; then
  report=$(lintian --no-cfg --fail-on none "$saulctl_deb" "$dev_deb" "$py_deb" 2>&1)
  grep -E '^[EW]: ' <<<"$report" || true
  errors=$(grep -c '^E: ' <<<"$report" || true)
  [[ $errors -eq 0 ]] && ok "lintian: no errors in the three packages" || fail "lintian: $errors errors (above)"
else
  fail "lintian is not installed: scripts/setup.sh installs it"
fi

((fails == 0)) || { echo "$fails check(s) failed"; exit 1; }
echo "deb: all checks passed"
