// Private helpers of the text capture formats: tokens with their columns, "(time)" stamps and exact number parsing
// (no floating point, no locale).
#pragma once

#include <charconv>
#include <cstdint>
#include <istream>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "saulproto/host/capture/capture.hpp"

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

/// The next space-separated word from pos, which starts at `start` (pos moves past it).
inline std::string_view word(std::string_view line, std::size_t& pos, std::size_t& start) {
  while (pos < line.size() && line[pos] == ' ') ++pos;
  start = pos;
  while (pos < line.size() && line[pos] != ' ') ++pos;
  return line.substr(start, pos - start);
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

/// Fills the column and message of a line's error; returns false.
inline bool column_error(CaptureError& error, std::size_t column, std::string message) {
  error.column = column;
  error.message = std::move(message);
  return false;
}

/// The "(SEC.FRAC)" time that starts a candump or serial log line (FRAC 1 to 9 digits) in ns, and where its ')' is;
/// false with column_error() when it is none or its seconds are above `max_seconds`.
inline bool parse_paren_time(std::string_view line, std::uint64_t max_seconds, std::uint64_t& ns, std::size_t& close,
                             CaptureError& error) {
  if (line.empty() || line[0] != '(') return column_error(error, 0, "expected '(' starting a timestamp");
  close = line.find(')');
  if (close == std::string_view::npos) return column_error(error, 0, "timestamp has no closing ')'");
  const std::string_view stamp = line.substr(1, close - 1);
  const std::size_t dot = stamp.find('.');
  if (dot == std::string_view::npos)
    return column_error(error, 1, "timestamp needs a '.' between seconds and fraction");
  // digits only (from_chars leaves a value too large for 64 bits as it was: 0)
  auto digits = [](std::string_view text, std::uint64_t& value) {
    const char* const end = text.data() + text.size();
    return !text.empty() && std::from_chars(text.data(), end, value).ptr == end;
  };
  std::uint64_t sec = 0, frac = 0;
  if (!digits(stamp.substr(0, dot), sec) || sec > max_seconds)
    return column_error(error, 1, "timestamp seconds are not a number");
  const std::string_view frac_text = stamp.substr(dot + 1);
  if (frac_text.size() > 9 || !digits(frac_text, frac))
    return column_error(error, 2 + dot, "timestamp fraction must be 1 to 9 digits");
  for (std::size_t i = frac_text.size(); i < 9; ++i) frac *= 10;  // to nanoseconds
  ns = sec * 1'000'000'000ULL + frac;
  return true;
}

/// Fills a text reader's error for a bad line (reading goes on at the next line); returns false.
inline bool line_error(CaptureError& error, std::uint64_t line, std::size_t column, std::string message) {
  error = CaptureError{column, std::move(message), PositionKind::line, line, Recovery::next_line};
  return false;
}

/// The next line of a text capture, without its CR and, on line 1, without a UTF-8 byte-order mark; nullopt at
/// the end. `buffer` holds it; `number` counts lines from 1.
inline std::optional<std::string_view> next_line(std::istream& in, std::string& buffer, std::uint64_t& number) {
  if (!std::getline(in, buffer)) return std::nullopt;
  ++number;
  std::string_view line = buffer;
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  if (number == 1 && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);
  return line;
}

}  // namespace saul::host::detail
