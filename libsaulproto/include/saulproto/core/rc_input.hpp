// RC input on the IO board: the system reference's channel map, and the choice between the two receivers.
//
// Channel map (channels in microseconds, index 0 = CH1; crsf::channels_us() gives them from a CRSF frame):
//   CH6 ESTOP  > 1500 us = kill. Evaluated first: when set, throttle and steer are 0 whatever else says.
//   CH5 ARM    > 1500 us = armed. Exactly 1500 is neither armed nor estop (strictly greater).
//   CH7 speed cap, 988..2012 us -> 10..100 % in 10 % steps (speed_cap_pct).
//   CH2 throttle, CH1 steer: 988..2012 us -> -1000..+1000 permille (stick_permille), then scaled by the cap,
//   which is what RC_CMD carries (docs/protocol.md: permille after the CH7 cap).
//
// Receiver selection (docs/protocol.md, limits and timing): CRSF on UART0 is primary; ELRS on UART2 takes over
// when CRSF has given no valid frame for more than 100 ms and ELRS has; neither for more than 100 ms is
// rc_loss. See ReceiverSelector.
//
// Everything is O(1), allocation-free and reads no clock: time comes from the caller.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "saulproto/core/interboard.hpp"

namespace saul::rc {

inline constexpr std::uint16_t kMinUs = 988;
inline constexpr std::uint16_t kMidUs = 1500;
inline constexpr std::uint16_t kMaxUs = 2012;
/// Stick deadband: |us - 1500| <= 5 us gives 0. The receivers resolve 0.625 us per tick and a centred stick
/// jitters by a tick or two; 5 us (8 ticks, 1 % of half travel) stops a centred stick creeping the robot
/// without a noticeable dead zone. Outside it the scale restarts at 0, so the output has no step.
inline constexpr std::uint16_t kDeadbandUs = 5;
inline constexpr std::size_t kChannelCount = 16;

/// Channel indices (0-based) of the functions in the system reference's table.
inline constexpr std::size_t kSteerChannel = 0;     ///< CH1
inline constexpr std::size_t kThrottleChannel = 1;  ///< CH2
inline constexpr std::size_t kArmChannel = 4;       ///< CH5
inline constexpr std::size_t kEstopChannel = 5;     ///< CH6
inline constexpr std::size_t kSpeedChannel = 6;     ///< CH7

using Channels = std::array<std::uint16_t, kChannelCount>;  ///< microseconds, index 0 = CH1

/// What the sticks and switches ask for.
struct Command {
  static constexpr const char* kName = "rc_command";
  std::int16_t throttle = 0;       ///< permille after the cap, + = forward (stick up, CH2 > 1500)
  std::int16_t steer = 0;          ///< permille after the cap, + = turn left (REP-103), i.e. CH1 < 1500
  std::uint8_t speed_cap_pct = 10;  ///< 10..100, from CH7
  bool armed = false;              ///< CH5 > 1500, reported as is even during estop (see map_channels)
  bool estop = false;              ///< CH6 > 1500
  template <class V> constexpr void fields(V&& v) const {
    v("throttle", throttle); v("steer", steer); v("speed_cap_pct", speed_cap_pct); v("armed", armed);
    v("estop", estop);
  }
  constexpr bool operator==(const Command&) const = default;
};

/// A stick channel as permille, before any cap: clamped to 988..2012 us, deadband around 1500, then linear,
/// truncated toward zero (never rounds a small deflection up). 988 -> -1000, 1500 -> 0, 2012 -> +1000.
constexpr std::int16_t stick_permille(std::uint16_t us) noexcept {
  const std::int32_t clamped = us < kMinUs ? kMinUs : (us > kMaxUs ? kMaxUs : us);
  const std::int32_t d = clamped - kMidUs;  // -512..+512
  const std::int32_t a = d < 0 ? -d : d;
  if (a <= kDeadbandUs) return 0;
  const std::int32_t half = kMaxUs - kMidUs - kDeadbandUs;  // 507
  const std::int32_t p = (a - kDeadbandUs) * 1000 / half;
  return static_cast<std::int16_t>(d < 0 ? -p : p);
}

/// CH7 as a speed cap: linear 988 us -> 10 %, 2012 us -> 100 %, rounded to the nearest 10 % step, a tie
/// going to the lower cap (the safer one); clamped outside 988..2012. So 988 -> 10, 1500 -> 50 (55 %
/// exactly, a tie), 2012 -> 100; 20 % from 1045 us, 100 % from 1956 us.
constexpr std::uint8_t speed_cap_pct(std::uint16_t us) noexcept {
  const std::int32_t clamped = us < kMinUs ? kMinUs : (us > kMaxUs ? kMaxUs : us);
  const std::int32_t x = clamped - kMinUs;     // 0..1024
  const std::int32_t step = (9 * x + 511) / 1024;  // round(9x / 1024), ties down: 0..9
  return static_cast<std::uint8_t>(10 + 10 * step);
}

/// The channel map. Pure; O(1).
/// ESTOP is evaluated first: with CH6 > 1500 the command has estop set and throttle = steer = 0. armed is
/// still CH5's position: forcing it false would turn the release of ESTOP, with the arm switch still up,
/// into a disarm -> arm edge, which the BALANCE board would take for the fresh arming that leaves ESTOP.
Command map_channels(const Channels& us) noexcept;

/// The inter-board RC_CMD carrying a command: throttle, steer, flags armed (bit0) and kill (bit1 = estop).
interboard::RcCmd to_rc_cmd(const Command& command) noexcept;

// ---------------------------------------------------------------------------------------------------------

enum class Source : std::uint8_t { none = 0, crsf = 1, elrs = 2 };
const char* to_string(Source source) noexcept;

/// Which receiver drives the robot.
///
/// Call on_frame(source, now) for every valid RC_CHANNELS_PACKED frame from that UART (not for link
/// statistics: they can keep coming while no stick data does), and update(now) at least once per control
/// loop. A receiver is "alive" while its last valid frame is at most kSilenceUs old: silent for *more than*
/// 100 ms means dead, so a frame exactly 100 ms old still counts. A receiver that never sent a frame is dead.
///
///   none (rc_loss) -> CRSF as soon as CRSF is alive; else -> ELRS as soon as ELRS is alive.
///   CRSF -> ELRS when CRSF is dead and ELRS alive; -> none when both are dead.
///   ELRS -> CRSF when CRSF is alive and its frames have been coming without a gap of more than 100 ms
///           for at least kReturnHoldUs (first to latest frame of the run), or at once if ELRS itself is
///           dead; -> none when both are dead.
/// The hold is the only hysteresis: a flaky CRSF that comes and goes does not flip the robot between two
/// radios on every frame. rc_loss() is true exactly when no source is active, including at start-up.
/// Timestamps are monotonic microseconds from the caller; one that goes backwards counts as age 0.
/// O(1), 56 bytes of state.
class ReceiverSelector {
 public:
  static constexpr std::uint64_t kSilenceUs = 100'000;
  static constexpr std::uint64_t kReturnHoldUs = 100'000;

  void on_frame(Source source, std::uint64_t now_us) noexcept;
  void update(std::uint64_t now_us) noexcept;

  [[nodiscard]] Source active() const noexcept { return active_; }
  [[nodiscard]] bool rc_loss() const noexcept { return active_ == Source::none; }

 private:
  struct Link {
    std::uint64_t last_us = 0;          // last valid frame
    std::uint64_t streak_start_us = 0;  // first frame after the last gap of more than kSilenceUs
    bool seen = false;
  };
  static bool alive(const Link& link, std::uint64_t now_us) noexcept;

  Link crsf_{};
  Link elrs_{};
  Source active_ = Source::none;
};

}  // namespace saul::rc
