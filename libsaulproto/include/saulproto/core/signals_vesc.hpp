// The VESC CAN frames' signals (docs/protocol.md §6): big-endian, byte-aligned; the controller id is bits 7..0
// of the 29-bit id. MessageDesc::id is the command. Codec in vesc.hpp.
//
// The scaled fields are shown in physical units by saulctl (Text::physical: current_a=3.5), as the structs'
// fields() do, under the signal's name (current; the struct's field is current_a).
#pragma once

#include "saulproto/core/signals.hpp"
#include "saulproto/core/vesc.hpp"

namespace saul::signals::of_vesc {

/// The controller: the target of a command or PING, the sender of a status frame, the pinger a PONG answers.
inline constexpr SignalDesc kController = le_u("controller_id", 0, 8).at(Place::can_id);

inline constexpr ValueName kHwTypeNames[] = {
    {saul::vesc::hw_type::kVesc, "vesc"}, {saul::vesc::hw_type::kVescBms, "vesc_bms"},
    {saul::vesc::hw_type::kCustomModule, "custom_module"}};

// A scaled int32 (bytes 0..3) or int16 field: raw / den, shown as the physical value.
constexpr SignalDesc scaled32(const char* name, const char* field, unsigned byte, std::int32_t den,
                              const char* unit) noexcept {
  return be_i(name, byte, 32).as_field(field).scaled(1, den).in(unit).shown(Text::physical);
}
constexpr SignalDesc scaled16(const char* name, const char* field, unsigned byte, std::int32_t den,
                              const char* unit) noexcept {
  return be_i(name, byte, 16).as_field(field).scaled(1, den).in(unit).shown(Text::physical);
}

inline constexpr SignalDesc kSetDuty[] = {kController, scaled32("duty", "duty", 0, 100000, "").valid(-100000, 100000)};
inline constexpr SignalDesc kSetCurrent[] = {kController, scaled32("current", "current_a", 0, 1000, "A")};
inline constexpr SignalDesc kSetCurrentBrake[] = {kController, scaled32("current", "current_a", 0, 1000, "A")};
inline constexpr SignalDesc kSetRpm[] = {kController, be_i("erpm", 0, 32).in("rpm")};
inline constexpr SignalDesc kSetPos[] = {kController,
                                         scaled32("pos", "pos_deg", 0, 1000000, "deg").valid(0, 360000000)};
inline constexpr SignalDesc kSetCurrentRel[] = {
    kController, scaled32("current_rel", "current_rel", 0, 100000, "").valid(-100000, 100000)};

inline constexpr SignalDesc kStatus1[] = {
    kController,
    be_i("erpm", 0, 32).in("rpm"),
    scaled16("current", "current_a", 4, 10, "A"),
    scaled16("duty", "duty", 6, 1000, "").valid(-1000, 1000),
};
inline constexpr SignalDesc kStatus2[] = {
    kController,
    scaled32("amp_hours", "ah_used", 0, 10000, "Ah"),
    scaled32("amp_hours_charged", "ah_charged", 4, 10000, "Ah"),
};
inline constexpr SignalDesc kStatus3[] = {
    kController,
    scaled32("watt_hours", "wh_used", 0, 10000, "Wh"),
    scaled32("watt_hours_charged", "wh_charged", 4, 10000, "Wh"),
};
inline constexpr SignalDesc kStatus4[] = {
    kController,
    scaled16("temp_fet", "temp_fet_c", 0, 10, "degC"),
    scaled16("temp_motor", "temp_motor_c", 2, 10, "degC"),
    scaled16("current_in", "current_in_a", 4, 10, "A"),
    scaled16("pid_pos", "pid_pos_deg", 6, 50, "deg"),
};
/// The tachometer counts 6 steps per electrical revolution. Bytes 6..7 are reserved (sent 0, ignored).
inline constexpr SignalDesc kStatus5[] = {
    kController,
    be_i("tachometer", 0, 32),
    scaled16("voltage_in", "voltage_in_v", 4, 10, "V"),
};
inline constexpr SignalDesc kStatus6[] = {
    kController,
    scaled16("adc1", "adc1_v", 0, 1000, "V"),
    scaled16("adc2", "adc2_v", 2, 1000, "V"),
    scaled16("adc3", "adc3_v", 4, 1000, "V"),
    scaled16("ppm", "ppm", 6, 1000, "").valid(-1000, 1000),
};
inline constexpr SignalDesc kPing[] = {kController, be_u("sender_id", 0, 8)};
inline constexpr SignalDesc kPong[] = {kController, be_u("responder_id", 0, 8),
                                       be_u("hw_type", 1, 8).named(kHwTypeNames)};

namespace detail {
template <class M>
constexpr MessageDesc message(const char* from, const char* to, std::span<const SignalDesc> s) noexcept {
  return describe<M>(Protocol::vesc_can, static_cast<std::uint32_t>(M::kCommand), M::kDlc, true, from, to, s);
}
}  // namespace detail

/// In the order of vesc::Message. "VESC" is the controller the id names.
inline constexpr MessageDesc kMessages[] = {
    detail::message<saul::vesc::SetDuty>("BALANCE", "VESC", kSetDuty),
    detail::message<saul::vesc::SetCurrent>("BALANCE", "VESC", kSetCurrent),
    detail::message<saul::vesc::SetCurrentBrake>("BALANCE", "VESC", kSetCurrentBrake),
    detail::message<saul::vesc::SetRpm>("BALANCE", "VESC", kSetRpm),
    detail::message<saul::vesc::SetPos>("BALANCE", "VESC", kSetPos),
    detail::message<saul::vesc::SetCurrentRel>("BALANCE", "VESC", kSetCurrentRel),
    detail::message<saul::vesc::Status1>("VESC", "BALANCE", kStatus1),
    detail::message<saul::vesc::Status2>("VESC", "BALANCE", kStatus2),
    detail::message<saul::vesc::Status3>("VESC", "BALANCE", kStatus3),
    detail::message<saul::vesc::Status4>("VESC", "BALANCE", kStatus4),
    detail::message<saul::vesc::Status5>("VESC", "BALANCE", kStatus5),
    detail::message<saul::vesc::Status6>("VESC", "BALANCE", kStatus6),
    detail::message<saul::vesc::Ping>("BALANCE", "VESC", kPing),
    detail::message<saul::vesc::Pong>("VESC", "BALANCE", kPong),
};

}  // namespace saul::signals::of_vesc
