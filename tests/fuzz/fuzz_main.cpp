// libFuzzer's entry points for the one fuzz program, saul_fuzz (tests/fuzz/CMakeLists.txt): the environment variable
// SAUL_FUZZ_TARGET names the target (fuzz_targets.inc) it runs; tests/fuzz/run.sh sets it for each. One program for
// every target, not one per target: CI's cold build compiles each source once and links once (24 links of the
// sanitized readers were over half of the fuzz test's build).
#include <cstdio>
#include <cstdlib>

#include "fuzz_targets.hpp"

namespace {
const saul::fuzz::Target* target = nullptr;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* name = std::getenv("SAUL_FUZZ_TARGET");
  target = saul::fuzz::find_target(name ? name : "");
  if (!target) {
    std::fprintf(stderr, "saul_fuzz: set SAUL_FUZZ_TARGET to one of the targets:");
    for (const auto& t : saul::fuzz::kTargets)
      std::fprintf(stderr, " %.*s", static_cast<int>(t.name.size()), t.name.data());
    std::fprintf(stderr, "\n");
    std::exit(2);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { return target->run(data, size); }
