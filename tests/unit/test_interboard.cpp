// Inter-board UART: golden frames worked out by hand (little-endian payloads) with the CRC from a bitwise
// CRC-8/MAXIM reference (docs/protocols.md §1.3), never from the encoder under test.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "saulproto/core/interboard.hpp"

using namespace saul;
using namespace saul::interboard;
using Bytes = std::vector<std::uint8_t>;

namespace {

Bytes encoded(const Message& m) {
  std::array<std::uint8_t, kMaxFrameSize> buf{};
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
      // throttle 500 = F4 01, steer -250 = 06 FF, flags armed
      {RcCmd{500, -250, RcCmd::kArmed}, {0xAA, 0x05, 0x01, 0xF4, 0x01, 0x06, 0xFF, 0x01, 0x0F}},
      // tof 1234 = D2 04, baro -56 = C8 FF, nfc 1
      {Sensor{1234, -56, 1}, {0xAA, 0x05, 0x02, 0xD2, 0x04, 0xC8, 0xFF, 0x01, 0x14}},
      // rc_loss | estop
      {Fault{Fault::kRcLoss | Fault::kEstop}, {0xAA, 0x01, 0x03, 0x05, 0x6A}},
      // pitch -12.34 deg = -1234 = 2E FB, pid_out 300 = 2C 01, state 1
      {State{-1234, 300, 1}, {0xAA, 0x05, 0x10, 0x2E, 0xFB, 0x2C, 0x01, 0x01, 0x51}},
      {LedCmd{2, 255, 128, 0}, {0xAA, 0x04, 0x11, 0x02, 0xFF, 0x80, 0x00, 0x4B}},
      // tone 3, 500 ms = F4 01
      {Buzzer{3, 500}, {0xAA, 0x03, 0x12, 0x03, 0xF4, 0x01, 0x27}},
      // speed cap 10 % (an addition to the reference, docs/protocol.md section 2); CRC worked out by hand
      {SpeedCap{10}, {0xAA, 0x01, 0x13, 0x0A, 0xC7}},
  };
  return g;
}

}  // namespace

TEST_CASE("every inter-board message encodes to its golden frame and decodes back") {
  for (const auto& g : goldens()) {
    INFO("message " << name_of(g.message));
    CHECK(encoded(g.message) == g.bytes);
    StreamDecoder d;
    auto got = decode_all(d, g.bytes);
    REQUIRE(got.size() == 1);
    CHECK(got[0] == g.message);
    CHECK(d.counters().frames == 1);
    CHECK(d.counters().bytes_skipped == 0);
  }
}

TEST_CASE("payload lengths are the fixed ones of the protocol") {
  CHECK(payload_length(0x01) == 5);
  CHECK(payload_length(0x02) == 5);
  CHECK(payload_length(0x03) == 1);
  CHECK(payload_length(0x10) == 5);
  CHECK(payload_length(0x11) == 4);
  CHECK(payload_length(0x12) == 3);
  CHECK_FALSE(payload_length(0x00).has_value());
  CHECK_FALSE(payload_length(0x04).has_value());
  CHECK_FALSE(payload_length(0xAA).has_value());
}

TEST_CASE("RC_CMD flag accessors") {
  CHECK(RcCmd{0, 0, 0x01}.armed());
  CHECK_FALSE(RcCmd{0, 0, 0x01}.kill());
  CHECK(RcCmd{0, 0, 0x02}.kill());
  CHECK(RcCmd{0, 0, 0x04}.disarm_switch());
  CHECK_FALSE(RcCmd{0, 0, 0x0B}.disarm_switch());
  CHECK(RcCmd{0, 0, 0x08}.button());
  CHECK_FALSE(RcCmd{0, 0, 0x07}.button());
}

TEST_CASE("extreme values round-trip") {
  const std::vector<Message> ms = {RcCmd{-32768, 32767, 0xFF}, Sensor{65535, -32768, 0}, State{32767, -32768, 5},
                                   Buzzer{255, 65535}, LedCmd{255, 0, 0, 255}, Fault{0}};
  StreamDecoder d;
  for (const auto& m : ms) {
    auto got = decode_all(d, encoded(m));
    REQUIRE(got.size() == 1);
    CHECK(got[0] == m);
  }
}

TEST_CASE("encode refuses a buffer that is too small") {
  std::array<std::uint8_t, 8> small{};
  auto r = encode(RcCmd{}, small);  // needs 9
  CHECK(r.reason() == Reason::buffer_too_small);
  std::array<std::uint8_t, 5> exact{};
  CHECK(encode(Fault{1}, exact).ok());
}

TEST_CASE("decode_payload rejects unknown types and wrong lengths") {
  const std::array<std::uint8_t, 5> p{};
  CHECK(decode_payload(0x04, p).reason() == Reason::unknown_type);
  CHECK(decode_payload(0x03, p).reason() == Reason::bad_length);
  CHECK(decode_payload(0x01, std::span(p).first(4)).reason() == Reason::bad_length);
  CHECK(decode_payload(0x01, p).ok());
}

TEST_CASE("stream: a bad CRC is counted and the frame dropped") {
  StreamDecoder d;
  auto got = decode_all(d, {0xAA, 0x01, 0x03, 0x05, 0x6B});
  CHECK(got.empty());
  CHECK(d.counters().crc_errors == 1);
  CHECK(d.counters().frames == 0);
  // the rejected start byte and the four bytes after it are all skipped
  CHECK(d.counters().bytes_skipped == 5);
}

