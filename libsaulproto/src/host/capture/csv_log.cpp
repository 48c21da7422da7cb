#include "saulproto/host/capture/csv_log.hpp"

#include <fmt/format.h>

#include <array>
#include <stdexcept>
#include <utility>

#include "capture_io.hpp"
#include "text_fields.hpp"

namespace saul::host {
namespace {

constexpr std::array<std::string_view, 7> kColumns = {"timestamp", "arbitration_id", "extended", "remote",
                                                      "error",     "dlc",            "data"};
enum Column : std::size_t { kTime, kId, kExtended, kRemote, kError, kDlc, kData };
constexpr std::string_view kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

int base64_value(char c) {
  const std::size_t i = kAlphabet.find(c);
  return i == std::string_view::npos ? -1 : static_cast<int>(i);
}

std::optional<bool> flag(std::string_view s) {
  if (s == "1" || s == "True" || s == "true") return true;
  if (s == "0" || s == "False" || s == "false") return false;
  return std::nullopt;
}

/// Python's repr of a float ("1700000000.00125", "1e-05", "1.7e+09") in nanoseconds, exactly as written (digits
/// beyond the nanosecond dropped); nullopt when negative or not a number.
std::optional<std::uint64_t> seconds_to_ns(std::string_view s) {
  const std::size_t e = s.find_first_of("eE");
  if (e == std::string_view::npos) return detail::parse_scaled(s, 1'000'000'000, 9);
  std::string_view exp = s.substr(e + 1);
  const bool negative = !exp.empty() && exp.front() == '-';
  if (!exp.empty() && (exp.front() == '-' || exp.front() == '+')) exp.remove_prefix(1);
  const auto shift = detail::parse_decimal(exp);
  if (!shift || *shift > 30) return std::nullopt;
  // Move the decimal point of the mantissa: rewrite it as a plain decimal number.
  const std::string_view mantissa = s.substr(0, e);
  const std::size_t dot = mantissa.find('.');
  std::string digits(mantissa.substr(0, dot));
  if (dot != std::string_view::npos) digits += mantissa.substr(dot + 1);
  auto point = static_cast<std::int64_t>(dot == std::string_view::npos ? mantissa.size() : dot);
  point += negative ? -static_cast<std::int64_t>(*shift) : static_cast<std::int64_t>(*shift);
  while (point <= 0) {
    digits.insert(digits.begin(), '0');
    ++point;
  }
  while (static_cast<std::int64_t>(digits.size()) < point) digits += '0';
  digits.insert(static_cast<std::size_t>(point), 1, '.');
  return detail::parse_scaled(digits, 1'000'000'000, 9);
}

}  // namespace

std::string base64_encode(std::span<const std::uint8_t> bytes) {
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = bytes.size() - i < 3 ? bytes.size() - i : 3;
    std::uint32_t v = std::uint32_t{bytes[i]} << 16;
    if (n > 1) v |= std::uint32_t{bytes[i + 1]} << 8;
    if (n > 2) v |= bytes[i + 2];
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(v >> (18 - 6 * k)) & 0x3F] : '=';
  }
  return out;
}

int base64_decode(std::string_view text, std::span<std::uint8_t> out) {
  while (!text.empty() && text.back() == '=') text.remove_suffix(1);
  if (text.size() % 4 == 1) return -1;
  std::size_t n = 0;
  std::uint32_t acc = 0;
  int bits = 0;
  for (char c : text) {
    const int v = base64_value(c);
    if (v < 0) return -1;
    acc = (acc << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      if (n == out.size()) return -1;
      out[n++] = static_cast<std::uint8_t>(acc >> bits);
      acc &= (1U << bits) - 1;
    }
  }
  return static_cast<int>(n);
}

// ---- reader ----

CsvLogReader::Step CsvLogReader::parse_line(std::string_view line) {
  if (line.find_first_not_of(" \t") == std::string_view::npos) return Step::skipped;
  return std::exchange(have_header_, true) ? row(line) : header(line);
}

CsvLogReader::Step CsvLogReader::header(std::string_view line) {
  std::vector<std::pair<std::size_t, std::string_view>> fields;
  detail::split_fields(line, ',', fields);
  field_.assign(kColumns.size(), 0);
  columns_ = fields.size();
  for (std::size_t c = 0; c < kColumns.size(); ++c) {
    std::size_t i = 0;
    while (i < fields.size() && fields[i].second != kColumns[c]) ++i;
    if (i == fields.size()) {
      for (std::size_t k = 0; k < kColumns.size(); ++k) field_[k] = k;  // carry on in python-can's order
      columns_ = kColumns.size();
      return corrupt(0, "not python-can's CSV header (timestamp,arbitration_id,extended,remote,error,dlc,data)");
    }
    field_[c] = i;
  }
  return Step::skipped;
}

CsvLogReader::Step CsvLogReader::row(std::string_view line) {
  std::vector<std::pair<std::size_t, std::string_view>> f;
  detail::split_fields(line, ',', f);
  if (f.size() != columns_)
    return corrupt(0, fmt::format("{} fields, the header has {}", f.size(), columns_));
  auto at = [&](Column c) { return f[field_[c]]; };
  const auto [time_col, time_text] = at(kTime);
  const auto ns = seconds_to_ns(time_text);
  if (!ns) return corrupt(time_col, "timestamp must be seconds, e.g. 1700000000.00125");
  auto [id_col, id_text] = at(kId);
  if (id_text.starts_with("0x") || id_text.starts_with("0X")) id_text.remove_prefix(2);
  const auto id = id_text.size() <= 8 ? detail::parse_hex(id_text) : std::nullopt;
  if (!id) return corrupt(id_col, "arbitration_id must be hexadecimal, e.g. 0x344");
  std::array<bool, 3> flags{};
  for (Column c : {kExtended, kRemote, kError}) {
    const auto v = flag(at(c).second);
    if (!v) return corrupt(at(c).first, fmt::format("{} must be 1 or 0", kColumns[c]));
    flags[c - kExtended] = *v;
  }
  const auto [dlc_col, dlc_text] = at(kDlc);
  const auto dlc = detail::parse_decimal(dlc_text);
  if (!dlc) return corrupt(dlc_col, "dlc must be a number");
  if (*dlc > 8) return corrupt(dlc_col, "CAN FD frame (more than 8 bytes): the robot's bus is classic CAN, FD is not supported");
  CanFrame fr;
  fr.timestamp_ns = *ns;
  std::string_view data_text = at(kData).second;
  while (!data_text.empty() && (data_text.back() == ' ' || data_text.back() == '\r')) data_text.remove_suffix(1);
  const int n = base64_decode(data_text, fr.data);
  if (n < 0) return corrupt(at(kData).first, "data must be base64 of at most 8 bytes");
  fr.dlc = static_cast<std::uint8_t>(*dlc);
  fr.remote = flags[1];
  fr.error = flags[2];
  if (fr.error) {
    if (fr.remote) return corrupt(at(kRemote).first, "an error frame cannot be a remote frame");
    if (*id > CanFrame::kMaxExtendedId) return corrupt(id_col, "error class above 1FFFFFFF");
    fr.id = static_cast<std::uint32_t>(*id);
  } else {
    fr.extended = flags[0];
    if (*id > (fr.extended ? CanFrame::kMaxExtendedId : CanFrame::kMaxStandardId))
      return corrupt(id_col, fr.extended ? "29-bit id above 1FFFFFFF" : "11-bit id above 7FF (extended is 0)");
    fr.id = static_cast<std::uint32_t>(*id);
  }
  if (!fr.remote && n != fr.dlc)
    return corrupt(at(kData).first, fmt::format("dlc {} but {} data bytes", fr.dlc, n));
  frame_ = fr;
  return Step::frame;
}

// ---- writer ----

void CsvLogWriter::put(const CanFrame& frame, std::string_view /*interface*/) {
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  out_ << fmt::format("{}.{:06},0x{:x},{},{},{},{},{}\n", ns / 1'000'000'000ULL, ns % 1'000'000'000ULL / 1000,
                      frame.id, frame.extended ? 1 : 0, frame.remote ? 1 : 0, frame.error ? 1 : 0, frame.dlc,
                      base64_encode(frame.payload()));
}

}  // namespace saul::host
