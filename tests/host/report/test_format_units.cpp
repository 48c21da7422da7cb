// saulctl's text shows scaled wire integers as physical values with units (docs/cli.md "Units"), JSON keeps the
// wire integers under their keys and puts the physical value beside them under "<name>_<unit>". Bytes and values worked out by hand from docs/protocol.md (SAUL: little-endian,
// pitch in 1/100 deg, battery in mV; CRSF: big-endian, 0.1 V, 1e-7 deg, RC ticks mapped 172 -> 988 us,
// 992 -> 1500 us, 1811 -> 2012 us as the receivers do).
#include <catch2/catch.hpp>

#include <fmt/format.h>

#include <initializer_list>
#include <random>
#include <vector>
#include <string>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/report/format.hpp"

using namespace saul;

namespace {

BusMessage decoded(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  const auto r = decode_bus_frame(f);
  REQUIRE(r);
  return r.value();
}

std::string text_of_frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  return host::describe(decoded(id, bytes));
}

nlohmann::json json_of_frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  return host::to_json(decoded(id, bytes));
}

}  // namespace

TEST_CASE("text: SAUL pitch, battery and tilt limit in degrees and volts, under their physical names") {
  // 0x400: pitch D2 04 = 1234 -> 12.34 deg, pid_out 78 00 = 120, speed 90 01 = 400 mm/s, state 1 = BALANCE.
  CHECK(text_of_frame(0x400, {0xD2, 0x04, 0x78, 0x00, 0x90, 0x01, 0x01}) ==
        "telemetry_a pitch=12.34\u00B0 pid_out=120 speed_mmps=400 state=BALANCE");
  // Negative and below one degree: 2E FB = -1234, FB FF = -5 -> -0.05 (the sign of a value under 1 kept).
  CHECK(text_of_frame(0x400, {0x2E, 0xFB, 0, 0, 0, 0, 0}).find("pitch=-12.34\u00B0 ") != std::string::npos);
  CHECK(text_of_frame(0x400, {0xFB, 0xFF, 0, 0, 0, 0, 0}).find("pitch=-0.05\u00B0 ") != std::string::npos);
  CHECK(text_of_frame(0x400, {0x64, 0x00, 0, 0, 0, 0, 0}).find("pitch=1.00\u00B0 ") != std::string::npos);
  // 0x401: battery C4 9B = 39876 mV -> 39.876 V; faults 0x05 = rc_loss + estop (shown as the byte).
  CHECK(text_of_frame(0x401, {0, 0, 0, 0, 0xC4, 0x9B, 0x05}) ==
        "telemetry_b vesc_l_rpm=0 vesc_r_rpm=0 battery=39.876V fault=5");
  // 0x303: tilt D0 07 = 2000 -> 20.00 deg, max speed B0 04 = 1200 mm/s.
  CHECK(text_of_frame(0x303, {0xD0, 0x07, 0xB0, 0x04}) == "config_cmd tilt_limit=20.00\u00B0 max_speed_mmps=1200");
}

TEST_CASE("JSON keeps the wire integers under their keys, the physical values beside them") {
  const auto j = json_of_frame(0x400, {0xD2, 0x04, 0x78, 0x00, 0x90, 0x01, 0x01});
  CHECK(j.dump() ==
        R"({"pid_out":120,"pitch":12.34,"pitch_raw":1234,"speed_mmps":400,"state":"BALANCE","type":"telemetry_a"})");
  // -0.05 deg, and a whole degree stays a decimal number (JSON readers see a float column, not ints then floats)
  CHECK(json_of_frame(0x400, {0xFB, 0xFF, 0, 0, 0, 0, 0}).dump().find(R"("pitch":-0.05,)") != std::string::npos);
  CHECK(json_of_frame(0x400, {0x64, 0x00, 0, 0, 0, 0, 0}).dump().find(R"("pitch":1.0,)") != std::string::npos);
  CHECK(json_of_frame(0x401, {0, 0, 0, 0, 0xC4, 0x9B, 0x05}).dump() ==
        R"({"battery":39.876,"battery_raw":39876,"fault":5,"type":"telemetry_b","vesc_l_rpm":0,"vesc_r_rpm":0})");
  CHECK(json_of_frame(0x303, {0xD0, 0x07, 0xB0, 0x04}).dump() ==
        R"({"max_speed_mmps":1200,"tilt_limit":20.0,"tilt_limit_raw":2000,"type":"config_cmd"})");
}

TEST_CASE("raw_key: the signal's name and _raw") {
  saul::signals::SignalDesc s;
  s.name = "pitch";
  CHECK(host::raw_key(s.in("deg")) == "pitch_raw");
}

TEST_CASE("text: already physical values are unchanged (VESC, speeds)") {
  // VESC STATUS_1 of controller 68 (0x944): ERPM 147, current 12 -> 1.2 A, duty 11 -> 0.011.
  CanFrame f;
  f.id = 0x944;
  f.extended = true;
  f.dlc = 8;
  const std::uint8_t d[8] = {0x00, 0x00, 0x00, 0x93, 0x00, 0x0C, 0x00, 0x0B};
  for (int i = 0; i < 8; ++i) f.data[static_cast<std::size_t>(i)] = d[i];
  const auto r = decode_bus_frame(f);
  REQUIRE(r);
  CHECK(host::describe(r.value()) == "vesc_status_1 controller_id=68 erpm=147 current=1.2 duty=0.011");
  CHECK(text_of_frame(0x300, {0x90, 0x01, 0x0C, 0xFE}) == "velocity_cmd speed_mmps=400 steer_mrad=-500");
}

