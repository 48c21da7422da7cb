// VESC CAN frames: the golden frames of the fact sheet's example table (protocols.md §3.8, worked out by hand:
// big-endian two's complement, id = command << 8 | controller), every rejection, round trips, the bus dispatch.
#include <catch2/catch.hpp>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <string_view>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/vesc.hpp"

using namespace saul;
using namespace saul::vesc;

namespace {

CanFrame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, bool extended = true) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  return f;
}

}  // namespace

static_assert(make_eid(Command::set_rpm, kLeftId) == 0x344);
static_assert(make_eid(Command::status_1, kRightId) == 0x938);
static_assert(make_eid(Command::status_6, kRightId) == 0x3A38);
static_assert(controller_of(0x1B38) == 56 && command_of(0x1B38) == 27);

TEST_CASE("VESC ids: 68 left, 56 right, command in bits 15..8") {
  CHECK(kLeftId == 0x44);
  CHECK(kRightId == 0x38);
  CHECK(make_eid(Command::set_duty, kLeftId) == 0x00000044);
  CHECK(make_eid(Command::pong, kLeftId) == 0x00001244);
  CHECK(std::string_view(to_string(Command::status_5)) == "status_5");
  CHECK(std::string_view(to_string(static_cast<Command>(200))) == "?");
}

TEST_CASE("SET_RPM 1500 to 68 is 0x00000344 00 00 05 DC") {
  const CanFrame golden = frame(0x344, {0x00, 0x00, 0x05, 0xDC});
  CHECK(encode(SetRpm{kLeftId, 1500}) == golden);
  auto d = decode_set_rpm(golden);
  REQUIRE(d.ok());
  CHECK(d->controller_id == 68);
  CHECK(d->erpm == 1500);
}

TEST_CASE("SET_RPM -1500 to 56 is 0x00000338 FF FF FA 24") {
  const CanFrame golden = frame(0x338, {0xFF, 0xFF, 0xFA, 0x24});
  CHECK(encode(SetRpm{kRightId, -1500}) == golden);
  auto d = decode_set_rpm(golden);
  REQUIRE(d.ok());
  CHECK(d.value() == SetRpm{56, -1500});
}

TEST_CASE("SET_DUTY 0.10 to 68 is 0x00000044 00 00 27 10") {
  const CanFrame golden = frame(0x044, {0x00, 0x00, 0x27, 0x10});  // 0x2710 = 10000
  CHECK(encode(SetDuty{68, 10000}) == golden);
  auto from = SetDuty::from(68, 0.10);
  REQUIRE(from.ok());
  CHECK(encode(from.value()) == golden);
  CHECK(encode(SetDuty::from(68, 0.10F).value()) == golden);  // 0.1F is a little above 0.1: still 10000
  auto d = decode_set_duty(golden);
  REQUIRE(d.ok());
  CHECK(d->duty_x100000 == 10000);
  CHECK(d->duty() == 0.1F);
}

TEST_CASE("SET_CURRENT 51 A to 23 (the bldc documentation's example) and 2.5 A to 68") {
  const CanFrame doc = frame(0x117, {0x00, 0x00, 0xC7, 0x38});  // 0xC738 = 51000 mA
  CHECK(encode(SetCurrent{23, 51000}) == doc);
  CHECK(encode(SetCurrent::from(23, 51.0).value()) == doc);
  const CanFrame golden = frame(0x144, {0x00, 0x00, 0x09, 0xC4});  // 0x09C4 = 2500 mA
  CHECK(encode(SetCurrent::from(68, 2.5).value()) == golden);
  auto d = decode_set_current(golden);
  REQUIRE(d.ok());
  CHECK(d.value() == SetCurrent{68, 2500});
  CHECK(d->current() == 2.5F);
}

TEST_CASE("SET_CURRENT_BRAKE 5 A to 56 is 0x00000238 00 00 13 88") {
  const CanFrame golden = frame(0x238, {0x00, 0x00, 0x13, 0x88});  // 0x1388 = 5000 mA
  CHECK(encode(SetCurrentBrake{56, 5000}) == golden);
  CHECK(encode(SetCurrentBrake::from(56, 5.0).value()) == golden);
  auto d = decode_set_current_brake(golden);
  REQUIRE(d.ok());
  CHECK(d->controller_id == 56);
  CHECK(d->current() == 5.0F);
}

