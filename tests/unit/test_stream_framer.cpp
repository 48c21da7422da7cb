// framing::StreamFramer (stream_framer.hpp) through the four decoders built on it: long seeded random streams of
// valid frames mixed with noise, truncated frames, bit flips and false or rejected start bytes, fed in random
// pieces, checked at random points against a reference model written here on purpose as plainly as possible:
// from scratch over everything received so far, "at each offset try to read one whole frame by the protocol's
// own text; on success jump past it, else move on one byte". CRCs are recomputed bit by bit here, and the model
// knows nothing of buffers or rescans; a decoder that loses a frame inside a false candidate, or that miscounts
// any counter, disagrees with it.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdlib>
#include <cstddef>
#include <cstdint>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/crsf.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pride.hpp"
#include "saulproto/core/slcan.hpp"
#include "saulproto/core/stream_framer.hpp"

using namespace saul;
using Bytes = std::vector<std::uint8_t>;
using Rng = std::mt19937;

namespace {

unsigned below(Rng& rng, unsigned n) { return static_cast<unsigned>(rng() % n); }
std::uint8_t any_byte(Rng& rng) { return static_cast<std::uint8_t>(rng()); }
std::uint8_t pick(Rng& rng, std::initializer_list<std::uint8_t> from) {
  return *(from.begin() + below(rng, static_cast<unsigned>(from.size())));
}

// CRC-8/MAXIM (reflected poly 0x31, i.e. 0x8C) and CRC-8/DVB-S2 (poly 0xD5), one bit at a time.
std::uint8_t crc8_maxim_bits(const std::uint8_t* p, std::size_t n) {
  std::uint8_t crc = 0;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint8_t>(crc ^ p[i]);
    for (int k = 0; k < 8; ++k) crc = static_cast<std::uint8_t>((crc & 1) ? (crc >> 1) ^ 0x8C : crc >> 1);
  }
  return crc;
}
std::uint8_t crc8_dvb_s2_bits(const std::uint8_t* p, std::size_t n) {
  std::uint8_t crc = 0;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint8_t>(crc ^ p[i]);
    for (int k = 0; k < 8; ++k) crc = static_cast<std::uint8_t>((crc & 0x80) ? (crc << 1) ^ 0xD5 : crc << 1);
  }
  return crc;
}

// Stream pieces shared by the binary protocols.
Bytes truncated(Rng& rng, Bytes frame) {
  if (frame.size() > 1) frame.resize(1 + below(rng, static_cast<unsigned>(frame.size() - 1)));
  return frame;
}
Bytes bit_flipped(Rng& rng, Bytes frame) {
  frame[below(rng, static_cast<unsigned>(frame.size()))] ^= static_cast<std::uint8_t>(1U << below(rng, 8));
  return frame;
}
Bytes then(Bytes head, const Bytes& tail) {
  head.insert(head.end(), tail.begin(), tail.end());
  return head;
}
Bytes noise(Rng& rng, std::initializer_list<std::uint8_t> likely) {
  Bytes out(1 + below(rng, 8));
  for (auto& b : out) b = below(rng, 2) ? pick(rng, likely) : any_byte(rng);
  return out;
}

// What the model says about the candidate at one offset, given the bytes from there to the end of what has arrived.
struct Decision {
  enum Kind { skip, frame, wait } kind = skip;
  std::size_t size = 1;  // bytes skipped, or in the frame
  Bytes record{};        // what the decoder must report for the frame
};
template <class Counters>
Decision skip_one(Counters& k) {
  ++k.bytes_skipped;
  return {};
}

// Inter-board and Pride: push(byte) returns the message it completed, and drop_partial() cuts (everything held is
// skipped). Their records are the messages encoded again (Self::encoded).
template <class Self>
struct MessagePerPush {
  template <class Counters>
  static std::size_t cut(std::size_t held, Counters& k) {
    k.bytes_skipped += static_cast<std::uint32_t>(held);
    return held;
  }
  template <class Decoder>
  static void cut(Decoder& d, std::vector<Bytes>&) {
    d.drop_partial();
  }
  template <class Decoder>
  static void feed(Decoder& d, std::span<const std::uint8_t> in, bool bytewise, std::vector<Bytes>& got) {
    const auto keep = [&](const auto& m) { got.push_back(Self::encoded(m)); };
    if (!bytewise) return d.push(in, keep);
    for (std::uint8_t b : in)
      if (auto m = d.push(b)) keep(*m);
  }
};
const Decision kWait{Decision::wait};

