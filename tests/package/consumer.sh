#!/usr/bin/env bash
# The C++ package as the Orin's code uses it: 'cmake --install' of the dev component into a temporary prefix, then
# tests/package/consumer (find_package(saulproto), targets saulproto::core and saulproto::host) configured with
# only that prefix, built and run; then the same two programs built with pkg-config alone.
#   consumer.sh SOURCE_DIR PACKAGE_BUILD_DIR      (PACKAGE_BUILD_DIR: made by packaging/build.sh)
set -euo pipefail
src=$1 pkg=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
cmake --install "$pkg" --prefix "$prefix" --component dev >/dev/null

# Nothing installed may point back into the source or build tree.
if grep -rl -e "$src" -e "$pkg" "$prefix"; then
  echo "FAIL: the files above refer to $src or $pkg"; exit 1
fi
for f in include/saulproto/core/saul_can.hpp include/saulproto/host/capture/capture.hpp; do
  [[ -f $prefix/$f ]] || { echo "FAIL: $f not installed"; exit 1; }
done

# Counts of the sample capture, by grep (independent of the library): 0x400 and 0x401 lines, and all frames.
log=$src/captures/robot_bus.log
want="frames=$(grep -c '^(' "$log") telemetry_a=$(grep -c ' can0 400#' "$log") telemetry_b=$(grep -c ' can0 401#' "$log")"
sum=0
for data in $(grep ' can0 400#' "$log" | sed 's/.*#//'); do  # pitch_x100: the first two bytes, little-endian int16
  pitch=$(( 16#${data:2:2}${data:0:2} ))
  ((pitch < 32768)) || pitch=$((pitch - 65536))
  sum=$((sum + pitch))
done
want="$want pitch_x100_sum=$sum"

run_pair() {  # run_pair HOW DIR: both programs of one build
  local how=$1 dir=$2
  "$dir/orin_node"
  local got
  got=$("$dir/capture_tool" "$log")
  [[ $got == "$want" ]] || { echo "FAIL ($how): capture_tool says '$got', grep says '$want'"; exit 1; }
  echo "capture_tool ($how): $got"
}

echo "== CMake: find_package(saulproto) with CMAKE_PREFIX_PATH=$prefix only"
cmake -S "$src/tests/package/consumer" -B "$tmp/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >/dev/null
cmake --build "$tmp/build" >/dev/null
run_pair cmake "$tmp/build"

echo "== pkg-config: saulproto-core, saulproto"
pcdir=$(dirname "$(find "$prefix" -name saulproto.pc)")
export PKG_CONFIG_PATH=$pcdir
mkdir -p "$tmp/pc"
# shellcheck disable=SC2046
c++ -std=c++20 -O1 "$src/tests/package/consumer/orin_node.cpp" $(pkg-config --cflags --libs saulproto-core) -o "$tmp/pc/orin_node"
# shellcheck disable=SC2046
c++ -std=c++20 -O1 "$src/tests/package/consumer/capture_tool.cpp" $(pkg-config --cflags --libs saulproto) -o "$tmp/pc/capture_tool"
run_pair pkg-config "$tmp/pc"
echo "consumer: ok"
