// The SAUL frames on the robot's CAN bus (500 kbit/s, 11-bit ids, little-endian payloads).
//
//   0x300 Orin -> BALANCE  velocity command            DLC 4   20 Hz
//   0x301 Orin -> BALANCE  PID gain, one per frame     DLC 8   on demand (see PidStager)
//   0x302 Orin -> BALANCE  mode                        DLC 1   on demand
//   0x303 Orin -> BALANCE  config (tilt limit, speed)  DLC 4   on demand
//   0x400 BALANCE -> Orin  telemetry A                 DLC 7   10 Hz
//   0x401 BALANCE -> Orin  telemetry B                 DLC 7   10 Hz
//   0x402 BALANCE -> Orin  command acknowledgement     DLC 3   once per handled 0x301 set, 0x302, 0x303
//
// Every message is a plain struct with encode() -> CanFrame and a decode_*() that checks the id, the format
// (standard, data frame) and the exact DLC, then the field ranges. All functions are O(1) and allocation-free.
#pragma once

#include <cstdint>
#include <variant>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/result.hpp"

namespace saul::saulcan {

inline constexpr std::uint32_t kVelocityCmdId = 0x300;
inline constexpr std::uint32_t kPidGainId = 0x301;
inline constexpr std::uint32_t kModeCmdId = 0x302;
inline constexpr std::uint32_t kConfigCmdId = 0x303;
inline constexpr std::uint32_t kTelemetryAId = 0x400;
inline constexpr std::uint32_t kTelemetryBId = 0x401;
inline constexpr std::uint32_t kCommandAckId = 0x402;

/// 0x302 mode values. 0..3 map onto robot states 0..3.
enum class Mode : std::uint8_t { off = 0, balance = 1, manual = 2, estop = 3 };

/// Robot state in 0x400 and in the UART STATE message.
enum class RobotState : std::uint8_t { off = 0, balance = 1, manual = 2, estop = 3, tilt_cutoff = 4, fault = 5 };

/// 0x402 result byte.
enum class AckResult : std::uint8_t { applied = 0, out_of_range = 1, not_allowed = 2, incomplete = 3 };

/// 0x301 gain index.
enum class Gain : std::uint8_t { kp = 0, ki = 1, kd = 2 };

/// Fault bits of 0x401. Bits 0..2 are the UART FAULT bits.
namespace fault {
inline constexpr std::uint8_t kRcLoss = 1U << 0;
inline constexpr std::uint8_t kMotorFault = 1U << 1;
inline constexpr std::uint8_t kEstop = 1U << 2;
inline constexpr std::uint8_t kTiltCutoff = 1U << 3;
inline constexpr std::uint8_t kOrinTimeout = 1U << 4;
inline constexpr std::uint8_t kWatchdogReset = 1U << 5;
inline constexpr std::uint8_t kIoLinkLoss = 1U << 6;
inline constexpr std::uint8_t kLowBattery = 1U << 7;
/// Name of bit n (0..7), e.g. "rc_loss".
const char* bit_name(unsigned bit) noexcept;
}  // namespace fault

const char* to_string(Mode mode) noexcept;
const char* to_string(RobotState state) noexcept;
const char* to_string(AckResult result) noexcept;
const char* to_string(Gain gain) noexcept;

/// 0x300: speed in mm/s (+ forward), steer in mrad (+ left).
struct VelocityCmd {
  static constexpr std::uint32_t kId = kVelocityCmdId;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "velocity_cmd";
  std::int16_t speed_mmps = 0;
  std::int16_t steer_mrad = 0;
  template <class V> constexpr void fields(V&& v) const { v("speed_mmps", speed_mmps); v("steer_mrad", steer_mrad); }
  constexpr bool operator==(const VelocityCmd&) const = default;
};

/// 0x301: one gain of a tuning set. Bytes: [index][sequence][0][0][float32 LE].
struct PidGain {
  static constexpr std::uint32_t kId = kPidGainId;
  static constexpr std::uint8_t kDlc = 8;
  static constexpr const char* kName = "pid_gain";
  Gain index = Gain::kp;
  std::uint8_t sequence = 0;
  float value = 0.0F;
  template <class V> constexpr void fields(V&& v) const { v("gain", index); v("sequence", sequence); v("value", value); }
  constexpr bool operator==(const PidGain&) const = default;
};

/// 0x302.
struct ModeCmd {
  static constexpr std::uint32_t kId = kModeCmdId;
  static constexpr std::uint8_t kDlc = 1;
  static constexpr const char* kName = "mode_cmd";
  Mode mode = Mode::off;
  template <class V> constexpr void fields(V&& v) const { v("mode", mode); }
  constexpr bool operator==(const ModeCmd&) const = default;
};

/// 0x303: tilt limit in degrees x100, maximum speed in mm/s.
struct ConfigCmd {
  static constexpr std::uint32_t kId = kConfigCmdId;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "config_cmd";
  static constexpr std::uint16_t kMinTiltX100 = 500;   ///< 5.00 degrees
  static constexpr std::uint16_t kMaxTiltX100 = 2500;  ///< 25.00 degrees: never above the spec's cutoff
  std::uint16_t tilt_limit_x100 = 2500;
  std::uint16_t max_speed_mmps = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("tilt_limit_x100", tilt_limit_x100); v("max_speed_mmps", max_speed_mmps);
  }
  constexpr bool operator==(const ConfigCmd&) const = default;
};

