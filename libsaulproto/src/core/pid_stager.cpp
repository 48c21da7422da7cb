#include "saulproto/core/pid_stager.hpp"

#include <cmath>

namespace saul::saulcan {

StagerOutcome PidStager::discard_staged() noexcept {
  StagerOutcome out;
  out.kind = StagerOutcome::Kind::discarded;
  out.sequence = sequence_;
  out.result = AckResult::incomplete;
  active_ = false;
  have_ = 0;
  return out;
}

StagerOutcome PidStager::poll(std::uint64_t now_us) noexcept {
  if (active_ && now_us - started_us_ > kWindowUs) return discard_staged();
  return {};
}

StagerOutcome PidStager::accept(const PidGain& gain, std::uint64_t now_us) noexcept {
  StagerOutcome ended;
  if (active_ && (gain.sequence != sequence_ || now_us - started_us_ > kWindowUs)) ended = discard_staged();
  if (!active_) {
    active_ = true;
    sequence_ = gain.sequence;
    started_us_ = now_us;
    have_ = 0;
  }
  const auto index = static_cast<std::uint8_t>(gain.index);
  if (index > 2) return ended;  // decode_pid_gain never yields this; ignore rather than index out of bounds
  values_[index] = gain.value;
  have_ = static_cast<std::uint8_t>(have_ | (1U << index));
  if (have_ != 0x7) return ended;

  StagerOutcome out;
  out.sequence = sequence_;
  active_ = false;
  have_ = 0;
  for (float v : values_) {
    if (!std::isfinite(v) || v < 0.0F) {
      out.kind = StagerOutcome::Kind::discarded;
      out.result = AckResult::out_of_range;
      return out;
    }
  }
  out.kind = StagerOutcome::Kind::applied;
  out.result = AckResult::applied;
  out.gains = PidGains{values_[0], values_[1], values_[2]};
  return out;
}

}  // namespace saul::saulcan
