// Acting as the VCU on the Pride ES link (core/pride.hpp): one frame every 5 ms on absolute deadlines, our own
// echo (one wire) filtered out before decoding, the controller's frames handed to the caller, and neutral
// frames (FB 0, LR 0) for a while before leaving. Time and the port come from outside, so tests run it on a
// fake clock and a fake port; saulctl drives it with the steady clock and a real serial port.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>

#include "saulproto/core/pride.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

/// Where the VCU takes the time from: the steady clock in saulctl, a fake one in tests.
using VcuClock = std::function<std::chrono::steady_clock::time_point()>;

struct PrideVcuCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t neutral_frames_sent = 0;    ///< since begin_neutral()
  std::uint64_t missed_slots = 0;           ///< 5 ms slots skipped because we were late by a whole period
  std::uint64_t controller_frames = 0;      ///< ControllerStatus frames decoded
  std::uint64_t late_echoes = 0;            ///< our own frames that came back after the echo filter gave up on them
  std::uint64_t foreign_vcu_frames = 0;     ///< VcuCommand frames that were not ours (another VCU on the wire?)
};

class PrideVcu {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;
  using StatusHandler = std::function<void(const pride::ControllerStatus&)>;

  /// Throws std::invalid_argument when the command is outside the manual's ranges.
  PrideVcu(SerialPort& port, VcuClock clock, pride::VcuCommand command);

  /// From now on only neutral frames (same speed level, FB 0, LR 0); finished() after kNeutralTime
  /// worth of them. Calling it again does not restart the neutral period.
  void begin_neutral();
  [[nodiscard]] bool neutral() const { return neutral_; }
  /// True once the neutral period is over.
  [[nodiscard]] bool finished() const;

  /// One step: sends the frame that is due (if any), then reads what arrives until the next deadline,
  /// filtering our echo and decoding; on_status is called for every controller frame. Returns early when a
  /// read returned nothing (e.g. EINTR), so the caller can check its stop condition. Throws SerialError.
  void step(const StatusHandler& on_status = {});

  [[nodiscard]] std::optional<pride::ControllerStatus> last_status() const { return last_status_; }
  [[nodiscard]] const PrideVcuCounters& counters() const { return counters_; }
  [[nodiscard]] const pride::EchoFilter::Counters& echo_counters() const { return echo_.counters(); }
  [[nodiscard]] const pride::Counters& decoder_counters() const { return decoder_.counters(); }
  [[nodiscard]] TimePoint next_deadline() const { return next_; }

 private:
  static constexpr std::chrono::microseconds kPeriod{pride::kFramePeriodUs};
  static constexpr std::chrono::milliseconds kNeutralTime{100};  // neutral frames sent before finished()
  // An expected echo that made no progress for this long is forgotten (hardware that does not echo). On one
  // wire the echo returns within ~2 ms; a loaded USB serial adapter can hold it back for a few frames.
  static constexpr std::chrono::milliseconds kEchoTimeout{15};

  void send_frame(TimePoint now);
  void take(std::span<const std::uint8_t> bytes, TimePoint now, const StatusHandler& on_status);

  SerialPort& port_;
  VcuClock clock_;
  pride::VcuCommand command_;
  pride::VcuCommand previous_command_;  // what the frames before neutral carried
  TimePoint next_;
  TimePoint echo_progress_{};  // last time an echo byte came back, or a send began an echo
  bool neutral_ = false;
  pride::EchoFilter echo_;
  pride::StreamDecoder decoder_;
  std::optional<pride::ControllerStatus> last_status_;
  PrideVcuCounters counters_;
};

}  // namespace saul::host
