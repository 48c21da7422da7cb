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
  }
  return Reason::unknown_type;
}

StreamDecoder::Step StreamDecoder::step(std::uint8_t byte) noexcept {
  if (length_ == 0) {
    if (byte != kStartByte) {
      ++counters_.bytes_skipped;
      return Step::skipped;
    }
    buffer_[length_++] = byte;
    return Step::consumed;
  }
  buffer_[length_++] = byte;
  if (length_ == 2) {  // LEN: reject at once if no type has this length
    if (byte == 0 || byte > kMaxPayload || byte == 2) {
      ++counters_.length_errors;
      return Step::rejected;
    }
    return Step::consumed;
  }
  if (length_ == 3) {  // TYPE
    const auto expected = payload_length(byte);
    if (!expected) {
      ++counters_.unknown_types;
      return Step::rejected;
    }
    if (*expected != buffer_[1]) {
      ++counters_.length_errors;
      return Step::rejected;
    }
    expected_ = static_cast<std::uint8_t>(kOverhead + *expected);
    return Step::consumed;
  }
  if (length_ < expected_) return Step::consumed;
  // Whole frame: CRC over TYPE and PAYLOAD.
  const std::span<const std::uint8_t> covered{buffer_ + 2, static_cast<std::size_t>(length_ - 3)};
  if (crc::crc8_maxim(covered) != buffer_[length_ - 1]) {
    ++counters_.crc_errors;
    return Step::rejected;
  }
  return Step::frame;
}

std::optional<Message> StreamDecoder::push(std::uint8_t byte) noexcept {
  // Bytes waiting to be scanned: the new byte, plus, after a rejection, the rejected candidate minus its
  // start byte. Bytes are moved, never copied twice, so the queue never holds more than kMaxFrameSize.
  std::uint8_t queue[kMaxFrameSize];
  std::size_t head = 0;
  std::size_t tail = 0;
  queue[tail++] = byte;
  std::optional<Message> found;

  while (head < tail) {
    const Step s = step(queue[head++]);
    if (s == Step::frame) {
      const auto decoded = decode_payload(buffer_[2], {buffer_ + 3, static_cast<std::size_t>(buffer_[1])});
      ++counters_.frames;
      found = decoded.value();  // type and length were checked byte by byte, so this cannot fail
      length_ = 0;
      expected_ = 0;
    } else if (s == Step::rejected) {
      ++counters_.bytes_skipped;  // the rejected start byte
      // New queue = rejected candidate after its start byte, then what was still queued.
      std::uint8_t rest[kMaxFrameSize];
      std::size_t n = 0;
      for (std::size_t i = 1; i < length_; ++i) rest[n++] = buffer_[i];
      for (std::size_t i = head; i < tail; ++i) rest[n++] = queue[i];
      for (std::size_t i = 0; i < n; ++i) queue[i] = rest[i];
      head = 0;
      tail = n;
      length_ = 0;
      expected_ = 0;
    }
  }
  return found;
}

void StreamDecoder::drop_partial() noexcept {
  counters_.bytes_skipped += length_;
  length_ = 0;
  expected_ = 0;
}

}  // namespace saul::interboard
