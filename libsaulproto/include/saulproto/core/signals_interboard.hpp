// The inter-board UART messages' signals (docs/protocol.md §2): little-endian payloads after TYPE, one fixed LEN
// per type. Codec in interboard.hpp.
#pragma once

#include "saulproto/core/interboard.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/core/signals_saul.hpp"

namespace saul::signals::of_interboard {

inline constexpr ValueName kRcFlagNames[] = {{0, "armed"}, {1, "kill"}, {2, "disarm_switch"}, {3, "button"}};
/// The UART FAULT bits are bits 0..2 of the 0x401 fault byte.
inline constexpr std::span<const ValueName> kFaultBitNames = std::span(of_saul::kFaultBitNames).first(3);

/// Permille after the CH7 speed cap.
inline constexpr SignalDesc kRcCmd[] = {
    le_i("throttle", 0, 16).in("permille").valid(-1000, 1000),
    le_i("steer", 2, 16).in("permille").valid(-1000, 1000),
    le_u("flags", 4, 8).bits_named(kRcFlagNames),
};
inline constexpr SignalDesc kSensor[] = {
    le_u("tof_mm", 0, 16).in("mm"),
    le_i("baro_delta_pa", 2, 16).in("Pa"),
    le_u("nfc_present", 4, 8).valid(0, 1),
};
inline constexpr SignalDesc kFault[] = {le_u("flags", 0, 8).bits_named(kFaultBitNames)};
/// error_state is the robot state (docs/protocol.md §4), as 0x400 state; saulctl shows its number.
inline constexpr SignalDesc kState[] = {
    le_i("pitch", 0, 16).as_field("pitch_x100").scaled(1, 100).in("deg"),
    le_i("pid_out", 2, 16).in("permille").valid(-1000, 1000),
    le_u("error_state", 4, 8).named(of_saul::kRobotStateNames).valid(0, 5),
};
inline constexpr SignalDesc kLedCmd[] = {le_u("pattern", 0, 8), le_u("r", 1, 8), le_u("g", 2, 8), le_u("b", 3, 8)};
inline constexpr SignalDesc kBuzzer[] = {le_u("tone_id", 0, 8), le_u("duration_ms", 1, 16).in("ms")};
inline constexpr SignalDesc kSpeedCap[] = {le_u("percent", 0, 8).in("%").valid(10, 100)};

namespace detail {
template <class M>
constexpr MessageDesc message(const char* from, const char* to, std::span<const SignalDesc> s) noexcept {
  const auto type = static_cast<std::uint8_t>(M::kType);
  return describe<M>(Protocol::interboard, type, *saul::interboard::payload_length(type), true, from, to, s);
}
}  // namespace detail

/// In the order of interboard::Message.
inline constexpr MessageDesc kMessages[] = {
    detail::message<saul::interboard::RcCmd>("IO", "BALANCE", kRcCmd),
    detail::message<saul::interboard::Sensor>("IO", "BALANCE", kSensor),
    detail::message<saul::interboard::Fault>("IO", "BALANCE", kFault),
    detail::message<saul::interboard::State>("BALANCE", "IO", kState),
    detail::message<saul::interboard::LedCmd>("BALANCE", "IO", kLedCmd),
    detail::message<saul::interboard::Buzzer>("BALANCE", "IO", kBuzzer),
    detail::message<saul::interboard::SpeedCap>("BALANCE", "IO", kSpeedCap),
};

}  // namespace saul::signals::of_interboard
