#include "saulproto/core/pride.hpp"

#include "saulproto/core/crc.hpp"

namespace saul::pride {

// The stream decoder's buffer and the fixed-size codecs assume every frame in the table has kFrameSize bytes.
static_assert(kFormats[0].size == kFrameSize && kFormats[1].size == kFrameSize,
              "frames of another length need a per-direction size in the decoder");
static_assert(kFormats[0].header[0] != kFormats[1].header[0], "the decoder picks the direction by the first byte");
static_assert(kFormats[0].direction == Direction::vcu_to_controller &&
                  kFormats[1].direction == Direction::controller_to_vcu,
              "kFormats is indexed by Direction");

namespace {

constexpr std::size_t kChecksumAt = kFrameSize - 1;

// Direction whose header starts with b, if any.
std::optional<Direction> header_start(std::uint8_t b) noexcept {
  for (const auto& f : kFormats)
    if (f.header[0] == b) return f.direction;
  return std::nullopt;
}

// Writes header, the three payload bytes and the checksum. out holds kFrameSize bytes.
void write_frame(Direction d, std::uint8_t b0, std::uint8_t b1, std::uint8_t b2, std::uint8_t* out) noexcept {
  const auto& f = format_of(d);
  out[0] = f.header[0];
  out[1] = f.header[1];
  out[2] = b0;
  out[3] = b1;
  out[4] = b2;
  out[kChecksumAt] = crc::pride_checksum({out, kChecksumAt});
}

// Checks and decodes a frame whose kFrameSize bytes are at f and whose header was already matched.
Result<Message> decode_checked_header(Direction d, const std::uint8_t* f) noexcept {
  if (crc::pride_checksum({f, kChecksumAt}) != f[kChecksumAt]) return Reason::bad_crc;
  if (d == Direction::vcu_to_controller) {
    const VcuCommand m{f[2], static_cast<std::int8_t>(f[3]), static_cast<std::int8_t>(f[4])};
    if (!m.in_range()) return Reason::out_of_range;
    return Message{m};
  }
  const ControllerStatus m{f[2], f[3], f[4]};
  if (!m.in_range()) return Reason::out_of_range;
  return Message{m};
}

}  // namespace

Direction direction_of(const Message& message) noexcept {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kDirection; }, message);
}

const char* name_of(const Message& message) noexcept {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kName; }, message);
}

Result<std::size_t> encode(const VcuCommand& message, std::span<std::uint8_t> out) noexcept {
  if (!message.in_range()) return Reason::out_of_range;
  if (out.size() < kFrameSize) return Reason::buffer_too_small;
  write_frame(VcuCommand::kDirection, message.speed_level, static_cast<std::uint8_t>(message.forward_back),
              static_cast<std::uint8_t>(message.left_right), out.data());
  return kFrameSize;
}

Result<std::size_t> encode(const ControllerStatus& message, std::span<std::uint8_t> out) noexcept {
  if (!message.in_range()) return Reason::out_of_range;
  if (out.size() < kFrameSize) return Reason::buffer_too_small;
  write_frame(ControllerStatus::kDirection, message.error_byte, message.battery_charge, message.unknown, out.data());
  return kFrameSize;
}

Result<std::size_t> encode(const Message& message, std::span<std::uint8_t> out) noexcept {
  return std::visit([out](const auto& m) { return encode(m, out); }, message);
}

Result<Message> decode_frame(std::span<const std::uint8_t> frame) noexcept {
  if (frame.size() != kFrameSize) return Reason::bad_length;
  const auto d = header_start(frame[0]);
  if (!d || format_of(*d).header[1] != frame[1]) return Reason::unknown_type;
  return decode_checked_header(*d, frame.data());
}

// ---- stream decoder -----------------------------------------------------------------------------------------