// ---- inter-board UART: [AA][LEN][TYPE][PAYLOAD x LEN][CRC8/MAXIM over TYPE and PAYLOAD] -------------------------

struct Interboard : MessagePerPush<Interboard> {
  using Decoder = interboard::StreamDecoder;
  using Counters = interboard::Counters;

  // The protocol's table of types and payload lengths is data, not framing: taken from payload_length(), so the
  // model follows a type added to the protocol.
  static std::vector<std::uint8_t> types() {
    std::vector<std::uint8_t> out;
    for (unsigned t = 0; t < 256; ++t)
      if (interboard::payload_length(static_cast<std::uint8_t>(t))) out.push_back(static_cast<std::uint8_t>(t));
    return out;
  }
  static bool some_type_has(std::uint8_t len) {
    static const std::vector<std::uint8_t> known = types();
    for (std::uint8_t t : known)
      if (*interboard::payload_length(t) == len) return true;
    return false;
  }
  static Bytes encoded(const interboard::Message& m) {
    std::array<std::uint8_t, interboard::kMaxFrameSize> buf{};
    return Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(*interboard::encode(m, buf)));
  }
  static Bytes frame(Rng& rng) {
    static const std::vector<std::uint8_t> known = types();
    const std::uint8_t type = known[below(rng, static_cast<unsigned>(known.size()))];
    Bytes f{0xAA, *interboard::payload_length(type), type};
    for (std::uint8_t i = 0; i < f[1]; ++i) f.push_back(any_byte(rng));
    f.push_back(crc8_maxim_bits(f.data() + 2, f.size() - 2));
    return f;
  }
  static Bytes piece(Rng& rng) {
    switch (below(rng, 9)) {
      case 0: return truncated(rng, frame(rng));
      case 1: return bit_flipped(rng, frame(rng));
      case 2:  // a false start whose claimed frame swallows the start of real ones
        return then({0xAA, pick(rng, {1, 3, 4, 5}), pick(rng, {0x01, 0x03, 0x11, 0x12})}, then(frame(rng), frame(rng)));
      case 3:  // start bytes rejected at LEN or at TYPE
        return below(rng, 2) ? Bytes{0xAA, pick(rng, {0, 2, 6, 0xAA, 0xFF})} : Bytes{0xAA, 5, pick(rng, {0, 4, 0x03})};
      case 4: return noise(rng, {0xAA, 0x01, 0x03, 0x05});
      default: return frame(rng);
    }
  }
  static Decision decide(const std::uint8_t* c, std::size_t n, Counters& k) {
    if (c[0] != 0xAA) return skip_one(k);
    if (n < 2) return kWait;
    if (!some_type_has(c[1])) {
      ++k.length_errors;
      return skip_one(k);
    }
    if (n < 3) return kWait;
    const auto want = interboard::payload_length(c[2]);
    if (!want) {
      ++k.unknown_types;
      return skip_one(k);
    }
    if (*want != c[1]) {
      ++k.length_errors;
      return skip_one(k);
    }
    const std::size_t size = 4U + c[1];
    if (n < size) return kWait;
    if (crc8_maxim_bits(c + 2, size - 3) != c[size - 1]) {
      ++k.crc_errors;
      return skip_one(k);
    }
    ++k.frames;
    return {Decision::frame, size, Bytes(c, c + size)};
  }
  static std::vector<std::uint32_t> fields(const Counters& k) {
    return {k.frames, k.crc_errors, k.length_errors, k.unknown_types, k.bytes_skipped};
  }
};

// ---- Pride ES: FE 54 SP FB LR CS / 4A 01 EB BC UN CS, CS = NOT of the byte sum ---------------------------------

struct Pride : MessagePerPush<Pride> {
  using Decoder = pride::StreamDecoder;
  using Counters = pride::Counters;

