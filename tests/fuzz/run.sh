#!/usr/bin/env bash
# Builds the libFuzzer program saul_fuzz (tests/fuzz/CMakeLists.txt) with clang, ASan and UBSan into its own build dir
# and runs each of its targets (fuzz_targets.inc; SAUL_FUZZ_TARGET picks one) for a bounded time, starting from its
# seed corpus in tests/fuzz/corpus/<target>/.
#   tests/fuzz/run.sh [--build-dir DIR] [TARGET...]      default: build-fuzz at the repository root, every target
#   FUZZ_SECONDS=10 (per target), FUZZ_SEED=N (libFuzzer's -seed; default 0 = a new random seed each run; the ctest
#   run uses a fixed one so that CI explores the same inputs every time and does not fail at random)
# New inputs found go to DIR/corpus/<target>/ (the seeds in the repository are left alone). A crash, leak, timeout
# or sanitizer report fails the target; its input is saved as DIR/crashes/<target>/crash-* (libFuzzer names it)
# and the path is printed. Ends with "N passed, N failed"; exit 1 when any failed.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build="$root/build-fuzz"
if [[ ${1:-} == --build-dir ]]; then build=$2; shift 2; fi
seconds=${FUZZ_SECONDS:-10}

command -v clang++ >/dev/null || { echo "fuzz: clang++ missing (scripts/setup.sh installs it)" >&2; exit 1; }
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=None >/dev/null || exit 1
cmake --build "$build" -j "${FUZZ_BUILD_JOBS:-1}" >/dev/null || { echo "fuzz: build failed" >&2; exit 1; }

# Largest input per target: a few frames for the stream decoders, a few records for the readers.
declare -A max_len=(
  [interboard]=256 [trace]=512 [pride]=256 [crsf]=512 [dispatch]=416 [console]=256 [slcan]=256 [esp_slip]=512
  [capture_candump]=4096 [capture_pcap]=4096 [capture_pcapng]=4096 [capture_asc]=4096
  [capture_blf]=4096 [capture_trc]=4096 [capture_csv]=4096 [capture_gvret_csv]=4096 [capture_mcap]=4096
  [compressed_gzip]=4096 [compressed_zstd]=4096
  [serial_serial]=4096 [serial_sigrok]=4096 [serial_sigrok_json]=8192 [serial_pulseview_csv]=4096
  [suite]=4096
)
targets=("$@")
# Every target of the program (the list it is built from: a list kept here once let two targets go unrun for weeks).
((${#targets[@]})) || targets=($(sed -n 's/^SAUL_FUZZ_TARGET(\(.*\))$/\1/p' "$here/fuzz_targets.inc"))

passed=0 failed=0
for t in "${targets[@]}"; do
  if ! grep -qx "SAUL_FUZZ_TARGET($t)" "$here/fuzz_targets.inc"; then
    echo "fuzz_$t: no such target"
    failed=$((failed + 1))
    continue
  fi
  work="$build/corpus/$t" crashes="$build/crashes/$t"
  mkdir -p "$work" "$crashes"
  log="$build/fuzz_$t.log"
  SAUL_FUZZ_TARGET=$t "$build/saul_fuzz" "$work" "$here/corpus/$t" -seed="${FUZZ_SEED:-0}" \
    -max_total_time="$seconds" -max_len="${max_len[$t]:-4096}" -timeout=5 \
    -rss_limit_mb=1024 -print_final_stats=1 -artifact_prefix="$crashes/" >"$log" 2>&1
  rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  if ((rc == 0)); then
    passed=$((passed + 1))
    printf 'fuzz_%-22s ok    %10s executions in %ss\n' "$t" "${execs:-?}" "$seconds"
  else
    failed=$((failed + 1))
    printf 'fuzz_%-22s FAIL  %10s executions (exit %d)\n' "$t" "${execs:-?}" "$rc"
    grep -E "ERROR|runtime error|SUMMARY|Test unit written" "$log" | head -8 | sed 's/^/    /'
    echo "    log: $log; again: SAUL_FUZZ_TARGET=$t $build/saul_fuzz $crashes/crash-*"
    echo "    after the fix, keep the input as a regression test: cp $crashes/crash-* $here/regression/$t/"
  fi
done
echo "$passed passed, $failed failed"
((failed == 0))
