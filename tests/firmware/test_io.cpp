// IO board logic, case by case: RC to RC_CMD byte for byte, the arming hold, ESTOP and the kill switch, receiver
// failover, BTS7960 outputs, SENSOR, CRSF telemetry, LEDs, horn and the console.
#include <catch2/catch.hpp>

#include <string>

#include "fakes.hpp"

using namespace fwtest;
using saulcan::RobotState;

namespace {

/// ARM switch on, RC flowing, BALANCE reporting upright and OFF.
IoRig& ready(IoRig& rig) {
  rig.sticks[4] = 2000;
  rig.run_ms(50);
  return rig;
}

/// Holds the button until the IO board arms (or max_ms); returns how long that took, in ms.
int hold_until_armed(IoRig& rig, int max_ms = 5000) {
  rig.gpio.button = true;
  int ms = 0;
  while (!rig.board->armed() && ms < max_ms) {
    rig.tick();
    ++ms;
  }
  return ms;
}

/// Arms the IO board and has the fake BALANCE follow (STATE says BALANCE).
void arm(IoRig& rig) {
  REQUIRE(hold_until_armed(rig) <= 3001);
  rig.gpio.button = false;
  rig.state.error_state = static_cast<std::uint8_t>(RobotState::balance);
  rig.run_ms(30);
  REQUIRE(rig.board->armed());
}

std::vector<IbFrame> frames_of_type(const IoRig& rig, std::uint8_t type) {
  std::vector<IbFrame> out;
  for (auto& f : rig.link_frames())
    if (f.type == type) out.push_back(f);
  return out;
}

}  // namespace

TEST_CASE("IO power-on: drivers disabled and PWM 0 before anything else, RC_CMD 100 Hz, SENSOR and FAULT 10 Hz") {
  IoRig rig;
  rig.tick();
  CHECK(rig.motors_off());
  rig.run_ms(999);
  CHECK(frames_of_type(rig, 0x01).size() >= 100);
  CHECK(frames_of_type(rig, 0x01).size() <= 103);  // + the ones sent at once on a change
  CHECK(frames_of_type(rig, 0x02).size() == 10);
  CHECK(frames_of_type(rig, 0x03).size() >= 10);
  CHECK_FALSE(rig.board->armed());
  CHECK(rig.watchdog.feeds == 1000);
}

TEST_CASE("RC_CMD carries the sticks after the CH7 cap, byte for byte, the armed flag only after the 3 s hold") {
  IoRig rig;
  rig.speed_cap = 100;   // BALANCE's speed cap raised to 100 % (it is 10 % until BALANCE says otherwise)
  rig.sticks[1] = 1759;  // CH2 throttle: (259 - 5) * 1000 / 507 = 500 permille
  rig.sticks[0] = 1632;  // CH1 right: steer -250 permille (REP-103: left is +)
  rig.sticks[6] = 2012;  // CH7: cap 100 %
  ready(rig);
  rig.link.tx.clear();
  rig.run_ms(10);
  const Bytes unarmed = ib_frame(0x01, cat({le16(500), le16(-250), {0x00}}));
  CHECK(hex(rig.link.tx).find(hex(unarmed)) != std::string::npos);
  rig.sticks[1] = 1500;  // arming needs the throttle stick centred
  rig.run_ms(10);
  arm(rig);
  rig.sticks[1] = 1759;
  rig.run_ms(10);
  rig.link.tx.clear();
  rig.run_ms(10);
  // the golden frame of docs/protocol.md: RC_CMD throttle 500, steer -250, armed
  CHECK(hex(rig.link.tx).find("AA 05 01 F4 01 06 FF 01 0F") != std::string::npos);

  SECTION("CH7 at 10 %: the same sticks give a tenth") {
    rig.sticks[6] = 988;
    rig.run_ms(20);
    rig.link.tx.clear();
    rig.run_ms(10);
    CHECK(hex(rig.link.tx).find(hex(ib_frame(0x01, cat({le16(50), le16(-25), {0x01}})))) != std::string::npos);
  }
}

