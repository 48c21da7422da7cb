// saulctl stats --signals: per signal count, mean, min and max in physical units. Frames and figures by hand from
// docs/protocol.md (0x400: pitch int16 LE in 1/100 deg, pid_out, speed_mmps, state; 0x401: battery in mV).
#include <catch2/catch.hpp>

#include <initializer_list>

#include "saulproto/host/report/serial_decode.hpp"
#include "saulproto/host/report/signal_stats.hpp"
#include "../capture/test_captures.hpp"

using namespace saul;

namespace {
CanFrame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) { return capture_test::make(id, false, bytes, 0); }
}  // namespace

TEST_CASE("signal stats: count, mean, min, max per signal in its unit; frames that do not decode add nothing") {
  host::SignalStats stats;
  stats.add(frame(0x400, {0xD2, 0x04, 0x78, 0x00, 0x90, 0x01, 0x01}));  // 12.34 deg, 120, 400 mm/s, BALANCE
  stats.add(frame(0x400, {0x0C, 0xFE, 0x00, 0x00, 0x00, 0x00, 0x02}));  // -5.00 deg, 0, 0, MANUAL
  stats.add(frame(0x400, {0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));        // wrong DLC: rejected, not counted
  stats.add(frame(0x123, {0x01}));                                      // unknown id
  stats.add(frame(0x401, {0, 0, 0, 0, 0xC4, 0x9B, 0x05}));              // 39.876 V
  const auto& s = stats.signals();
  REQUIRE(s.count({"telemetry_a", "pitch"}) == 1);
  const auto& pitch = s.at({"telemetry_a", "pitch"});
  CHECK(pitch.count == 2);
  CHECK(pitch.mean() == Approx((12.34 - 5.0) / 2));
  CHECK(pitch.min == Approx(-5.0));
  CHECK(pitch.max == Approx(12.34));
  CHECK(pitch.unit == "deg");
  const auto& state = s.at({"telemetry_a", "state"});  // a named value as its integer
  CHECK(state.count == 2);
  CHECK(state.mean() == Approx(1.5));
  CHECK(s.at({"telemetry_b", "battery"}).max == Approx(39.876));
  CHECK(s.at({"telemetry_b", "battery"}).unit == "V");
  CHECK(s.size() == 4 + 4);  // telemetry_a: pitch, pid_out, speed_mmps, state; telemetry_b: 2 rpm, battery, faults
  const auto j = stats.json();
  REQUIRE(j.is_array());
  CHECK(j.size() == 8);
  CHECK(j[0]["message"] == "telemetry_a");  // sorted by message, then signal
  CHECK(j[0]["signal"] == "pid_out");
  CHECK(stats.text().find("telemetry_b            battery") != std::string::npos);
  CHECK(host::SignalStats{}.text().empty());
}

TEST_CASE("signal stats of serial messages: inter-board and CRSF through signal_values(SerialMessage)") {
  host::SignalStats stats;
  interboard::State st;
  st.pitch_x100 = -1234;
  stats.add(host::signal_values(host::SerialMessage{interboard::Message{st}}));
  crsf::BatterySensor b;
  b.voltage_x10 = 168;  // 16.8 V
  stats.add(host::signal_values(host::SerialMessage{host::CrsfMessage{crsf::kSyncByte, crsf::Message{b}}}));
  stats.add(host::signal_values(host::SerialMessage{pride::Message{}}));  // no description: nothing
  CHECK(stats.signals().at({"state", "pitch"}).mean() == Approx(-12.34));
  CHECK(stats.signals().at({"battery_sensor", "voltage"}).mean() == Approx(16.8));
  CHECK(stats.signals().at({"battery_sensor", "voltage"}).unit == "V");
}
