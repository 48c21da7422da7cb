#include "saulproto/host/capture/trc.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "capture_io.hpp"
#include "civil_time.hpp"
#include "text_fields.hpp"

namespace saul::host {
namespace {

using detail::kFdUnsupported;

constexpr std::int64_t kDaysFrom1899To1970 = 25569;  // 1899-12-30 .. 1970-01-01
constexpr std::uint64_t kStartStepNs = 864'000'000;  // 1e-5 days: a start time exact with 5 decimals

}  // namespace

std::optional<std::uint64_t> parse_trc_start_time(std::string_view days) {
  const std::size_t dot = days.find('.');
  const std::string_view whole = days.substr(0, dot);
  std::string_view frac = dot == std::string_view::npos ? std::string_view{} : days.substr(dot + 1);
  const auto d = detail::parse_decimal(whole);
  if (!d || *d < static_cast<std::uint64_t>(kDaysFrom1899To1970) || *d > 3'000'000) return std::nullopt;
  if (frac.size() > 14) frac = frac.substr(0, 14);  // beyond 14 decimals of a day: below a nanosecond
  std::uint64_t f = 0;
  if (!frac.empty()) {
    const auto v = detail::parse_decimal(frac);
    if (!v) return std::nullopt;
    f = *v;
  }
  std::uint64_t frac_ns = f * 86'400;  // f < 10^14: no overflow
  if (frac.size() <= 9) {
    for (std::size_t i = frac.size(); i < 9; ++i) frac_ns *= 10;
  } else {
    for (std::size_t i = 9; i < frac.size(); ++i) frac_ns /= 10;
  }
  return (*d - static_cast<std::uint64_t>(kDaysFrom1899To1970)) * detail::kNsPerDay + frac_ns;
}

// ---- reader ----

TrcReader::Step TrcReader::parse_line(std::string_view line) {
  line_length_ = line.size();
  detail::split_tokens(line, tokens_);
  if (tokens_.empty()) return Step::skipped;
  if (tokens_[0].second.front() == ';') return directive(line);
  return version_ >= 20 ? v2_line() : v1_line();
}

TrcReader::Step TrcReader::directive(std::string_view line) {
  const std::size_t start = line.find(';');
  const std::string_view text = line.substr(start + 1);
  const std::size_t eq = text.find('=');
  if (!text.starts_with("$") || eq == std::string_view::npos) return Step::skipped;  // a comment
  const std::string_view key = text.substr(0, eq);
  std::string_view value = text.substr(eq + 1);
  while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
  const std::size_t column = start + 2 + eq;
  if (key == "$FILEVERSION") {
    static constexpr std::pair<std::string_view, int> kVersions[] = {
        {"1.0", 10}, {"1.1", 11}, {"1.2", 12}, {"1.3", 13}, {"2.0", 20}, {"2.1", 21}};
    for (const auto& [name, number] : kVersions) {
      if (value != name) continue;
      version_ = number;
      if (columns_.empty() && number == 20) columns_ = "NOTIdlD";
      if (columns_.empty() && number == 21) columns_ = "NOTBIdRLD";
      return Step::skipped;
    }
    return corrupt(column, fmt::format("TRC file version '{}' is not one of 1.0 1.1 1.2 1.3 2.0 2.1", value));
  }
  if (key == "$STARTTIME") {
    start_ns_ = parse_trc_start_time(value);
    if (!start_ns_) return corrupt(column, "start time must be days since 1899-12-30, e.g. 44548.6028595139");
    return Step::skipped;
  }
  if (key == "$COLUMNS") {
    std::string columns;
    for (std::size_t i = 0; i < value.size(); ++i) {
      const char c = value[i];
      if (c == ',' || c == ' ') continue;
      if (std::string_view("NOTBIdRlLD").find(c) == std::string_view::npos || columns.find(c) != std::string::npos)
        return corrupt(column + i, fmt::format("unknown or repeated column '{}'", c));
      columns += c;
    }
    if (columns.find('O') == std::string::npos || columns.find('T') == std::string::npos ||
        columns.find('I') == std::string::npos || columns.back() != 'D' ||
        (columns.find('l') == std::string::npos && columns.find('L') == std::string::npos))
      return corrupt(column, "columns must include O, T, I, l or L, and end with D");
    columns_ = std::move(columns);
    return Step::skipped;
  }
  return Step::skipped;  // other directives
}

TrcReader::Step TrcReader::frame_from(std::size_t time_token, std::optional<std::size_t> bus_token,
                                      std::size_t id_token, std::size_t dlc_token, bool dlc_is_length,
                                      std::size_t data_token, bool remote) {
  const auto [time_col, time_text] = tokens_[time_token];
  const auto offset = detail::parse_scaled(time_text, 1'000'000, 6);  // ms with up to 6 decimals, in ns
  if (!offset) return corrupt(time_col, "time offset must be milliseconds, e.g. 1059.900");
  const bool error = id_token == kErrorLine;
  CanFrame f = error ? detail::bus_error_frame() : CanFrame{};
  f.timestamp_ns = start_ns_.value_or(0) + *offset;
  name_ = "can0";
  if (bus_token && *bus_token < tokens_.size()) {  // (an error line may end before it)
    const auto [bus_col, bus_text] = tokens_[*bus_token];
    const auto bus = detail::parse_decimal(bus_text);
    if (bus && *bus > 0 && *bus <= 255)
      name_ = detail::channel_name(*bus);
    else if (!error)
      return corrupt(bus_col, "bus must be 1..255");  // an error line's reads as can0
  }
  if (error) {
    frame_ = f;
    return Step::frame;
  }
  const auto [id_col, id_text] = tokens_[id_token];
  const auto id = id_text.size() <= 8 ? detail::parse_hex(id_text) : std::nullopt;
  if (!id) return corrupt(id_col, "id must be 1 to 8 hex digits");
  f.extended = id_text.size() > 4;
  if (*id > (f.extended ? CanFrame::kMaxExtendedId : CanFrame::kMaxStandardId))
    return corrupt(id_col, f.extended ? "29-bit id above 1FFFFFFF" : "11-bit id above 7FF");
  f.id = static_cast<std::uint32_t>(*id);
  if (dlc_token >= tokens_.size()) return corrupt(line_length_, "missing data length");
  const auto [dlc_col, dlc_text] = tokens_[dlc_token];
  const auto dlc = detail::parse_decimal(dlc_text);
  if (!dlc || *dlc > (dlc_is_length ? 8U : 15U))
    return corrupt(dlc_col, dlc_is_length ? "data length must be 0..8 (classic CAN)" : "DLC must be 0..15");
  f.dlc = static_cast<std::uint8_t>(*dlc > 8 ? 8 : *dlc);  // classic CAN: a DLC of 9..15 still means 8 bytes
  if (!remote && data_token < tokens_.size() && tokens_[data_token].second == "RTR") remote = true;
  f.remote = remote;
  if (!remote) {
    if (tokens_.size() < data_token + f.dlc)
      return corrupt(line_length_, fmt::format("{} data bytes announced, {} found", f.dlc,
                                               tokens_.size() > data_token ? tokens_.size() - data_token : 0));
    for (std::size_t i = 0; i < f.dlc; ++i) {
      const auto [col, text] = tokens_[data_token + i];
      const auto b = text.size() == 2 ? detail::parse_hex(text) : std::nullopt;
      if (!b) return corrupt(col, "data byte must be 2 hex digits");
      f.data[i] = static_cast<std::uint8_t>(*b);
    }
  }
  frame_ = f;
  return Step::frame;
}

TrcReader::Step TrcReader::v1_line() {
  const auto [col0, number] = tokens_[0];
  if (number.back() != ')') return corrupt(col0, "expected a message number like '12)' (or a ';' comment)");
  const bool has_bus = version_ == 12 || version_ == 13;
  const auto bus = has_bus ? std::optional<std::size_t>(2) : std::nullopt;
  const std::size_t type_token = has_bus ? 3 : 2;
  if (version_ == 10) {  // no type column: number) time id dlc data
    if (tokens_.size() < 4) return corrupt(line_length_, "expected time, id and length");
    if (tokens_[2].second == "FFFFFFFF") return Step::skipped;  // a bus status line
    return frame_from(1, std::nullopt, 2, 3, false, 4, false);
  }
  if (tokens_.size() <= type_token) return corrupt(line_length_, "expected time and message type");
  const auto [type_col, type] = tokens_[type_token];
  if (type == "Warng") return Step::skipped;  // bus status (BUSHEAVY, BUSOFF ...)
  if (type == "Error") return frame_from(1, bus, kErrorLine, 0, false, 0, false);
  if (type != "Rx" && type != "Tx") return corrupt(type_col, fmt::format("unknown message type '{}'", type));
  const std::size_t id_token = type_token + 1;
  const std::size_t dlc_token = id_token + (version_ == 13 ? 2 : 1);
  if (tokens_.size() <= id_token) return corrupt(line_length_, "missing id");
  return frame_from(1, bus, id_token, dlc_token, false, dlc_token + 1, false);
}

TrcReader::Step TrcReader::v2_line() {
  const std::size_t t = columns_.find('T');
  if (tokens_.size() <= t) return corrupt(line_length_, "expected the message type column");
  const auto [type_col, type] = tokens_[t];
  auto index = [&](char c) -> std::optional<std::size_t> {
    const std::size_t i = columns_.find(c);
    return i == std::string::npos ? std::nullopt : std::optional<std::size_t>(i);
  };
  if (type == "ST" || type == "EC" || type == "EV") return Step::skipped;  // status, error counters, events
  if (type == "FD" || type == "FB" || type == "FE" || type == "BI") return corrupt(type_col, std::string(kFdUnsupported));
  const std::size_t o = columns_.find('O');
  if (o >= tokens_.size()) return corrupt(line_length_, "line has fewer columns than $COLUMNS");
  if (type == "ER") return frame_from(o, index('B'), kErrorLine, 0, false, 0, false);
  if (type != "DT" && type != "RR") return corrupt(type_col, fmt::format("unknown message type '{}'", type));
  const bool by_length = index('l').has_value();
  const std::size_t length = by_length ? *index('l') : *index('L');
  const std::size_t id = *index('I');
  const std::size_t bus = index('B').value_or(0);
  if (tokens_.size() <= std::max({length, id, bus})) return corrupt(line_length_, "line has fewer columns than $COLUMNS");
  return frame_from(o, index('B'), id, length, by_length, *index('D'), type == "RR");
}

// ---- writer ----

void TrcWriter::begin(std::uint64_t first_ns) {
  start_ns_ = first_ns - first_ns % kStartStepNs;
  const std::uint64_t days = start_ns_ / detail::kNsPerDay;
  const std::uint64_t steps = start_ns_ % detail::kNsPerDay / kStartStepNs;
  const detail::Civil c = detail::civil_from_days(static_cast<std::int64_t>(days));
  const std::uint64_t in_day = start_ns_ % detail::kNsPerDay / 1'000'000;  // ms
  out_ << fmt::format(";$FILEVERSION=2.1\r\n;$STARTTIME={}.{:05}00000\r\n;$COLUMNS=N,O,T,B,I,d,R,L,D\r\n;\r\n",
                      days + static_cast<std::uint64_t>(kDaysFrom1899To1970), steps)
       << fmt::format(";   Start time: {:02}.{:02}.{} {:02}:{:02}:{:02}.{:03}.0 (UTC)\r\n", c.day, c.month, c.year,
                      in_day / 3'600'000, in_day / 60'000 % 60, in_day / 1000 % 60, in_day % 1000)
       << ";   Generated by libsaulproto (saulctl convert / record)\r\n"
          ";   Bus N is the N-th interface of the recording, in order of appearance\r\n"
          ";-------------------------------------------------------------------------------\r\n"
          ";   Message   Time    Type    ID     Rx/Tx\r\n"
          ";   Number    Offset  |  Bus  [hex]  |  Reserved\r\n"
          ";   |         [ms]    |  |    |      |  |  Data Length Code\r\n"
          ";   |         |       |  |    |      |  |  |    Data [hex] ...\r\n"
          ";   |         |       |  |    |      |  |  |    |\r\n"
          ";---+-- ------+------ +- +- --+----- +- +- +--- +- -- -- -- -- -- -- --\r\n";
}

void TrcWriter::put(const CanFrame& frame, std::string_view interface) {
  const std::size_t index = detail::channel_index(buses_, interface, 255, "TRC");
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  const std::uint64_t us = (ns > start_ns_ ? ns - start_ns_ : 0) / 1000;
  const std::string time = fmt::format("{}.{:03}", us / 1000, us % 1000);
  std::string line;
  if (frame.error) {
    line = fmt::format("{:>7} {:>13} ER {:>2} {:>8} Rx -  0", ++number_, time, index + 1, "-");
  } else {
    const std::string id = frame.extended ? fmt::format("{:08X}", frame.id) : fmt::format("{:04X}", frame.id);
    line = fmt::format("{:>7} {:>13} {} {:>2} {:>8} Rx -  {:<4}", ++number_, time, frame.remote ? "RR" : "DT",
                       index + 1, id, frame.dlc);
    for (std::uint8_t b : frame.payload()) line += fmt::format(" {:02X}", b);
    while (!line.empty() && line.back() == ' ') line.pop_back();
  }
  out_ << line << "\r\n";
}

}  // namespace saul::host
