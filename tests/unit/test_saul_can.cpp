// SAUL CAN frames: golden payloads worked out by hand (little-endian, IEEE-754 floats from their bit patterns).
#include <catch2/catch.hpp>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <string>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/saul_can.hpp"

using namespace saul;
using namespace saul::saulcan;

namespace {

CanFrame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, bool extended = false) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  return f;
}

}  // namespace

TEST_CASE("0x300 velocity: 1000 mm/s, -500 mrad") {
  const CanFrame golden = frame(0x300, {0xE8, 0x03, 0x0C, 0xFE});
  CHECK(encode(VelocityCmd{1000, -500}) == golden);
  auto d = decode_velocity_cmd(golden);
  REQUIRE(d.ok());
  CHECK(d->speed_mmps == 1000);
  CHECK(d->steer_mrad == -500);
}

TEST_CASE("0x301 gains: Kp 1.5, Ki 0.25, Kd 0.05 in set 7") {
  // 1.5f = 0x3FC00000, 0.25f = 0x3E800000, 0.05f = 0x3D4CCCCD (little-endian in bytes 4..7)
  const CanFrame kp = frame(0x301, {0x00, 0x07, 0x00, 0x00, 0x00, 0x00, 0xC0, 0x3F});
  const CanFrame ki = frame(0x301, {0x01, 0x07, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3E});
  const CanFrame kd = frame(0x301, {0x02, 0x07, 0x00, 0x00, 0xCD, 0xCC, 0x4C, 0x3D});
  CHECK(encode(PidGain{Gain::kp, 7, 1.5F}) == kp);
  CHECK(encode(PidGain{Gain::ki, 7, 0.25F}) == ki);
  CHECK(encode(PidGain{Gain::kd, 7, 0.05F}) == kd);
  auto d = decode_pid_gain(kd);
  REQUIRE(d.ok());
  CHECK(d->index == Gain::kd);
  CHECK(d->sequence == 7);
  CHECK(d->value == 0.05F);
}

TEST_CASE("0x301 ignores the reserved bytes and rejects an index above 2") {
  CHECK(decode_pid_gain(frame(0x301, {0x01, 0x07, 0x12, 0x34, 0x00, 0x00, 0x80, 0x3E})).ok());
  CHECK(decode_pid_gain(frame(0x301, {0x03, 0x07, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3E})).reason() ==
        Reason::out_of_range);
}

TEST_CASE("0x301 passes a NaN through to the stager") {
  // 0x7FC00000 is a quiet NaN
  auto d = decode_pid_gain(frame(0x301, {0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0xC0, 0x7F}));
  REQUIRE(d.ok());
  CHECK(std::isnan(d->value));
}

TEST_CASE("0x302 mode: every value 0..3, and 4 rejected") {
  CHECK(encode(ModeCmd{Mode::balance}) == frame(0x302, {0x01}));
  CHECK(encode(ModeCmd{Mode::estop}) == frame(0x302, {0x03}));
  for (std::uint8_t v = 0; v <= 3; ++v) {
    auto d = decode_mode_cmd(frame(0x302, {v}));
    REQUIRE(d.ok());
    CHECK(static_cast<std::uint8_t>(d->mode) == v);
  }
  CHECK(decode_mode_cmd(frame(0x302, {0x04})).reason() == Reason::out_of_range);
}

TEST_CASE("0x303 config: 20.00 deg, 1500 mm/s") {
  const CanFrame golden = frame(0x303, {0xD0, 0x07, 0xDC, 0x05});
  CHECK(encode(ConfigCmd{2000, 1500}) == golden);
  auto d = decode_config_cmd(golden);
  REQUIRE(d.ok());
  CHECK(d->tilt_limit_x100 == 2000);
  CHECK(d->max_speed_mmps == 1500);
}

TEST_CASE("0x400 telemetry A: pitch -2.50 deg, pid 420, 300 mm/s, BALANCE") {
  const CanFrame golden = frame(0x400, {0x06, 0xFF, 0xA4, 0x01, 0x2C, 0x01, 0x01});
  CHECK(encode(TelemetryA{-250, 420, 300, RobotState::balance}) == golden);
  auto d = decode_telemetry_a(golden);
  REQUIRE(d.ok());
  CHECK(*d == TelemetryA{-250, 420, 300, RobotState::balance});
  CHECK(decode_telemetry_a(frame(0x400, {0, 0, 0, 0, 0, 0, 0x06})).reason() == Reason::out_of_range);
  CHECK(decode_telemetry_a(frame(0x400, {0, 0, 0, 0, 0, 0, 0x05})).ok());
}

TEST_CASE("0x401 telemetry B: 1200 / -1180 rpm, 39.6 V, rc_loss + orin_timeout") {
  const CanFrame golden = frame(0x401, {0xB0, 0x04, 0x64, 0xFB, 0xB0, 0x9A, 0x11});
  CHECK(encode(TelemetryB{1200, -1180, 39600, fault::kRcLoss | fault::kOrinTimeout}) == golden);
  auto d = decode_telemetry_b(golden);
  REQUIRE(d.ok());
  CHECK(d->battery_mv == 39600);
  CHECK(d->faults == 0x11);
}

TEST_CASE("0x402 ack: 0x301 set 7 rejected incomplete") {
  const CanFrame golden = frame(0x402, {0x01, 0x07, 0x03});
  CHECK(encode(CommandAck{0x01, 7, AckResult::incomplete}) == golden);
  auto d = decode_command_ack(golden);
  REQUIRE(d.ok());
  CHECK(d->result == AckResult::incomplete);
  CHECK(decode_command_ack(frame(0x402, {0x04, 0, 0})).reason() == Reason::out_of_range);
  CHECK(decode_command_ack(frame(0x402, {0x02, 0, 4})).reason() == Reason::out_of_range);
}