TEST_CASE("text: inter-board STATE pitch in degrees") {
  interboard::State s;
  s.pitch_x100 = -1234;
  s.pid_out = 300;
  s.error_state = 1;
  CHECK(host::describe(interboard::Message{s}) == "state pitch=-12.34\u00B0 pid_out=300 error_state=1");
  CHECK(host::to_json(interboard::Message{s})["pitch_raw"] == -1234);
  CHECK(host::to_json(interboard::Message{s}).dump().find(R"("pitch":-12.34,)") != std::string::npos);
}

TEST_CASE("text: CRSF battery, GPS, attitude and RC channels in V, A, degrees, km/h, rad and microseconds") {
  crsf::BatterySensor b;
  b.voltage_x10 = 168;  // 16.8 V
  b.current_x10 = 5;    // 0.5 A
  b.capacity_mah = 1200;
  b.remaining_pct = 80;
  CHECK(host::describe(crsf::Message{b}) ==
        "battery_sensor voltage=16.8V current=0.5A capacity_mah=1200 remaining_pct=80");
  CHECK(host::to_json(crsf::Message{b}).dump() ==
        R"({"capacity_mah":1200,"current":0.5,"current_raw":5,"remaining_pct":80,"type":"battery_sensor",)"
        R"("voltage":16.8,"voltage_raw":168})");

  crsf::Gps g;
  g.latitude_e7 = 473977420;     // 47.3977420 deg N: all seven decimals kept
  g.longitude_e7 = -1223456789;  // 122.3456789 deg W
  g.groundspeed_x10 = 123;       // 12.3 km/h
  g.heading_x100 = 9000;         // 90.00 deg
  g.altitude_m = 500;
  g.satellites = 9;
  CHECK(host::describe(crsf::Message{g}) ==
        "gps latitude=47.3977420\u00B0 longitude=-122.3456789\u00B0 groundspeed=12.3km/h heading=90.00\u00B0 "
        "altitude_m=500 satellites=9");
  CHECK(host::to_json(crsf::Message{g})["latitude_raw"] == 473977420);
  const std::string gps = host::to_json(crsf::Message{g}).dump();
  CHECK(gps.find(R"("latitude":47.397742,)") != std::string::npos);  // shortest form: the trailing 0 goes
  CHECK(gps.find(R"("longitude":-122.3456789,)") != std::string::npos);
  CHECK(gps.find(R"("groundspeed":12.3,)") != std::string::npos);
  CHECK(gps.find(R"("heading":90.0,)") != std::string::npos);

  crsf::Attitude a;
  a.pitch_rad_x10000 = 15708;  // 1.5708 rad
  a.roll_rad_x10000 = -1;
  CHECK(host::describe(crsf::Message{a}) == "attitude pitch=1.5708rad roll=-0.0001rad yaw=0.0000rad");

  crsf::RcChannels rc;
  rc.ticks.fill(992);  // centre: 1500 us
  rc.ticks[0] = 172;   // 988 us
  rc.ticks[1] = 1811;  // 2012 us
  const std::string text = host::describe(crsf::Message{rc});
  CHECK(text.rfind("rc_channels ch1=988\u00B5s ch2=2012\u00B5s ch3=1500\u00B5s ", 0) == 0);
  CHECK(text.find("ch16=1500\u00B5s") != std::string::npos);
  for (std::uint16_t t : {std::uint16_t{172}, std::uint16_t{500}, std::uint16_t{992}, std::uint16_t{1500},
                          std::uint16_t{1811}, std::uint16_t{2047}}) {
    rc.ticks[0] = t;
    CHECK(host::describe(crsf::Message{rc}).find(fmt::format("ch1={}\u00B5s ", crsf::ticks_to_us(t))) !=
          std::string::npos);
  }
  CHECK(host::to_json(crsf::Message{rc})["ch1_raw"] == 2047);  // JSON: microseconds, and the ticks beside them
  CHECK(host::to_json(crsf::Message{rc}).dump().find(R"("ch1":2159,)") != std::string::npos);
}

TEST_CASE("write_value_text writes a physical decimal exactly as fmt's {:g} would (its short cut for x/10^k)") {
  // The short cut skips formatting a double; this holds it to fmt's own "{:g}" of the same value, for every scale
  // the descriptions use and some they do not, over signed values near the edges of %g's fixed notation.
  std::mt19937_64 rng(15);
  int checked = 0;
  for (std::int32_t den : {1, 10, 100, 1000, 10000, 100000, 4}) {
    saul::signals::SignalDesc s;
    s.kind = saul::signals::Kind::signed_int;
    s.length = 48;
    s = s.scaled(1, den).shown(saul::signals::Text::physical);
    std::vector<std::int64_t> raws = {0, 1, -1, 9, 10, 99, 100, 101, 999999, 1000000, -1000000, 123456789, 1999999999};
    for (int i = 0; i < 3000; ++i) {
      const int digits = static_cast<int>(rng() % 13);
      std::int64_t v = static_cast<std::int64_t>(rng() % 10);
      for (int d = 0; d < digits; ++d) v = v * 10 + static_cast<std::int64_t>(rng() % 10);
      raws.push_back(rng() % 2 ? v : -v);
    }
    for (std::int64_t raw : raws) {
      char text[64];
      const std::string got(text, host::write_value_text(text, s, raw, {}));
      const std::string want = fmt::format("{:g}", saul::signals::raw_to_physical(s, raw));
      if (got != want) FAIL_CHECK(fmt::format("1/{} of {}: {} but {{:g}} gives {}", den, raw, got, want));
      ++checked;
    }
  }
  CHECK(checked > 20000);
}