TEST_CASE("arming hold: exactly 3 s of a fresh press, upright, ARM switch on") {
  IoRig rig;
  ready(rig);
  SECTION("3 s to the millisecond") {
    CHECK(hold_until_armed(rig) == 3001);  // the press is seen at the first tick; 3000 ms later it arms
  }
  SECTION("released at 2.9 s: nothing; the next press starts from zero") {
    rig.gpio.button = true;
    rig.run_ms(2900);
    rig.gpio.button = false;
    rig.run_ms(5);
    CHECK_FALSE(rig.board->armed());
    CHECK(hold_until_armed(rig) == 3001);
  }
  SECTION("not upright: |pitch| 5.01 degrees from STATE") {
    rig.state.pitch_x100 = -501;
    rig.run_ms(30);
    CHECK(hold_until_armed(rig, 4000) == 4000);
    CHECK_FALSE(rig.board->armed());
  }
  SECTION("5.00 degrees is upright") {
    rig.state.pitch_x100 = 500;
    rig.run_ms(30);
    CHECK(hold_until_armed(rig) == 3001);
  }
  SECTION("ARM switch off") {
    rig.sticks[4] = 1000;
    rig.run_ms(30);
    CHECK(hold_until_armed(rig, 4000) == 4000);
  }
  SECTION("no STATE from BALANCE (pitch unknown)") {
    rig.balance_on = false;
    rig.run_ms(150);
    CHECK(hold_until_armed(rig, 4000) == 4000);
  }
  SECTION("tilted during the hold: cancelled, and it needs a release before counting again") {
    rig.gpio.button = true;
    rig.run_ms(2000);
    rig.state.pitch_x100 = 900;
    rig.run_ms(40);
    rig.state.pitch_x100 = 0;
    rig.run_ms(2000);
    CHECK_FALSE(rig.board->armed());
    rig.gpio.button = false;
    rig.run_ms(5);
    CHECK(hold_until_armed(rig) == 3001);
  }
}

TEST_CASE("arming hold: a button already down at power-on never arms until released") {
  IoRig rig;
  rig.gpio.button = true;
  rig.sticks[4] = 2000;
  rig.run_ms(5000);
  CHECK_FALSE(rig.board->armed());
  rig.gpio.button = false;
  rig.run_ms(5);
  CHECK(hold_until_armed(rig) == 3001);
}

TEST_CASE("the armed flag drops with the ARM switch, RC loss, a latched BALANCE, or a refused arming") {
  IoRig rig;
  ready(rig);
  SECTION("ARM switch off") {
    arm(rig);
    rig.sticks[4] = 1000;
    rig.run_ms(10);
    CHECK_FALSE(rig.board->armed());
  }
  SECTION("BALANCE enters TILT_CUTOFF") {
    arm(rig);
    rig.state.error_state = static_cast<std::uint8_t>(RobotState::tilt_cutoff);
    rig.run_ms(25);
    CHECK_FALSE(rig.board->armed());
    // and the next hold arms again while BALANCE still reports the latched state
    rig.run_ms(5);
    CHECK(hold_until_armed(rig) == 3001);
  }
  SECTION("BALANCE never reports BALANCE/MANUAL: dropped 250 ms after the arming") {
    REQUIRE(hold_until_armed(rig) == 3001);
    rig.gpio.button = false;
    int ms = 0;
    while (rig.board->armed() && ms < 1000) {
      rig.tick();
      ++ms;
    }
    CHECK(ms == 251);
  }
}

