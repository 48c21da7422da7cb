#include "saulproto/core/trace.hpp"

#include "saulproto/core/bytes.hpp"
#include "saulproto/core/crc.hpp"

namespace saul::trace {

const char* to_string(Excite excite) noexcept {
  switch (excite) {
    case Excite::none: return "none";
    case Excite::step: return "step";
    case Excite::chirp: return "chirp";
    case Excite::prbs: return "prbs";
  }
  return "?";
}

// Byte offsets of the payload (docs/protocol.md section 10).
void write_payload(const LoopTrace& r, std::uint8_t* p) noexcept {
  bytes::put_u32le(p, r.time_us);
  bytes::put_u32le(p + 4, r.seq);
  const std::int16_t words[] = {r.pitch_x100, r.rate_x10, r.setpoint_x100, r.p_term, r.i_term, r.d_term,
                                r.output, r.erpm_left, r.erpm_right, r.wheel_mmps, r.request_mmps};
  for (std::size_t i = 0; i < sizeof words / sizeof words[0]; ++i) bytes::put_i16le(p + 8 + 2 * i, words[i]);
  p[30] = r.state;
  p[31] = r.faults;
  p[32] = r.excite;
  bytes::put_i16le(p + 33, r.excite_x100);
}

Result<std::size_t> encode(const LoopTrace& record, std::span<std::uint8_t> out) noexcept {
  if (out.size() < kFrameSize) return Reason::buffer_too_small;
  out[0] = interboard::kStartByte;
  out[1] = static_cast<std::uint8_t>(kPayloadLength);
  out[2] = kType;
  write_payload(record, out.data() + 3);
  out[kFrameSize - 1] = crc::crc8_maxim(out.subspan(2, 1 + kPayloadLength));
  return kFrameSize;
}

Result<LoopTrace> decode_payload(std::span<const std::uint8_t> payload) noexcept {
  if (payload.size() != kPayloadLength) return Reason::bad_length;
  const std::uint8_t* p = payload.data();
  LoopTrace r;
  r.time_us = bytes::get_u32le(p);
  r.seq = bytes::get_u32le(p + 4);
  std::int16_t* words[] = {&r.pitch_x100, &r.rate_x10, &r.setpoint_x100, &r.p_term, &r.i_term, &r.d_term,
                           &r.output, &r.erpm_left, &r.erpm_right, &r.wheel_mmps, &r.request_mmps};
  for (std::size_t i = 0; i < sizeof words / sizeof words[0]; ++i) *words[i] = bytes::get_i16le(p + 8 + 2 * i);
  r.state = p[30];
  r.faults = p[31];
  r.excite = p[32];
  r.excite_x100 = bytes::get_i16le(p + 33);
  return r;
}

void ConsoleDecoder::Rules::reject(Reason reason, std::uint32_t& counter) noexcept {
  ++counter;
  if (events < sizeof queue / sizeof queue[0]) queue[events++] = {reason, interboard::kStartByte, base};
}

framing::Verdict ConsoleDecoder::Rules::check(std::span<const std::uint8_t> c) noexcept {
  using framing::Verdict;
  const std::uint8_t byte = c.back();
  switch (c.size()) {
    case 1:
      if (byte == interboard::kStartByte) return Verdict::more;
      text = true;  // console text: handed on in order, not skipped
      ++counters.text_bytes;
      if (events < sizeof queue / sizeof queue[0]) queue[events++] = {Reason::ok, byte, base};
      return Verdict::reject;
    case 2:
      if (byte != kPayloadLength) {
        reject(Reason::bad_length, counters.length_errors);
        return Verdict::reject;
      }
      return Verdict::more;
    case 3:
      if (byte != kType) {
        reject(Reason::unknown_type, counters.unknown_types);
        return Verdict::reject;
      }
      return Verdict::more;
    default: break;
  }
  if (c.size() < kFrameSize) return Verdict::more;
  if (crc::crc8_maxim(c.subspan(2, 1 + kPayloadLength)) != byte) {
    reject(Reason::bad_crc, counters.crc_errors);
    return Verdict::reject;
  }
  ++counters.records;
  return Verdict::frame;
}

void ConsoleDecoder::Rules::skipped(std::size_t n) noexcept {
  base += n;
  if (text) {
    text = false;
  } else {
    counters.bytes_skipped += static_cast<std::uint32_t>(n);
  }
}

void ConsoleDecoder::take_frame(std::span<const std::uint8_t> frame) noexcept {
  found_ = decode_payload(frame.subspan(3, kPayloadLength)).value();  // length and CRC checked by check()
  found_offset_ = rules_.base;
  rules_.base += frame.size();
}

}  // namespace saul::trace
