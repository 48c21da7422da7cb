#include "saulproto/core/hex.hpp"
#include "saulproto/core/slcan.hpp"

namespace saul::slcan {
namespace {

constexpr char kHex[] = "0123456789ABCDEF";

// Parses n hex digits at s; false if any is not hex.
bool parse_hex(std::string_view s, std::size_t n, std::uint32_t& value) noexcept {
  if (s.size() < n) return false;
  value = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const int v = hex::value(s[i]);
    if (v < 0) return false;
    value = (value << 4) | static_cast<std::uint32_t>(v);
  }
  return true;
}

void copy_text(char (&dst)[24], std::string_view src) noexcept {
  std::size_t n = src.size() < sizeof(dst) - 1 ? src.size() : sizeof(dst) - 1;
  for (std::size_t i = 0; i < n; ++i) dst[i] = src[i];
  dst[n] = '\0';
}

}  // namespace

std::optional<char> bitrate_preset(std::uint32_t bitrate) noexcept {
  switch (bitrate) {
    case 10'000: return '0';
    case 20'000: return '1';
    case 50'000: return '2';
    case 100'000: return '3';
    case 125'000: return '4';
    case 250'000: return '5';
    case 500'000: return '6';
    case 1'000'000: return '8';
    default: return std::nullopt;
  }
}

Result<std::size_t> encode_frame(const CanFrame& frame, std::span<char> out) noexcept {
  if (frame.error) return Reason::error_frame;
  if (!frame.valid()) return Reason::invalid_frame;
  if (out.size() < kMaxClassicLine + 1) return Reason::buffer_too_small;
  std::size_t n = 0;
  out[n++] = frame.remote ? (frame.extended ? 'R' : 'r') : (frame.extended ? 'T' : 't');
  const int digits = frame.extended ? 8 : 3;
  for (int i = digits - 1; i >= 0; --i) out[n++] = kHex[(frame.id >> (4 * i)) & 0xF];
  out[n++] = static_cast<char>('0' + frame.dlc);
  for (std::uint8_t b : frame.payload()) {
    out[n++] = kHex[b >> 4];
    out[n++] = kHex[b & 0xF];
  }
  out[n++] = kCr;
  return n;
}

Result<std::size_t> encode_frame_with_ms(const CanFrame& frame, std::uint16_t ms, std::span<char> out) noexcept {
  auto r = encode_frame(frame, out);
  if (!r) return r;
  std::size_t n = *r - 1;  // overwrite the CR
  const std::uint16_t t = static_cast<std::uint16_t>(ms % 60000U);
  for (int i = 3; i >= 0; --i) out[n++] = kHex[(t >> (4 * i)) & 0xF];
  out[n++] = kCr;
  return n;
}

Result<CanFrame> parse_frame(std::string_view line, DeviceTime* device_time) noexcept {
  if (line.empty()) return Reason::syntax;
  CanFrame f;
  const char kind = line[0];
  switch (kind) {
    case 't': break;
    case 'T': f.extended = true; break;
    case 'r': f.remote = true; break;
    case 'R': f.extended = true; f.remote = true; break;
    default: return Reason::syntax;
  }
  const std::size_t id_digits = f.extended ? 8 : 3;
  std::uint32_t id = 0;
  if (!parse_hex(line.substr(1), id_digits, id)) return Reason::syntax;
  f.id = id;
  if (line.size() < 2 + id_digits) return Reason::truncated;
  const char dlc_char = line[1 + id_digits];
  if (dlc_char < '0' || dlc_char > '8') return Reason::invalid_frame;
  f.dlc = static_cast<std::uint8_t>(dlc_char - '0');
  std::size_t pos = 2 + id_digits;
  if (!f.remote) {
    for (std::uint8_t i = 0; i < f.dlc; ++i) {
      std::uint32_t b = 0;
      if (!parse_hex(line.substr(pos), 2, b)) return line.size() < pos + 2 ? Reason::truncated : Reason::syntax;
      f.data[i] = static_cast<std::uint8_t>(b);
      pos += 2;
    }
  }
  const std::string_view rest = line.substr(pos);
  DeviceTime t;
  if (rest.size() == 4 || rest.size() == 8) {
    std::uint32_t v = 0;
    if (!parse_hex(rest, rest.size(), v)) return Reason::syntax;
    t.unit = rest.size() == 4 ? DeviceTime::Unit::milliseconds : DeviceTime::Unit::microseconds;
    t.value = v;
  } else if (!rest.empty()) {
    return Reason::bad_length;
  }
  if (!f.valid()) return Reason::invalid_frame;
  if (device_time) *device_time = t;
  return f;
}

Event LineDecoder::finish_line(std::string_view line, bool bel) noexcept {
  Event e;
  Counters& counters = rules_.counters;
  if (bel) {
    e.kind = Event::Kind::error;
    ++counters.acks;
    return e;
  }
  if (line.empty()) {
    e.kind = Event::Kind::ok;
    ++counters.acks;
    return e;
  }
  switch (line[0]) {
    case 't':
    case 'T':
    case 'r':
    case 'R': {
      auto f = parse_frame(line, &e.device_time);
      if (f) {
        e.kind = Event::Kind::frame;
        e.frame = *f;
        ++counters.frames;
        return e;
      }
      e.reason = f.reason();
      break;
    }
    case 'z':
    case 'Z':
      if (line.size() == 1) {
        e.kind = Event::Kind::tx_ack;
        ++counters.acks;
        return e;
      }
      e.reason = Reason::syntax;
      break;
    case 'd':
    case 'D':
    case 'b':
    case 'B':
      ++counters.fd_frames;
      e.reason = Reason::invalid_frame;
      break;
    case 'V':
    case 'v':
      e.kind = Event::Kind::version;
      copy_text(e.text, line.substr(1));
      return e;
    case 'F': {
      std::uint32_t v = 0;
      if (line.size() == 3 && parse_hex(line.substr(1), 2, v)) {
        e.kind = Event::Kind::status;
        e.value = v;
        return e;
      }
      e.reason = Reason::syntax;
      break;
    }
    case 'e':
      e.kind = Event::Kind::bus_error;
      copy_text(e.text, line.substr(1));
      return e;
    case 's':
      e.kind = Event::Kind::bus_state;
      copy_text(e.text, line.substr(1));
      return e;
    default:
      e.reason = Reason::syntax;
      break;
  }
  e.kind = Event::Kind::rejected;
  copy_text(e.text, line);
  ++counters.rejected_lines;
  return e;
}

framing::Verdict LineDecoder::Rules::check(std::span<const std::uint8_t> c) noexcept {
  using framing::Verdict;
  const char last = static_cast<char>(c.back());
  const bool ends = last == kCr || last == kBel || last == '\n';
  if (overlong) {  // every byte of the rest of the line comes alone
    if (ends) overlong = false;
    return Verdict::reject;
  }
  if (ends) return last == '\n' && c.size() == 1 ? Verdict::reject : Verdict::frame;  // tolerate CR LF
  if (c.size() > kMaxLine) {
    ++counters.overlong_lines;
    overlong = true;
    return Verdict::discard;
  }
  return Verdict::more;
}

std::optional<Event> LineDecoder::push(char c) noexcept {
  std::optional<Event> event;
  framer_.push(static_cast<std::uint8_t>(c), rules_, [this, &event](std::span<const std::uint8_t> line) {
    const std::string_view text(reinterpret_cast<const char*>(line.data()), line.size() - 1);
    event = finish_line(text, static_cast<char>(line.back()) == kBel);
  });
  return event;
}

}  // namespace saul::slcan
