// Pride ES link: golden frames with their checksums summed by hand (CS = ~(sum of the five bytes before it)),
// never computed by the encoder under test. Layout FE 54 SP FB LR CS / 4A 01 EB BC UN CS (inferred: docs/protocol.md, Pride ES).
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "saulproto/core/pride.hpp"

using namespace saul;
using namespace saul::pride;
using Bytes = std::vector<std::uint8_t>;

namespace {

Bytes encoded(const Message& m) {
  std::array<std::uint8_t, kFrameSize> buf{};
  auto n = encode(m, buf);
  REQUIRE(n.ok());
  return Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(*n));
}

std::vector<Message> decode_all(StreamDecoder& d, const Bytes& in) {
  std::vector<Message> out;
  for (auto b : in)
    if (auto m = d.push(b)) out.push_back(*m);
  return out;
}

struct Golden {
  Message message;
  Bytes bytes;
};

const std::vector<Golden>& goldens() {
  static const std::vector<Golden> g = {
      // FE + 54 + 07 + 32 + 00 = 0x18B -> 0x8B -> ~ = 0x74 (speed 7, forward 50)
      {VcuCommand{7, 50, 0}, {0xFE, 0x54, 0x07, 0x32, 0x00, 0x74}},
      // 4A + 01 + 02 + 64 + 00 = 0xB1 -> ~ = 0x4E (ready, battery 100)
      {ControllerStatus{0x02, 0x64, 0x00}, {0x4A, 0x01, 0x02, 0x64, 0x00, 0x4E}},
      // fastest, backward 100 (0x9C), left 50 (0xCE): FE + 54 + 0E + 9C + CE = 0x2CA -> 0xCA -> ~ = 0x35.
      // As signed chars: -2 + 84 + 14 - 100 - 50 = -54 = 0xCA: the same low byte.
      {VcuCommand{0x0E, -100, -50}, {0xFE, 0x54, 0x0E, 0x9C, 0xCE, 0x35}},
      // forward 100, left 100: FE + 54 + 00 + 64 + 9C = 0x252 -> 0x52 -> ~ = 0xAD
      {VcuCommand{0, 100, -100}, {0xFE, 0x54, 0x00, 0x64, 0x9C, 0xAD}},
      // error, battery 0xFF, unknown 0x10: 4A + 01 + 82 + FF + 10 = 0x1DC -> 0xDC -> ~ = 0x23
      {ControllerStatus{0x82, 0xFF, 0x10}, {0x4A, 0x01, 0x82, 0xFF, 0x10, 0x23}},
      // all zero: FE + 54 = 0x152 -> 0x52 -> ~ = 0xAD
      {VcuCommand{0, 0, 0}, {0xFE, 0x54, 0x00, 0x00, 0x00, 0xAD}},
  };
  return g;
}

std::uint8_t sum8(const Bytes& b) {
  std::uint8_t s = 0;
  for (auto x : b) s = static_cast<std::uint8_t>(s + x);
  return s;
}

}  // namespace

TEST_CASE("pride: the layout table is the inferred one") {
  CHECK(kFrameSize == 6);
  CHECK(format_of(Direction::vcu_to_controller).header == std::array<std::uint8_t, 2>{0xFE, 0x54});
  CHECK(format_of(Direction::controller_to_vcu).header == std::array<std::uint8_t, 2>{0x4A, 0x01});
  CHECK(std::string_view(format_of(Direction::vcu_to_controller).name) == VcuCommand::kName);
  CHECK(std::string_view(format_of(Direction::controller_to_vcu).fields[0]) == "error_byte");
}

TEST_CASE("pride: every golden frame encodes, sums to 0xFF, and decodes back in both directions") {
  for (const auto& g : goldens()) {
    INFO("message " << name_of(g.message));
    CHECK(encoded(g.message) == g.bytes);
    CHECK(sum8(g.bytes) == 0xFF);
    auto one = decode_frame(g.bytes);
    REQUIRE(one.ok());
    CHECK(*one == g.message);
    StreamDecoder d;
    auto got = decode_all(d, g.bytes);
    REQUIRE(got.size() == 1);
    CHECK(got[0] == g.message);
    CHECK(d.counters() == Counters{1, 0, 0, 0});
  }
  CHECK(direction_of(Message{VcuCommand{}}) == Direction::vcu_to_controller);
  CHECK(direction_of(Message{ControllerStatus{}}) == Direction::controller_to_vcu);
}