TEST_CASE("SET_CURRENT_REL 0.5 to 68 is 0x00000A44 00 00 C3 50") {
  const CanFrame golden = frame(0xA44, {0x00, 0x00, 0xC3, 0x50});  // 0xC350 = 50000
  CHECK(encode(SetCurrentRel{68, 50000}) == golden);
  CHECK(encode(SetCurrentRel::from(68, 0.5).value()) == golden);
  auto d = decode_set_current_rel(golden);
  REQUIRE(d.ok());
  CHECK(d->current_rel() == 0.5F);
}

TEST_CASE("SET_POS 90 deg to 68 is 0x00000444 05 5D 4A 80") {
  const CanFrame golden = frame(0x444, {0x05, 0x5D, 0x4A, 0x80});  // 0x055D4A80 = 90 000 000
  CHECK(encode(SetPos{68, 90'000'000}) == golden);
  CHECK(encode(SetPos::from(68, 90.0).value()) == golden);
  auto d = decode_set_pos(golden);
  REQUIRE(d.ok());
  CHECK(d->pos_x1000000 == 90'000'000);
  CHECK(d->pos() == 90.0F);
}

TEST_CASE("STATUS from 56: ERPM -1200, 3.5 A, duty 0.25") {
  // FFFFFB50 = -1200, 0x0023 = 35 (3.5 A), 0x00FA = 250 (0.250)
  const CanFrame golden = frame(0x938, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA});
  CHECK(encode(Status1{56, -1200, 35, 250}) == golden);
  auto d = decode_status_1(golden);
  REQUIRE(d.ok());
  CHECK(d->controller_id == 56);
  CHECK(d->erpm == -1200);
  CHECK(d->current() == 3.5F);
  CHECK(d->duty() == 0.25F);
}

TEST_CASE("STATUS_2 from 56: 1.2345 Ah used, 0.0100 Ah charged") {
  const CanFrame golden = frame(0xE38, {0x00, 0x00, 0x30, 0x39, 0x00, 0x00, 0x00, 0x64});  // 12345, 100
  CHECK(encode(Status2{56, 12345, 100}) == golden);
  auto d = decode_status_2(golden);
  REQUIRE(d.ok());
  CHECK(d.value() == Status2{56, 12345, 100});
  CHECK(d->ah_used() == Approx(1.2345F));
  CHECK(d->ah_charged() == Approx(0.01F));
}

TEST_CASE("STATUS_3 from 56: 45.6789 Wh used, 0 charged") {
  const CanFrame golden = frame(0xF38, {0x00, 0x06, 0xF8, 0x55, 0x00, 0x00, 0x00, 0x00});  // 0x06F855 = 456789
  CHECK(encode(Status3{56, 456789, 0}) == golden);
  auto d = decode_status_3(golden);
  REQUIRE(d.ok());
  CHECK(d->wh_used_x10000 == 456789);
  CHECK(d->wh_used() == Approx(45.6789F));
  CHECK(d->wh_charged() == 0.0F);
}

TEST_CASE("STATUS_4 from 56: FET 35.2 C, motor 40.0 C, 1.2 A in, PID position 90 deg") {
  // 0x0160 = 352, 0x0190 = 400, 0x000C = 12, 0x1194 = 4500 = 90 x 50
  const CanFrame golden = frame(0x1038, {0x01, 0x60, 0x01, 0x90, 0x00, 0x0C, 0x11, 0x94});
  CHECK(encode(Status4{56, 352, 400, 12, 4500}) == golden);
  auto d = decode_status_4(golden);
  REQUIRE(d.ok());
  CHECK(d->temp_fet() == Approx(35.2F));
  CHECK(d->temp_motor() == 40.0F);
  CHECK(d->current_in() == Approx(1.2F));
  CHECK(d->pid_pos() == 90.0F);
}

TEST_CASE("STATUS_5 from 56: tachometer 123456, 36.5 V, reserved bytes ignored") {
  const CanFrame golden = frame(0x1B38, {0x00, 0x01, 0xE2, 0x40, 0x01, 0x6D, 0x00, 0x00});  // 0x01E240, 0x016D = 365
  CHECK(encode(Status5{56, 123456, 365}) == golden);
  auto d = decode_status_5(golden);
  REQUIRE(d.ok());
  CHECK(d->tachometer == 123456);
  CHECK(d->voltage_in() == 36.5F);
  CanFrame later = golden;
  later.data[6] = 0xAB;
  later.data[7] = 0xCD;
  auto l = decode_status_5(later);
  REQUIRE(l.ok());
  CHECK(l.value() == d.value());
}