  static Bytes encoded(const pride::Message& m) {
    std::array<std::uint8_t, pride::kFrameSize> buf{};
    return Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(*pride::encode(m, buf)));
  }
  static std::uint8_t checksum(const std::uint8_t* p) {
    unsigned sum = 0;
    for (int i = 0; i < 5; ++i) sum += p[i];
    return static_cast<std::uint8_t>(~sum);
  }
  static Bytes frame(Rng& rng) {
    if (below(rng, 2))
      return encoded(pride::ControllerStatus{any_byte(rng), any_byte(rng), any_byte(rng)});
    const auto stick = [&] { return static_cast<std::int8_t>(static_cast<int>(below(rng, 201)) - 100); };
    return encoded(pride::VcuCommand{static_cast<std::uint8_t>(below(rng, 15)), stick(), stick()});
  }
  static Bytes piece(Rng& rng) {
    switch (below(rng, 9)) {
      case 0: return truncated(rng, frame(rng));
      case 1: return bit_flipped(rng, frame(rng));
      case 2: return then(below(rng, 2) ? Bytes{0xFE, 0x54} : Bytes{0x4A, 0x01}, then(frame(rng), frame(rng)));
      case 3: {  // a good checksum on a field out of the manual's range
        Bytes f{0xFE, 0x54, pick(rng, {0x0F, 0x40, 0xFF}), 0, pick(rng, {101, 0x80})};
        f.push_back(checksum(f.data()));
        return f;
      }
      case 4: return Bytes{pick(rng, {0xFE, 0x4A}), pick(rng, {0x00, 0xFE, 0x4A, 0x55})};  // second byte wrong
      case 5: return noise(rng, {0xFE, 0x54, 0x4A, 0x01});
      default: return frame(rng);
    }
  }
  static Decision decide(const std::uint8_t* c, std::size_t n, Counters& k) {
    if (c[0] != 0xFE && c[0] != 0x4A) return skip_one(k);
    if (n < 2) return kWait;
    if (c[1] != (c[0] == 0xFE ? 0x54 : 0x01)) return skip_one(k);
    if (n < 6) return kWait;
    if (checksum(c) != c[5]) {
      ++k.checksum_errors;
      return skip_one(k);
    }
    const auto stick_ok = [](std::uint8_t b) { return std::abs(static_cast<std::int8_t>(b)) <= 100; };
    if (c[0] == 0xFE && (c[2] > 0x0E || !stick_ok(c[3]) || !stick_ok(c[4]))) {
      ++k.out_of_range;
      return skip_one(k);
    }
    ++k.frames;
    return {Decision::frame, 6, Bytes(c, c + 6)};
  }
  static std::vector<std::uint32_t> fields(const Counters& k) {
    return {k.frames, k.checksum_errors, k.out_of_range, k.bytes_skipped};
  }
};

// ---- CRSF: [SYNC][LEN][TYPE][PAYLOAD x LEN-2][CRC8/DVB-S2 over TYPE and PAYLOAD] ---------------------------------

struct Crsf {
  using Decoder = crsf::StreamDecoder;
  using Counters = crsf::Counters;

