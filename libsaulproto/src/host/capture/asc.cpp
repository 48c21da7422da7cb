#include "saulproto/host/capture/asc.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <stdexcept>

#include "../util.hpp"
#include "capture_io.hpp"
#include "civil_time.hpp"
#include "text_fields.hpp"

namespace saul::host {
namespace {

using detail::kFdUnsupported;
using detail::Civil;
using detail::civil_from_days;
using detail::days_from_civil;
using detail::kNsPerSecond;

constexpr std::array<std::string_view, 12> kMonths = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                                      "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
constexpr std::array<std::string_view, 7> kWeekdays = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};

bool iequals(std::string_view a, std::string_view b) {
  return std::ranges::equal(a, b, [](char x, char y) { return detail::ascii_lower(x) == detail::ascii_lower(y); });
}

bool all_digits(std::string_view s) { return !s.empty() && s.find_first_not_of("0123456789") == s.npos; }

bool hex_digits(std::string_view s) { return !s.empty() && s.find_first_not_of("0123456789abcdefABCDEF") == s.npos; }

using detail::parse_unsigned;

/// "12.345678" (1 to 9 fraction digits, or none) to nanoseconds.
std::optional<std::uint64_t> parse_time(std::string_view s) {
  const std::size_t dot = s.find('.');
  if (dot != std::string_view::npos && (dot + 1 == s.size() || s.size() - dot - 1 > 9)) return std::nullopt;
  return detail::parse_scaled(s, kNsPerSecond, 9);
}

std::optional<unsigned> month_of(std::string_view s) {
  for (std::size_t i = 0; i < kMonths.size(); ++i)
    if (iequals(s, kMonths[i])) return static_cast<unsigned>(i + 1);
  // German abbreviations, as CANoe writes them on German Windows
  if (iequals(s, "Mrz") || s == "M\xC3\xA4r" || s == "M\xE4r") return 3U;
  if (iequals(s, "Mai")) return 5U;
  if (iequals(s, "Okt")) return 10U;
  if (iequals(s, "Dez")) return 12U;
  return std::nullopt;
}

}  // namespace

std::optional<std::uint64_t> parse_asc_date(std::string_view text) {
  std::vector<std::pair<std::size_t, std::string_view>> tokens;
  detail::split_tokens(text, tokens);
  std::vector<std::string_view> t;
  for (const auto& token : tokens) t.push_back(token.second);
  std::size_t i = 0;
  if (i < t.size() && !month_of(t[i])) ++i;  // weekday
  if (i + 4 > t.size()) return std::nullopt;
  const auto month = month_of(t[i++]);
  const auto day = parse_unsigned(t[i++], 10);
  const std::string_view clock = t[i++];
  if (!month || !day || *day < 1 || *day > 31) return std::nullopt;
  // HH:MM:SS[.fff]
  const std::size_t c1 = clock.find(':');
  const std::size_t c2 = c1 == std::string_view::npos ? c1 : clock.find(':', c1 + 1);
  if (c2 == std::string_view::npos) return std::nullopt;
  const auto hour = parse_unsigned(clock.substr(0, c1), 10);
  const auto minute = parse_unsigned(clock.substr(c1 + 1, c2 - c1 - 1), 10);
  const auto second = parse_time(clock.substr(c2 + 1));
  if (!hour || !minute || !second || *hour > 23 || *minute > 59 || *second >= 61 * kNsPerSecond) return std::nullopt;
  std::uint64_t h = *hour;
  if (i < t.size() && (iequals(t[i], "am") || iequals(t[i], "pm"))) {
    if (h < 1 || h > 12) return std::nullopt;
    const bool pm = iequals(t[i], "pm");
    if (h == 12) h = 0;
    if (pm) h += 12;
    ++i;
  }
  if (i >= t.size()) return std::nullopt;
  const auto year = parse_unsigned(t[i], 10);
  if (!year || *year < 1970 || *year > 9999) return std::nullopt;
  const std::int64_t days = days_from_civil(static_cast<std::int64_t>(*year), *month, static_cast<unsigned>(*day));
  if (days < 0) return std::nullopt;
  return (static_cast<std::uint64_t>(days) * 86400U + h * 3600U + *minute * 60U) * kNsPerSecond + *second;
}

