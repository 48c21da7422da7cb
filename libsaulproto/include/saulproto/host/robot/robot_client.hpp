// Talking to the robot over a CAN link: send a mode / PID set / config frame and wait for its 0x402 acknowledgement,
// one behaviour for saulctl, bench scripts and tests. Frames that arrive while waiting go to an observer, so the
// caller can keep printing telemetry. Time is the steady clock; waits are bounded by the caller's timeout.
#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>

#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/link/can_link.hpp"

namespace saul::host {

struct CommandOutcome {
  enum class Status { applied, rejected, no_answer };
  Status status = Status::no_answer;
  saulcan::AckResult result = saulcan::AckResult::applied;  ///< when an acknowledgement arrived
  std::chrono::microseconds latency{0};                     ///< first frame sent -> acknowledgement received
};

const char* to_string(CommandOutcome::Status s);

/// What the robot did after an acknowledged mode change, as its 0x400 telemetry shows it.
struct StateCheck {
  enum class Result { confirmed, differs, no_telemetry };
  Result result = Result::no_telemetry;
  saulcan::RobotState expected = saulcan::RobotState::off;
  std::optional<saulcan::RobotState> seen;  ///< the last state 0x400 reported (when one came)
  std::chrono::microseconds after{0};       ///< acknowledgement -> the 0x400 that decided
  /// One line for the user: what the robot does now and, when it differs, what to do.
  [[nodiscard]] std::string text() const;
};

/// The robot state a mode command asks for (mode 0..3 name states 0..3).
saulcan::RobotState state_for(saulcan::Mode mode);

class RobotClient {
 public:
  using Observer = std::function<void(const CanFrame&)>;

  explicit RobotClient(CanLink& link, Observer observer = {}) : link_(link), observer_(std::move(observer)) {}

  /// Mode 3 (estop), sent at once. Does not wait for anything.
  void send_estop();

  /// 0x302, then waits for the 0x402 of command 0x02.
  CommandOutcome set_mode(saulcan::Mode mode, std::chrono::milliseconds timeout);

  /// Three 0x301 frames of one new sequence number, back to back; waits for the 0x402 of command 0x01 with
  /// that sequence number. The sequence number starts from a value derived from the clock, so two saulctl runs
  /// in a row do not reuse one.
  CommandOutcome set_pid(float kp, float ki, float kd, std::chrono::milliseconds timeout);

  /// 0x303, then waits for the 0x402 of command 0x03.
  CommandOutcome set_config(std::uint16_t tilt_limit_x100, std::uint16_t max_speed_mmps,
                            std::chrono::milliseconds timeout);

  /// Waits for one acknowledgement of `command` (and `sequence` when given); other frames go to the observer.
  CommandOutcome wait_for_ack(std::uint8_t command, std::optional<std::uint8_t> sequence,
                              std::chrono::steady_clock::time_point sent_at, std::chrono::milliseconds timeout);

  /// After an acknowledged mode change: waits up to `timeout` for a 0x400 that shows `expected` (0x400 comes at
  /// 10 Hz; the first one after the acknowledgement may still carry the old state, so it waits for a match and
  /// reports the last state seen when none came). Other frames go to the observer.
  StateCheck confirm_state(saulcan::RobotState expected,
                           std::chrono::milliseconds timeout = kStateConfirmTime);

  /// Three 0x400 periods.
  static constexpr std::chrono::milliseconds kStateConfirmTime{300};

  [[nodiscard]] std::uint8_t last_sequence() const { return sequence_; }

 private:
  CanLink& link_;
  Observer observer_;
  // A fresh start value per run: the receiver treats a repeated sequence number as the same set.
  std::uint8_t sequence_ = static_cast<std::uint8_t>(std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::system_clock::now().time_since_epoch()).count());
};

}  // namespace saul::host
