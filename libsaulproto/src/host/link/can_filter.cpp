// CAN id filters (can_link.hpp): parsing "400", "400:7F0", "0x00000344" and the software check, in one place for
// every verb and transport. Hex digits through core/hex.hpp, as every text codec reads them.
#include <fmt/format.h>

#include <stdexcept>

#include "saulproto/core/hex.hpp"
#include "saulproto/host/link/can_link.hpp"

namespace saul::host {

std::uint32_t parse_can_id(std::string_view text, std::string_view whole, bool& extended) {
  std::string_view t = text;
  if (t.starts_with("0x") || t.starts_with("0X")) t.remove_prefix(2);
  if (t.empty() || t.size() > 8) throw std::invalid_argument(fmt::format("bad CAN id '{}' in '{}'", text, whole));
  std::uint32_t v = 0;
  for (char c : t) {
    const int d = hex::value(c);
    if (d < 0) throw std::invalid_argument(fmt::format("bad CAN id '{}' in '{}': ids are hex", text, whole));
    v = v << 4 | static_cast<std::uint32_t>(d);
  }
  extended = t.size() > 3 || v > CanFrame::kMaxStandardId;
  if (v > CanFrame::kMaxExtendedId)
    throw std::invalid_argument(fmt::format("CAN id '{}' in '{}' is above 1FFFFFFF", text, whole));
  return v;
}

CanFilter parse_id_filter(std::string_view text) {
  const auto colon = text.find(':');
  CanFilter f;
  f.id = parse_can_id(text.substr(0, colon), text, f.extended);
  if (colon == std::string_view::npos) {
    f.mask = f.extended ? CanFrame::kMaxExtendedId : CanFrame::kMaxStandardId;
  } else {
    bool ignored = false;
    f.mask = parse_can_id(text.substr(colon + 1), text, ignored);
  }
  return f;
}

bool passes(const std::vector<CanFilter>& filters, const CanFrame& frame) {
  if (filters.empty() || frame.error) return true;
  for (const auto& f : filters)
    if (f.extended == frame.extended && (frame.id & f.mask) == (f.id & f.mask)) return true;
  return false;
}

}  // namespace saul::host