std::string format_asc_date(std::uint64_t ns) {
  const std::uint64_t sec = ns / kNsPerSecond;
  const auto days = static_cast<std::int64_t>(sec / 86400U);
  const std::uint64_t in_day = sec % 86400U;
  const Civil c = civil_from_days(days);
  return fmt::format("{} {} {:02} {:02}:{:02}:{:02} {}", kWeekdays[detail::weekday_from_days(days)],
                     kMonths[c.month - 1], c.day, in_day / 3600U, in_day / 60U % 60U, in_day % 60U, c.year);
}

// ---- reader ----

std::uint64_t AscReader::absolute(std::uint64_t time_ns) {
  if (deltas_) {
    elapsed_ns_ += time_ns;
    time_ns = elapsed_ns_;
  }
  return start_ns_.value_or(0) + time_ns;
}

AscReader::Step AscReader::parse_line(std::string_view line) {
  detail::split_tokens(line, tokens_);
  if (tokens_.empty()) return Step::skipped;
  const auto [col0, first] = tokens_[0];
  if (first[0] >= '0' && first[0] <= '9') return timed_line(line);
  if (first.substr(0, 2) == "//") return Step::skipped;
  if (iequals(first, "date")) {
    if (!trigger_block_date_) {
      if (auto d = parse_asc_date(line.substr(col0 + first.size()))) start_ns_ = d;
    }
    return Step::skipped;
  }
  if (iequals(first, "base")) {
    if (tokens_.size() < 2 || !(iequals(tokens_[1].second, "hex") || iequals(tokens_[1].second, "dec")))
      return corrupt(tokens_.size() < 2 ? line.size() : tokens_[1].first, "base must be 'hex' or 'dec'");
    base_ = iequals(tokens_[1].second, "hex") ? 16 : 10;
    if (tokens_.size() >= 4 && iequals(tokens_[2].second, "timestamps")) {
      if (iequals(tokens_[3].second, "relative")) {
        deltas_ = true;
      } else if (iequals(tokens_[3].second, "absolute")) {
        deltas_ = false;
      } else {
        return corrupt(tokens_[3].first, "timestamps must be 'absolute' or 'relative'");
      }
    }
    return Step::skipped;
  }
  if (iequals(first, "begin") && tokens_.size() >= 2 && iequals(tokens_[1].second, "triggerblock")) {
    const std::size_t after = tokens_[1].first + tokens_[1].second.size();
    if (auto d = parse_asc_date(line.substr(after))) {
      start_ns_ = d;
      trigger_block_date_ = true;
    }
    elapsed_ns_ = 0;
    return Step::skipped;
  }
  if (iequals(first, "end") && tokens_.size() >= 2 && iequals(tokens_[1].second, "triggerblock"))
    return Step::skipped;
  if ((iequals(first, "no") && tokens_.size() >= 2 && iequals(tokens_[1].second, "internal")) ||
      (iequals(first, "internal") && tokens_.size() >= 2 && iequals(tokens_[1].second, "events")))
    return Step::skipped;
  return corrupt(col0, "not an ASC line (expected a header keyword or a time)");
}

AscReader::Step AscReader::timed_line(std::string_view line) {
  const auto time = parse_time(tokens_[0].second);
  if (!time) return corrupt(tokens_[0].first, "time must be seconds with up to 9 decimals, e.g. 1.250000");
  if (tokens_.size() < 2) return corrupt(line.size(), "nothing after the time");
  const std::string_view ch = tokens_[1].second;
  if (iequals(ch, "CANFD")) return canfd_line(line, *time);
  if (!all_digits(ch)) return Step::skipped;  // an event: "Start of measurement", "Trigger", ...
  if (tokens_.size() >= 3 && iequals(tokens_[2].second.substr(0, 10), "errorframe")) {
    const auto n = channel(1);
    return n ? emit(detail::bus_error_frame(), *n, *time) : Step::corrupt;
  }
  if (tokens_.size() >= 4 && (iequals(tokens_[3].second, "rx") || iequals(tokens_[3].second, "tx")))
    return frame_line(line, *time);
  if (tokens_.size() >= 4 && iequals(tokens_[3].second, "txrq")) return Step::skipped;  // a transmit request
  if (tokens_.size() == 2) return corrupt(line.size(), "nothing after the channel");
  std::string_view id = tokens_[2].second;
  if (!id.empty() && (id.back() == 'x' || id.back() == 'X')) id.remove_suffix(1);
  if (hex_digits(id))
    return corrupt(tokens_.size() >= 4 ? tokens_[3].first : line.size(), "expected Rx or Tx after the id");
  return Step::skipped;  // an event of the channel: "Statistic:", "SV:", ...
}