TEST_CASE("pride: encoders reject out-of-range fields instead of clamping") {
  std::array<std::uint8_t, kFrameSize> buf{};
  CHECK(encode(VcuCommand{0x0E, 100, -100}, buf).ok());
  CHECK(encode(VcuCommand{0x0F, 0, 0}, buf).reason() == Reason::out_of_range);
  CHECK(encode(VcuCommand{0, 101, 0}, buf).reason() == Reason::out_of_range);
  CHECK(encode(VcuCommand{0, -101, 0}, buf).reason() == Reason::out_of_range);
  CHECK(encode(VcuCommand{0, 0, 101}, buf).reason() == Reason::out_of_range);
  CHECK(encode(VcuCommand{0, 0, -128}, buf).reason() == Reason::out_of_range);
  std::array<std::uint8_t, kFrameSize - 1> small{};
  CHECK(encode(VcuCommand{}, small).reason() == Reason::buffer_too_small);
  CHECK(encode(ControllerStatus{}, small).reason() == Reason::buffer_too_small);
}

TEST_CASE("pride: controller error byte accessors") {
  CHECK(ControllerStatus{0x02, 0, 0}.ready());
  CHECK_FALSE(ControllerStatus{0x02, 0, 0}.error());
  CHECK(ControllerStatus{0x82, 0, 0}.error());
  CHECK_FALSE(ControllerStatus{0x82, 0, 0}.ready());
  CHECK(ControllerStatus{0x82, 0, 0}.known_error_byte());
  // Undocumented values are neither ready nor the known error: the VCU must not drive on them.
  CHECK_FALSE(ControllerStatus{0x03, 0, 0}.ready());
  CHECK_FALSE(ControllerStatus{0x03, 0, 0}.error());
  CHECK_FALSE(ControllerStatus{0x03, 0, 0}.known_error_byte());
}

TEST_CASE("pride: decode_frame reasons") {
  const Bytes good{0xFE, 0x54, 0x07, 0x32, 0x00, 0x74};
  CHECK(decode_frame(std::span(good).first(5)).reason() == Reason::bad_length);
  CHECK(decode_frame(Bytes{0xFE, 0x55, 0x07, 0x32, 0x00, 0x73}).reason() == Reason::unknown_type);
  CHECK(decode_frame(Bytes{0x00, 0x54, 0x07, 0x32, 0x00, 0x74}).reason() == Reason::unknown_type);
  CHECK(decode_frame(Bytes{0xFE, 0x54, 0x07, 0x32, 0x00, 0x75}).reason() == Reason::bad_crc);
  // Speed level 0x0F with a correct checksum: FE + 54 + 0F = 0x161 -> 0x61 -> ~ = 0x9E.
  CHECK(decode_frame(Bytes{0xFE, 0x54, 0x0F, 0x00, 0x00, 0x9E}).reason() == Reason::out_of_range);
}

TEST_CASE("pride stream: a bad checksum is counted and the candidate skipped") {
  StreamDecoder d;
  auto got = decode_all(d, {0xFE, 0x54, 0x07, 0x32, 0x00, 0x75});
  CHECK(got.empty());
  CHECK(d.counters().checksum_errors == 1);
  CHECK(d.counters().bytes_skipped == 6);
  CHECK(d.pending() == 0);
}

TEST_CASE("pride stream: an out-of-range frame is counted, skipped, and the search resumes after its start") {
  StreamDecoder d;
  // FE 54 0F 00 00 9E (speed 0x0F, checksum right) then a real controller frame.
  auto got = decode_all(d, {0xFE, 0x54, 0x0F, 0x00, 0x00, 0x9E, 0x4A, 0x01, 0x02, 0x64, 0x00, 0x4E});
  REQUIRE(got.size() == 1);
  CHECK(got[0] == Message{ControllerStatus{0x02, 0x64, 0x00}});
  CHECK(d.counters() == Counters{1, 0, 1, 6});
}