TEST_CASE("BTS7960: forward on RPWM, reverse on LPWM, enables high, only while armed and BALANCE armed") {
  IoRig rig;
  rig.speed_cap = 100;
  rig.sticks[6] = 2012;
  ready(rig);
  rig.sticks[1] = 1759;  // throttle 500
  rig.run_ms(10);
  CHECK(rig.motors_off());  // not armed
  rig.sticks[1] = 1500;  // arming needs the throttle stick centred
  rig.run_ms(10);
  arm(rig);
  rig.sticks[1] = 1759;
  rig.run_ms(10);
  CHECK(rig.pwm[PwmChannel::left_rpwm] == 500);
  CHECK(rig.pwm[PwmChannel::left_lpwm] == 0);
  CHECK(rig.pwm[PwmChannel::right_rpwm] == 500);
  CHECK(rig.gpio[OutputPin::left_r_en]);
  CHECK(rig.gpio[OutputPin::left_l_en]);
  CHECK(rig.gpio[OutputPin::right_r_en]);
  CHECK(rig.gpio[OutputPin::right_l_en]);
  rig.sticks[1] = 1241;  // throttle -500
  rig.sticks[0] = 1368;  // CH1 left: steer +250
  rig.run_ms(10);
  // left = -500 - 250, right = -500 + 250
  CHECK(rig.pwm[PwmChannel::left_rpwm] == 0);
  CHECK(rig.pwm[PwmChannel::left_lpwm] == 750);
  CHECK(rig.pwm[PwmChannel::right_rpwm] == 0);
  CHECK(rig.pwm[PwmChannel::right_lpwm] == 250);
  // BALANCE goes OFF: drivers off
  rig.state.error_state = 0;
  rig.run_ms(25);
  CHECK(rig.motors_off());
}

TEST_CASE("kill switch: in that very step the drivers go off and FAULT(estop) is the first thing sent") {
  IoRig rig;
  rig.speed_cap = 100;
  rig.sticks[6] = 2012;
  ready(rig);
  arm(rig);  // with the throttle stick centred, as arming needs
  rig.sticks[1] = 1759;
  rig.run_ms(10);
  REQUIRE(rig.board->motors_enabled());
  rig.link.tx.clear();
  rig.gpio.kill = true;
  rig.tick();
  CHECK(rig.motors_off());
  CHECK_FALSE(rig.board->armed());
  const auto frames = rig.link_frames();
  REQUIRE(frames.size() >= 2);
  CHECK(hex(rig.link.tx).rfind(hex(ib_frame(0x03, {0x04})), 0) == 0);  // AA 01 03 04 CRC first
  CHECK(frames[1].type == 0x01);
  CHECK(frames[1].payload == cat({le16(0), le16(0), {0x02}}));  // RC_CMD: sticks zeroed, kill, not armed
  // enables were switched off before any PWM write in that step
  REQUIRE_FALSE(rig.gpio.log.empty());
  CHECK(rig.gpio.log.front() == std::make_pair(OutputPin::left_r_en, false));
  // no arming while the kill switch is active, even with a full hold
  rig.gpio.button = false;
  rig.run_ms(5);
  CHECK(hold_until_armed(rig, 4000) == 4000);
}

TEST_CASE("RC ESTOP (CH6) is acted on inside the receive loop, before the rest of the iteration") {
  IoRig rig;
  rig.speed_cap = 100;
  rig.sticks[6] = 2012;
  ready(rig);
  arm(rig);  // with the throttle stick centred, as arming needs
  rig.sticks[1] = 1759;
  rig.run_ms(10);
  rig.link.tx.clear();
  rig.sticks[5] = 2000;
  rig.next_crsf = rig.now;  // the next tick delivers a frame
  rig.tick();
  CHECK(rig.motors_off());
  CHECK(rig.board->estop_active());
  CHECK(hex(rig.link.tx).rfind(hex(ib_frame(0x03, {0x04})), 0) == 0);
  // ESTOP released: not armed, and the flag needs a fresh hold
  rig.sticks[5] = 1000;
  rig.run_ms(20);
  CHECK_FALSE(rig.board->estop_active());
  CHECK_FALSE(rig.board->armed());
}

