#!/usr/bin/env bash
# Builds the unit and firmware test executables with g++ -fsanitize=address,undefined (-O1) in a build dir of
# their own and runs each once: any ASan/UBSan report fails.
#   tests/fuzz/sanitize.sh [BUILD_DIR]      default: build-asan at the repository root
#   SANITIZE_BUILD_JOBS=1 (compile jobs)
#   SANITIZE_FIRMWARE=1: the firmware tests too (ctest leaves them out: ~4.5 min CPU to build both and 2 min CPU,
#   5 min wall on 2 busy cores, to run the firmware scenarios under ASan; the unit tests alone run in 1-2 s)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build-asan}
flags="-O1 -fsanitize=address,undefined -fno-omit-frame-pointer"  # -O1 after Debug's -g: quicker to build and run
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DSAUL_BUILD_TESTS=ON -DSAUL_BUILD_BENCH=OFF \
  -DSAUL_VM_TEST=OFF -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
tests=(unit/saul_unit_tests)
[[ ${SANITIZE_FIRMWARE:-0} == 1 ]] && tests+=(firmware/saul_firmware_tests)
cmake --build "$build" -j "${SANITIZE_BUILD_JOBS:-1}" --target "${tests[@]#*/}" >/dev/null
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1  # any UB report ends the run with an error
failed=0
for t in "${tests[@]}"; do
  exe="$build/tests/${t#*/}"
  [[ -x $exe ]] || exe=$(find "$build" -name "${t#*/}" -type f -perm -u+x | head -1)
  start=$SECONDS
  if "$exe" >"$build/${t#*/}.log" 2>&1; then
    echo "${t#*/} under ASan+UBSan: ok ($(grep -E "test cases" "$build/${t#*/}.log" | tail -1)) in $((SECONDS - start)) s"
  else
    echo "${t#*/} under ASan+UBSan: FAILED, see $build/${t#*/}.log"
    grep -E "ERROR|runtime error|SUMMARY|FAILED" "$build/${t#*/}.log" | head -10 | sed 's/^/    /'
    failed=1
  fi
done
exit $failed
