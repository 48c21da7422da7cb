#include "saulproto/core/hex.hpp"
#include "saulproto/host/capture/candump.hpp"

#include <fmt/format.h>

#include <charconv>
#include <stdexcept>

namespace saul::host {
namespace {

bool fail(CandumpError& error, std::size_t column, std::string message) {
  error.column = column;
  error.message = std::move(message);
  return false;
}

}  // namespace

bool parse_candump_line(std::string_view line, CandumpLine& out, CandumpError& error) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  // "(" seconds "." fraction ")"
  if (line.empty() || line[0] != '(') return fail(error, 0, "expected '(' starting a timestamp");
  const std::size_t close = line.find(')');
  if (close == std::string_view::npos) return fail(error, 0, "timestamp has no closing ')'");
  const std::string_view stamp = line.substr(1, close - 1);
  const std::size_t dot = stamp.find('.');
  if (dot == std::string_view::npos) return fail(error, 1, "timestamp needs a '.' between seconds and fraction");
  std::uint64_t sec = 0;
  std::uint64_t frac = 0;
  const std::string_view sec_text = stamp.substr(0, dot);
  const std::string_view frac_text = stamp.substr(dot + 1);
  if (sec_text.empty() || std::from_chars(sec_text.data(), sec_text.data() + sec_text.size(), sec).ptr !=
                              sec_text.data() + sec_text.size())
    return fail(error, 1, "timestamp seconds are not a number");
  if (frac_text.empty() || frac_text.size() > 9 ||
      std::from_chars(frac_text.data(), frac_text.data() + frac_text.size(), frac).ptr !=
          frac_text.data() + frac_text.size())
    return fail(error, 2 + dot, "timestamp fraction must be 1 to 9 digits");
  for (std::size_t i = frac_text.size(); i < 9; ++i) frac *= 10;  // to nanoseconds

  // interface
  std::size_t pos = close + 1;
  while (pos < line.size() && line[pos] == ' ') ++pos;
  const std::size_t if_start = pos;
  while (pos < line.size() && line[pos] != ' ') ++pos;
  if (pos == if_start) return fail(error, if_start, "missing interface name");
  out.interface = line.substr(if_start, pos - if_start);
  while (pos < line.size() && line[pos] == ' ') ++pos;

