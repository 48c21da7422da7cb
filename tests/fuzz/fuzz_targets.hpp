// The fuzz targets by name (fuzz_targets.inc), for the two programs that run them: the libFuzzer program
// (fuzz_main.cpp, tests/fuzz/run.sh) and the corpus replay of the test build (replay_corpus.cpp).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string_view>

#define SAUL_FUZZ_TARGET(name) extern "C" int saul_fuzz_##name(const std::uint8_t* data, std::size_t size);
#include "fuzz_targets.inc"
#undef SAUL_FUZZ_TARGET

namespace saul::fuzz {

struct Target {
  std::string_view name;
  int (*run)(const std::uint8_t*, std::size_t);
};

inline constexpr Target kTargets[] = {
#define SAUL_FUZZ_TARGET(name) {#name, saul_fuzz_##name},
#include "fuzz_targets.inc"
#undef SAUL_FUZZ_TARGET
};

/// The target of that name, or nullptr.
inline const Target* find_target(std::string_view name) {
  for (const Target& t : kTargets)
    if (t.name == name) return &t;
  return nullptr;
}

}  // namespace saul::fuzz