TEST_CASE("receivers: CRSF primary, ELRS after more than 100 ms of CRSF silence, neither = rc_loss") {
  IoRig rig;
  rig.elrs_on = true;
  rig.speed_cap = 100;
  rig.sticks[6] = 2012;
  ready(rig);
  arm(rig);  // with the throttle stick centred, as arming needs
  rig.sticks[1] = 1759;
  rig.run_ms(10);
  CHECK(rig.board->active_source() == rc::Source::crsf);
  rig.crsf.feed(crsf_rc_frame(rig.sticks));  // CRSF's last frame, taken at the next tick
  rig.crsf_on = false;
  rig.run_ms(101);
  CHECK(rig.board->active_source() == rc::Source::crsf);  // its last frame is exactly 100 ms old: alive
  rig.run_ms(1);
  CHECK(rig.board->active_source() == rc::Source::elrs);
  CHECK(rig.board->armed());  // a failover is not a loss
  CHECK(rig.board->motors_enabled());
  rig.link.tx.clear();
  rig.elrs.feed(crsf_rc_frame(rig.sticks));
  rig.elrs_on = false;
  rig.tick();  // the last ELRS frame
  int ms = 0;
  while (!rig.board->rc_loss() && ms < 500) {
    rig.tick();
    ++ms;
  }
  CHECK(ms == 101);
  CHECK(rig.motors_off());
  CHECK_FALSE(rig.board->armed());
  // FAULT(rc_loss) went out in the step that saw the loss
  CHECK(hex(rig.link.tx).find(hex(ib_frame(0x03, {0x01}))) != std::string::npos);
}

TEST_CASE("SENSOR: ToF, barometer delta from the first reading, NFC, 10 Hz, byte for byte") {
  IoRig rig;
  rig.sensors.readings = {true, 1234, true, 101300, true, 0};
  rig.run_ms(100);
  rig.sensors.readings.pressure_pa = 101300 - 56;
  rig.link.tx.clear();
  rig.run_ms(100);
  // the golden frame of docs/protocol.md: SENSOR 1234 mm, -56 Pa, NFC present
  CHECK(hex(rig.link.tx).find("AA 05 02 D2 04 C8 FF 01 14") != std::string::npos);
  rig.sensors.readings = {};  // everything missing: ToF 65535 = no reading
  rig.link.tx.clear();
  rig.run_ms(100);
  CHECK(hex(rig.link.tx).find(hex(ib_frame(0x02, cat({le16(0xFFFF), le16(0), {0x00}})))) != std::string::npos);
}

TEST_CASE("CRSF telemetry to the active receiver: attitude, flight mode, battery, byte for byte") {
  IoRig rig;
  rig.state.pitch_x100 = -1234;
  rig.sensors.readings.battery_mv = 39600;
  rig.run_ms(1000);
  const std::string log = hex(rig.crsf.tx);
  // ATTITUDE: -12.34 deg = -0.21537 rad -> -2153 = F7 97, roll 0, yaw 0
  CHECK(log.find(hex(crsf_frame(0x1E, {0xF7, 0x97, 0, 0, 0, 0}))) != std::string::npos);
  // FLIGHT_MODE "OFF"
  CHECK(log.find(hex(crsf_frame(0x21, {'O', 'F', 'F', 0}))) != std::string::npos);
  // BATTERY_SENSOR 39.6 V = 396 = 01 8C
  CHECK(log.find(hex(crsf_frame(0x08, {0x01, 0x8C, 0, 0, 0, 0, 0, 0}))) != std::string::npos);
  CHECK(rig.elrs.tx.empty());
  rig.gpio.kill = true;
  rig.crsf.tx.clear();
  rig.run_ms(400);
  CHECK(hex(rig.crsf.tx).find(hex(crsf_frame(0x21, {'K', 'I', 'L', 'L', 0}))) != std::string::npos);
}

