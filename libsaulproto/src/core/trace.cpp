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

namespace {

bool same_word(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; };
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

constexpr std::size_t kMaxWords = 7;

struct Parser {
  std::string_view words[kMaxWords];
  std::size_t count = 0;
  bool too_many = false;
  CommandParse result{true, {}, {}};

  explicit Parser(std::string_view line) noexcept {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == '\n')) ++i;
      const std::size_t start = i;
      while (i < line.size() && !(line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == '\n')) ++i;
      if (i == start) break;
      if (count < kMaxWords) {
        words[count++] = line.substr(start, i - start);
      } else {
        too_many = true;
      }
    }
  }
  CommandParse fail(Reason reason, const char* message, std::size_t argument) noexcept {
    result.error = {reason, message, static_cast<std::uint8_t>(argument), nullptr};
    return result;
  }
  CommandParse done(const Command& command) noexcept {
    result.command = command;
    return result;
  }
  /// Exactly n words, else the count's error naming the usage.
  bool count_is(std::size_t n, const char* usage) noexcept {
    if (count < n && !too_many) {
      fail(Reason::missing_argument, usage, count);
      return false;
    }
    if (count > n || too_many) {
      fail(Reason::extra_argument, usage, n);
      return false;
    }
    return true;
  }
  /// Word i as a number in [lo, hi] (not 0 when nonzero is set).
  bool number(std::size_t i, float lo, float hi, bool nonzero, const char* range, float& out) noexcept {
    const auto v = console::parse_float(words[i]);
    if (!v) {
      fail(v.reason(), v.reason() == Reason::not_finite ? "not a finite number" : "not a number", i);
      return false;
    }
    if (*v < lo || *v > hi || (nonzero && *v == 0.0F)) {
      fail(Reason::out_of_range, range, i);
      return false;
    }
    out = *v;
    return true;
  }
};

constexpr const char* kAmplitudeRange = "amplitude must be -2 to 2 degrees, not 0";
constexpr const char* kDurationRange = "duration must be above 0 and at most 20 seconds";
constexpr const char* kFrequencyRange = "frequency must be 0.05 to 100 Hz";

CommandParse parse_trace(Parser& p) noexcept {
  constexpr const char* kUsage = "usage: trace on [N] | trace off | trace dump | trace arm";
  if (p.count < 2) return p.fail(Reason::missing_argument, kUsage, 1);
  const std::string_view what = p.words[1];
  if (what == "on") {
    if (p.count > 3 || p.too_many) return p.fail(Reason::extra_argument, kUsage, 3);
    TraceOn on;
    if (p.count == 3) {
      float n = 0.0F;
      if (!p.number(2, 1.0F, kMaxDivider, true, "divider must be a whole number 1 to 1000", n)) return p.result;
      if (n != static_cast<float>(static_cast<std::uint16_t>(n)))
        return p.fail(Reason::out_of_range, "divider must be a whole number 1 to 1000", 2);
      on.divider = static_cast<std::uint16_t>(n);
    }
    return p.done(on);
  }
  Command command;
  if (what == "off") {
    command = TraceOff{};
  } else if (what == "dump") {
    command = TraceDump{};
  } else if (what == "arm") {
    command = TraceArm{};
  } else {
    return p.fail(Reason::unknown_command, kUsage, 1);
  }
  if (!p.count_is(2, kUsage)) return p.result;
  return p.done(command);
}

CommandParse parse_excite(Parser& p) noexcept {
  constexpr const char* kUsage =
      "usage: excite step|prbs <deg> <s> | excite chirp <deg> <f0 Hz> <f1 Hz> <s> | excite off";
  if (p.count < 2) return p.fail(Reason::missing_argument, kUsage, 1);
  const std::string_view what = p.words[1];
  if (what == "off") {
    if (!p.count_is(2, kUsage)) return p.result;
    return p.done(ExciteOff{});
  }
  ExciteStart e;
  std::size_t n = 4;
  if (what == "step") {
    e.kind = Excite::step;
  } else if (what == "prbs") {
    e.kind = Excite::prbs;
  } else if (what == "chirp") {
    e.kind = Excite::chirp;
    n = 6;
  } else {
    return p.fail(Reason::unknown_command, kUsage, 1);
  }
  if (!p.count_is(n, kUsage)) return p.result;
  if (!p.number(2, -kMaxAmplitudeDeg, kMaxAmplitudeDeg, true, kAmplitudeRange, e.amplitude_deg)) return p.result;
  if (e.kind == Excite::chirp) {
    if (!p.number(3, kMinFrequencyHz, kMaxFrequencyHz, false, kFrequencyRange, e.f0_hz)) return p.result;
    if (!p.number(4, kMinFrequencyHz, kMaxFrequencyHz, false, kFrequencyRange, e.f1_hz)) return p.result;
  }
  if (!p.number(n - 1, 0.0F, kMaxDurationS, true, kDurationRange, e.duration_s)) return p.result;
  return p.done(e);
}

}  // namespace

Result<std::size_t> format_command(const Command& command, std::span<char> out) noexcept {
  console::TextWriter w(out);
  if (const auto* on = std::get_if<TraceOn>(&command)) {
    w.text("trace on ").unsigned_number(on->divider);
  } else if (std::holds_alternative<TraceOff>(command)) {
    w.text("trace off");
  } else if (std::holds_alternative<TraceDump>(command)) {
    w.text("trace dump");
  } else if (std::holds_alternative<TraceArm>(command)) {
    w.text("trace arm");
  } else if (const auto* e = std::get_if<ExciteStart>(&command)) {
    w.text("excite ").text(to_string(e->kind)).ch(' ').real(e->amplitude_deg);
    if (e->kind == Excite::chirp) w.ch(' ').real(e->f0_hz).ch(' ').real(e->f1_hz);
    w.ch(' ').real(e->duration_s);
  } else {
    w.text("excite off");
  }
  return w.ch('\n').finish();
}

CommandParse parse_command(std::string_view line) noexcept {
  Parser p(line);
  if (p.count == 0) return {};
  if (same_word(p.words[0], "trace")) return parse_trace(p);
  if (same_word(p.words[0], "excite")) return parse_excite(p);
  return {};
}

}  // namespace saul::trace
