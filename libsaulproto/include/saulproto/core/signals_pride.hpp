// The Pride ES controller link's messages (docs/protocol.md §8, the manual in pride.hpp): three one-byte fields
// after the two header bytes, each at its place in pride::kFormats (THE layout table: its order is inferred, so
// it stays the one place to change). The manual gives ranges and no units or scales, so every signal is its wire
// integer under the struct's name. Codec in pride.hpp.
#pragma once

#include <string_view>

#include "saulproto/core/pride.hpp"
#include "saulproto/core/signals.hpp"

namespace saul::signals::of_pride {

namespace detail {
using saul::pride::Direction;
/// A one-byte field of a message, at its place in pride::kFormats.
constexpr SignalDesc byte(Direction d, const char* field, Kind kind) noexcept {
  const auto& fields = saul::pride::format_of(d).fields;
  unsigned at = 0;
  while (at < fields.size() && std::string_view(fields[at]) != field) ++at;  // none: past the payload (test_signals)
  return number(field, ByteOrder::little_endian, 8 * at, 8, kind);
}
constexpr SignalDesc command(const char* field, Kind kind) noexcept {
  return byte(Direction::vcu_to_controller, field, kind);
}
constexpr SignalDesc status(const char* field) noexcept {
  return byte(Direction::controller_to_vcu, field, Kind::unsigned_int);
}
}  // namespace detail

/// The two error_byte values the manual documents; saulctl shows the number (as inter-board error_state).
inline constexpr ValueName kErrorByteNames[] = {{saul::pride::ControllerStatus::kReady, "ready"},
                                                {saul::pride::ControllerStatus::kError, "error"}};

/// Speed setting 0 (slowest) .. 14; sticks -100 .. +100: + forward / right (the manual's signs).
inline constexpr SignalDesc kVcuCommand[] = {
    detail::command("speed_level", Kind::unsigned_int)
        .valid(0, saul::pride::VcuCommand::kMaxSpeedLevel, Check::decoder),
    detail::command("forward_back", Kind::signed_int)
        .valid(-saul::pride::VcuCommand::kMaxStick, saul::pride::VcuCommand::kMaxStick, Check::decoder),
    detail::command("left_right", Kind::signed_int)
        .valid(-saul::pride::VcuCommand::kMaxStick, saul::pride::VcuCommand::kMaxStick, Check::decoder),
};
/// battery_charge's scale and unknown's meaning are not in the manual.
inline constexpr SignalDesc kControllerStatus[] = {
    detail::status("error_byte").named(kErrorByteNames),
    detail::status("battery_charge"),
    detail::status("unknown"),
};

/// A message's id: its two header bytes, the first one high (0xFE54, 0x4A01).
constexpr std::uint32_t id_of(saul::pride::Direction d) noexcept {
  const auto& header = saul::pride::format_of(d).header;
  return std::uint32_t{header[0]} << 8 | header[1];
}

namespace detail {
template <class M>
constexpr MessageDesc message(const char* from, const char* to, std::span<const SignalDesc> s) noexcept {
  return describe<M>(Protocol::pride, id_of(M::kDirection), saul::pride::kPayloadSize, true, from, to, s);
}
}  // namespace detail

/// In the order of pride::Message.
inline constexpr MessageDesc kMessages[] = {
    detail::message<saul::pride::VcuCommand>("VCU", "PRIDE", kVcuCommand),
    detail::message<saul::pride::ControllerStatus>("PRIDE", "VCU", kControllerStatus),
};

}  // namespace saul::signals::of_pride
