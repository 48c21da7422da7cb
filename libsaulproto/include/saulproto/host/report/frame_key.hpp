// A CAN frame's content (id, format, flags, DLC and the 8 data bytes; not its time) as two words, and a hash of it
// for direct-mapped caches of what is computed from the content alone (a rendered line, a decode, stuff bits):
// robot buses repeat the same frames, so such a cache answers most frames without computing anything.
#pragma once

#include <cstddef>
#include <cstdint>

#include "saulproto/core/can_frame.hpp"

namespace saul::host {

struct FrameKey {
  std::uint64_t k1 = 0;  ///< id | extended << 32 | remote << 33 | error << 34 | dlc << 40
  std::uint64_t k2 = 0;  ///< data[0..7], data[0] lowest
  friend bool operator==(const FrameKey&, const FrameKey&) = default;
  /// The slot in a table of `size` entries (a power of two).
  [[nodiscard]] std::size_t slot(std::size_t size) const noexcept {
    const std::uint64_t h = (k1 * 0x9E3779B97F4A7C15ULL) ^ (k2 * 0xC2B2AE3D27D4EB4FULL);
    return static_cast<std::size_t>(h ^ (h >> 29)) & (size - 1);
  }
};

inline FrameKey frame_key(const CanFrame& f) noexcept {
  FrameKey k;
  k.k1 = std::uint64_t{f.id} | std::uint64_t{f.extended} << 32 | std::uint64_t{f.remote} << 33 |
         std::uint64_t{f.error} << 34 | std::uint64_t{f.dlc} << 40;
  for (std::size_t i = 0; i < 8; ++i) k.k2 |= std::uint64_t{f.data[i]} << (8 * i);
  return k;
}

}  // namespace saul::host
