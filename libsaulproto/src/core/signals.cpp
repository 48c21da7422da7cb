#include "saulproto/core/signals.hpp"

#include "saulproto/core/signals_crsf.hpp"
#include "saulproto/core/signals_interboard.hpp"
#include "saulproto/core/signals_pride.hpp"
#include "saulproto/core/signals_saul.hpp"
#include "saulproto/core/signals_vesc.hpp"

namespace saul::signals {

const char* to_string(Protocol protocol) noexcept {
  switch (protocol) {
    case Protocol::saul_can: return "saul_can";
    case Protocol::vesc_can: return "vesc_can";
    case Protocol::crsf: return "crsf";
    case Protocol::interboard: return "interboard";
    case Protocol::pride: return "pride";
  }
  return "?";
}

std::span<const MessageDesc> messages(Protocol protocol) noexcept {
  switch (protocol) {
    case Protocol::saul_can: return of_saul::kMessages;
    case Protocol::vesc_can: return of_vesc::kMessages;
    case Protocol::crsf: return of_crsf::kMessages;
    case Protocol::interboard: return of_interboard::kMessages;
    case Protocol::pride: return of_pride::kMessages;
  }
  return {};
}

const MessageDesc* find(Protocol protocol, std::uint32_t id) noexcept {
  for (const auto& m : messages(protocol))
    if (m.id == id) return &m;
  return nullptr;
}

const MessageDesc* find_can(std::uint32_t can_id, bool extended) noexcept {
  if (!extended) return find(Protocol::saul_can, can_id);
  if (saul::vesc::command_of(can_id) > 0xFF) return nullptr;  // id bits 28..16 set: not a VESC frame
  return find(Protocol::vesc_can, saul::vesc::command_of(can_id));
}

const MessageDesc* find_named(Protocol protocol, std::string_view name) noexcept {
  for (const auto& m : messages(protocol))
    if (name == m.name) return &m;
  return nullptr;
}

const SignalDesc* find_signal(const MessageDesc& m, std::string_view name_or_field) noexcept {
  for (const auto& s : m.signals)
    if (name_or_field == s.name || name_or_field == s.field) return &s;
  return nullptr;
}

}  // namespace saul::signals
