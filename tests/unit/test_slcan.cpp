// slcan lines: vectors from the Linux slcan comment block and the CANable README (docs/protocols.md §4.5),
// written out by hand.
#include <catch2/catch.hpp>

#include <array>
#include <string>
#include <vector>

#include "saulproto/core/slcan.hpp"

using namespace saul;
using namespace saul::slcan;

namespace {

std::string enc(const CanFrame& f) {
  std::array<char, kMaxClassicLine + 1> buf{};
  auto n = encode_frame(f, buf);
  REQUIRE(n.ok());
  return std::string(buf.data(), *n);
}

CanFrame data(std::uint32_t id, bool ext, std::vector<std::uint8_t> bytes) {
  auto f = CanFrame::data_frame(id, ext, bytes);
  REQUIRE(f.ok());
  return *f;
}

std::vector<Event> feed(LineDecoder& d, std::string_view s) {
  std::vector<Event> out;
  for (char c : s)
    if (auto e = d.push(c)) out.push_back(*e);
  return out;
}

}  // namespace

TEST_CASE("slcan encodes the robot's frames byte-exactly") {
  CHECK(enc(data(0x344, true, {0x00, 0x00, 0x05, 0xDC})) == "T000003444000005DC\r");
  CHECK(enc(data(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA})) == "T000009388FFFFFB50002300FA\r");
  CHECK(enc(data(0x44, true, {0x00, 0x00, 0x27, 0x10})) == "T00000044400002710\r");
  CHECK(enc(data(0x123, false, {})) == "t1230\r");
  CHECK(enc(data(0x300, false, {0xE8, 0x03, 0x0C, 0xFE})) == "t3004E8030CFE\r");
  CanFrame rtr;
  rtr.id = 0x400;
  rtr.remote = true;
  rtr.dlc = 7;
  CHECK(enc(rtr) == "r4007\r");
  rtr.extended = true;
  CHECK(enc(rtr) == "R000004007\r");
}

TEST_CASE("slcan refuses error frames, invalid frames and small buffers") {
  std::array<char, kMaxClassicLine + 1> buf{};
  CanFrame err;
  err.error = true;
  CHECK(encode_frame(err, buf).reason() == Reason::error_frame);
  CanFrame bad;
  bad.id = 0x800;
  CHECK(encode_frame(bad, buf).reason() == Reason::invalid_frame);
  std::array<char, 10> small{};
  CHECK(encode_frame(data(0x1, false, {}), small).reason() == Reason::buffer_too_small);
}

TEST_CASE("slcan bitrate presets: S6 is 500 kbit/s; 750k/800k are ambiguous and not offered") {
  CHECK(bitrate_preset(500'000) == '6');
  CHECK(bitrate_preset(125'000) == '4');
  CHECK(bitrate_preset(1'000'000) == '8');
  CHECK_FALSE(bitrate_preset(800'000).has_value());
  CHECK_FALSE(bitrate_preset(750'000).has_value());
}

TEST_CASE("slcan parses frames, with and without device timestamps, upper and lower case") {
  DeviceTime t;
  auto f = parse_frame("t4563112233", &t);
  REQUIRE(f.ok());
  CHECK(f->id == 0x456);
  CHECK(f->dlc == 3);
  CHECK(f->data[2] == 0x33);
  CHECK(t.unit == DeviceTime::Unit::none);

  auto g = parse_frame("T12abcdef2aa55EA5F", &t);
  REQUIRE(g.ok());
  CHECK(g->extended);
  CHECK(g->id == 0x12ABCDEF);
  CHECK(g->data[1] == 0x55);
  CHECK(t.unit == DeviceTime::Unit::milliseconds);
  CHECK(t.value == 59999);

  auto h = parse_frame("r1230", &t);
  REQUIRE(h.ok());
  CHECK(h->remote);
  CHECK(h->dlc == 0);

  auto us = parse_frame("t123111000F4240", &t);
  REQUIRE(us.ok());
  CHECK(t.unit == DeviceTime::Unit::microseconds);
  CHECK(t.value == 1'000'000);
}

TEST_CASE("slcan rejects malformed frame lines with a reason") {
  CHECK(parse_frame("t12").reason() == Reason::syntax);
  CHECK(parse_frame("t123").reason() == Reason::truncated);
  CHECK(parse_frame("t1239").reason() == Reason::invalid_frame);       // DLC 9 is FD
  CHECK(parse_frame("t1232AA").reason() == Reason::truncated);         // 2 bytes announced, 1 given
  CHECK(parse_frame("t1231GG").reason() == Reason::syntax);
  CHECK(parse_frame("t1231AABB").reason() == Reason::bad_length);      // 2 stray digits
  CHECK(parse_frame("t8001AA").reason() == Reason::invalid_frame);     // 11-bit id above 7FF
  CHECK(parse_frame("x1231AA").reason() == Reason::syntax);
}

TEST_CASE("slcan line decoder: frames, acks, version, status, FD and junk, in any chunking") {
  const std::string stream =
      "t3004E8030CFE\r"       // frame
      "\r"                    // OK (Lawicel)
      "\a"                    // error (Lawicel)
      "z\r"                   // tx ack
      "V1010\r"               // version
      "F04\r"                 // status: error warning
      "d1239112233445566778899AABBCC\r"  // FD: counted and rejected
      "hello\r"               // junk
      "T000003444000005DC\r";
  LineDecoder d;
  auto ev = feed(d, stream);
  REQUIRE(ev.size() == 9);
  CHECK(ev[0].kind == Event::Kind::frame);
  CHECK(ev[0].frame.id == 0x300);
  CHECK(ev[1].kind == Event::Kind::ok);
  CHECK(ev[2].kind == Event::Kind::error);
  CHECK(ev[3].kind == Event::Kind::tx_ack);
  CHECK(ev[4].kind == Event::Kind::version);
  CHECK(std::string(ev[4].text) == "1010");
  CHECK(ev[5].kind == Event::Kind::status);
  CHECK(ev[5].value == 0x04);
  CHECK(ev[6].kind == Event::Kind::rejected);
  CHECK(ev[7].kind == Event::Kind::rejected);
  CHECK(ev[8].kind == Event::Kind::frame);
  CHECK(ev[8].frame.extended);
  CHECK(d.counters().frames == 2);
  CHECK(d.counters().fd_frames == 1);
  CHECK(d.counters().rejected_lines == 2);
  CHECK(d.counters().acks == 3);

  // The same stream fed through the span overload in one go gives the same events.
  LineDecoder d2;
  std::vector<Event> ev2;
  d2.push(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(stream.data()), stream.size()),
          [&](const Event& e) { ev2.push_back(e); });
  CHECK(ev2.size() == ev.size());
}

TEST_CASE("slcan line decoder drops an overlong line and recovers at the next CR") {
  LineDecoder d;
  std::string junk(kMaxLine + 50, 'x');
  auto ev = feed(d, junk + "\rt1230\r");
  REQUIRE(ev.size() == 1);
  CHECK(ev[0].kind == Event::Kind::frame);
  CHECK(d.counters().overlong_lines == 1);
}

TEST_CASE("slcan encode with a millisecond stamp wraps at 60000") {
  std::array<char, kMaxClassicLine + 1> buf{};
  auto n = encode_frame_with_ms(data(0x123, false, {0x01}), 60001, buf);
  REQUIRE(n.ok());
  CHECK(std::string(buf.data(), *n) == "t1231010001\r");
}