TEST_CASE("LEDs: LED_CMD from BALANCE, local ESTOP first, arming hold shown as a chase") {
  IoRig rig;
  ready(rig);
  rig.run_ms(20);
  REQUIRE(rig.leds.pixels.size() == 16);  // the default strip
  CHECK(rig.leds.pixels[0].b > 0);  // OFF: breathe blue (from STATE; no LED_CMD yet)
  std::uint8_t buf[16];
  const auto n = interboard::encode(interboard::LedCmd{1, 255, 128, 0}, buf);
  rig.link.feed(Bytes(buf, buf + *n));
  rig.run_ms(20);
  CHECK(rig.leds.pixels[5] == Rgb{255, 128, 0});
  rig.gpio.button = true;
  rig.run_ms(50);
  int lit = 0;
  for (const auto& p : rig.leds.pixels) lit += p == Rgb{0, 255, 0} ? 1 : 0;
  CHECK(lit == 1);
  rig.gpio.button = false;
  rig.gpio.kill = true;
  bool red = false;
  bool dark = false;
  for (int i = 0; i < 600; ++i) {  // blinking red
    rig.tick();
    red = red || rig.leds.pixels[0] == Rgb{255, 0, 0};
    dark = dark || rig.leds.pixels[0] == Rgb{};
    CHECK((rig.leds.pixels[0] == Rgb{255, 0, 0} || rig.leds.pixels[0] == Rgb{}));
  }
  CHECK(red);
  CHECK(dark);
}

TEST_CASE("horn, buzzer, headlight, fan") {
  IoConfig c;
  c.elrs_fitted = false;
  IoRig rig(c);
  ready(rig);
  CHECK(rig.horn.hz == 0);
  rig.sticks[7] = 2000;  // CH8
  rig.run_ms(10);
  CHECK(rig.horn.hz == 2000);
  rig.sticks[7] = 1000;
  std::uint8_t buf[16];
  const auto n = interboard::encode(interboard::Buzzer{3, 500}, buf);
  rig.link.feed(Bytes(buf, buf + *n));
  rig.run_ms(10);
  CHECK(rig.horn.hz == 3000);
  rig.run_ms(500);
  CHECK(rig.horn.hz == 0);
  CHECK(rig.pwm[PwmChannel::headlight] == 0);
  rig.sticks[2] = 2000;  // CH3
  rig.run_ms(10);
  CHECK(rig.pwm[PwmChannel::headlight] == 1000);
  CHECK_FALSE(rig.gpio[OutputPin::fan]);
  arm(rig);
  CHECK(rig.gpio[OutputPin::fan]);
}

TEST_CASE("IO console: status, refusals, estop, disarm, reboot") {
  IoRig rig;
  ready(rig);
  const std::string status = rig.reply_to("status");
  CHECK(status.find("report=status board=io state=OFF pitch_x100=0 pid_out=0 kp=0 ki=0 kd=0 tilt_limit_x100=2500 "
                    "speed_limit_pct=10 faults=0") != std::string::npos);
  CHECK(status.find("report=can_stats tx=0") != std::string::npos);
  CHECK(status.find("report=uart_stats frames=") != std::string::npos);
  CHECK(rig.reply_to("arm") == "error: hold the arming button for 3 s (or use the BALANCE console) [not_allowed]\n");
  CHECK(rig.reply_to("pid 1 2 3") == "error: set on the BALANCE board [not_allowed]\n");
  CHECK(rig.reply_to("speed_limit 20") == "error: set on the BALANCE board [not_allowed]\n");
  CHECK(rig.reply_to("reboot") == "ok\n");
  CHECK(rig.board->reboot_requested());

  arm(rig);
  rig.link.tx.clear();
  CHECK(rig.reply_to("estop") == "ok\n");
  CHECK(rig.motors_off());
  CHECK_FALSE(rig.board->armed());
  CHECK(hex(rig.link.tx).rfind(hex(ib_frame(0x03, {0x04})), 0) == 0);
  rig.run_ms(600);
  CHECK_FALSE(rig.board->estop_active());  // reported for 500 ms; BALANCE keeps its own latch

  rig.run_ms(5);
  arm(rig);
  CHECK(rig.reply_to("disarm") == "ok\n");
  CHECK_FALSE(rig.board->armed());
}