TEST_CASE("stream: garbage before a frame is skipped and counted") {
  StreamDecoder d;
  auto got = decode_all(d, {0x00, 0x11, 0x22, 0xAA, 0x01, 0x03, 0x05, 0x6A});
  REQUIRE(got.size() == 1);
  CHECK(got[0] == Message{Fault{5}});
  CHECK(d.counters().bytes_skipped == 3);
}

TEST_CASE("stream: unknown type is rejected and the search resumes after the rejected start byte") {
  StreamDecoder d;
  // AA 05 AA: TYPE 0xAA is unknown; the real frame starts at the third byte.
  auto got = decode_all(d, {0xAA, 0x05, 0xAA, 0x01, 0x03, 0x05, 0x6A});
  REQUIRE(got.size() == 1);
  CHECK(got[0] == Message{Fault{5}});
  CHECK(d.counters().unknown_types == 1);
  CHECK(d.counters().bytes_skipped == 2);  // AA 05
}

TEST_CASE("stream: a corrupted LEN is rejected and the frame right behind it found") {
  StreamDecoder d;
  // LEN 0x07 exists for no type; the next byte starts a real frame.
  auto got = decode_all(d, {0xAA, 0x07, 0xAA, 0x01, 0x03, 0x05, 0x6A});
  REQUIRE(got.size() == 1);
  CHECK(d.counters().length_errors == 1);
  // LEN that is some type's length but not this TYPE's: AA 04 01 (RC_CMD is 5)
  StreamDecoder d2;
  auto got2 = decode_all(d2, {0xAA, 0x04, 0x01, 0xAA, 0x01, 0x03, 0x05, 0x6A});
  REQUIRE(got2.size() == 1);
  CHECK(d2.counters().length_errors == 1);
  CHECK(d2.counters().bytes_skipped == 3);
}

TEST_CASE("stream: a real frame hidden inside a false candidate is found after the CRC fails") {
  StreamDecoder d;
  // AA 05 01 looks like an RC_CMD and swallows the next 6 bytes, which hold a whole FAULT frame.
  // Its CRC fails; the rescan starts at 05 and finds the FAULT frame. The trailing 0x00 is noise.
  auto got = decode_all(d, {0xAA, 0x05, 0x01, 0xAA, 0x01, 0x03, 0x05, 0x6A, 0x00});
  REQUIRE(got.size() == 1);
  CHECK(got[0] == Message{Fault{5}});
  CHECK(d.counters().crc_errors == 1);
  CHECK(d.counters().bytes_skipped == 4);  // AA 05 01 ... 00
}

TEST_CASE("stream: back-to-back frames and a frame split across pushes") {
  Bytes all;
  for (const auto& g : goldens()) all.insert(all.end(), g.bytes.begin(), g.bytes.end());
  StreamDecoder d;
  std::vector<Message> got;
  // Feed in uneven chunks through the span overload.
  std::size_t pos = 0;
  std::size_t chunk = 1;
  while (pos < all.size()) {
    const std::size_t n = std::min(chunk, all.size() - pos);
    d.push(std::span<const std::uint8_t>(all.data() + pos, n), [&](const Message& m) { got.push_back(m); });
    pos += n;
    chunk = chunk % 7 + 2;
  }
  REQUIRE(got.size() == goldens().size());
  for (std::size_t i = 0; i < got.size(); ++i) CHECK(got[i] == goldens()[i].message);
  CHECK(d.counters().bytes_skipped == 0);
}

TEST_CASE("stream: drop_partial counts the partial frame as skipped") {
  StreamDecoder d;
  decode_all(d, {0xAA, 0x05, 0x01, 0x00});
  CHECK(d.pending() == 4);
  d.drop_partial();
  CHECK(d.pending() == 0);
  CHECK(d.counters().bytes_skipped == 4);
}

TEST_CASE("stream: 1 MiB of random bytes with frames spliced in at known offsets yields exactly those frames") {
  std::mt19937 rng(20261122);
  std::uniform_int_distribution<int> byte(0, 255);
  Bytes stream(1 << 20);
  for (auto& b : stream) b = static_cast<std::uint8_t>(byte(rng));

  // Splice a golden frame every ~1 KiB, cycling through all message types.
  std::vector<Message> expected;
  std::size_t frame_bytes = 0;
  for (std::size_t off = 100, i = 0; off + kMaxFrameSize < stream.size(); off += 997 + (i * 13) % 50, ++i) {
    const auto& g = goldens()[i % goldens().size()];
    std::copy(g.bytes.begin(), g.bytes.end(), stream.begin() + static_cast<std::ptrdiff_t>(off));
    expected.push_back(g.message);
    frame_bytes += g.bytes.size();
  }

  for (std::size_t chunk : {std::size_t{1}, std::size_t{3}, std::size_t{64}, std::size_t{4096}}) {
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
    // Every byte is accounted for: in a frame, skipped, or pending at the end.
    CHECK(frame_bytes + c.bytes_skipped + d.pending() == stream.size());
    CHECK(c.crc_errors + c.length_errors + c.unknown_types > 0);
  }
}