TEST_CASE("pride stream: garbage and a lone header start before a frame are skipped") {
  StreamDecoder d;
  // 00 11 noise, FE not followed by 54, 4A not followed by 01, FE FE 54...: the second FE starts the frame.
  auto got = decode_all(d, {0x00, 0x11, 0xFE, 0x00, 0x4A, 0x4B, 0xFE, 0xFE, 0x54, 0x07, 0x32, 0x00, 0x74});
  REQUIRE(got.size() == 1);
  CHECK(got[0] == Message{VcuCommand{7, 50, 0}});
  CHECK(d.counters() == Counters{1, 0, 0, 7});
}

TEST_CASE("pride stream: a frame hidden inside a false candidate is found after the checksum fails") {
  StreamDecoder d;
  // FE 54 swallows 4A 01 02 64 as its payload+CS; the sum fails; the rescan starts at 54 and finds 4A 01 ...
  auto got = decode_all(d, {0xFE, 0x54, 0x4A, 0x01, 0x02, 0x64, 0x00, 0x4E});
  REQUIRE(got.size() == 1);
  CHECK(got[0] == Message{ControllerStatus{0x02, 0x64, 0x00}});
  CHECK(d.counters() == Counters{1, 1, 0, 2});
}

TEST_CASE("pride stream: back-to-back frames of both directions, fed in uneven chunks") {
  Bytes all;
  for (const auto& g : goldens()) all.insert(all.end(), g.bytes.begin(), g.bytes.end());
  StreamDecoder d;
  std::vector<Message> got;
  std::size_t pos = 0;
  std::size_t chunk = 1;
  while (pos < all.size()) {
    const std::size_t n = std::min(chunk, all.size() - pos);
    d.push(std::span<const std::uint8_t>(all.data() + pos, n), [&](const Message& m) { got.push_back(m); });
    pos += n;
    chunk = chunk % 5 + 2;
  }
  REQUIRE(got.size() == goldens().size());
  for (std::size_t i = 0; i < got.size(); ++i) CHECK(got[i] == goldens()[i].message);
  CHECK(d.counters().bytes_skipped == 0);
}

TEST_CASE("pride stream: drop_partial and reset") {
  StreamDecoder d;
  decode_all(d, {0xFE, 0x54, 0x07});
  CHECK(d.pending() == 3);
  d.drop_partial();
  CHECK(d.pending() == 0);
  CHECK(d.counters().bytes_skipped == 3);
  d.reset();
  CHECK(d.counters() == Counters{});
}

TEST_CASE("pride stream: random garbage with frames spliced at known offsets yields exactly those frames") {
  std::mt19937 rng(20261122);
  std::uniform_int_distribution<int> byte(0, 255);
  Bytes stream(256 * 1024);
  for (auto& b : stream) b = static_cast<std::uint8_t>(byte(rng));

  std::vector<Message> expected;
  std::size_t frame_bytes = 0;
  for (std::size_t off = 50, i = 0; off + kFrameSize < stream.size(); off += 301 + (i * 7) % 40, ++i) {
    const auto& g = goldens()[i % goldens().size()];
    std::copy(g.bytes.begin(), g.bytes.end(), stream.begin() + static_cast<std::ptrdiff_t>(off));
    expected.push_back(g.message);
    frame_bytes += g.bytes.size();
  }

  for (std::size_t chunk : {std::size_t{1}, std::size_t{7}, std::size_t{4096}}) {
    INFO("chunk size " << chunk);
    StreamDecoder d;
    std::vector<Message> got;
    for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
      const std::size_t n = std::min(chunk, stream.size() - pos);
      d.push(std::span<const std::uint8_t>(stream.data() + pos, n), [&](const Message& m) { got.push_back(m); });
    }
    REQUIRE(got.size() == expected.size());
    CHECK(got == expected);
    const auto& c = d.counters();
    CHECK(c.frames == expected.size());
    CHECK(frame_bytes + c.bytes_skipped + d.pending() == stream.size());
    CHECK(c.checksum_errors > 0);  // random FE 54 / 4A 01 pairs
  }
}

// ---- echo filter ----

namespace {
Bytes filter_all(EchoFilter& f, const Bytes& in) {
  Bytes out;
  for (auto b : in)
    if (auto kept = f.push(b)) out.push_back(*kept);
  return out;
}
}  // namespace

