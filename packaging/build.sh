#!/usr/bin/env bash
# Builds what is installed and packaged, in a release build of its own: the libraries, saulctl with its completion
# and man page, the Python module for Debian's /usr/bin/python3; then the .deb files (CPack): saulctl,
# libsaulproto-dev, python3-saulproto. tests/package runs it in CI.
#   packaging/build.sh [BUILD_DIR]      default build-package/; the packages land in BUILD_DIR/deb/
#   SAUL_PACKAGE_FLAGS="-O2"            the compiler's optimisation (CMAKE_CXX_FLAGS_RELEASE), default -O2
#   JOBS=N                              parallel compile jobs, default nproc
# saulctl links Debian's shared libraries here (SAUL_LEAN_LINK off): a zlib or ncurses security update reaches it.
# Install one:  sudo apt install ./build-package/deb/saulctl_*.deb
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dir=${1:-$root/build-package}
cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="${SAUL_PACKAGE_FLAGS:--O2} -DNDEBUG" \
      -DCMAKE_INSTALL_PREFIX=/usr -DSAUL_PACKAGE=ON -DSAUL_PYTHON=ON -DPython_EXECUTABLE=/usr/bin/python3 \
      -DSAUL_BUILD_TESTS=OFF -DSAUL_BUILD_BENCH=OFF -DSAUL_SANITIZE=OFF -DSAUL_WERROR=ON \
      -DSAUL_LEAN_LINK=OFF >/dev/null
cmake --build "$dir" -j "${JOBS:-$(nproc)}"
rm -rf "$dir/deb"
(cd "$dir" && cpack -G DEB >/dev/null)
ls "$dir"/deb/*.deb
