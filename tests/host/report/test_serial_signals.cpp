// One renderer (issue 34): the Pride link's messages and CRSF's 0x17 subset RC channels render through their signal
// descriptions like every other message: text, JSON, decode --format long's rows, MCAP's schema and plot's lookup
// all name and scale their signals from core/signals_pride.hpp and signals_crsf.hpp. The frames are written out by
// hand: Pride's from the manual's layout (pride.hpp: header, SP FB LR or EB BC UN, CS = ~sum), the same bytes as
// captures/pride_uart.serial; CRSF's 0x17 frame is test_crsf.cpp's (CH5..CH7 at 11 bits: 1000, 1024, 2047).
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <string>
#include <utility>
#include <vector>

#include "saulproto/host/report/mcap_serial.hpp"
#include "saulproto/host/report/serial_decode.hpp"
#include "saulproto/host/report/signal_rows.hpp"
#include "saulproto/host/report/telemetry_plot.hpp"

using namespace saul;
using namespace saul::host;

namespace {

std::vector<SerialMessage> decode(SerialProtocol protocol, const std::vector<std::uint8_t>& bytes) {
  SerialStreamDecoder d(protocol);
  std::vector<SerialMessage> out;
  const SerialStreamDecoder::Callback on = [&](const SerialMessage& m) { out.push_back(m); };
  d.push(bytes, on);
  d.finish(on);
  return out;
}

/// (signal, value, unit) of each long-format row.
std::vector<std::tuple<std::string, double, std::string>> rows(const SerialMessage& m) {
  std::vector<std::tuple<std::string, double, std::string>> out;
  for (const auto& r : signal_rows(signal_values(m))) out.emplace_back(r.signal, r.value, r.unit);
  return out;
}

}  // namespace

TEST_CASE("Pride: both messages render through their descriptions under the manual's names without units") {
  // FE 54 | SP 07 FB 32 (+50) LR 00 | CS: FE+54+07+32+00 = 0x18B, ~0x8B = 0x74
  // FE 54 | SP 0E FB 9C (-100) LR CE (-50) | CS 0x35;  4A 01 | EB 02 (ready) BC 64 (100) UN 00 | CS 0x4E
  const auto got = decode(SerialProtocol::pride, {0xFE, 0x54, 0x07, 0x32, 0x00, 0x74,   //
                                                  0xFE, 0x54, 0x0E, 0x9C, 0xCE, 0x35,   //
                                                  0x4A, 0x01, 0x02, 0x64, 0x00, 0x4E});
  REQUIRE(got.size() == 3);

  const SignalValues vcu = signal_values(got[1]);
  REQUIRE(vcu.message != nullptr);
  CHECK(vcu.message->protocol == signals::Protocol::pride);
  CHECK(std::string(vcu.message->name) == "vcu_command");
  CHECK(vcu.message->id == 0xFE54);
  CHECK(rows(got[1]) == std::vector<std::tuple<std::string, double, std::string>>{
                            {"speed_level", 14, ""}, {"forward_back", -100, ""}, {"left_right", -50, ""}});
  CHECK(describe(got[1]) == "vcu_command speed_level=14 forward_back=-100 left_right=-50");
  CHECK(to_json(got[1]) ==
        nlohmann::json::parse(R"({"type":"vcu_command","speed_level":14,"forward_back":-100,"left_right":-50})"));
  CHECK(describe(got[0]) == "vcu_command speed_level=7 forward_back=50 left_right=0");

  const SignalValues status = signal_values(got[2]);
  REQUIRE(status.message != nullptr);
  CHECK(status.message->id == 0x4A01);
  CHECK(describe(got[2]) == "controller_status error_byte=2 battery_charge=100 unknown=0");
  CHECK(to_json(got[2]) ==
        nlohmann::json::parse(R"({"type":"controller_status","error_byte":2,"battery_charge":100,"unknown":0})"));
  CHECK(rows(got[2]) == std::vector<std::tuple<std::string, double, std::string>>{
                            {"error_byte", 2, ""}, {"battery_charge", 100, ""}, {"unknown", 0, ""}});
  // the manual's two error-byte values are named in the description; text and JSON keep the number
  CHECK(std::string(signals::value_name(status.message->signals[0], 0x02)) == "ready");
  CHECK(std::string(signals::value_name(status.message->signals[0], 0x82)) == "error");

  // plot --field and the bench conditions: the same names through the one lookup
  PlotMessage pm;
  pm.serial = &got[1];
  pm.name = "vcu_command";
  CHECK(pm.field("forward_back") == -100.0);
  CHECK_FALSE(pm.field("throttle"));
  CHECK(unknown_signal_error("'vcu_command' (vcu_command)", vcu.message, "throttle") ==
        "'vcu_command' (vcu_command) has no signal 'throttle'; its signals: speed_level, forward_back, left_right");

  // MCAP: the schema from the description, as every other message's
  const auto schema = nlohmann::json::parse(mcap_serial_json_schema(got[0]));
  CHECK(schema.at("title") == "vcu_command");
  CHECK(schema.at("description") == "vcu_command (VCU -> PRIDE), as saulctl decode --json shows it");
  CHECK(schema.at("required") == nlohmann::json::parse(R"(["type","speed_level","forward_back","left_right"])"));
  CHECK(schema.at("properties").at("forward_back").at("type") == "integer");
}

TEST_CASE("CRSF 0x17: the subset RC channels render through their description with channels in microseconds") {
  // C8 08 17 | 24: CH5, 11 bits, no digital switch | E8 03 E0 FF 01: 1000, 1024, 2047 | CRC 03
  const auto got = decode(SerialProtocol::crsf, {0xC8, 0x08, 0x17, 0x24, 0xE8, 0x03, 0xE0, 0xFF, 0x01, 0x03});
  REQUIRE(got.size() == 1);
  const SignalValues v = signal_values(got[0]);
  REQUIRE(v.message != nullptr);
  CHECK(std::string(v.message->name) == "rc_channels_subset");
  // value x 2^(10 - 11) + 988: 1488, 1500, 2011.5 us; the header's first channel 1-based, its resolution in bits
  CHECK(rows(got[0]) == std::vector<std::tuple<std::string, double, std::string>>{{"first_channel", 5, ""},
                                                                                 {"resolution_bits", 11, ""},
                                                                                 {"digital_switch", 0, ""},
                                                                                 {"ch5", 1488, "us"},
                                                                                 {"ch6", 1500, "us"},
                                                                                 {"ch7", 2011.5, "us"}});
  CHECK(describe(got[0]) ==
        "rc_channels_subset address=0xC8 first_channel=5 resolution_bits=11 digital_switch=0 ch5=1488 ch6=1500 "
        "ch7=2011.5");
  CHECK(to_json(got[0]) == nlohmann::json::parse(R"({"type":"rc_channels_subset","address":200,"first_channel":5,
        "resolution_bits":11,"digital_switch":0,"ch5":1488.0,"ch6":1500.0,"ch7":2011.5})"));
  PlotMessage pm;
  pm.serial = &got[0];
  CHECK(pm.field("ch7") == 2011.5);
  CHECK_FALSE(pm.field("ch8"));  // described, but not in this frame
  // the schema knows every channel; a frame carries some, so only the header is required
  const auto schema = nlohmann::json::parse(mcap_serial_json_schema(got[0]));
  CHECK(schema.at("properties").contains("ch32"));
  CHECK(schema.at("required") ==
        nlohmann::json::parse(R"(["type","first_channel","resolution_bits","digital_switch","address"])"));
}