TEST_CASE("echo: the VCU's own frame is dropped and the controller's reply passes") {
  EchoFilter f;
  const Bytes mine{0xFE, 0x54, 0x07, 0x32, 0x00, 0x74};
  const Bytes reply{0x4A, 0x01, 0x02, 0x64, 0x00, 0x4E};
  REQUIRE(f.sent(mine));
  CHECK(f.expected() == 6);
  Bytes wire = mine;
  wire.insert(wire.end(), reply.begin(), reply.end());
  CHECK(filter_all(f, wire) == reply);
  CHECK(f.expected() == 0);
  CHECK(f.counters() == EchoFilter::Counters{6, 0, 0, 0});
}

TEST_CASE("echo: with nothing sent every byte passes, even one equal to a header") {
  EchoFilter f;
  const Bytes wire{0xFE, 0x54, 0x00};
  CHECK(filter_all(f, wire) == wire);
  CHECK(f.counters() == EchoFilter::Counters{});
}

TEST_CASE("echo: two frames sent back to back are both dropped, in order") {
  EchoFilter f;
  const Bytes a{0xFE, 0x54, 0x07, 0x32, 0x00, 0x74};
  const Bytes b{0xFE, 0x54, 0x00, 0x00, 0x00, 0xAD};
  REQUIRE(f.sent(a));
  REQUIRE(f.sent(b));
  Bytes wire = a;
  wire.insert(wire.end(), b.begin(), b.end());
  wire.push_back(0x4A);
  CHECK(filter_all(f, wire) == Bytes{0x4A});
  CHECK(f.counters().echoes_dropped == 12);
}

TEST_CASE("echo: a garbled echo byte passes, counts a mismatch and forgets the rest of the echo") {
  EchoFilter f;
  REQUIRE(f.sent(Bytes{0xFE, 0x54, 0x07, 0x32, 0x00, 0x74}));
  // Collision on the third byte: 0x07 came back as 0x87. The four echo bytes not yet seen (07 32 00 74) are
  // forgotten, so 32 00 74 are passed on; the decoder's checksum rejects the broken frame.
  const Bytes wire{0xFE, 0x54, 0x87, 0x32, 0x00, 0x74};
  CHECK(filter_all(f, wire) == Bytes{0x87, 0x32, 0x00, 0x74});
  CHECK(f.counters() == EchoFilter::Counters{2, 1, 4, 0});
  CHECK(f.expected() == 0);
}

TEST_CASE("echo: sent() refuses what does not fit, all or nothing; clear() forgets") {
  EchoFilter f;
  Bytes big(EchoFilter::kCapacity - 2, 0x11);
  REQUIRE(f.sent(big));
  CHECK_FALSE(f.sent(Bytes{1, 2, 3}));
  CHECK(f.counters().overflows == 3);
  CHECK(f.expected() == EchoFilter::kCapacity - 2);
  CHECK(f.sent(Bytes{1, 2}));
  CHECK(f.expected() == EchoFilter::kCapacity);
  f.clear();
  CHECK(f.expected() == 0);
  CHECK(f.counters().lost == EchoFilter::kCapacity);
}

TEST_CASE("echo: the ring wraps around over many frames") {
  EchoFilter f;
  StreamDecoder d;
  std::vector<Message> got;
  for (int i = 0; i < 100; ++i) {
    std::array<std::uint8_t, kFrameSize> mine{};
    REQUIRE(encode(VcuCommand{static_cast<std::uint8_t>(i % 15), static_cast<std::int8_t>(i - 50), 0}, mine).ok());
    std::array<std::uint8_t, kFrameSize> reply{};
    REQUIRE(encode(ControllerStatus{0x02, static_cast<std::uint8_t>(i), 0}, reply).ok());
    REQUIRE(f.sent(mine));
    for (auto b : mine)
      if (auto kept = f.push(b))
        if (auto m = d.push(*kept)) got.push_back(*m);
    for (auto b : reply)
      if (auto kept = f.push(b))
        if (auto m = d.push(*kept)) got.push_back(*m);
  }
  // The VCU's decoder sees only the controller's frames.
  REQUIRE(got.size() == 100);
  for (std::size_t i = 0; i < got.size(); ++i)
    CHECK(got[i] == Message{ControllerStatus{0x02, static_cast<std::uint8_t>(i), 0}});
  CHECK(f.counters() == EchoFilter::Counters{600, 0, 0, 0});
  CHECK(d.counters().bytes_skipped == 0);
}

// ---- layout check ----