TEST_CASE("STATUS_6 from 56: ADC 1.234 V, 0 V, 3.3 V, PPM -0.5") {
  // 0x04D2 = 1234, 0x0CE4 = 3300, 0xFE0C = -500
  const CanFrame golden = frame(0x3A38, {0x04, 0xD2, 0x00, 0x00, 0x0C, 0xE4, 0xFE, 0x0C});
  CHECK(encode(Status6{56, 1234, 0, 3300, -500}) == golden);
  auto d = decode_status_6(golden);
  REQUIRE(d.ok());
  CHECK(d->adc1() == Approx(1.234F));
  CHECK(d->adc2() == 0.0F);
  CHECK(d->adc3() == Approx(3.3F));
  CHECK(d->ppm() == -0.5F);
}

TEST_CASE("PING 68 -> 56 and PONG 56 -> 68") {
  const CanFrame ping = frame(0x1138, {0x44});
  const CanFrame pong = frame(0x1244, {0x38, 0x00});
  CHECK(encode(Ping{56, 68}) == ping);
  CHECK(encode(Pong{68, 56, hw_type::kVesc}) == pong);
  auto p = decode_ping(ping);
  REQUIRE(p.ok());
  CHECK(p->controller_id == 56);
  CHECK(p->sender_id == 68);
  auto q = decode_pong(pong);
  REQUIRE(q.ok());
  CHECK(q.value() == Pong{68, 56, 0});
}

TEST_CASE("scaling truncates toward zero, in double, like the VESC firmware's senders") {
  // 0.29 x 100000 = 28999.999999999996 in double: truncated, not rounded.
  CHECK(SetDuty::from(68, 0.29)->duty_x100000 == 28999);
  CHECK(SetDuty::from(68, -0.29)->duty_x100000 == -28999);  // toward zero, not down
  CHECK(SetDuty::from(68, -0.000009)->duty_x100000 == 0);
  CHECK(SetCurrent::from(68, 1.2349)->current_x1000 == 1234);
  CHECK(SetCurrent::from(68, -2.5009)->current_x1000 == -2500);
  // A float argument is widened first, exactly as the firmware's float parameters are:
  // 1.234F = 1.2339999675..., so 1233; the double 1.234 gives 1234.
  CHECK(to_fixed_i16(1.234F, 1000.0).value() == 1233);
  CHECK(to_fixed_i16(1.234, 1000.0).value() == 1234);
  CHECK(to_fixed_i32(45.6789F, 10000.0).value() == 456789);
}

TEST_CASE("scaling rejects NaN, infinity and values outside the integer") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  CHECK(SetDuty::from(68, nan).reason() == Reason::not_finite);
  CHECK(SetCurrent::from(68, inf).reason() == Reason::not_finite);
  CHECK(SetPos::from(68, -inf).reason() == Reason::not_finite);
  CHECK(SetPos::from(68, 2148.0).reason() == Reason::out_of_range);  // 2.148e9 > INT32_MAX
  CHECK(SetPos::from(68, 2147.0).ok());
  CHECK(to_fixed_i32(2147483647.9, 1.0).value() == 2147483647);
  CHECK(to_fixed_i32(-2147483648.9, 1.0).value() == std::numeric_limits<std::int32_t>::min());
  CHECK(to_fixed_i32(2147483648.0, 1.0).reason() == Reason::out_of_range);
  CHECK(to_fixed_i32(-2147483649.0, 1.0).reason() == Reason::out_of_range);
  CHECK(to_fixed_i16(32767.99, 1.0).value() == 32767);
  CHECK(to_fixed_i16(-32768.99, 1.0).value() == -32768);
  CHECK(to_fixed_i16(32768.0, 1.0).reason() == Reason::out_of_range);
  CHECK(to_fixed_i16(nan, 10.0).reason() == Reason::not_finite);
}

