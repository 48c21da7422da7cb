// Private helpers of the text capture formats (ASC, TRC, the CSV logs): white-space tokens with their columns and
// exact number parsing (no floating point, no locale). Not installed, not part of the API.
#pragma once

#include <charconv>
#include <cstdint>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

namespace saul::host::detail {

/// Splits at spaces and tabs; each token with its 0-based column. Reuses `out`'s storage.
inline void split_tokens(std::string_view line, std::vector<std::pair<std::size_t, std::string_view>>& out) {
  out.clear();
  for (std::size_t i = 0; i < line.size();) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.emplace_back(start, line.substr(start, i - start));
  }
}

/// Splits at every `separator` (CSV without quoting); each field with its 0-based column. Reuses `out`'s storage.
inline void split_fields(std::string_view line, char separator,
                         std::vector<std::pair<std::size_t, std::string_view>>& out) {
  out.clear();
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(separator, start);
    out.emplace_back(start, line.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
    if (end == std::string_view::npos) return;
    start = end + 1;
  }
}

/// A whole number in `base` made of digits only (no sign, no prefix, not empty); nullopt otherwise or on overflow.
inline std::optional<std::uint64_t> parse_unsigned(std::string_view s, int base) {
  if (s.empty()) return std::nullopt;
  std::uint64_t v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v, base);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}
inline std::optional<std::uint64_t> parse_decimal(std::string_view s) { return parse_unsigned(s, 10); }
inline std::optional<std::uint64_t> parse_hex(std::string_view s) { return parse_unsigned(s, 16); }

/// "12.345678" in units of `unit` (a power of ten, e.g. 1e9 for seconds to ns, 1e6 for ms to ns): digits, an
/// optional '.' and fraction digits (those beyond `max_decimals` are dropped: truncation). nullopt when it is not
/// such a number or does not fit 64 bits.
inline std::optional<std::uint64_t> parse_scaled(std::string_view s, std::uint64_t unit, unsigned max_decimals) {
  const std::size_t dot = s.find('.');
  const std::string_view whole = s.substr(0, dot);
  const auto w = parse_decimal(whole);
  if (!w || *w > UINT64_MAX / unit) return std::nullopt;
  std::uint64_t value = *w * unit;
  if (dot == std::string_view::npos) return value;
  const std::string_view frac = s.substr(dot + 1);
  for (char c : frac)
    if (c < '0' || c > '9') return std::nullopt;
  std::uint64_t scale = unit;
  for (std::size_t i = 0; i < frac.size() && i < max_decimals && scale >= 10; ++i) {
    scale /= 10;
    const auto digit = static_cast<std::uint64_t>(frac[i] - '0') * scale;
    if (value > UINT64_MAX - digit) return std::nullopt;
    value += digit;
  }
  return value;
}

}  // namespace saul::host::detail
