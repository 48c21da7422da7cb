// Shared helpers of the libFuzzer targets (tests/fuzz/run.sh builds and runs them).
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

namespace saul::fuzz {

/// Chunk sizes for the "same input, different chunking" checks: a fixed cycle so every run is reproducible.
inline std::size_t chunk_size(std::size_t i) {
  constexpr std::size_t kSizes[] = {1, 7, 3, 64, 2, 13, 255, 5};
  return kSizes[i % (sizeof kSizes / sizeof kSizes[0])];
}

/// Calls feed(span) on consecutive pieces of data.
template <class F>
void in_chunks(std::span<const std::uint8_t> data, F&& feed) {
  std::size_t at = 0;
  for (std::size_t i = 0; at < data.size(); ++i) {
    std::size_t n = chunk_size(i);
    if (n > data.size() - at) n = data.size() - at;
    feed(data.subspan(at, n));
    at += n;
  }
}

/// A property failed: abort so libFuzzer records the input.
[[noreturn]] inline void fail() { std::abort(); }

}  // namespace saul::fuzz

/// The target saul_fuzz_<prefix>_<format> (fuzz_targets.inc): check(CaptureFormat::<format>, data, size).
#define SAUL_FUZZ_FORMAT_TARGET(prefix, check, format)                                     \
  extern "C" int saul_fuzz_##prefix##_##format(const std::uint8_t* data, std::size_t size) { \
    return check(saul::host::CaptureFormat::format, data, size);                           \
  }
