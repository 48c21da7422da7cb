// The SAUL CAN frames' signals (docs/protocol.md §3, §4): little-endian, byte-aligned; codec in saul_can.hpp.
#pragma once

#include "saulproto/core/saul_can.hpp"
#include "saulproto/core/signals.hpp"

namespace saul::signals::of_saul {

using saulcan::AckResult;
using saulcan::Gain;
using saulcan::Mode;
using saulcan::RobotState;

// Value names: the words saulcan::to_string() prints (tests/unit/test_signals.cpp holds them to it).
inline constexpr ValueName kGainNames[] = {{0, "kp"}, {1, "ki"}, {2, "kd"}};
inline constexpr ValueName kModeNames[] = {{0, "off"}, {1, "balance"}, {2, "manual"}, {3, "estop"}};
/// Robot states (0x400 state, UART STATE error_state).
inline constexpr ValueName kRobotStateNames[] = {{0, "OFF"},    {1, "BALANCE"},     {2, "MANUAL"},
                                                 {3, "ESTOP"},  {4, "TILT_CUTOFF"}, {5, "FAULT"}};
/// 0x402 command: the low byte of the acknowledged id.
inline constexpr ValueName kAckCommandNames[] = {
    {1, saulcan::PidGain::kName}, {2, saulcan::ModeCmd::kName}, {3, saulcan::ConfigCmd::kName}};
inline constexpr ValueName kAckResultNames[] = {
    {0, "applied"}, {1, "rejected_out_of_range"}, {2, "rejected_not_allowed"}, {3, "rejected_incomplete"}};
/// 0x401 fault bits (saulcan::fault); bits 0..2 are also the UART FAULT bits.
inline constexpr ValueName kFaultBitNames[] = {{0, "rc_loss"},      {1, "motor_fault"},    {2, "estop"},
                                               {3, "tilt_cutoff"},  {4, "orin_timeout"},   {5, "watchdog_reset"},
                                               {6, "io_link_loss"}, {7, "low_battery"}};

inline constexpr SignalDesc kVelocityCmd[] = {
    le_i("speed_mmps", 0, 16).in("mm/s"),
    le_i("steer_mrad", 2, 16).in("mrad"),
};

/// One gain per frame: byte 0 says which (the multiplexer), the float in bytes 4..7 is that gain. Bytes 2..3 are
/// reserved (sent 0, ignored).
inline constexpr SignalDesc kPidGain[] = {
    le_u("gain", 0, 8).shown(Text::name).named(kGainNames).multiplexer()
        .valid(0, 2, Check::decoder),
    le_u("sequence", 1, 8),
    le_f32("kp", 4).as_field("value").when(0),
    le_f32("ki", 4).as_field("value").when(1),
    le_f32("kd", 4).as_field("value").when(2),
};

inline constexpr SignalDesc kModeCmd[] = {
    le_u("mode", 0, 8).shown(Text::name).named(kModeNames).valid(0, 3, Check::decoder),
};

/// Tilt limit 5.00..25.00 deg: the receiving firmware applies the range and acknowledges (docs/protocol.md §5).
inline constexpr SignalDesc kConfigCmd[] = {
    le_u("tilt_limit", 0, 16).as_field("tilt_limit_x100").scaled(1, 100).in("deg")
        .valid(saulcan::ConfigCmd::kMinTiltX100, saulcan::ConfigCmd::kMaxTiltX100),
    le_u("max_speed_mmps", 2, 16).in("mm/s"),
};

inline constexpr SignalDesc kTelemetryA[] = {
    le_i("pitch", 0, 16).as_field("pitch_x100").scaled(1, 100).in("deg"),
    le_i("pid_out", 2, 16).in("permille").valid(-1000, 1000),
    le_i("speed_mmps", 4, 16).in("mm/s"),
    le_u("state", 6, 8).shown(Text::name).named(kRobotStateNames).valid(0, 5, Check::decoder),
};

/// vesc_l_rpm and vesc_r_rpm are mechanical rpm (ERPM / pole pairs); fault is the byte of fault bits.
inline constexpr SignalDesc kTelemetryB[] = {
    le_i("vesc_l_rpm", 0, 16).in("rpm"),
    le_i("vesc_r_rpm", 2, 16).in("rpm"),
    le_u("battery", 4, 16).as_field("battery_mv").scaled(1, 1000).in("V"),
    le_u("fault", 6, 8).as_field("faults").bits_named(kFaultBitNames),
};

inline constexpr SignalDesc kCommandAck[] = {
    le_u("command", 0, 8).named(kAckCommandNames).valid(1, 3, Check::decoder),
    le_u("sequence", 1, 8),
    le_u("result", 2, 8).shown(Text::name).named(kAckResultNames).valid(0, 3, Check::decoder),
};

namespace detail {
template <class M>
constexpr MessageDesc message(const char* from, const char* to, std::span<const SignalDesc> s) noexcept {
  return describe<M>(Protocol::saul_can, M::kId, M::kDlc, true, from, to, s);
}
}  // namespace detail

/// In the order of saulcan::Message.
inline constexpr MessageDesc kMessages[] = {
    detail::message<saulcan::VelocityCmd>("Orin", "BALANCE", kVelocityCmd),
    detail::message<saulcan::PidGain>("Orin", "BALANCE", kPidGain),
    detail::message<saulcan::ModeCmd>("Orin", "BALANCE", kModeCmd),
    detail::message<saulcan::ConfigCmd>("Orin", "BALANCE", kConfigCmd),
    detail::message<saulcan::TelemetryA>("BALANCE", "Orin", kTelemetryA),
    detail::message<saulcan::TelemetryB>("BALANCE", "Orin", kTelemetryB),
    detail::message<saulcan::CommandAck>("BALANCE", "Orin", kCommandAck),
};

}  // namespace saul::signals::of_saul
