// signal_value(): a signal by its one name (docs/cli.md "Signal names and units"), as plot --field and the bench
// suites' conditions take it. The frames are written out by hand from docs/protocol.md's layouts, not encoded.
#include <catch2/catch.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/host/report/signal_rows.hpp"

using namespace saul::host;

namespace {

saul::CanFrame frame(std::uint32_t id, std::vector<std::uint8_t> bytes) {
  saul::CanFrame f;
  f.id = id;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  return f;
}

SignalValues values_of(const saul::CanFrame& f) {
  const auto m = saul::decode_bus_frame(f);
  REQUIRE(m);
  return signal_values(m.value());
}

}  // namespace

TEST_CASE("signal lookup: 0x400 telemetry_a by name, physical and _raw, a named value by name and number") {
  // pitch -1234 (2E FB: -12.34 deg), pid_out 300 (2C 01), speed_mmps 400 (90 01), state 1 = BALANCE.
  const auto v = values_of(frame(0x400, {0x2E, 0xFB, 0x2C, 0x01, 0x90, 0x01, 0x01}));
  CHECK(signal_value(v, "pitch")->number == -12.34);
  CHECK(signal_value(v, "pitch_raw")->number == -1234);
  CHECK(signal_value(v, "pid_out")->number == 300);
  CHECK(signal_value(v, "speed_mmps")->number == 400);
  CHECK(signal_value(v, "state")->number == 1);
  CHECK(signal_value(v, "state")->text == "BALANCE");
  // The structs' field names are not names: one scheme, not two.
  CHECK_FALSE(signal_value(v, "pitch_x100"));
  CHECK_FALSE(signal_value(v, "pid_out_raw"));  // only a scaled signal has a _raw twin, as in decode --json
}

TEST_CASE("signal lookup: 0x401 telemetry_b battery in volts, fault bits as their number") {
  // vesc_l_rpm -1180 (64 FB), vesc_r_rpm 1200 (B0 04), battery 39876 mV (C4 9B), fault 0x11.
  const auto v = values_of(frame(0x401, {0x64, 0xFB, 0xB0, 0x04, 0xC4, 0x9B, 0x11}));
  CHECK(signal_value(v, "battery")->number == 39.876);
  CHECK(signal_value(v, "battery_raw")->number == 39876);
  CHECK(signal_value(v, "vesc_l_rpm")->number == -1180);
  CHECK(signal_value(v, "fault")->number == 17);
  CHECK(signal_value(v, "fault")->text == "17");
  CHECK_FALSE(signal_value(v, "battery_mv"));
  CHECK_FALSE(signal_value(v, "faults"));
}

TEST_CASE("signal lookup: a multiplexed signal only in the frames that carry it") {
  // 0x301 pid_gain: gain 2 = kd, sequence 9, two reserved bytes, 0.25f = 3E800000 little-endian.
  const auto v = values_of(frame(0x301, {0x02, 0x09, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3E}));
  CHECK(signal_value(v, "kd")->number == 0.25);
  CHECK(signal_value(v, "gain")->text == "kd");
  CHECK_FALSE(signal_value(v, "kp"));
}

TEST_CASE("signal lookup: the names, and the one-line error for a name the message lacks") {
  const auto* a = saul::signals::find_named(saul::signals::Protocol::saul_can, "telemetry_a");
  REQUIRE(a != nullptr);
  CHECK(signal_names(*a) == std::vector<std::string>{"pitch", "pitch_raw", "pid_out", "speed_mmps", "state"});
  CHECK(has_signal(*a, "pitch_raw"));
  CHECK_FALSE(has_signal(*a, "pitch_x100"));
  CHECK(unknown_signal_error("telemetry_a", a, "pitch_x100") ==
        "telemetry_a has no signal 'pitch_x100'; its signals: pitch, pitch_raw, pid_out, speed_mmps, state");
  CHECK(unknown_signal_error("crsf_0x32", nullptr, "x") ==  // an undecoded CRSF frame: the one thing without
        "crsf_0x32 has no signal description, so no signal 'x' (docs/cli.md, \"Signal names and units\")");
}
