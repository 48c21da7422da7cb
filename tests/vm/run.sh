#!/usr/bin/env bash
# The real-kernel harness: runs the project's own binaries inside a Debian kernel under QEMU (TCG, no KVM needed),
# so SocketCAN (vcan) and libserialport (8250 UART, USB serial, CDC-ACM) are tested on real kernel drivers.
# See tests/vm/README.md.
#
#   tests/vm/run.sh [--build-dir DIR] [--dynamic] [--only REGEX] [--verbose] [--timeout SECONDS] [--no-build]
#
#   --build-dir DIR   where the kernel cache and initramfs (DIR/vm) and the static build (DIR/vm-static) go;
#                     default: build/ in the source tree
#   --only REGEX      run only the guest tests whose name matches (busybox grep; no spaces: use '.')
#   --verbose         show every test's output, not only the failures', and the whole console at the end
#   --timeout S       bound for the boot and all tests (default 240)
#   --dynamic         instead of the static build: the normal build's own saulctl and saul_vm_guest from DIR
#                     (a configured build dir), with the shared libraries ldd names; no second compile
#   --no-build        use the binaries as they are (when changing only tests/vm/guest/init.sh)
#   --saulctl FILE    with --dynamic: this saulctl instead of DIR's (the ctest gives the package build's: the
#                     released binary, and without the sanitizers each start takes a fraction of the time in TCG)
# Environment: SAUL_VM_JOBS (build parallelism, default 2); SAUL_VM_KERNEL_PACKAGE (the kernel package to
# download instead of the one linux-image-amd64 depends on); SAUL_VM_KERNEL_DEB (use this linux-image .deb file).
#
# Steps: find the tools; fetch Debian's kernel package once (apt-get download, dpkg-deb -x: nothing installed) into
# DIR/vm/kernel; build saulctl and tests/vm/guest (statically with cmake -DSAUL_STATIC=ON in DIR/vm-static, or
# with --dynamic in DIR itself); pack a busybox initramfs with them, the kernel modules (order from
# modprobe --show-depends), candump/cansend and the libraries ldd names; boot once, QEMU tracing the modem lines of
# ttyS1/ttyUSB0 into DIR/vm/modem-trace.log; read the guest's marker lines from the console and its verdict from
# isa-debug-exit; check the ESP flasher's DTR/RTS sequences in the trace (tests/vm/check_modem_lines.py).
# Exit status 0 only when the guest ran every test and all passed.
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
build="$root/build"
only=""
verbose=0
boot_timeout=240
rebuild=1
dynamic=0
saulctl_given=""
while (($#)); do
  case "$1" in
    --build-dir) build=$2; shift 2 ;;
    --only) only=$2; shift 2
      [[ $only != *" "* ]] || { echo "vm: --only takes no spaces (it goes on the kernel command line): use '.'" >&2; exit 2; } ;;
    --verbose) verbose=1; shift ;;
    --timeout) boot_timeout=$2; shift 2 ;;
    --no-build) rebuild=0; shift ;;
    --dynamic) dynamic=1; shift ;;
    --saulctl) saulctl_given=$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d'; exit 0 ;;
    *) echo "vm: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ -z $saulctl_given ]] || ((dynamic)) || { echo "vm: --saulctl goes with --dynamic" >&2; exit 2; }
mkdir -p "$build"
build=$(cd "$build" && pwd)
vm="$build/vm"
static="$build/vm-static"
jobs=${SAUL_VM_JOBS:-2}
export PATH="$PATH:/usr/sbin:/sbin"

t_start=$(date +%s.%N)
since() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN{printf "%.1f s", b - a}'; }
die() { echo "vm: ERROR: $*" >&2; exit 1; }

# ---- tools -------------------------------------------------------------------------------------------------------
need() {  # command, package
  command -v "$1" >/dev/null || die "$1 not found: install the Debian package $2 (scripts/setup.sh installs it)"
}
need qemu-system-x86_64 qemu-system-x86
need cpio cpio
need depmod kmod
need modprobe kmod
need candump can-utils
need cansend can-utils
need dpkg-deb dpkg
need cmake cmake
need ninja ninja-build
need strip binutils
need python3 python3  # tests/vm/check_modem_lines.py
busybox=/bin/busybox
[[ -x $busybox ]] || die "$busybox not found: install the Debian package busybox-static"
if ldd "$busybox" >/dev/null 2>&1; then
  die "$busybox is dynamically linked: install busybox-static (it replaces busybox)"