  static bool sync(std::uint8_t b) { return b == 0xC8 || b == 0x00 || b == 0xEA || b == 0xEC || b == 0xEE; }
  static bool known(std::uint8_t t) {
    for (int k : {0x02, 0x08, 0x0B, 0x14, 0x16, 0x17, 0x1E, 0x21, 0x28, 0x29})
      if (t == k) return true;
    return false;
  }
  static Bytes frame(Rng& rng) {
    const std::size_t payload = below(rng, 3) ? below(rng, 24) : below(rng, 61);
    const std::uint8_t address = below(rng, 3) ? std::uint8_t{0xC8} : pick(rng, {0x00, 0xEA, 0xEC, 0xEE});
    const std::uint8_t type = below(rng, 4) ? pick(rng, {0x16, 0x14, 0x08, 0x29}) : any_byte(rng);
    Bytes f{address, static_cast<std::uint8_t>(payload + 2), type};
    for (std::size_t i = 0; i < payload; ++i) f.push_back(any_byte(rng));
    f.push_back(crc8_dvb_s2_bits(f.data() + 2, payload + 1));
    return f;
  }
  static Bytes piece(Rng& rng) {
    switch (below(rng, 9)) {
      case 0: return truncated(rng, frame(rng));
      case 1: return bit_flipped(rng, frame(rng));
      case 2:  // a false SYNC whose LEN swallows the real frames after it
        return then({0xC8, static_cast<std::uint8_t>(2 + below(rng, 61))}, then(frame(rng), frame(rng)));
      case 3: return Bytes{pick(rng, {0xC8, 0xEE}), pick(rng, {0, 1, 63, 0xC8, 0xFF})};  // LEN out of range
      case 4: return noise(rng, {0xC8, 0x00, 0xEE, 0x02, 0x16});
      default: return frame(rng);
    }
  }
  static Decision decide(const std::uint8_t* c, std::size_t n, Counters& k) {
    if (!sync(c[0])) return skip_one(k);
    if (n < 2) return kWait;
    if (c[1] < 2 || c[1] > 62) {
      ++k.length_errors;
      return skip_one(k);
    }
    const std::size_t size = c[1] + 2U;
    if (n < size) return kWait;
    if (crc8_dvb_s2_bits(c + 2, size - 3) != c[size - 1]) {
      ++k.crc_errors;
      return skip_one(k);
    }
    ++k.frames;
    if (!known(c[2])) ++k.unknown_types;
    Bytes record{c[0], c[2]};
    record.insert(record.end(), c + 3, c + size - 1);
    return {Decision::frame, size, record};
  }
  // flush(): the unfinished candidate is given up (incomplete), its SYNC skipped, the rest read again.
  static std::size_t cut(std::size_t, Counters& k) {
    ++k.incomplete;
    ++k.bytes_skipped;
    return 1;
  }
  static void keep(const crsf::Frame& f, std::vector<Bytes>& got) {
    Bytes record{f.address, f.type};
    record.insert(record.end(), f.payload().begin(), f.payload().end());
    for (std::size_t i = f.payload_size; i < f.data.size(); ++i) CHECK(f.data[i] == 0);
    got.push_back(record);
  }
  static void cut(Decoder& d, std::vector<Bytes>& got) {
    d.flush([&](const crsf::Frame& f) { keep(f, got); });
  }
  static void feed(Decoder& d, std::span<const std::uint8_t> in, bool bytewise, std::vector<Bytes>& got) {
    const auto on_frame = [&](const crsf::Frame& f) { keep(f, got); };
    if (!bytewise) return d.push(in, on_frame);
    for (std::uint8_t b : in) d.push(b, on_frame);
  }
  static std::vector<std::uint32_t> fields(const Counters& k) {
    return {k.frames, k.crc_errors, k.length_errors, k.unknown_types, k.bytes_skipped, k.incomplete};
  }
};

// ---- slcan: lines ended by CR, BEL or LF -------------------------------------------------------------------------

struct Slcan {
  using Decoder = slcan::LineDecoder;
  using Counters = slcan::Counters;
  using Kind = slcan::Event::Kind;