std::optional<std::uint64_t> AscReader::channel(std::size_t token) {
  const auto n = parse_unsigned(tokens_[token].second, 10);
  if (n && *n > 0 && *n <= 255) return n;
  corrupt(tokens_[token].first, "channel must be 1..255");
  return std::nullopt;
}

AscReader::Step AscReader::emit(CanFrame f, std::uint64_t channel, std::uint64_t time_ns) {
  f.timestamp_ns = absolute(time_ns);
  frame_ = f;
  name_ = detail::channel_name(channel);
  return Step::frame;
}

bool AscReader::data_bytes(std::size_t first, CanFrame& f) {
  for (std::size_t i = 0; i < f.dlc; ++i) {
    const auto [col, text] = tokens_[first + i];
    const auto b = text.size() <= 3 ? parse_unsigned(text, base_) : std::nullopt;
    if (!b || *b > 0xFF) {
      corrupt(col, "data byte is not a number 0..255 in the file's base");
      return false;
    }
    f.data[i] = static_cast<std::uint8_t>(*b);
  }
  return true;
}

bool AscReader::parse_id(std::size_t token, CanFrame& f) {
  const auto [id_col, id_token] = tokens_[token];
  std::string_view id_text = id_token;
  if (id_text.back() == 'x' || id_text.back() == 'X') {
    f.extended = true;
    id_text.remove_suffix(1);
  }
  const auto id = parse_unsigned(id_text, base_);
  if (!id) {
    corrupt(id_col, base_ == 16 ? "id is not hexadecimal" : "id is not a decimal number");
    return false;
  }
  if (*id > (f.extended ? CanFrame::kMaxExtendedId : CanFrame::kMaxStandardId)) {
    corrupt(id_col, f.extended ? "29-bit id above 1FFFFFFF" : "11-bit id above 7FF (extended ids end in 'x')");
    return false;
  }
  f.id = static_cast<std::uint32_t>(*id);
  return true;
}

AscReader::Step AscReader::frame_line(std::string_view line, std::uint64_t time_ns) {
  const auto n = channel(1);
  CanFrame f;
  if (!n || !parse_id(2, f)) return Step::corrupt;
  if (tokens_.size() < 5) return corrupt(line.size(), "expected 'd' (data) or 'r' (remote) after the direction");
  const auto [kind_col, kind] = tokens_[4];
  if (kind == "r" || kind == "R") {
    f.remote = true;
    if (tokens_.size() >= 6 && all_digits(tokens_[5].second)) {
      const auto dlc = parse_unsigned(tokens_[5].second, base_);
      if (!dlc || *dlc > CanFrame::kMaxDlc) return corrupt(tokens_[5].first, "remote frame length must be 0..8");
      f.dlc = static_cast<std::uint8_t>(*dlc);
    }
  } else if (kind == "d" || kind == "D") {
    if (tokens_.size() < 6) return corrupt(line.size(), "missing DLC after 'd'");
    const auto dlc = parse_unsigned(tokens_[5].second, base_);
    if (!dlc) return corrupt(tokens_[5].first, "DLC is not a number");
    if (*dlc > 15) return corrupt(tokens_[5].first, "DLC above 15");
    f.dlc = static_cast<std::uint8_t>(*dlc > CanFrame::kMaxDlc ? CanFrame::kMaxDlc : *dlc);  // 9..15: 8 bytes
    if (tokens_.size() < std::size_t{6} + f.dlc)
      return corrupt(line.size(), fmt::format("{} data bytes announced, {} found", f.dlc, tokens_.size() - 6));
    if (!data_bytes(6, f)) return Step::corrupt;
    // anything after the data (Vector's "Length = ... BitCount = ... ID = ...") is ignored
  } else {
    return corrupt(kind_col, "expected 'd' (data) or 'r' (remote) after the direction");
  }
  return emit(f, *n, time_ns);
}