TEST_CASE("fault bit names follow the wire decisions") {
  CHECK(std::string_view(fault::bit_name(0)) == "rc_loss");
  CHECK(std::string_view(fault::bit_name(4)) == "orin_timeout");
  CHECK(std::string_view(fault::bit_name(7)) == "low_battery");
}

TEST_CASE("every SAUL decoder rejects a wrong DLC, an extended id and a remote frame") {
  const std::initializer_list<std::pair<std::uint32_t, std::uint8_t>> ids = {
      {0x300, 4}, {0x301, 8}, {0x302, 1}, {0x303, 4}, {0x400, 7}, {0x401, 7}, {0x402, 3}};
  for (auto [id, dlc] : ids) {
    INFO("id " << id);
    CanFrame ok;
    ok.id = id;
    ok.dlc = dlc;
    if (id == 0x402) ok.data[0] = 1;
    CHECK(decode(ok).ok());

    CanFrame shorter = ok;
    shorter.dlc = static_cast<std::uint8_t>(dlc - 1);
    CHECK(decode(shorter).reason() == Reason::wrong_dlc);
    if (dlc < 8) {
      CanFrame longer = ok;
      longer.dlc = static_cast<std::uint8_t>(dlc + 1);
      CHECK(decode(longer).reason() == Reason::wrong_dlc);
    }
    CanFrame ext = ok;
    ext.extended = true;
    CHECK(decode(ext).reason() == Reason::extended_id);
    CanFrame rtr = ok;
    rtr.remote = true;
    CHECK(decode(rtr).reason() == Reason::remote_frame);
    CanFrame err = ok;
    err.error = true;
    CHECK(decode(err).reason() == Reason::error_frame);
  }
  CHECK(decode(frame(0x304, {})).reason() == Reason::unknown_id);
  CHECK(decode(frame(0x2FF, {})).reason() == Reason::unknown_id);
  CHECK(decode(frame(0x403, {})).reason() == Reason::unknown_id);
}

TEST_CASE("every SAUL message round-trips through the bus dispatch") {
  const std::initializer_list<BusMessage> all = {
      saulcan::VelocityCmd{-32768, 32767},
      saulcan::PidGain{Gain::ki, 255, 123.5F},
      saulcan::ModeCmd{Mode::manual},
      saulcan::ConfigCmd{500, 65535},
      saulcan::TelemetryA{32767, -1000, -32768, RobotState::fault},
      saulcan::TelemetryB{-32768, 32767, 65535, 0xFF},
      saulcan::CommandAck{0x03, 0, AckResult::not_allowed},
  };
  for (const auto& m : all) {
    INFO(name_of(m));
    const CanFrame f = encode_bus_message(m);
    CHECK_FALSE(f.extended);
    auto back = decode_bus_frame(f);
    REQUIRE(back.ok());
    CHECK(back.value() == m);
  }
}

TEST_CASE("bus dispatch: error frames, invalid frames and unknown ids carry a reason") {
  CanFrame err;
  err.error = true;
  err.id = 0x40;
  CHECK(decode_bus_frame(err).reason() == Reason::error_frame);
  CanFrame too_long = frame(0x300, {1, 2, 3, 4});
  too_long.dlc = 9;
  CHECK(decode_bus_frame(too_long).reason() == Reason::invalid_frame);
  CHECK(decode_bus_frame(frame(0x123, {1})).reason() == Reason::unknown_id);
}

TEST_CASE("CanFrame::data_frame checks id range and length") {
  const std::uint8_t d[9] = {};
  CHECK(CanFrame::data_frame(0x7FF, false, std::span(d, 8)).ok());
  CHECK(CanFrame::data_frame(0x800, false, std::span(d, 1)).reason() == Reason::invalid_frame);
  CHECK(CanFrame::data_frame(0x1FFFFFFF, true, std::span(d, 1)).ok());
  CHECK(CanFrame::data_frame(0x20000000, true, std::span(d, 1)).reason() == Reason::invalid_frame);
  CHECK(CanFrame::data_frame(0x1, false, std::span(d, 9)).reason() == Reason::invalid_frame);
}

TEST_CASE("value names, written out by hand from docs/protocol.md (their one home is signals_saul.hpp)") {
  using namespace saul::saulcan;
  CHECK(std::string(to_string(Mode::off)) + to_string(Mode::balance) + to_string(Mode::manual) +
            to_string(Mode::estop) == "offbalancemanualestop");
  CHECK(std::string(to_string(RobotState::off)) + " " + to_string(RobotState::balance) + " " +
            to_string(RobotState::manual) + " " + to_string(RobotState::estop) + " " +
            to_string(RobotState::tilt_cutoff) + " " + to_string(RobotState::fault) ==
        "OFF BALANCE MANUAL ESTOP TILT_CUTOFF FAULT");
  CHECK(std::string(to_string(AckResult::applied)) + " " + to_string(AckResult::out_of_range) + " " +
            to_string(AckResult::not_allowed) + " " + to_string(AckResult::incomplete) ==
        "applied rejected_out_of_range rejected_not_allowed rejected_incomplete");
  CHECK(std::string(to_string(Gain::kp)) + to_string(Gain::ki) + to_string(Gain::kd) == "kpkikd");
  std::string bits;
  for (unsigned b = 0; b < 9; ++b) bits += std::string(fault::bit_name(b)) + " ";
  CHECK(bits == "rc_loss motor_fault estop tilt_cutoff orin_timeout watchdog_reset io_link_loss low_battery ? ");
  CHECK(std::string(to_string(static_cast<Mode>(9))) == "?");  // a value no table names
}
