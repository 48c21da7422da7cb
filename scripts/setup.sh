#!/usr/bin/env bash
# Install what this project needs from Debian's packages, only what is missing.
# Safe to run again: it does nothing when everything is there.
#   scripts/setup.sh            build + test dependencies
#   scripts/setup.sh --build    only what building needs (scripts/test.sh installs the rest while it compiles)
#   scripts/setup.sh --test     only what the tests need beyond that, and the npm packages
#   SAUL_SKIP_EMBEDDED=1 ...    leave out the arm-none-eabi cross compiler (saves ~50 s)
set -euo pipefail
part=all
case "${1:-}" in
  --build) part=build; shift ;;
  --test) part=test; shift ;;
esac

# Building the libraries, saulctl, the simulator, the tests and the benchmarks (clang: the test preset's compiler).
build_packages=(
  cmake ninja-build g++ pkg-config
  clang libclang-rt-14-dev  # the test build (CMakePresets.json "test") and its ASan/UBSan runtimes; libFuzzer
  libcli11-dev libfmt-dev nlohmann-json3-dev libserialport-dev zlib1g-dev libzstd-dev
  libncurses-dev  # saulctl's full-screen views
  catch2 libbenchmark-dev
  nettle-dev  # MD5 of ESP flash regions (host/flash/esp_flasher.cpp)
  libfftw3-dev  # saulctl tune's FFTs (host/tune)
  liblz4-dev  # lz4 chunks of MCAP files (host/capture/mcap.cpp)
  libdeflate-dev  # fast CRC-32 of MCAP files (host/capture/mcap.cpp)
)
# Running the tests: interop tools, the browser, the VM, the package checks, the independent analysis.
test_packages=(
  tmux  # drives saulctl's full-screen views in tests/cli/views.sh
  python3-numpy python3-scipy  # the independent checks of saulctl tune (tests/tune)
  libjs-dygraphs gnuplot-nox chromium  # saulctl plot: HTML page, SVG/PNG/PDF reports; headless browser test
  zsh  # the zsh completion check (tests/cli/completion.sh)
  tshark python3-can can-utils  # interop checks of the capture formats (tests/cli/captures_interop.sh)
  sigrok-cli  # UART decodes of logic captures (tests/cli/uart_interop.sh, captures/make_sigrok_fixtures.sh)
  qemu-system-x86 busybox-static cpio kmod  # the real-kernel harness (tests/vm; can-utils too)
  pybind11-dev python3-pybind11 python3-dev python3-pytest  # the Python module and its tests (python/)
  help2man dpkg-dev man-db  # the .deb: man page, dpkg-shlibdeps, man -l on the page (packaging/, tests/package)
  lintian  # Debian's package checker on the .deb files (tests/package/deb.sh)
  strace  # counts the threads of decode's and stats' two-core paths (tests/cli/decode_fast.sh)
  time  # GNU time: the peak memory of tests/cli/memory_flat.sh (without it that test only says SKIP)
)
packages=()
[[ $part == test ]] || packages+=("${build_packages[@]}")
[[ $part == build ]] || packages+=("${test_packages[@]}")
if [[ $part != build && "${SAUL_SKIP_EMBEDDED:-0}" != 1 ]]; then
  packages+=(gcc-arm-none-eabi libstdc++-arm-none-eabi-newlib libnewlib-arm-none-eabi)
fi
packages+=("$@")

# npm packages the tests use (tests/npm/package.json): DuckDB's Node package for the long CSV check; @mcap/core,
# @mcap/support and ajv, the independent MCAP reader, writer and JSON Schema validator (tests/cli/mcap.sh).
# With the machine's Node.js and npm, from the npm registry; only when they are not there yet.
npm_packages() {
  local dir
  [[ $part != build ]] || return 0
  dir="$(cd "$(dirname "$0")/.." && pwd)/tests/npm"
  [[ -d $dir/node_modules/@duckdb/node-api && -d $dir/node_modules/@mcap/core && -d $dir/node_modules/@mcap/support &&
     -d $dir/node_modules/ajv ]] && return 0
  command -v npm >/dev/null || { echo "setup: npm missing (Node.js): tests/cli/long_csv.sh needs it" >&2; return 1; }
  echo "setup: installing npm packages in tests/npm"
  # No lock file: the one npm writes here records no download addresses and lacks the other platforms' bindings,
  # which makes npm ci refuse it; the version is pinned exactly in package.json (its bindings pin theirs).
  npm install --prefix "$dir" --no-package-lock --no-audit --no-fund --loglevel=error >/dev/null
}

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  npm_packages
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo=""
if [[ $(id -u) != 0 ]]; then
  command -v sudo >/dev/null || { echo "setup: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
# tshark's wireshark-common asks whether non-root users may capture: answer "no" up front so nothing prompts.
echo "wireshark-common wireshark-common/install-setuid boolean false" | $sudo debconf-set-selections
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
npm_packages
echo "setup: done"