namespace {
// A raw capture of the wire: every 5 ms the VCU's frame, then the controller's reply (bytes only, no idle time),
// with fields that vary from period to period.
Bytes synthetic_capture(std::size_t periods, std::size_t length) {
  Bytes out;
  for (std::size_t i = 0; i < periods; ++i) {
    const Bytes vcu{0xFE, 0x54, static_cast<std::uint8_t>(i % 15), static_cast<std::uint8_t>((i * 7) % 201 - 100),
                    static_cast<std::uint8_t>((i * 13) % 201 - 100)};
    const Bytes ctl{0x4A, 0x01, static_cast<std::uint8_t>(i % 50 == 0 ? 0x82 : 0x02),
                    static_cast<std::uint8_t>(200 - i % 100), static_cast<std::uint8_t>(i * 3)};
    for (const Bytes* f : {&vcu, &ctl}) {
      Bytes frame = *f;
      // Cut or pad to the requested length with extra payload bytes, then the checksum.
      if (frame.size() + 1 > length) frame.resize(length - 1);
      while (frame.size() + 1 < length) frame.push_back(static_cast<std::uint8_t>(i * 5 + frame.size()));
      std::uint8_t s = 0;
      for (auto b : frame) s = static_cast<std::uint8_t>(s + b);
      frame.push_back(static_cast<std::uint8_t>(~s));
      out.insert(out.end(), frame.begin(), frame.end());
    }
  }
  return out;
}
}  // namespace

TEST_CASE("layout check: a synthetic 5 ms capture confirms 6-byte frames for both headers") {
  const Bytes capture = synthetic_capture(400, 6);
  const LayoutReport r = check_layout(capture);
  CHECK(r.bytes == capture.size());
  for (const auto& h : r.headers) {
    INFO("header " << int(h.header[0]));
    CHECK(h.positions == 400);
    CHECK(h.spacing == 12);  // one VCU frame and one controller frame per period
    CHECK(h.spacing_count == 399);
    CHECK(h.long_spacings == 0);
    CHECK(hits_at(h, 6) == 400);
    CHECK(h.best_length == 6);
    for (std::size_t len = kMinCandidateLength; len <= kMaxCandidateLength; ++len)
      if (len != 6) CHECK(hits_at(h, len) < 40);  // chance hits only
  }
  CHECK(r.headers[0].header == kFormats[0].header);
  CHECK(r.headers[1].header == kFormats[1].header);
}

TEST_CASE("layout check: frames of another length are reported at that length, not at 6") {
  for (std::size_t length : {std::size_t{5}, std::size_t{7}, std::size_t{8}}) {
    INFO("true length " << length);
    const Bytes capture = synthetic_capture(400, length);
    const LayoutReport r = check_layout(capture);
    for (const auto& h : r.headers) {
      CHECK(h.positions == 400);
      CHECK(h.spacing == 2 * length);
      CHECK(h.best_length == length);
      CHECK(hits_at(h, length) == 400);
      CHECK(hits_at(h, 6) < 40);
    }
  }
}

TEST_CASE("layout check: one direction only, noise, empty input") {
  Bytes capture;
  for (int i = 0; i < 100; ++i) {
    std::array<std::uint8_t, kFrameSize> f{};
    REQUIRE(encode(ControllerStatus{0x02, static_cast<std::uint8_t>(i), 7}, f).ok());
    capture.insert(capture.end(), f.begin(), f.end());
    if (i % 10 == 9) capture.insert(capture.end(), 200, 0x00);  // a long gap of zeros every 10 frames
  }
  const LayoutReport r = check_layout(capture);
  CHECK(r.headers[1].positions == 100);
  CHECK(r.headers[1].spacing == 6);
  CHECK(r.headers[1].spacing_count == 90);
  CHECK(r.headers[1].long_spacings == 9);
  CHECK(r.headers[1].best_length == 6);
  CHECK(r.headers[0].positions == 0);
  CHECK(r.headers[0].best_length == 0);
  CHECK(r.headers[0].spacing == 0);

  const LayoutReport empty = check_layout({});
  CHECK(empty.bytes == 0);
  CHECK(empty.headers[0].positions == 0);
  // A header at the very end: counted as a position, but no candidate fits.
  const LayoutReport tail = check_layout(Bytes{0x00, 0xFE, 0x54});
  CHECK(tail.headers[0].positions == 1);
  CHECK(tail.headers[0].best_length == 0);
}
