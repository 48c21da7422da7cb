#include "saulproto/core/interboard.hpp"

#include "saulproto/core/bytes.hpp"
#include "saulproto/core/crc.hpp"

namespace saul::interboard {
namespace {

// Writes a message's payload (little-endian) into p; returns its length.
struct PayloadWriter {
  std::uint8_t* p;
  std::size_t operator()(const RcCmd& m) const noexcept {
    bytes::put_i16le(p, m.throttle);
    bytes::put_i16le(p + 2, m.steer);
    p[4] = m.flags;
    return 5;
  }
  std::size_t operator()(const Sensor& m) const noexcept {
    bytes::put_u16le(p, m.tof_mm);
    bytes::put_i16le(p + 2, m.baro_delta_pa);
    p[4] = m.nfc_present;
    return 5;
  }
  std::size_t operator()(const Fault& m) const noexcept {
    p[0] = m.flags;
    return 1;
  }
  std::size_t operator()(const State& m) const noexcept {
    bytes::put_i16le(p, m.pitch_x100);
    bytes::put_i16le(p + 2, m.pid_out);
    p[4] = m.error_state;
    return 5;
  }
  std::size_t operator()(const LedCmd& m) const noexcept {
    p[0] = m.pattern;
    p[1] = m.r;
    p[2] = m.g;
    p[3] = m.b;
    return 4;
  }
  std::size_t operator()(const Buzzer& m) const noexcept {
    p[0] = m.tone_id;
    bytes::put_u16le(p + 1, m.duration_ms);
    return 3;
  }
  std::size_t operator()(const SpeedCap& m) const noexcept {
    p[0] = m.percent;
    return 1;
  }
};

}  // namespace

Type type_of(const Message& message) noexcept {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kType; }, message);
}

const char* name_of(const Message& message) noexcept {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kName; }, message);
}

Result<std::size_t> encode(const Message& message, std::span<std::uint8_t> out) noexcept {
  const auto type = static_cast<std::uint8_t>(type_of(message));
  const std::size_t size = kOverhead + *payload_length(type);
  if (out.size() < size) return Reason::buffer_too_small;
  const std::size_t len = std::visit(PayloadWriter{out.data() + 3}, message);
  out[0] = kStartByte;
  out[1] = static_cast<std::uint8_t>(len);
  out[2] = type;
  out[3 + len] = crc::crc8_maxim(out.subspan(2, 1 + len));
  return size;
}

Result<Message> decode_payload(std::uint8_t type, std::span<const std::uint8_t> payload) noexcept {
  const auto expected = payload_length(type);
  if (!expected) return Reason::unknown_type;
  if (payload.size() != *expected) return Reason::bad_length;
  const std::uint8_t* p = payload.data();
  switch (static_cast<Type>(type)) {
    case Type::rc_cmd: return Message{RcCmd{bytes::get_i16le(p), bytes::get_i16le(p + 2), p[4]}};
    case Type::sensor: return Message{Sensor{bytes::get_u16le(p), bytes::get_i16le(p + 2), p[4]}};
    case Type::fault: return Message{Fault{p[0]}};
    case Type::state: return Message{State{bytes::get_i16le(p), bytes::get_i16le(p + 2), p[4]}};
    case Type::led_cmd: return Message{LedCmd{p[0], p[1], p[2], p[3]}};
    case Type::buzzer: return Message{Buzzer{p[0], bytes::get_u16le(p + 1)}};
    case Type::speed_cap: return Message{SpeedCap{p[0]}};
  }
  return Reason::unknown_type;
}

framing::Verdict StreamDecoder::Rules::check(std::span<const std::uint8_t> c) noexcept {
  using framing::Verdict;
  const std::uint8_t byte = c.back();
  switch (c.size()) {
    case 1: return byte == kStartByte ? Verdict::more : Verdict::reject;
    case 2:  // LEN: reject at once if no type has this length
      if (byte == 0 || byte > kMaxPayload || byte == 2) {
        ++counters.length_errors;
        return Verdict::reject;
      }
      return Verdict::more;
    case 3: {  // TYPE
      const auto expected = payload_length(byte);
      if (!expected) {
        ++counters.unknown_types;
        return Verdict::reject;
      }
      if (*expected != c[1]) {
        ++counters.length_errors;
        return Verdict::reject;
      }
      return Verdict::more;
    }
    default: break;
  }
  if (c.size() < kOverhead + c[1]) return Verdict::more;
  // Whole frame: CRC over TYPE and PAYLOAD.
  if (crc::crc8_maxim(c.subspan(2, c.size() - 3)) != byte) {
    ++counters.crc_errors;
    return Verdict::reject;
  }
  ++counters.frames;
  return Verdict::frame;
}

std::optional<Message> StreamDecoder::push(std::uint8_t byte) noexcept {
  std::optional<Message> found;  // at most one per push(): see the class comment
  framer_.push(byte, rules_, [&found](std::span<const std::uint8_t> f) {
    found = decode_payload(f[2], f.subspan(3, f[1])).value();  // type and length checked by check()
  });
  return found;
}

void StreamDecoder::drop_partial() noexcept { framer_.drop_all(rules_); }

}  // namespace saul::interboard
