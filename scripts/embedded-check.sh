#!/usr/bin/env bash
# Builds libsaulproto's core for a Cortex-M4 with arm-none-eabi-g++ (standing in for the ESP32-S3's xtensa
# toolchain, which Debian does not package), links it into a small program, and prints the sizes.
# Fails if the core stops compiling without exceptions/RTTI or needs anything a microcontroller lacks.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/build/embedded}
CXX=${ARM_CXX:-arm-none-eabi-g++}
command -v "$CXX" >/dev/null || { echo "embedded-check: $CXX not found; run scripts/setup.sh" >&2; exit 1; }
mkdir -p "$out"
# Headers of the core are what firmware includes: no allocation-based or stream containers in them.
if grep -nE '#include <(string|vector|map|memory|iostream|sstream|fstream|functional|list|deque)>' \
     "$root"/libsaulproto/include/saulproto/core/*.hpp "$root"/firmware/logic/include/saulfw/*.hpp \
     "$root"/firmware/logic/*.cpp; then
  echo "embedded-check: FAIL: a core or firmware logic file includes a heap or iostream header (above)" >&2
  exit 1
fi
# ESP-IDF's placement attributes (DMA_ATTR, DRAM_ATTR, ...) name a section of their own at each use (__COUNTER__):
# on both a static member's declaration in its class and its definition, GCC warns "ignoring attribute section ...
# conflicts with previous" (the ESP-IDF build does not run here). One of them carries it: the definition.
while IFS= read -r hit; do
  name=$(sed -nE 's/.*_ATTR static [^;]*[^A-Za-z0-9_]([A-Za-z_][A-Za-z0-9_]*) *(\[[^;]*)?;.*/\1/p' <<<"${hit#*:*:}")
  file=${hit%%:*} line=${hit#*:}
  if [[ -n $name ]] && grep -qE "_ATTR [^;]*::$name\b" "$file"; then
    echo "embedded-check: FAIL: $file:${line%%:*}: $name has its placement attribute on its declaration and its" \
         "definition: keep the definition's" >&2
    exit 1
  fi
done < <(grep -nE '_ATTR static ' "$root"/firmware/*/main/*.cpp)
flags=(-std=c++20 -mcpu=cortex-m4 -mthumb -Os -fno-exceptions -fno-rtti -ffunction-sections -fdata-sections
       -Wall -Wextra -Werror -I "$root/libsaulproto/include")
objs=()
for src in "$root"/libsaulproto/src/core/*.cpp; do
  obj="$out/$(basename "${src%.cpp}").o"
  "$CXX" "${flags[@]}" -c "$src" -o "$obj"
  objs+=("$obj")
done
rm -f "$out/libsaulproto_core.a"
arm-none-eabi-ar rcs "$out/libsaulproto_core.a" "${objs[@]}"
"$CXX" "${flags[@]}" --specs=nano.specs --specs=nosys.specs -Wl,--gc-sections \
  "$root/tests/embedded/link_check.cpp" "$out/libsaulproto_core.a" -o "$out/link_check.elf"
echo "embedded-check: core objects (arm-none-eabi, cortex-m4, -Os):"
arm-none-eabi-size -t "${objs[@]}" | sed "s#$out/##"
echo "embedded-check: linked test program:"
arm-none-eabi-size "$out/link_check.elf" | sed "s#$out/##"
# The core must not drag in exception or RTTI support.
if arm-none-eabi-nm -C "$out/link_check.elf" | grep -E '__cxa_throw|__cxa_allocate_exception|typeinfo for' >/dev/null; then
  echo "embedded-check: FAIL: exception or RTTI symbols linked into the core" >&2
  exit 1
fi
# The firmware logic of both boards (firmware/logic), built the same way on top of the core, then linked with
# stub hardware (tests/embedded/firmware_check.cpp): no exceptions, no RTTI, and no heap at all.
fw_objs=()
for src in "$root"/firmware/logic/*.cpp; do
  obj="$out/firmware_$(basename "${src%.cpp}").o"
  "$CXX" "${flags[@]}" -I "$root/firmware/logic/include" -c "$src" -o "$obj"
  fw_objs+=("$obj")
done
rm -f "$out/libsaul_firmware_logic.a"
arm-none-eabi-ar rcs "$out/libsaul_firmware_logic.a" "${fw_objs[@]}"
"$CXX" "${flags[@]}" -I "$root/firmware/logic/include" --specs=nano.specs --specs=nosys.specs -Wl,--gc-sections \
  "$root/tests/embedded/firmware_check.cpp" "$out/libsaul_firmware_logic.a" "$out/libsaulproto_core.a" \
  -o "$out/firmware_check.elf"
echo "embedded-check: firmware logic objects (arm-none-eabi, cortex-m4, -Os):"
arm-none-eabi-size -t "${fw_objs[@]}" | sed "s#$out/##"
echo "embedded-check: linked firmware program (BALANCE and IO logic on stub hardware):"
arm-none-eabi-size "$out/firmware_check.elf" | sed "s#$out/##"
if arm-none-eabi-nm -C "$out/firmware_check.elf" | grep -E '__cxa_throw|__cxa_allocate_exception|typeinfo for' >/dev/null; then
  echo "embedded-check: FAIL: exception or RTTI symbols linked into the firmware logic" >&2
  exit 1
fi
# (newlib's own abort and atexit bring _malloc_r into any program, so look at what our objects ask for.)
if arm-none-eabi-nm -C -u "${fw_objs[@]}" "${objs[@]}" | grep -E ' (malloc|calloc|realloc|free|_malloc_r|operator new)' >/dev/null; then
  echo "embedded-check: FAIL: the firmware logic or the core calls the heap" >&2
  exit 1
fi
echo "embedded-check: ok"