fi

# ---- kernel: Debian's package, downloaded once, unpacked, not installed -------------------------------------------
# Module sets, in dependency order by modprobe: CAN (vcan needs can-dev), QEMU's xHCI + FTDI USB serial, and the
# USB gadget loopback (dummy_hcd) with g_serial for a CDC-ACM /dev/ttyACM0. usb_f_acm is loaded by name at run
# time, not a symbol dependency, so it is listed itself (before g_serial).
modules=(vcan can_raw xhci_pci ftdi_sio cdc_acm dummy_hcd usb_f_acm g_serial)
# g_serial plays a CANable2 with the slcan firmware (16d0:117e), so saulctl ports recognises it.
g_serial_params="use_acm=1 n_ports=1 idVendor=0x16d0 idProduct=0x117e iManufacturer=SAUL-VM iProduct=CANable2-lookalike iSerialNumber=VM0002"
# What is unpacked from the package: the kernel and the module folders the sets above come from.
kernel_parts=(./boot/vmlinuz-* ./lib/modules/*/modules.builtin ./lib/modules/*/modules.builtin.modinfo
  ./lib/modules/*/modules.order ./lib/modules/*/kernel/net/can ./lib/modules/*/kernel/drivers/net/can
  ./lib/modules/*/kernel/drivers/usb ./lib/modules/*/kernel/fs/configfs)

t0=$(date +%s.%N)
mkdir -p "$vm/kernel"
if [[ -n ${SAUL_VM_KERNEL_DEB:-} ]]; then
  [[ -f $SAUL_VM_KERNEL_DEB ]] || die "SAUL_VM_KERNEL_DEB=$SAUL_VM_KERNEL_DEB: no such file"
  pkg=$(dpkg-deb -f "$SAUL_VM_KERNEL_DEB" Package)
elif [[ -n ${SAUL_VM_KERNEL_PACKAGE:-} ]]; then
  pkg=$SAUL_VM_KERNEL_PACKAGE
else
  # linux-image-amd64 is the metapackage; its dependency is the real kernel package (linux-image-6.1.0-NN-amd64).
  pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}' || true)
  if [[ -z $pkg ]]; then
    # No package lists (offline, or no apt-get update yet): a kernel cached by an earlier run will do.
    pkg=$(find "$vm/kernel" -mindepth 2 -maxdepth 2 -name .ok -printf '%h\n' 2>/dev/null | sort | tail -1 | xargs -r basename)
    [[ -n $pkg ]] || die "cannot find Debian's kernel package: 'apt-cache depends linux-image-amd64' names none " \
      "(run apt-get update, or set SAUL_VM_KERNEL_DEB to a linux-image-*-amd64 .deb)"
  fi
fi
kdir="$vm/kernel/$pkg"
kernel_note="cached"
if [[ ! -f $kdir/.ok ]]; then
  rm -rf "$kdir" "$kdir.tmp"
  mkdir -p "$kdir.tmp"
  if [[ -n ${SAUL_VM_KERNEL_DEB:-} ]]; then
    deb=$SAUL_VM_KERNEL_DEB
    kernel_note="from $deb"
  else
    # apt-get download as root warns that its sandbox user cannot write here; harmless.
    if ! (cd "$kdir.tmp" && apt-get download "$pkg") >"$vm/kernel/download.log" 2>&1; then
      cat "$vm/kernel/download.log" >&2
      die "cannot download the kernel package $pkg (above: apt-get's answer)"
    fi
    deb=$(ls "$kdir.tmp"/*.deb)
    kernel_note="downloaded $(du -h "$deb" | cut -f1)"
  fi
  dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$kdir.tmp" --wildcards "${kernel_parts[@]}" ||
    die "cannot unpack $deb"
  rm -f "$kdir.tmp"/*.deb
  kver=$(ls "$kdir.tmp/lib/modules")
  depmod -b "$kdir.tmp" "$kver" || die "depmod failed on $kdir.tmp"
  mv "$kdir.tmp" "$kdir"
  touch "$kdir/.ok"
fi
kver=$(ls "$kdir/lib/modules")
vmlinuz="$kdir/boot/vmlinuz-$kver"
[[ -f $vmlinuz ]] || die "$vmlinuz missing: remove $kdir and run again"
echo "vm: kernel $kver ($kernel_note) in $(since "$t0")"

# ---- saulctl and the guest program --------------------------------------------------------------------------------
t0=$(date +%s.%N)
if ((dynamic)); then
  # The binaries the normal build made (what ctest tests and users run), with their shared libraries.
  [[ -f $build/CMakeCache.txt ]] || die "--dynamic needs a configured build dir: $build has no CMakeCache.txt"
  if ((rebuild)); then
    targets=(saul_vm_guest)
    [[ -n $saulctl_given ]] || targets+=(saulctl)
    cmake --build "$build" -j "$jobs" --target "${targets[@]}" >"$vm/build.log" 2>&1 ||
      { tail -40 "$vm/build.log" >&2; die "building ${targets[*]} in $build failed (log: $vm/build.log)"; }
  fi
  saulctl=${saulctl_given:-$build/saulctl/saulctl}
  guest="$build/tests/vm/guest/saul_vm_guest"
  what="$saulctl and saul_vm_guest (dynamic, from $build)"
else
  # -Og: about half the compile time of -O2 with CLI11 and fmt header-only; speed does not matter in the guest.
  # Warnings are the normal build's business (-Werror there); here only behaviour is tested.
  if ((rebuild)); then
    if [[ ! -f $static/CMakeCache.txt ]]; then
      cmake -S "$root" -B "$static" -G Ninja -DSAUL_STATIC=ON -DSAUL_BUILD_TESTS=OFF -DSAUL_BUILD_BENCH=OFF \
        -DSAUL_WERROR=OFF -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-Og >"$vm/cmake.log" 2>&1 ||
        { cat "$vm/cmake.log" >&2; die "configuring the static build in $static failed"; }
    fi
    cmake --build "$static" -j "$jobs" --target saulctl saul_vm_guest >"$vm/build.log" 2>&1 ||
      { tail -40 "$vm/build.log" >&2; die "the static build failed (full log: $vm/build.log)"; }
  fi
  saulctl="$static/saulctl/saulctl"
  guest="$static/tests/vm/guest/saul_vm_guest"
  what="static saulctl and saul_vm_guest ($static)"
  for b in "$saulctl" "$guest"; do
    if ldd "$b" >/dev/null 2>&1; then die "$b is not statically linked"; fi
  done
fi
for b in "$saulctl" "$guest"; do
  [[ -x $b ]] || die "$b missing (run without --no-build)"
done
if ((rebuild)); then
  echo "vm: $what built in $(since "$t0")"
else
  echo "vm: $what as they are (--no-build)"
fi

# ---- initramfs -----------------------------------------------------------------------------------------------------
t0=$(date +%s.%N)
stage="$vm/initramfs"
rm -rf "$stage"
mkdir -p "$stage"/{bin,usr/bin,proc,sys,dev,tmp,etc,lib/modules}
cp "$busybox" "$stage/bin/busybox"
for applet in $("$busybox" --list); do
  [[ $applet == busybox ]] || ln -s busybox "$stage/bin/$applet"
done
install -m 755 "$root/tests/vm/guest/init.sh" "$stage/init"
# A program and, when it is dynamically linked (can-utils as Debian ships them; saulctl with --dynamic), its
# loader and libraries at the paths ldd names.
add_program() {
  strip -o "$stage/usr/bin/$(basename "$1")" "$1"
  { ldd "$1" 2>/dev/null || true; } | awk '/=> \// {print $3} /^[[:space:]]*\// {print $1}' | while read -r lib; do
    [[ -f $stage/$lib ]] && continue
    mkdir -p "$stage/$(dirname "$lib")"
    cp -L "$lib" "$stage/$lib"
  done
}
add_program "$saulctl"
add_program "$guest"
add_program "$(command -v candump)"
add_program "$(command -v cansend)"
# Modules in load order, each once.
: >"$stage/etc/modules.order"
for m in "${modules[@]}"; do
  modprobe -d "$kdir" -S "$kver" --show-depends "$m" ||
    die "modprobe cannot resolve module $m in $kdir (kernel $kver)"
done | awk '$1 == "insmod" && !seen[$2]++ {print $2}' >"$vm/modules.paths"
while read -r ko; do
  name=$(basename "$ko")
  cp "$ko" "$stage/lib/modules/$name"
  params=""
  [[ $name == g_serial.ko ]] && params=$g_serial_params
  echo "$name $params" >>"$stage/etc/modules.order"
done <"$vm/modules.paths"
initrd="$vm/initramfs.cpio.gz"
(cd "$stage" && find . | cpio -o -H newc --quiet | gzip -1) >"$initrd"
echo "vm: initramfs $(du -h "$initrd" | cut -f1) ($(wc -l <"$stage/etc/modules.order") modules) in $(since "$t0")"

# ---- boot ------------------------------------------------------------------------------------------------------------
t0=$(date +%s.%N)
sock=$(mktemp -d /tmp/saul-vm.XXXXXX)  # short paths: unix sockets allow 107 bytes
peer=""
cleanup() {
  [[ -n $peer ]] && kill "$peer" 2>/dev/null
  rm -rf "$sock"
}
trap cleanup EXIT
# The host end of the guest's /dev/ttyS1 (8250) and /dev/ttyUSB0 (QEMU's FTDI): answers every byte XOR 0x5A.
"$guest" echo-peer "$sock/uart" "$sock/usb" 2>"$vm/echo-peer.log" &
peer=$!

append="console=ttyS0 quiet loglevel=3 panic=-1"
[[ -n $only ]] && append+=" saulvm.only=$only"
((verbose)) && append+=" saulvm.verbose=1"
console="$vm/console.log"
# DTR/RTS of the guest's ttyS1 and ttyUSB0, which no socket carries: QEMU's trace of every 8250 register write and
# every FTDI control request, host-timestamped (-msg timestamp=on: "PID@SEC.USEC:event ..."), one file for both.
modem_trace="$vm/modem-trace.log"
rm -f "$modem_trace"
# 768 MB: the initramfs (ASan builds of saulctl and the guest, their libraries) unpacks into RAM; at 256 MB a
# 24 MB compressed image no longer fitted ("Initramfs unpacking failed: write error", then no init).
# A loaded host (ctest -j2 running a libFuzzer job beside this on a 2-core CI machine) keeps QEMU's one vCPU thread
# off the CPU for 100 ms and more, and the modem-line check then sees a hold that lasted too long (255 ms for 100 ms,
# twice in CI, never on an idle machine): the guest's sleeps end on time, its next write waits for the host. So QEMU
# runs with a larger CPU share where that is allowed (root, as in CI): nice -10 against the processes of this session
# (ctest's other jobs), and a session of its own with autogroup nice -10 against other sessions. SAUL_VM_PRIORITY=0:
# as it is.
prio=()
if [[ ${SAUL_VM_PRIORITY:-1} != 0 && $(id -u) == 0 ]] && command -v setsid >/dev/null; then
  prio=(setsid -w bash -c 'echo -10 >/proc/$$/autogroup 2>/dev/null; exec nice -n -10 "$@"' _)
fi
set +e
"${prio[@]}" timeout -k 5 "$boot_timeout" qemu-system-x86_64 \
  -machine q35,accel=tcg -smp 1 -m 768M -nographic -no-reboot -net none \
  -kernel "$vmlinuz" -initrd "$initrd" -append "$append" \
  -device isa-debug-exit,iobase=0xf4,iosize=0x04 \
  -global isa-serial.baudbase=921600 \
  -serial mon:stdio \
  -chardev "socket,id=s1,path=$sock/uart,server=on,wait=off" -serial chardev:s1 \
  -device qemu-xhci,id=xhci \
  -chardev "socket,id=u1,path=$sock/usb,server=on,wait=off" \
  -device usb-serial,bus=xhci.0,chardev=u1,serial=SAULVM01,always-plugged=on \
  -msg timestamp=on -D "$modem_trace" -trace enable=serial_write -trace enable=usb_serial_handle_control \
  </dev/null >"$console" 2>"$vm/qemu.err"
qemu_rc=$?
set -e
boot_time=$(since "$t0")
wait "$peer" 2>/dev/null || true
peer=""

# ---- results ---------------------------------------------------------------------------------------------------------
# Console lines: strip CRs and whatever the BIOS left before a marker.
tr -d '\r' <"$console" | grep -a '@@VM' | sed 's/.*@@VM /@@VM /' >"$vm/markers.log" || true
passed=$(grep -c '^@@VM PASS ' "$vm/markers.log" || true)
failed=$(grep -c '^@@VM FAIL ' "$vm/markers.log" || true)
grep -a '^@@VM BOOT ' "$vm/markers.log" | sed 's/^@@VM /vm: /' || true
grep -a '^@@VM SETUP ' "$vm/markers.log" | sed 's/^@@VM SETUP /vm: guest setup problem:/' || true
awk '/^@@VM PASS / {sub(/^@@VM PASS /, ""); print "  pass  " $0}
     /^@@VM FAIL / {sub(/^@@VM FAIL /, ""); print "  FAIL  " $0}
     /^@@VM \| /   {sub(/^@@VM \| /, ""); print "        " $0}' "$vm/markers.log"
done_line=$(grep '^@@VM DONE ' "$vm/markers.log" || true)
verdict=ok
case $qemu_rc in
  1) ;;  # the guest wrote 0 to isa-debug-exit: all passed
  3) verdict=failures ;;
  124|137) verdict="QEMU timed out after ${boot_timeout} s"; failed=$((failed + 1)) ;;
  *) verdict="QEMU exited with status $qemu_rc"; failed=$((failed + 1)) ;;
esac
if [[ -z $done_line ]]; then
  [[ $verdict == ok || $verdict == failures ]] && failed=$((failed + 1))
  echo "vm: the guest did not finish ($verdict); last console lines:"
  tr -d '\r' <"$console" | tail -25 | sed 's/^/    /'
  [[ -s $vm/qemu.err ]] && sed 's/^/    qemu: /' "$vm/qemu.err"
elif [[ $qemu_rc == 1 && $failed != 0 ]] || [[ $qemu_rc == 3 && $failed == 0 ]]; then
  echo "vm: the guest's verdict (QEMU status $qemu_rc) disagrees with its markers"
  failed=$((failed + 1))
fi
# The flasher's reset sequences: the guest names the windows it bracketed ("@@VM MODEM CODE CASE"), the checker
# rebuilds DTR/RTS from QEMU's trace and compares them with each case's expected sequence (on the host: the guest
# cannot see its own modem lines).
modem_cases=$(sed -n 's/^@@VM MODEM \([0-9]*\) \([a-z0-9-]*\)$/\1:\2/p' "$vm/markers.log")
if [[ -n $modem_cases ]]; then
  modem_opts=()
  ((verbose)) && modem_opts+=(--verbose)
  # shellcheck disable=SC2086  # one CODE:CASE per word
  python3 "$root/tests/vm/check_modem_lines.py" "$modem_trace" $modem_cases "${modem_opts[@]}" \
    >"$vm/modem-check.log" 2>&1 || true
  sed 's/^/  /' "$vm/modem-check.log"
  mpass=$(grep -c '^pass ' "$vm/modem-check.log" || true)
  mfail=$(grep -c '^FAIL ' "$vm/modem-check.log" || true)
  mwant=$(wc -w <<<"$modem_cases")
  # A verdict per case, or the checker itself broke (its output above says how).
  ((mpass + mfail == mwant)) || mfail=$((mwant - mpass))
  passed=$((passed + mpass))
  failed=$((failed + mfail))
fi
((passed + failed > 0)) || failed=1
((verbose)) && { echo "vm: console:"; tr -d '\r' <"$console" | sed 's/^/    /'; }
((verbose)) && sed 's/^/vm: /' "$vm/echo-peer.log"
echo "vm: boot and tests $boot_time, total $(since "$t_start") (console: $console)"
echo "$passed passed, $failed failed"
[[ $failed == 0 ]]