framing::Verdict StreamDecoder::Rules::check(std::span<const std::uint8_t> c) noexcept {
  using framing::Verdict;
  const auto d = header_start(c[0]);
  if (!d) return Verdict::reject;  // not a header start: skipped
  if (c.size() == 2) return format_of(*d).header[1] == c[1] ? Verdict::more : Verdict::reject;
  if (c.size() < kFrameSize) return Verdict::more;
  const auto decoded = decode_checked_header(*d, c.data());
  if (decoded.ok()) {
    ++counters.frames;
    return Verdict::frame;
  }
  if (decoded.reason() == Reason::bad_crc)
    ++counters.checksum_errors;
  else
    ++counters.out_of_range;
  return Verdict::reject;
}

std::optional<Message> StreamDecoder::push(std::uint8_t byte) noexcept {
  // Decoded a second time rather than kept from check(): a Message is a variant, and the copy is 6 bytes.
  std::optional<Message> found;
  framer_.push(byte, rules_, [&found](std::span<const std::uint8_t> f) { found = decode_frame(f).value(); });
  return found;
}

void StreamDecoder::drop_partial() noexcept { framer_.drop_all(rules_); }

// ---- echo filter --------------------------------------------------------------------------------------------

bool EchoFilter::sent(std::span<const std::uint8_t> bytes) noexcept {
  if (bytes.size() > kCapacity - count_) {
    counters_.overflows += static_cast<std::uint32_t>(bytes.size());
    return false;
  }
  for (std::uint8_t b : bytes) {
    ring_[(head_ + count_) % kCapacity] = b;
    ++count_;
  }
  return true;
}

std::optional<std::uint8_t> EchoFilter::push(std::uint8_t byte) noexcept {
  if (count_ == 0) return byte;
  if (ring_[head_] == byte) {
    head_ = static_cast<std::uint8_t>((head_ + 1) % kCapacity);
    --count_;
    ++counters_.echoes_dropped;
    return std::nullopt;
  }
  ++counters_.mismatches;
  clear();
  return byte;
}

void EchoFilter::clear() noexcept {
  counters_.lost += count_;
  count_ = 0;
  head_ = 0;
}

// ---- layout check -------------------------------------------------------------------------------------------

LayoutReport check_layout(std::span<const std::uint8_t> capture) noexcept {
  LayoutReport report;
  report.bytes = static_cast<std::uint32_t>(capture.size());
  const std::size_t n = capture.size();
  for (std::size_t h = 0; h < kFormats.size(); ++h) {
    HeaderReport& r = report.headers[h];
    r.header = kFormats[h].header;
    std::uint32_t tally[kMaxTalliedSpacing + 1] = {};
    std::size_t last = 0;
    for (std::size_t i = 0; i + 1 < n; ++i) {
      if (capture[i] != r.header[0] || capture[i + 1] != r.header[1]) continue;
      if (r.positions > 0) {
        const std::size_t d = i - last;
        if (d <= kMaxTalliedSpacing)
          ++tally[d];
        else
          ++r.long_spacings;
      }
      last = i;
      ++r.positions;
      // Running 8-bit sum: a candidate of length L passes when its L bytes sum to 0xFF.
      std::uint8_t sum = 0;
      for (std::size_t len = 1; len <= kMaxCandidateLength && i + len <= n; ++len) {
        sum = static_cast<std::uint8_t>(sum + capture[i + len - 1]);
        if (len >= kMinCandidateLength && sum == 0xFF) ++r.checksum_hits[len - kMinCandidateLength];
      }
    }
    for (std::size_t d = 1; d <= kMaxTalliedSpacing; ++d) {
      if (tally[d] > r.spacing_count) {  // strict: ties go to the shorter spacing
        r.spacing_count = tally[d];
        r.spacing = static_cast<std::uint32_t>(d);
      }
    }
    std::uint32_t best = 0;
    for (std::size_t i = 0; i < kCandidateLengths; ++i) {
      if (r.checksum_hits[i] > best) {
        best = r.checksum_hits[i];
        r.best_length = static_cast<std::uint8_t>(kMinCandidateLength + i);
      }
    }
  }
  return report;
}

}  // namespace saul::pride
