// A CAN frame's content (id, format, flags, DLC and the 8 data bytes; not its time) as two words, and a hash of it
// for direct-mapped caches of what is computed from the content alone (a rendered line, a decode, stuff bits):
// robot buses repeat the same frames, so such a cache answers most frames without computing anything. MemoJudge
// turns such a cache off where the frames do not repeat.
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

/// Whether a cache of frame contents is worth its lookups. Where contents never repeat (a counter, a timestamp,
/// random payloads) a lookup only costs: storing what will not be asked for again takes 1/10 of decode's time and
/// pushes out entries that would be. After kJudged lookups with fewer than 1 in 16 hits, use() says no for the next
/// kSkipped frames, then the cache is judged again. O(1), two compares per frame.
class MemoJudge {
 public:
  /// Whether to look in the cache for this frame (then say how it went to looked()).
  [[nodiscard]] bool use() noexcept {
    if (skip_ == 0) return true;
    --skip_;
    return false;
  }
  void looked(bool hit) noexcept {
    hits_ = static_cast<std::uint16_t>(hits_ + (hit ? 1 : 0));
    if (++probes_ < kJudged) return;
    if (hits_ < kJudged / 16) skip_ = kSkipped;
    probes_ = hits_ = 0;
  }

 private:
  static constexpr std::uint16_t kJudged = 256, kSkipped = 4096;
  std::uint16_t probes_ = 0, hits_ = 0, skip_ = 0;
};

}  // namespace saul::host
