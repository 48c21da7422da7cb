// Numbers with units as people type them ("500k", "1.5G", "2MHz", "250ms"): the one reader every verb, link
// text and bench suite uses, so "500k" means the same in --bitrate, slcan:/dev/ttyACM0@500k and --rotate-size.
// No allocation, no exceptions: nullopt for anything it does not read, the caller words the error.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string_view>

namespace saul::quantity {

/// A positive number, then optionally k/K, M or G (`kilo`, its square, its cube), then optionally one of `units`
/// (tried in order: "iB" before "B"). The value times the prefix's scale, rounded; nullopt for anything else
/// (no sign, no space, nothing after the unit, nothing that does not fit 2^63). O(length).
inline std::optional<std::uint64_t> parse(std::string_view text, std::initializer_list<std::string_view> units,
                                          double kilo) noexcept {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end == text.data()) return std::nullopt;
  std::string_view unit = text.substr(static_cast<std::size_t>(end - text.data()));
  for (const std::string_view u : units) {
    if (unit.ends_with(u)) {
      unit.remove_suffix(u.size());
      break;
    }
  }
  double scale = 0;
  if (unit.empty()) scale = 1;
  if (unit == "k" || unit == "K") scale = kilo;
  if (unit == "M") scale = kilo * kilo;
  if (unit == "G") scale = kilo * kilo * kilo;
  // (above 2^63 llround has no answer: such a number is refused, not wrapped)
  if (scale == 0 || !(v > 0) || !(v * scale < 9.2e18)) return std::nullopt;
  return static_cast<std::uint64_t>(std::llround(v * scale));
}

/// A duration in microseconds: a number (not negative) and a unit, us, ms, s (also no unit) or m/min. O(length).
inline std::optional<std::uint64_t> parse_duration_us(std::string_view text) noexcept {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end == text.data()) return std::nullopt;
  const std::string_view unit = text.substr(static_cast<std::size_t>(end - text.data()));
  double us = 0;
  if (unit == "ms") us = v * 1e3;
  else if (unit == "s" || unit.empty()) us = v * 1e6;
  else if (unit == "us") us = v;
  else if (unit == "m" || unit == "min") us = v * 60e6;
  else return std::nullopt;
  if (!(us >= 0) || !(us < 9.2e18)) return std::nullopt;
  return static_cast<std::uint64_t>(std::llround(us));
}

}  // namespace saul::quantity