TEST_CASE("every VESC decoder rejects error, standard, remote, wrong-DLC and other-command frames") {
  const std::initializer_list<Message> all = {
      SetDuty{68, 1}, SetCurrent{68, 1}, SetCurrentBrake{68, 1}, SetRpm{68, 1}, SetPos{68, 1},
      SetCurrentRel{68, 1}, Status1{56, 1, 2, 3}, Status2{56, 1, 2}, Status3{56, 1, 2}, Status4{56, 1, 2, 3, 4},
      Status5{56, 1, 2}, Status6{56, 1, 2, 3, 4}, Ping{56, 68}, Pong{68, 56, 0},
  };
  for (const auto& m : all) {
    const CanFrame ok = encode(m);
    INFO(std::visit([](const auto& x) { return x.kName; }, m));
    REQUIRE(decode(ok).ok());
    CHECK(decode(ok).value() == m);

    CanFrame standard = ok;
    standard.extended = false;
    standard.id &= 0x7FF;
    CHECK(decode(standard).reason() == Reason::standard_id);
    CanFrame remote = ok;
    remote.remote = true;
    CHECK(decode(remote).reason() == Reason::remote_frame);
    CanFrame error = ok;
    error.error = true;
    CHECK(decode(error).reason() == Reason::error_frame);
    CanFrame shorter = ok;
    shorter.dlc = static_cast<std::uint8_t>(ok.dlc - 1);
    CHECK(decode(shorter).reason() == Reason::wrong_dlc);
    if (ok.dlc < 8) {
      CanFrame longer = ok;
      longer.dlc = static_cast<std::uint8_t>(ok.dlc + 1);
      CHECK(decode(longer).reason() == Reason::wrong_dlc);
    }
    CanFrame high_bits = ok;
    high_bits.id |= 0x10000;  // bits 28..16 are 0 in every VESC id
    CHECK(decode(high_bits).reason() == Reason::unknown_id);
  }
  // A typed decoder given another command's frame.
  CHECK(decode_set_rpm(encode(SetDuty{68, 1})).reason() == Reason::unknown_id);
  CHECK(decode_status_1(encode(Status5{56, 1, 2})).reason() == Reason::unknown_id);
  CHECK(decode_pong(encode(Ping{56, 68})).reason() == Reason::unknown_id);
  CHECK(decode_set_pos(frame(0x444, {0, 0, 0, 0}, false)).reason() == Reason::standard_id);
  CHECK(decode_status_2(frame(0xE38, {0, 0, 0, 0, 0, 0, 0}, true)).reason() == Reason::wrong_dlc);
}

TEST_CASE("VESC commands this codec does not know are unknown_id") {
  // FILL_RX_BUFFER 5, PROCESS_SHORT_BUFFER 8, SET_CURRENT_BRAKE_REL 11, DETECT_APPLY_ALL_FOC 19, BMS 38, 255
  for (std::uint32_t command : {5U, 8U, 11U, 19U, 38U, 255U}) {
    INFO(command);
    CHECK(decode(frame((command << 8) | 68, {0, 0, 0, 0})).reason() == Reason::unknown_id);
  }
}

TEST_CASE("the 6-byte SET_CURRENT and SET_CURRENT_REL forms (with an off-delay) are rejected") {
  CHECK(decode(frame(0x144, {0x00, 0x00, 0x09, 0xC4, 0x01, 0xF4})).reason() == Reason::wrong_dlc);
  CHECK(decode(frame(0xA44, {0x00, 0x00, 0xC3, 0x50, 0x01, 0xF4})).reason() == Reason::wrong_dlc);
}

TEST_CASE("broadcast id 255 decodes like any controller id") {
  auto d = decode(frame(0x3FF, {0x00, 0x00, 0x00, 0x00}));
  REQUIRE(d.ok());
  CHECK(std::get<SetRpm>(d.value()) == SetRpm{kBroadcastId, 0});
}

