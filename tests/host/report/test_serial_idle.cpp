// Serial captures: a message carries the time of the chunk its frame's last byte came in, and a candidate frame
// that hides real frames is given up when the line goes quiet (docs/protocol.md), so they come out at once. The
// frames are the hand-checked vectors of tests/unit/test_crsf.cpp (T3, T4, T7) and of captures/interboard_uart.serial.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "saulproto/host/report/serial_decode.hpp"

using namespace saul;
using namespace saul::host;

namespace {

using Bytes = std::vector<std::uint8_t>;
const Bytes kT3 = {0xC8, 0x0C, 0x14, 0x3C, 0x3E, 0x64, 0x09, 0x00, 0x04, 0x03, 0x37, 0x62, 0x08, 0x95};  // link stats
const Bytes kT4 = {0xC8, 0x0A, 0x08, 0x00, 0xA8, 0x00, 0x7B, 0x00, 0x05, 0xDC, 0x4B, 0x29};  // battery
const Bytes kT7 = {0xC8, 0x04, 0x0B, 0x00, 0xC8, 0xED};                                      // heartbeat
const Bytes kFault = {0xAA, 0x01, 0x03, 0x05, 0x6A};                                          // inter-board fault 5

Bytes concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

SerialChunk chunk(std::uint64_t ms_x1000, SerialProtocol p, Bytes bytes) {
  SerialChunk c;
  c.timestamp_ns = ms_x1000 * 1000;  // microseconds in, ns out
  c.link = "serial:/dev/ttyUSB0";
  c.protocol = p;
  c.bytes = std::move(bytes);
  return c;
}

/// "time_us name" of every message, in delivery order.
std::vector<std::string> decode(const std::vector<SerialChunk>& chunks, SerialDecodeCounters* counters = nullptr) {
  SerialCaptureDecoder d;
  std::vector<std::string> out;
  const SerialCaptureDecoder::Callback on = [&](const SerialChunk& c, SerialProtocol, const SerialMessage& m) {
    out.push_back(std::to_string(c.timestamp_ns.value_or(0) / 1000) + " " + name_of(m));
  };
  for (const auto& c : chunks) d.add(c, on);
  d.finish(on);
  if (counters) *counters = d.links().at(0).counters;
  return out;
}

}  // namespace

TEST_CASE("CRSF: a stray 00 3E before a frame, then the line goes quiet: the frame keeps its own time") {
  // 00 is a valid CRSF address and 3E a valid LEN: a 64-byte candidate opens and the heartbeat sits inside it.
  // Frames then come every 20 ms. Before the fix the heartbeat came out with the chunk that completed the 64 bytes.
  const auto p = SerialProtocol::crsf;
  SerialDecodeCounters c;
  const auto got = decode({chunk(0, p, concat({{0x00, 0x3E}, kT7})), chunk(20'000, p, kT3), chunk(40'000, p, kT4),
                           chunk(60'000, p, kT3), chunk(80'000, p, kT4)},
                          &c);
  CHECK(got == std::vector<std::string>{"0 heartbeat", "20000 link_statistics", "40000 battery_sensor",
                                        "60000 link_statistics", "80000 battery_sensor"});
  CHECK(c.frames == 5);
  CHECK(c.incomplete == 1);    // the false candidate, given up at the gap
  CHECK(c.bytes_skipped == 2);  // 00 and 3E
  CHECK(c.bytes == 2 + 6 + 14 + 12 + 14 + 12);
}

TEST_CASE("CRSF: without a gap the frames behind a false candidate carry the time of their last byte") {
  // One byte per chunk 24 us apart, as a logic analyser at 420000 baud sees them: no idle gap anywhere, so the
  // 64-byte candidate runs to its end; the frames found behind it are stamped with their own last byte.
  const Bytes stream = concat({{0x00, 0x3E}, kT7, kT3, kT4, kT3, kT4, Bytes(20, 0x55)});
  std::vector<SerialChunk> chunks;
  for (std::size_t i = 0; i < stream.size(); ++i) chunks.push_back(chunk(i * 24, SerialProtocol::crsf, {stream[i]}));
  const auto got = decode(chunks);
  // last bytes at indexes 7 (2 + 6 - 1), 21, 33, 47, 59
  CHECK(got == std::vector<std::string>{"168 heartbeat", "504 link_statistics", "792 battery_sensor",
                                        "1128 link_statistics", "1416 battery_sensor"});
}

TEST_CASE("CRSF: a real frame split over two reads by a slow USB adapter is not given up at the gap") {
  const auto p = SerialProtocol::crsf;
  const Bytes head(kT3.begin(), kT3.begin() + 5);
  const Bytes tail(kT3.begin() + 5, kT3.end());
  SerialDecodeCounters c;
  const auto got = decode({chunk(0, p, kT7), chunk(1'000, p, head), chunk(17'000, p, tail)}, &c);
  CHECK(got == std::vector<std::string>{"0 heartbeat", "17000 link_statistics"});
  CHECK(c.incomplete == 0);
  CHECK(c.bytes_skipped == 0);
}

TEST_CASE("inter-board: a stray start with a valid length hides a frame until the line goes quiet") {
  // AA 05 01 opens a 9-byte rc_cmd candidate; the 5-byte fault frame after it ends inside. 10 ms of silence.
  const auto p = SerialProtocol::interboard;
  SerialDecodeCounters c;
  const auto got = decode({chunk(100, p, concat({{0xAA, 0x05, 0x01}, kFault})), chunk(10'100, p, kFault)}, &c);
  CHECK(got == std::vector<std::string>{"100 fault", "10100 fault"});
  CHECK(c.frames == 2);
  CHECK(c.bytes_skipped == 3);  // AA 05 01
  CHECK(c.incomplete == 1);
  CHECK(c.bytes == 13);
}

TEST_CASE("idle gaps per protocol") {
  CHECK(idle_gap_ns(SerialProtocol::crsf) == 1'748'000);
  CHECK(idle_gap_ns(SerialProtocol::pride) > 6 * 11 * 1'000'000'000ULL / 38'400);  // longer than a frame
}