  // frame: ID '#' DATA
  const std::size_t frame_start = pos;
  std::size_t end = line.find(' ', pos);
  if (end == std::string_view::npos) end = line.size();
  const std::string_view text = line.substr(frame_start, end - frame_start);
  const std::size_t hash = text.find('#');
  if (hash == std::string_view::npos) return fail(error, frame_start, "frame needs '#' between id and data");
  if (hash != 3 && hash != 8) return fail(error, frame_start, "id must be 3 hex digits (11-bit) or 8 (29-bit)");
  std::uint32_t id = 0;
  for (std::size_t i = 0; i < hash; ++i) {
    const int v = hex::value(text[i]);
    if (v < 0) return fail(error, frame_start + i, "id is not hexadecimal");
    id = (id << 4) | static_cast<std::uint32_t>(v);
  }
  CanFrame f;
  f.timestamp_ns = sec * 1'000'000'000ULL + frac;
  std::string_view data = text.substr(hash + 1);
  std::size_t data_col = frame_start + hash + 1;
  if (!data.empty() && data[0] == '#')
    return fail(error, data_col, "CAN FD frame: the robot's bus is classic CAN, FD is not supported");
  if (hash == 8) {
    constexpr std::uint32_t kErrFlag = 0x2000'0000;
    if (id & kErrFlag) {
      f.error = true;
      id &= CanFrame::kMaxExtendedId;
    } else {
      f.extended = true;
      if (id > CanFrame::kMaxExtendedId) return fail(error, frame_start, "29-bit id above 1FFFFFFF");
    }
  } else if (id > CanFrame::kMaxStandardId) {
    return fail(error, frame_start, "11-bit id above 7FF");
  }
  f.id = id;
  // A raw DLC of 9..F after 8 data bytes (len8_dlc, can-utils since 2020.12: "3FF#55AA010203040506_D", "123#R8_D"):
  // classic CAN carries 8 bytes then, which is what the frame keeps.
  bool raw_dlc = false;
  if (data.size() >= 2 && data[data.size() - 2] == '_') {
    const int v = hex::value(data.back());
    if (v < 9) return fail(error, data_col + data.size() - 1, "raw DLC suffix must be _9 to _F (after 8 data bytes)");
    data.remove_suffix(2);
    raw_dlc = true;
  }
  if (!data.empty() && (data[0] == 'R' || data[0] == 'r')) {
    if (f.error) return fail(error, data_col, "an error frame cannot be a remote frame");
    f.remote = true;
    if (data.size() == 2 && data[1] >= '0' && data[1] <= '8') {
      f.dlc = static_cast<std::uint8_t>(data[1] - '0');
    } else if (data.size() != 1) {
      return fail(error, data_col + 1, "remote frame length must be one digit 0..8");
    }
  } else {
    std::uint8_t n = 0;
    for (std::size_t i = 0; i < data.size();) {
      if (data[i] == '.') {
        ++i;
        continue;
      }
      if (i + 1 >= data.size()) return fail(error, data_col + i, "data has an odd number of hex digits");
      const int hi = hex::value(data[i]);
      const int lo = hex::value(data[i + 1]);
      if (hi < 0 || lo < 0) return fail(error, data_col + i, "data is not hexadecimal");
      if (n == 8) return fail(error, data_col + i, "more than 8 data bytes");
      f.data[n++] = static_cast<std::uint8_t>(hi << 4 | lo);
      i += 2;
    }
    f.dlc = n;
  }
  if (raw_dlc && f.dlc != 8)
    return fail(error, data_col + data.size(), "a raw DLC suffix needs 8 data bytes (or R8)");
  out.frame = f;
  return true;
}

std::string format_candump_frame(const CanFrame& frame) {
  std::string s;
  if (frame.error) {
    s = fmt::format("{:08X}#", frame.id | 0x2000'0000U);
  } else if (frame.extended) {
    s = fmt::format("{:08X}#", frame.id);
  } else {
    s = fmt::format("{:03X}#", frame.id);
  }
  if (frame.remote) {
    s += 'R';
    if (frame.dlc) s += static_cast<char>('0' + frame.dlc);
    return s;
  }
  static constexpr char kHex[] = "0123456789ABCDEF";
  for (std::uint8_t b : frame.payload()) {
    s += kHex[b >> 4];
    s += kHex[b & 0xF];
  }
  return s;
}

std::string candump_interface(std::string_view interface) {
  std::string name(interface.empty() ? std::string_view("can0") : interface);
  for (char& c : name)
    if (static_cast<unsigned char>(c) <= 0x20 || c == 0x7F) c = '_';
  return name;
}

std::string format_candump_line(const CanFrame& frame, std::string_view interface) {
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  return fmt::format("({:010}.{:06}) {} {}", ns / 1'000'000'000ULL, (ns % 1'000'000'000ULL) / 1000,
                     candump_interface(interface), format_candump_frame(frame));
}

CandumpReader::Status CandumpReader::next() {
  while (std::getline(in_, line_)) {
    ++line_number_;
    if (line_.empty() || line_[0] != '(') continue;  // comment or blank, as canplayer does
    if (parse_candump_line(line_, current_, error_)) return Status::frame;
    error_.kind = PositionKind::line;
    error_.position = line_number_;
    error_.recovery = Recovery::next_line;
    return Status::corrupt;
  }
  return Status::end;
}

void CandumpWriter::write(const CanFrame& frame, std::string_view interface) {
  check_open();
  check_writable(frame);
  out_ << format_candump_line(frame, interface) << '\n';
  check_written();
}

}  // namespace saul::host
