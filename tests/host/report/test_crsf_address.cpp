// CRSF frames keep the address byte they started with: a flight controller acts only on RC frames addressed
// 0xC8, so a 0x00-addressed frame (Betaflight's captured test data) must not read like a receiver's. The frames
// are T7 of tests/unit/test_crsf.cpp (0xC8) and the same HEARTBEAT re-addressed to 0x00 and 0xEE, their
// CRC-8/DVB-S2 unchanged because the CRC covers TYPE and payload only, plus the 0x17 subset frame of test_crsf.cpp.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

#include "saulproto/host/report/serial_decode.hpp"

using namespace saul;
using namespace saul::host;

namespace {

std::vector<SerialMessage> decode(const std::vector<std::uint8_t>& bytes) {
  SerialStreamDecoder d(SerialProtocol::crsf);
  std::vector<SerialMessage> out;
  const SerialStreamDecoder::Callback on = [&](const SerialMessage& m) { out.push_back(m); };
  d.push(bytes, on);
  d.finish(on);
  return out;
}

}  // namespace

TEST_CASE("CRSF: the address byte is part of the decoded message, in text and JSON") {
  const auto got = decode({0xC8, 0x04, 0x0B, 0x00, 0xC8, 0xED,    // heartbeat to the flight controller
                           0x00, 0x04, 0x0B, 0x00, 0xC8, 0xED,    // the same, broadcast
                           0xEE, 0x04, 0x0B, 0x00, 0xC8, 0xED});  // the same, to a TX module
  REQUIRE(got.size() == 3);
  CHECK(describe(got[0]) == "heartbeat address=0xC8 origin=200");
  CHECK(describe(got[1]) == "heartbeat address=0x00 origin=200");
  CHECK(describe(got[2]) == "heartbeat address=0xEE origin=200");
  CHECK(to_json(got[1]) == nlohmann::json::parse(R"({"type":"heartbeat","address":0,"origin":200})"));
  CHECK(name_of(got[0]) == "heartbeat");
  REQUIRE(std::holds_alternative<CrsfMessage>(got[1]));
  CHECK(std::get<CrsfMessage>(got[1]).address == 0x00);
}

TEST_CASE("CRSF: a 0x17 subset RC frame decodes with its channels in microseconds") {
  const auto got = decode({0xC8, 0x08, 0x17, 0x24, 0xE8, 0x03, 0xE0, 0xFF, 0x01, 0x03});
  REQUIRE(got.size() == 1);
  CHECK(describe(got[0]) ==
        "rc_channels_subset address=0xC8 first_channel=5 resolution_bits=11 digital_switch=0 ch5=1488 ch6=1500 "
        "ch7=2011.5");
  const auto j = to_json(got[0]);
  CHECK(j["ch7"] == 2011.5);
  CHECK(j["first_channel"] == 5);
}

TEST_CASE("CRSF: an exception from the message callback leaves push() and finish() as it is thrown") {
  // The core's decoder is noexcept: thrown through it, plot's usage error ended saulctl with "terminate called".
  SerialStreamDecoder d(SerialProtocol::crsf);
  const SerialStreamDecoder::Callback stop = [](const SerialMessage& m) { throw std::runtime_error(name_of(m)); };
  const std::vector<std::uint8_t> heartbeat{0xC8, 0x04, 0x0B, 0x00, 0xC8, 0xED};
  CHECK_THROWS_WITH(d.push(heartbeat, stop), "heartbeat");
  // C8 3E opens a 62-byte candidate that holds T7 back until finish() gives it up and rescans what followed
  SerialStreamDecoder e(SerialProtocol::crsf);
  std::vector<std::string> names;
  e.push(std::vector<std::uint8_t>{0xC8, 0x3E, 0xC8, 0x04, 0x0B, 0x00, 0xC8, 0xED},
         [&](const SerialMessage& m) { names.push_back(name_of(m)); });
  CHECK(names.empty());
  CHECK_THROWS_WITH(e.finish(stop), "heartbeat");
}