/// 0x400: pitch in degrees x100 (+ nose up), PID output in permille, speed in mm/s, robot state.
struct TelemetryA {
  static constexpr std::uint32_t kId = kTelemetryAId;
  static constexpr std::uint8_t kDlc = 7;
  static constexpr const char* kName = "telemetry_a";
  std::int16_t pitch_x100 = 0;
  std::int16_t pid_out = 0;
  std::int16_t speed_mmps = 0;
  RobotState state = RobotState::off;
  template <class V> constexpr void fields(V&& v) const {
    v("pitch_x100", pitch_x100); v("pid_out", pid_out); v("speed_mmps", speed_mmps); v("state", state);
  }
  constexpr bool operator==(const TelemetryA&) const = default;
};

/// 0x401: mechanical RPM of both wheels, pack voltage in mV, fault bits (namespace fault).
struct TelemetryB {
  static constexpr std::uint32_t kId = kTelemetryBId;
  static constexpr std::uint8_t kDlc = 7;
  static constexpr const char* kName = "telemetry_b";
  std::int16_t vesc_l_rpm = 0;
  std::int16_t vesc_r_rpm = 0;
  std::uint16_t battery_mv = 0;
  std::uint8_t faults = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("vesc_l_rpm", vesc_l_rpm); v("vesc_r_rpm", vesc_r_rpm); v("battery_mv", battery_mv); v("faults", faults);
  }
  constexpr bool operator==(const TelemetryB&) const = default;
};

/// 0x402: which command (low byte of its id: 0x01, 0x02, 0x03), the 0x301 sequence (0 otherwise), result.
struct CommandAck {
  static constexpr std::uint32_t kId = kCommandAckId;
  static constexpr std::uint8_t kDlc = 3;
  static constexpr const char* kName = "command_ack";
  std::uint8_t command = 0;
  std::uint8_t sequence = 0;
  AckResult result = AckResult::applied;
  template <class V> constexpr void fields(V&& v) const {
    v("command", command); v("sequence", sequence); v("result", result);
  }
  constexpr bool operator==(const CommandAck&) const = default;
};

using Message = std::variant<VelocityCmd, PidGain, ModeCmd, ConfigCmd, TelemetryA, TelemetryB, CommandAck>;

// Encoders: the frame to put on the bus (standard id, data frame, exact DLC, unused bytes zero).
CanFrame encode(const VelocityCmd& m) noexcept;
CanFrame encode(const PidGain& m) noexcept;
CanFrame encode(const ModeCmd& m) noexcept;
CanFrame encode(const ConfigCmd& m) noexcept;
CanFrame encode(const TelemetryA& m) noexcept;
CanFrame encode(const TelemetryB& m) noexcept;
CanFrame encode(const CommandAck& m) noexcept;
CanFrame encode(const Message& m) noexcept;

// Decoders. Each checks, in this order: id (unknown_id), error frame, remote frame, extended id, DLC
// (wrong_dlc), then field ranges (out_of_range for an enum value that does not exist).
Result<VelocityCmd> decode_velocity_cmd(const CanFrame& f) noexcept;
Result<PidGain> decode_pid_gain(const CanFrame& f) noexcept;
Result<ModeCmd> decode_mode_cmd(const CanFrame& f) noexcept;
Result<ConfigCmd> decode_config_cmd(const CanFrame& f) noexcept;
Result<TelemetryA> decode_telemetry_a(const CanFrame& f) noexcept;
Result<TelemetryB> decode_telemetry_b(const CanFrame& f) noexcept;
Result<CommandAck> decode_command_ack(const CanFrame& f) noexcept;

/// Any SAUL frame by its id; unknown_id when the id is not one of 0x300..0x303, 0x400..0x402.
Result<Message> decode(const CanFrame& f) noexcept;
/// decode() with only the message's name kept: the same checks and reasons (decode_bus_name()).
Result<DecodedName> decode_name(const CanFrame& f) noexcept;
/// decode() into any variant that holds the SAUL messages (decode_bus_frame()'s BusMessage): the message is built
/// once, in the variant it is wanted in, rather than in Message and then copied over.
template <class Variant>
Result<Variant> decode_as(const CanFrame& f) noexcept {
  if (f.error) return Reason::error_frame;
  switch (f.id) {
    case kVelocityCmdId: return widen_to<Variant>(decode_velocity_cmd(f));
    case kPidGainId: return widen_to<Variant>(decode_pid_gain(f));
    case kModeCmdId: return widen_to<Variant>(decode_mode_cmd(f));
    case kConfigCmdId: return widen_to<Variant>(decode_config_cmd(f));
    case kTelemetryAId: return widen_to<Variant>(decode_telemetry_a(f));
    case kTelemetryBId: return widen_to<Variant>(decode_telemetry_b(f));
    case kCommandAckId: return widen_to<Variant>(decode_command_ack(f));
    default: return Reason::unknown_id;
  }
}

/// True when id is one of the SAUL ids (whatever the frame's shape).
constexpr bool is_saul_id(std::uint32_t id) noexcept {
  return (id >= kVelocityCmdId && id <= kConfigCmdId) || (id >= kTelemetryAId && id <= kCommandAckId);
}

}  // namespace saul::saulcan
