#include "saulproto/core/rc_input.hpp"

namespace saul::rc {
namespace {

// Scales a permille by the cap, truncating toward zero so the result never exceeds the cap.
std::int16_t capped(std::int16_t permille, std::uint8_t cap_pct) noexcept {
  return static_cast<std::int16_t>(static_cast<std::int32_t>(permille) * cap_pct / 100);
}

}  // namespace

Command map_channels(const Channels& us) noexcept {
  Command c;
  c.estop = us[kEstopChannel] > kMidUs;  // first, every time
  c.armed = us[kArmChannel] > kMidUs;
  c.speed_cap_pct = speed_cap_pct(us[kSpeedChannel]);
  if (c.estop) return c;  // throttle and steer stay 0
  const std::uint8_t cap = c.speed_cap_pct;
  c.throttle = capped(stick_permille(us[kThrottleChannel]), cap);
  // Stick right (CH1 > 1500) is a right turn, which is negative steer in the REP-103 sense of 0x300.
  c.steer = capped(static_cast<std::int16_t>(-stick_permille(us[kSteerChannel])), cap);
  return c;
}

interboard::RcCmd to_rc_cmd(const Command& command) noexcept {
  std::uint8_t flags = 0;
  if (command.armed) flags |= interboard::RcCmd::kArmed;
  if (command.estop) flags |= interboard::RcCmd::kKill;
  return {command.throttle, command.steer, flags};
}

const char* to_string(Source source) noexcept {
  switch (source) {
    case Source::none: return "none";
    case Source::crsf: return "crsf";
    case Source::elrs: return "elrs";
  }
  return "unknown";
}

bool ReceiverSelector::alive(const Link& link, std::uint64_t now_us) noexcept {
  if (!link.seen) return false;
  const std::uint64_t age = now_us >= link.last_us ? now_us - link.last_us : 0;
  return age <= kSilenceUs;
}

void ReceiverSelector::on_frame(Source source, std::uint64_t now_us) noexcept {
  Link* link = source == Source::crsf ? &crsf_ : (source == Source::elrs ? &elrs_ : nullptr);
  if (link == nullptr) return;
  if (!alive(*link, now_us)) link->streak_start_us = now_us;  // first frame after a gap (or ever)
  link->last_us = now_us;
  link->seen = true;
  update(now_us);
}

void ReceiverSelector::update(std::uint64_t now_us) noexcept {
  const bool crsf = alive(crsf_, now_us);
  const bool elrs = alive(elrs_, now_us);
  switch (active_) {
    case Source::none:
    case Source::crsf:
      active_ = crsf ? Source::crsf : (elrs ? Source::elrs : Source::none);
      break;
    case Source::elrs: {
      // Held = how long CRSF's frames have been arriving without a gap: measured to its last frame, not to
      // now, so one lone frame (alive for 100 ms after it) never counts as 100 ms of service.
      const std::uint64_t held =
          crsf_.last_us >= crsf_.streak_start_us ? crsf_.last_us - crsf_.streak_start_us : 0;
      if (crsf && (held >= kReturnHoldUs || !elrs)) {
        active_ = Source::crsf;
      } else if (!elrs) {
        active_ = Source::none;
      }
      break;
    }
  }
}

}  // namespace saul::rc
