// Receiver side of 0x301 PID tuning: three frames (Kp, Ki, Kd) of one sequence number become one set,
// applied all at once or not at all.
//
// Rules (docs/protocol.md, 0x301):
//  - a set is complete when indices 0, 1 and 2 of one sequence number arrived within 100 ms of its first frame;
//  - a frame of another sequence number, or one arriving after the window, discards the staged set
//    (incomplete) and starts a new one;
//  - a repeated index inside the set replaces the earlier value;
//  - a complete set with a NaN, infinite or negative gain is discarded as a whole (out_of_range).
// Each set ends in exactly one outcome, so BALANCE sends exactly one 0x402 per set.
//
// Time comes in as a monotonic microsecond count from the caller; the stager never reads a clock.
// O(1) per call, 24 bytes of state, no allocation.
#pragma once

#include <cstdint>

#include "saulproto/core/saul_can.hpp"

namespace saul::saulcan {

struct PidGains {
  float kp = 0.0F;
  float ki = 0.0F;
  float kd = 0.0F;
  constexpr bool operator==(const PidGains&) const = default;
};

/// What happened to a set. At most one set ends per call.
struct StagerOutcome {
  enum class Kind : std::uint8_t {
    none,       ///< nothing ended (frame staged, or nothing to expire)
    applied,    ///< gains holds a complete, valid set: apply it now
    discarded,  ///< the set with `sequence` was dropped; result says why (incomplete or out_of_range)
  };
  Kind kind = Kind::none;
  std::uint8_t sequence = 0;
  PidGains gains{};
  AckResult result = AckResult::applied;  ///< for the 0x402 acknowledgement
  constexpr bool operator==(const StagerOutcome&) const = default;
};

class PidStager {
 public:
  static constexpr std::uint64_t kWindowUs = 100'000;

  /// Takes one decoded 0x301 frame received at now_us. Returns the set it completes (applied or discarded),
  /// or the older set it ends (discarded, incomplete), or none. Both cannot happen at once: a frame that
  /// ends an older set starts a new one, which holds one gain and so cannot be complete.
  StagerOutcome accept(const PidGain& gain, std::uint64_t now_us) noexcept;

  /// Call periodically (e.g. every control loop): discards a set whose window has passed.
  StagerOutcome poll(std::uint64_t now_us) noexcept;

  [[nodiscard]] bool staging() const noexcept { return active_; }

 private:
  StagerOutcome discard_staged() noexcept;

  float values_[3] = {0, 0, 0};
  std::uint64_t started_us_ = 0;
  std::uint8_t sequence_ = 0;
  std::uint8_t have_ = 0;  // bit i = index i staged
  bool active_ = false;
};

}  // namespace saul::saulcan