  static Bytes record(Kind kind, const CanFrame* f) {
    Bytes r{static_cast<std::uint8_t>(kind)};
    if (f) {
      for (int s = 0; s < 32; s += 8) r.push_back(static_cast<std::uint8_t>(f->id >> s));
      r.insert(r.end(), {f->extended, f->remote, f->dlc});
      r.insert(r.end(), f->payload().begin(), f->payload().end());
    }
    return r;
  }
  static Bytes text(std::string_view s) { return Bytes(s.begin(), s.end()); }
  static Bytes line(Rng& rng) {
    switch (below(rng, 12)) {
      case 0: return text("\r");
      case 1: return text("\a");
      case 2: return text(below(rng, 2) ? "z\r" : "Z\r");
      case 3: return text(below(rng, 2) ? "V1013\r" : "F0A\r");
      case 4: return text(below(rng, 2) ? "d1231AA\r" : "B12345678011\r");
      case 5: return text(below(rng, 2) ? "e1\r" : "Fxy\r");
      case 6: return text(below(rng, 2) ? "t12\r" : "hello\r");
      case 7: {  // too long for the decoder's line buffer
        Bytes l(155 + below(rng, 12), static_cast<std::uint8_t>('t'));
        l.push_back(pick(rng, {'\r', '\a', '\n'}));
        return l;
      }
      default: {
        std::array<std::uint8_t, 8> data{};
        for (auto& b : data) b = any_byte(rng);
        const bool ext = below(rng, 2) != 0;
        const auto id = static_cast<std::uint32_t>(rng()) & (ext ? 0x1FFFFFFFU : 0x7FFU);
        auto f = *CanFrame::data_frame(id, ext, {data.data(), below(rng, 9)});
        f.remote = below(rng, 6) == 0;
        std::array<char, slcan::kMaxClassicLine + 1> buf{};
        const auto n = below(rng, 3) ? *slcan::encode_frame(f, buf)
                                     : *slcan::encode_frame_with_ms(f, static_cast<std::uint16_t>(rng()), buf);
        Bytes l(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
        if (below(rng, 4) == 0) l.push_back('\n');  // CR LF
        return l;
      }
    }
  }
  static Bytes piece(Rng& rng) {
    switch (below(rng, 8)) {
      case 0: return truncated(rng, line(rng));
      case 1: return bit_flipped(rng, line(rng));
      case 2: return noise(rng, {'\r', '\n', '\a', 't', '0'});
      default: return line(rng);
    }
  }
  // One ended line by the slcan text (what each first letter means), with its counters.
  static Bytes classify(std::string_view l, bool bel, Counters& k) {
    if (bel || l.empty()) {
      ++k.acks;
      return record(bel ? Kind::error : Kind::ok, nullptr);
    }
    const char c = l[0];
    const bool hex2 = l.size() == 3 && std::isxdigit(static_cast<unsigned char>(l[1])) &&
                      std::isxdigit(static_cast<unsigned char>(l[2]));
    if (c == 't' || c == 'T' || c == 'r' || c == 'R') {
      if (auto f = slcan::parse_frame(l)) {
        ++k.frames;
        return record(Kind::frame, &*f);
      }
    } else if ((c == 'z' || c == 'Z') && l.size() == 1) {
      ++k.acks;
      return record(Kind::tx_ack, nullptr);
    } else if (c == 'd' || c == 'D' || c == 'b' || c == 'B') {
      ++k.fd_frames;
    } else if (c == 'V' || c == 'v') {
      return record(Kind::version, nullptr);
    } else if (c == 'F' && hex2) {
      return record(Kind::status, nullptr);
    } else if (c == 'e' || c == 's') {
      return record(c == 'e' ? Kind::bus_error : Kind::bus_state, nullptr);
    }
    ++k.rejected_lines;
    return record(Kind::rejected, nullptr);
  }
  static Decision decide(const std::uint8_t* c, std::size_t n, Counters& k) {
    std::size_t end = 0;  // the line's end: CR, BEL or LF
    while (end < n && c[end] != '\r' && c[end] != '\a' && c[end] != '\n') ++end;
    if (end > slcan::kMaxLine) {  // counted as soon as it is too long; dropped up to and with its end
      ++k.overlong_lines;
      return end < n ? Decision{Decision::skip, end + 1} : kWait;
    }
    if (end == n) return kWait;
    if (end == 0 && c[0] == '\n') return {};  // the LF of CR LF
    const std::string_view l(reinterpret_cast<const char*>(c), end);
    return {Decision::frame, end + 1, classify(l, c[end] == '\a', k)};
  }
  static void feed(Decoder& d, std::span<const std::uint8_t> in, bool bytewise, std::vector<Bytes>& got) {
    const auto keep = [&](const slcan::Event& e) {
      got.push_back(record(e.kind, e.kind == Kind::frame ? &e.frame : nullptr));
    };
    if (!bytewise) return d.push(in, keep);
    for (std::uint8_t b : in)
      if (auto e = d.push(static_cast<char>(b))) keep(*e);
  }
  static std::vector<std::uint32_t> fields(const Counters& k) {
    return {k.frames, k.acks, k.rejected_lines, k.fd_frames, k.overlong_lines};
  }
};

// ---- the model and the comparison ------------------------------------------------------------------------------

template <class P>
struct Model {
  std::vector<Bytes> records;
  typename P::Counters counters{};
  std::size_t pending = 0;
};

template <class P>
constexpr bool kHasCut = requires(typename P::Decoder& d, std::vector<Bytes>& g) { P::cut(d, g); };

// The model over s[0..end), the decoder having been cut (drop_partial / flush) after each offset in cuts.
template <class P>
Model<P> reference(const Bytes& s, std::size_t end, const std::vector<std::size_t>& cuts) {
  Model<P> m;
  std::size_t p = 0;
  const auto read_until = [&](std::size_t limit, bool cut) {
    while (p < limit) {
      Decision d = P::decide(s.data() + p, limit - p, m.counters);
      if (d.kind == Decision::wait) {
        if (!cut) return;
        if constexpr (kHasCut<P>) p += P::cut(limit - p, m.counters);
        continue;
      }
      if (d.kind == Decision::frame) m.records.push_back(std::move(d.record));
      p += d.size;
    }
  };
  for (std::size_t c : cuts)
    if (c <= end) read_until(c, true);
  read_until(end, false);
  m.pending = end - p;
  return m;
}

template <class P>
void differential(std::uint32_t seed, std::size_t length) {
  Rng rng(seed);
  Bytes s;
  while (s.size() < length) {
    const Bytes piece = P::piece(rng);
    s.insert(s.end(), piece.begin(), piece.end());
  }
  std::vector<std::size_t> checkpoints, cuts;
  for (int i = 0; i < 40; ++i) checkpoints.push_back(1 + below(rng, static_cast<unsigned>(s.size())));
  if (kHasCut<P>)
    for (int i = 0; i < 8; ++i) cuts.push_back(1 + below(rng, static_cast<unsigned>(s.size())));
  checkpoints.push_back(s.size());
  std::sort(checkpoints.begin(), checkpoints.end());
  std::sort(cuts.begin(), cuts.end());
  cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());