TEST_CASE("every VESC message round-trips with extreme values") {
  constexpr auto i32min = std::numeric_limits<std::int32_t>::min();
  constexpr auto i32max = std::numeric_limits<std::int32_t>::max();
  constexpr auto i16min = std::numeric_limits<std::int16_t>::min();
  constexpr auto i16max = std::numeric_limits<std::int16_t>::max();
  const std::initializer_list<Message> all = {
      SetDuty{0, i32min}, SetCurrent{255, i32max}, SetCurrentBrake{1, -1}, SetRpm{68, i32min},
      SetPos{56, i32max}, SetCurrentRel{254, -100000}, Status1{56, i32max, i16min, i16max},
      Status2{68, i32min, i32max}, Status3{68, -1, 0}, Status4{56, i16min, i16max, -1, 0},
      Status5{56, i32min, i16max}, Status6{68, i16max, i16min, 1, -1}, Ping{255, 0}, Pong{0, 255, 0xFF},
  };
  for (const auto& m : all) {
    const CanFrame f = encode(m);
    INFO(std::visit([](const auto& x) { return x.kName; }, m));
    CHECK(f.extended);
    CHECK_FALSE(f.remote);
    CHECK(f.valid());
    CHECK(f.id <= 0xFFFF);
    auto back = decode(f);
    REQUIRE(back.ok());
    CHECK(back.value() == m);
    CHECK(encode(back.value()).same_wire(f));
  }
}

TEST_CASE("status and set commands have the DLC of the table") {
  CHECK(encode(SetDuty{}).dlc == 4);
  CHECK(encode(SetCurrentRel{}).dlc == 4);
  CHECK(encode(Status1{}).dlc == 8);
  CHECK(encode(Status6{}).dlc == 8);
  CHECK(encode(Status5{56, -1, -1}).data[6] == 0);  // reserved bytes are sent as 0
  CHECK(encode(Status5{56, -1, -1}).data[7] == 0);
  CHECK(encode(Ping{}).dlc == 1);
  CHECK(encode(Pong{}).dlc == 2);
}

TEST_CASE("decode_bus_frame decodes a VESC frame and a SAUL frame through the same call") {
  auto vesc_msg = decode_bus_frame(frame(0x938, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}));
  REQUIRE(vesc_msg.ok());
  REQUIRE(std::holds_alternative<Status1>(vesc_msg.value()));
  CHECK(std::get<Status1>(vesc_msg.value()) == Status1{56, -1200, 35, 250});
  CHECK(std::string_view(name_of(vesc_msg.value())) == "vesc_status_1");

  auto saul_msg = decode_bus_frame(frame(0x300, {0xE8, 0x03, 0x0C, 0xFE}, false));
  REQUIRE(saul_msg.ok());
  CHECK(std::get<saulcan::VelocityCmd>(saul_msg.value()) == saulcan::VelocityCmd{1000, -500});

  // The id alone does not choose the codec; the format does. 29-bit 0x300 is SET_RPM to controller 0,
  // 11-bit 0x344 is no SAUL frame.
  auto ext300 = decode_bus_frame(frame(0x300, {0xE8, 0x03, 0x0C, 0xFE}, true));
  REQUIRE(ext300.ok());
  CHECK(std::get<SetRpm>(ext300.value()) == SetRpm{0, static_cast<std::int32_t>(0xE8030CFEU)});
  CHECK(decode_bus_frame(frame(0x344, {0x00, 0x00, 0x05, 0xDC}, false)).reason() == Reason::unknown_id);
  CHECK(decode_bus_frame(frame(0x1344, {0x00, 0x00, 0x05, 0xDC})).reason() == Reason::unknown_id);  // command 19
  CanFrame too_big = frame(0x344, {0x00, 0x00, 0x05, 0xDC});
  too_big.id = 0x2000'0344;
  CHECK(decode_bus_frame(too_big).reason() == Reason::invalid_frame);
}

TEST_CASE("encode_bus_message picks the VESC encoder for VESC messages") {
  const std::initializer_list<BusMessage> all = {
      vesc::SetRpm{kLeftId, 1500}, vesc::Status1{kRightId, -1200, 35, 250}, vesc::Pong{68, 56, 0},
      saulcan::VelocityCmd{400, 0},
  };
  for (const auto& m : all) {
    INFO(name_of(m));
    const CanFrame f = encode_bus_message(m);
    CHECK(f.extended == !std::holds_alternative<saulcan::VelocityCmd>(m));
    auto back = decode_bus_frame(f);
    REQUIRE(back.ok());
    CHECK(back.value() == m);
  }
  CHECK(encode_bus_message(vesc::SetRpm{kLeftId, 1500}) == frame(0x344, {0x00, 0x00, 0x05, 0xDC}));
}