AscReader::Step AscReader::canfd_line(std::string_view line, std::uint64_t time_ns) {
  if (tokens_.size() < 5) return corrupt(line.size(), "CANFD line ends after the channel");
  const auto n = channel(2);
  if (!n) return Step::corrupt;
  if (iequals(tokens_[4].second.substr(0, 10), "errorframe") || iequals(tokens_[3].second.substr(0, 10), "errorframe"))
    return emit(detail::bus_error_frame(), *n, time_ns);
  CanFrame f;
  if (!parse_id(4, f)) return Step::corrupt;
  std::size_t k = 5;
  if (k < tokens_.size() && !all_digits(tokens_[k].second)) ++k;  // the symbolic name, when the writer gives one
  if (tokens_.size() < k + 4) return corrupt(line.size(), "expected BRS, ESI, DLC and data length after the id");
  const auto brs = parse_unsigned(tokens_[k].second, 10);
  const auto esi = parse_unsigned(tokens_[k + 1].second, 10);
  const auto dlc = parse_unsigned(tokens_[k + 2].second, base_);
  const auto length = parse_unsigned(tokens_[k + 3].second, 10);
  if (!brs || !esi || *brs > 1 || *esi > 1) return corrupt(tokens_[k].first, "BRS and ESI must be 0 or 1");
  if (!dlc || *dlc > 15) return corrupt(tokens_[k + 2].first, "DLC must be 0..F");
  if (!length || *length > 64) return corrupt(tokens_[k + 3].first, "data length must be 0..64");
  const std::size_t data = k + 4;
  if (tokens_.size() < data + *length)
    return corrupt(line.size(), fmt::format("{} data bytes announced, {} found", *length, tokens_.size() - data));
  // After the data: message duration, bit count, then the flags (hex): EDL 0x1000 marks CAN FD, 0x10 remote.
  const std::size_t flags_at = data + *length + 2;
  std::optional<std::uint64_t> flags;
  if (flags_at < tokens_.size()) flags = parse_unsigned(tokens_[flags_at].second, 16);
  // One rule for every CANFD line: it is CAN FD (reported, skipped) when anything on it says so: the EDL flag, or
  // what only an FD frame has (bit rate switch, error state indicator, DLC above 8, more than 8 bytes), even where
  // the flags column leaves EDL clear (python-can's logfile.asc: a 64-byte line with flags 0). Otherwise it is a
  // classic frame logged on an FD channel (log2asc -f, CANoe) and read as one. An ErrorFrame on a CANFD line (above)
  // is a bus error, as on a CAN line: an event, not a frame's content.
  const bool fd = (flags && (*flags & 0x1000) != 0) || *brs == 1 || *esi == 1 || *length > 8 || *dlc > 8;
  if (fd) return corrupt(tokens_[1].first, std::string(kFdUnsupported));
  f.remote = flags ? (*flags & 0x10) != 0 : (*length == 0 && *dlc > 0);
  f.dlc = static_cast<std::uint8_t>(*dlc > CanFrame::kMaxDlc ? CanFrame::kMaxDlc : *dlc);
  if (!f.remote) {
    if (*length != f.dlc) return corrupt(tokens_[k + 3].first, fmt::format("data length {} but DLC {}", *length, *dlc));
    if (!data_bytes(data, f)) return Step::corrupt;
  }
  return emit(f, *n, time_ns);
}

// ---- writer ----

void AscWriter::begin(std::uint64_t first_ns) {
  start_ns_ = first_ns - first_ns % kNsPerSecond;
  const std::string date = format_asc_date(start_ns_);
  out_ << "date " << date << "\nbase hex  timestamps absolute\ninternal events logged\nBegin Triggerblock " << date
       << "\n   0.000000 Start of measurement\n";
}

void AscWriter::put(const CanFrame& frame, std::string_view interface) {
  const std::size_t index = detail::channel_index(channels_, interface, 255, "ASC");
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  const std::uint64_t rel = ns > start_ns_ ? ns - start_ns_ : 0;
  const std::uint64_t usec = rel / 1000U;
  std::string line = fmt::format("{:4}.{:06} {}  ", usec / 1'000'000U, usec % 1'000'000U, index + 1);
  if (frame.error) {
    line += "ErrorFrame";
  } else {
    const std::string id = fmt::format("{:X}{}", frame.id, frame.extended ? "x" : "");
    if (frame.remote) {
      line += fmt::format("{:<15} Rx   r {}", id, frame.dlc);
    } else {
      line += fmt::format("{:<15} Rx   d {}", id, frame.dlc);
      for (std::uint8_t b : frame.payload()) line += fmt::format(" {:02X}", b);
    }
  }
  line += '\n';
  out_ << line;
}

void AscWriter::finish() { out_ << "End TriggerBlock\n"; }

}  // namespace saul::host