  typename P::Decoder d;
  std::vector<Bytes> got;
  std::size_t fed = 0;
  auto next_cut = cuts.begin();
  Model<P> m;
  for (std::size_t at : checkpoints) {
    while (fed < at) {  // random pieces, byte by byte or as a span, stopping at each cut
      std::size_t stop = std::min(at, fed + 1 + below(rng, 200));
      if (next_cut != cuts.end() && *next_cut <= stop) stop = *next_cut;
      P::feed(d, {s.data() + fed, stop - fed}, below(rng, 2) != 0, got);
      fed = stop;
      if (next_cut != cuts.end() && *next_cut == fed) {
        if constexpr (kHasCut<P>) P::cut(d, got);
        ++next_cut;
      }
    }
    m = reference<P>(s, at, cuts);
    INFO("seed " << seed << ", after " << at << " of " << s.size() << " bytes");
    const auto diff = std::mismatch(got.begin(), got.end(), m.records.begin(), m.records.end());
    INFO("frames: decoder " << got.size() << ", model " << m.records.size() << ", first difference at "
                            << (diff.first - got.begin()));
    REQUIRE(diff.first == got.end());
    REQUIRE(diff.second == m.records.end());
    REQUIRE(P::fields(d.counters()) == P::fields(m.counters));
    if constexpr (requires { d.pending(); }) REQUIRE(d.pending() == m.pending);
  }
  // The stream must have exercised every counter, or the comparison proves less than it seems.
  for (std::uint32_t v : P::fields(m.counters)) CHECK(v > 0);
}

}  // namespace

TEST_CASE("stream framer: inter-board decoder agrees with the offset-by-offset model on random streams") {
  for (std::uint32_t seed : {1U, 2U, 3U}) differential<Interboard>(seed, 30000);
}

TEST_CASE("stream framer: Pride decoder agrees with the offset-by-offset model on random streams") {
  for (std::uint32_t seed : {11U, 12U, 13U}) differential<Pride>(seed, 30000);
}

TEST_CASE("stream framer: CRSF decoder agrees with the offset-by-offset model on random streams") {
  for (std::uint32_t seed : {21U, 22U, 23U}) differential<Crsf>(seed, 60000);
}

TEST_CASE("stream framer: slcan decoder agrees with the line-by-line model on random streams") {
  for (std::uint32_t seed : {31U, 32U, 33U}) differential<Slcan>(seed, 60000);
}

namespace {
// Rules that never make up their mind: only the framer's own bound keeps its buffer from overflowing.
struct Undecided {
  std::size_t skipped_bytes = 0;
  std::size_t checks = 0;
  framing::Verdict check(std::span<const std::uint8_t>) noexcept {
    ++checks;
    return framing::Verdict::more;
  }
  void skipped(std::size_t n) noexcept { skipped_bytes += n; }
};
}  // namespace

TEST_CASE("stream framer: a candidate never outgrows the buffer, even with Rules that never decide") {
  framing::StreamFramer<4> f;
  Undecided rules;
  for (int i = 0; i < 10; ++i) {
    f.push(static_cast<std::uint8_t>(i), rules, [](std::span<const std::uint8_t>) { FAIL("no frame expected"); });
    CHECK(f.pending() <= 3);
    CHECK(rules.skipped_bytes + f.pending() == static_cast<std::size_t>(i + 1));
  }
  f.drop_all(rules);
  CHECK(f.pending() == 0);
  CHECK(rules.skipped_bytes == 10);
}
