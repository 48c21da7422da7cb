// The three safety rules of issue 17 and the decisions of docs/protocol.md ("Safety decisions"), one test each:
//   1. after any disarm or latch, arming needs a new press (released, then held 3 s), whichever board latched;
//   2. a live radio's CH5 at disarm forbids every arming and disarms within one loop iteration (no radio at all:
//      console arming stays possible);
//   3. one speed cap for every motor output of both boards, 10 % at power-on, one 10 % step per command, raised only
//      while disarmed; CH7 only lowers it;
//   decisions: arming needs the throttle stick centred; `mode off` (and console disarm) in a latched state goes to
//   OFF, or is refused while an estop input is active.
// End to end on the simulated robot (both boards' real logic, firmware/sim's World) and board by board on the rigs.
#include <catch2/catch.hpp>

#include <optional>
#include <string>

#include "fakes.hpp"
#include "saulsim/world.hpp"

using namespace fwtest;
using saulcan::RobotState;

namespace {

bool is_armed(RobotState s) { return s == RobotState::balance || s == RobotState::manual; }

/// The simulated robot with the SET_RPM it has put on the bus followed by hand.
struct Robot {
  sim::World world;
  std::int32_t left = 0;
  std::int32_t right = 0;
  std::int32_t peak_erpm = 0;      // largest |SET_RPM| since the last reset_peaks()
  std::uint16_t peak_duty = 0;     // largest BTS7960 duty on the IO board's pins likewise
  bool armed_ever = false;         // BALANCE armed at any tick since the last reset_peaks()

  void tick() {
    world.step();
    for (const auto& f : world.take_can_output()) {
      if (auto l = set_rpm_of(f, 68)) left = *l;
      if (auto r = set_rpm_of(f, 56)) right = *r;
    }
    peak_erpm = std::max({peak_erpm, std::abs(left), std::abs(right)});
    peak_duty = std::max(peak_duty, world.io_drive_duty());
    armed_ever = armed_ever || is_armed(state());
  }
  void run_ms(int ms) {
    for (int i = 0; i < ms; ++i) tick();
  }
  void reset_peaks() {
    peak_erpm = 0;
    peak_duty = 0;
    armed_ever = false;
  }
  void sim(const std::string& command) { REQUIRE(world.command(command).rfind("error", 0) != 0); }
  /// A console line to a board and what it replied within 5 ms.
  std::string console(const std::string& board, const std::string& line) {
    (void)world.take_console_output(board);
    world.console_input(board, line + "\n");
    run_ms(5);
    return world.take_console_output(board);
  }
  [[nodiscard]] RobotState state() const { return world.balance().state(); }
  bool wheels_zero() const { return left == 0 && right == 0; }
  /// Holds the button for `ms`, then releases it.
  void press(int ms) {
    sim("button down");
    run_ms(ms);
    sim("button up");
    run_ms(20);
  }
};

Robot& powered_on(Robot& r) {
  r.run_ms(1000);  // the IO board arms only on a fresh STATE from BALANCE showing it upright
  return r;
}

}  // namespace

// ---- rule 1 ---------------------------------------------------------------------------------------------------------

TEST_CASE("rule 1: a button held through an ESTOP or a watchdog reset never arms; released and pressed anew, it does") {
  Robot r;
  powered_on(r);
  r.sim("button down");
  r.run_ms(2000);  // a hold under way
  SECTION("Orin ESTOP (0x302 mode 3)") { r.world.send_can(std_frame(0x302, {3})); }
  SECTION("BALANCE console estop") { r.world.console_input("balance", "estop\n"); }
  SECTION("IO console estop") { r.world.console_input("io", "estop\n"); }
  SECTION("a BALANCE hang: its watchdog resets it into FAULT") { r.sim("hang balance"); }
  r.run_ms(100);
  REQUIRE((r.state() == RobotState::estop || r.state() == RobotState::fault));
  r.reset_peaks();
  r.run_ms(6000);  // twice the hold, the button never released
  CHECK_FALSE(r.armed_ever);
  CHECK_FALSE(r.world.io().armed());
  CHECK(r.peak_erpm == 0);
  // A new press alone does not leave the latch (only OFF is armed): a disarm first, then the new press arms.
  r.sim("button up");
  r.run_ms(600);  // the IO board's console estop lasts 500 ms
  r.press(3100);
  CHECK_FALSE(is_armed(r.state()));
  r.run_ms(500);  // the IO board keeps its refused flag 250 ms (arm_confirm_us) before it takes a new press
  CHECK(r.console("balance", "disarm") == "ok\n");
  CHECK(r.state() == RobotState::off);
  r.press(3100);
  CHECK(is_armed(r.state()));
}

// Issue 33's minimal cases: a stop or disarm that leaves the state as it was still cancels a hold in progress.
TEST_CASE("rule 1: a stop or disarm during a hold cancels it even when the state does not change (issue 33)") {
  Robot r;
  powered_on(r);
  RobotState before = RobotState::off;
  bool by_console = true;  // else the Orin
  SECTION("OFF, BALANCE console disarm") {}
  SECTION("OFF, the Orin's mode 0") { by_console = false; }
  SECTION("ESTOP, BALANCE console estop") { before = RobotState::estop; }
  SECTION("ESTOP, the Orin's mode 3") {
    before = RobotState::estop;
    by_console = false;
  }
  if (before == RobotState::estop) {
    r.world.send_can(std_frame(0x302, {3}));
    r.run_ms(50);
  }
  REQUIRE(r.state() == before);
  r.reset_peaks();
  r.sim("button down");
  r.run_ms(1500);
  // the stop or disarm, in the state the robot is in (it stays)
  const bool off = before == RobotState::off;
  if (by_console) {
    CHECK(r.console("balance", off ? "disarm" : "estop") == "ok\n");
  } else {
    r.world.send_can(std_frame(0x302, {static_cast<std::uint8_t>(off ? 0 : 3)}));
  }
  r.run_ms(1700);  // the button up at 3.2 s: the IO board's hold has completed
  r.sim("button up");
  r.run_ms(2000);
  CHECK_FALSE(r.armed_ever);
  CHECK(r.peak_erpm == 0);
  CHECK(r.state() == before);
}

TEST_CASE("a latch is left only to OFF: console arm and a new press are refused in ESTOP, a disarm comes first") {
  Robot r;
  powered_on(r);
  r.world.send_can(std_frame(0x302, {3}));
  r.run_ms(50);
  REQUIRE(r.state() == RobotState::estop);
  CHECK(r.console("balance", "arm").find("latched: disarm first") != std::string::npos);
  r.press(3200);
  r.run_ms(300);
  CHECK(r.state() == RobotState::estop);
  SECTION("console disarm") { CHECK(r.console("balance", "disarm") == "ok\n"); }
  SECTION("CH5 moved to disarm (its edge), then back") {
    r.sim("radio 5 1000");
    r.run_ms(30);
    CHECK(r.state() == RobotState::off);
    r.sim("radio 5 2000");
    r.run_ms(30);
  }
  r.run_ms(30);
  CHECK(r.state() == RobotState::off);
  CHECK(r.console("balance", "arm") == "ok\n");
  CHECK(is_armed(r.state()));
}

TEST_CASE("CH5 already at disarm when a latch comes is no way out of it: the switch must move") {
  Robot r;
  powered_on(r);
  r.sim("radio 5 1000");
  r.run_ms(50);
  r.world.send_can(std_frame(0x302, {3}));
  r.run_ms(200);
  CHECK(r.state() == RobotState::estop);  // the CH5 level is no disarm of the latch: ESTOP stays on display
}

TEST_CASE("rule 1 on BALANCE alone: an IO arming whose button was never seen released since the latch is refused") {
  BalanceRig rig;
  rig.run_ms(30);
  rig.arm_via_io();
  REQUIRE(rig.board->state() == RobotState::balance);
  rig.rc.flags = interboard::RcCmd::kArmed | interboard::RcCmd::kButton;  // pressed again while armed
  rig.run_ms(20);
  CHECK(rig.reply_to("estop") == "ok\n");
  // The IO board drops its flag and raises it again with the button never released (an IO board that missed the
  // latch): BALANCE refuses.
  rig.rc.flags = interboard::RcCmd::kButton;
  rig.run_ms(20);
  rig.rc.flags = interboard::RcCmd::kArmed | interboard::RcCmd::kButton;
  rig.run_ms(20);
  CHECK(rig.board->state() == RobotState::estop);
  // The button seen released, then a new edge: still ESTOP (a latch is left only to OFF); a disarm first.
  const auto released_then_new_edge = [&] {
    rig.rc.flags = 0;
    rig.run_ms(20);
    rig.rc.flags = interboard::RcCmd::kButton;
    rig.run_ms(20);
    rig.rc.flags = interboard::RcCmd::kArmed | interboard::RcCmd::kButton;
    rig.run_ms(20);
  };
  released_then_new_edge();
  CHECK(rig.board->state() == RobotState::estop);
  CHECK(rig.reply_to("disarm") == "ok\n");
  CHECK(rig.board->state() == RobotState::off);
  // The button seen released after the disarm, then a new edge: armed.
  released_then_new_edge();
  CHECK(rig.board->state() == RobotState::balance);
}

TEST_CASE("rule 1 on the IO board: a hold running when BALANCE latches is cancelled until the button is released") {
  IoRig rig;
  rig.sticks[4] = 2000;
  rig.run_ms(50);
  rig.gpio.button = true;
  rig.run_ms(2000);
  rig.state.error_state = static_cast<std::uint8_t>(RobotState::estop);  // BALANCE latched (Orin ESTOP)
  rig.run_ms(40);
  rig.state.error_state = static_cast<std::uint8_t>(RobotState::off);    // and disarmed to OFF by mode 0
  rig.run_ms(5000);
  CHECK_FALSE(rig.board->armed());
  rig.gpio.button = false;
  rig.run_ms(10);
  rig.gpio.button = true;
  rig.run_ms(3010);
  CHECK(rig.board->armed());
}

// ---- rule 2 ---------------------------------------------------------------------------------------------------------

TEST_CASE("rule 2: with a live radio, CH5 at disarm refuses the console arm, disarms a console-armed robot at once") {
  Robot r;
  powered_on(r);
  r.sim("radio 5 1000");
  r.run_ms(30);
  CHECK(r.console("balance", "arm") == "error: the ARM switch (CH5) is at disarm [not_allowed]\n");
  r.sim("radio 5 1500");  // exactly 1500 is not arm either
  r.run_ms(30);
  CHECK(r.console("balance", "arm").find("CH5") != std::string::npos);
  r.sim("radio 5 2000");
  r.run_ms(30);
  REQUIRE(r.console("balance", "arm") == "ok\n");
  r.run_ms(500);
  REQUIRE(r.state() == RobotState::balance);
  r.sim("radio 5 1000");
  // The radio sends every 10 ms: the first frame with CH5 at disarm disarms in the iteration that reads it.
  int ms = 0;
  while (is_armed(r.state()) && ms < 50) {
    r.tick();
    ++ms;
  }
  CHECK(ms <= 10);
  CHECK(r.state() == RobotState::off);
  CHECK(r.wheels_zero());
}

TEST_CASE("rule 2 in one iteration: the CRSF frame with CH5 at disarm -> RC_CMD disarm_switch -> BALANCE OFF") {
  SECTION("IO: the flag goes out in the iteration that reads the frame") {
    IoRig rig;
    rig.sticks[4] = 2000;
    rig.run_ms(50);
    rig.sticks[4] = 1000;
    rig.next_crsf = rig.now;  // the next tick delivers a frame
    rig.link.tx.clear();
    rig.tick();
    bool flagged = false;
    for (const auto& f : rig.link_frames())
      if (f.type == 0x01 && (f.payload.at(4) & 0x04) != 0) flagged = true;
    CHECK(flagged);
  }
  SECTION("BALANCE: OFF and SET_RPM 0 in the step that reads it") {
    BalanceRig rig;
    rig.run_ms(30);
    REQUIRE(rig.reply_to("arm") == "ok\n");
    rig.run_ms(20);
    const std::size_t mark = rig.can.tx.size();
    rig.rc.flags = interboard::RcCmd::kDisarmSwitch;
    rig.send_rc(rig.rc);
    rig.tick();
    CHECK(rig.board->state() == RobotState::off);
    const auto w = rig.wheels_since(mark);
    REQUIRE_FALSE(w.empty());
    CHECK(w.back() == std::make_pair(0, 0));
  }
}

TEST_CASE("rule 2: no radio at all (a bench without a transmitter): no rc_loss, console arming possible") {
  Robot r;
  r.sim("rc loss");  // before the first frame: the receivers never speak
  powered_on(r);
  CHECK((r.world.io().fault_flags() & interboard::Fault::kRcLoss) == 0);
  CHECK(r.console("balance", "arm") == "ok\n");
  // A radio that appears and goes again is RC loss: FAULT
  r.sim("rc ok");
  r.run_ms(200);
  REQUIRE(is_armed(r.state()));
  r.sim("rc loss");
  r.run_ms(150);
  CHECK(r.state() == RobotState::fault);
  CHECK(r.wheels_zero());
}

// ---- rule 3 ---------------------------------------------------------------------------------------------------------

TEST_CASE("rule 3: one cap for both boards, 10 % at power-on whatever CH7 says, raised only while disarmed") {
  Robot r;
  r.sim("radio 7 2012");  // CH7 at 100 %
  powered_on(r);
  r.press(3100);
  REQUIRE(r.state() == RobotState::balance);
  REQUIRE(r.world.io().armed());
  r.sim("radio 2 2012");  // full throttle
  r.reset_peaks();
  r.run_ms(300);
  CHECK(r.peak_duty > 0);
  CHECK(r.peak_duty <= 100);  // BTS7960: 10 % of full duty
  CHECK(r.peak_erpm <= 200 * 60 * 7 / 628);  // VESCs: 10 % of 2000 mm/s
  // Raising it while armed: refused (the drive would change under the operator's hands).
  CHECK(r.console("balance", "speed_limit 20") == "error: raise the speed limit only while disarmed [not_allowed]\n");
  CHECK(r.world.balance().speed_limit_pct() == 10);
  // Disarmed: one 10 % step per command.
  r.sim("radio 2 1500");
  REQUIRE(r.console("balance", "disarm") == "ok\n");
  CHECK(r.console("balance", "speed_limit 30") ==
        "error: raise the speed limit one 10 % step at a time [not_allowed]\n");
  CHECK(r.console("balance", "speed_limit 20") == "ok\n");
  CHECK(r.console("balance", "speed_limit 30") == "ok\n");
  r.sim("upright");
  r.run_ms(1500);
  r.press(3100);
  REQUIRE(r.state() == RobotState::balance);
  r.sim("radio 2 2012");
  r.reset_peaks();
  r.run_ms(300);
  CHECK(r.peak_duty > 100);
  CHECK(r.peak_duty <= 300);
  // CH7 lowers it: at 10 % the IO board's duty is a tenth within one radio frame.
  r.sim("radio 7 988");
  r.run_ms(11);
  r.reset_peaks();
  r.run_ms(100);
  CHECK(r.peak_duty <= 100);
  // Lowering by console is allowed while armed and follows at once on both boards.
  CHECK(r.console("balance", "speed_limit 10") == "ok\n");
}

TEST_CASE("rule 3 on the IO board: it keeps 10 % until BALANCE's SPEED_CAP says otherwise, and ignores a bad one") {
  IoRig rig;
  rig.sticks[6] = 2012;
  rig.sticks[4] = 2000;
  rig.run_ms(50);
  REQUIRE(rig.arm_quickly());
  rig.sticks[1] = 2012;
  rig.run_ms(20);
  CHECK(rig.pwm[PwmChannel::left_rpwm] == 100);
  rig.speed_cap = 55;  // not a 10 % step: ignored
  rig.run_ms(40);
  CHECK(rig.pwm[PwmChannel::left_rpwm] == 100);
  rig.speed_cap = 40;
  rig.run_ms(40);
  CHECK(rig.pwm[PwmChannel::left_rpwm] == 400);
  rig.sticks[0] = 988;  // full left: steering never pushes a side above the cap
  rig.run_ms(20);
  CHECK(rig.pwm[PwmChannel::right_rpwm] == 400);
  CHECK(rig.board->speed_cap_pct() == 40);
}

// ---- decisions ------------------------------------------------------------------------------------------------------

TEST_CASE("decision: arming needs the throttle stick centred (CH2 within 1500 +- 5 us)") {
  Robot r;
  powered_on(r);
  r.sim("radio 2 1600");
  r.run_ms(20);
  r.press(4000);
  CHECK_FALSE(is_armed(r.state()));
  CHECK(r.console("balance", "arm") == "error: the throttle stick is not centred [not_allowed]\n");
  r.sim("radio 2 1505");  // inside the deadband: centred
  r.run_ms(20);
  r.press(3100);
  CHECK(r.state() == RobotState::balance);
  CHECK(r.wheels_zero() == (r.world.balance().pid_out() == 0));  // nothing but the balance loop drives it
}

TEST_CASE("decision: mode off (and console disarm) in ESTOP goes to OFF; refused while an estop input is active") {
  BalanceRig rig;
  rig.run_ms(30);
  rig.arm_via_io();
  const auto mode0 = [&] {
    const std::size_t mark = rig.can.tx.size();
    rig.can.rx.push_back(std_frame(0x302, {0}));
    rig.tick();
    return rig.frames_with_id(0x402, mark);
  };
  SECTION("no estop input any more: OFF, motors zero, the cause kept in 0x401, arming needed") {
    rig.can.rx.push_back(std_frame(0x302, {3}));
    rig.run_ms(5);
    REQUIRE(rig.board->state() == RobotState::estop);
    CHECK(mode0() == std::vector<CanFrame>{std_frame(0x402, {0x02, 0x00, 0x00})});  // applied
    CHECK(rig.board->state() == RobotState::off);
    CHECK((rig.board->faults() & saulcan::fault::kEstop) != 0);
    rig.run_ms(20);
    CHECK(rig.last_wheels() == std::make_pair(0, 0));
    CHECK(rig.board->state() == RobotState::off);  // the IO armed flag still high is no arming
  }
  SECTION("the kill switch still on: not allowed, ESTOP stays") {
    rig.rc.flags = static_cast<std::uint8_t>(rig.rc.flags | interboard::RcCmd::kKill);
    rig.run_ms(20);
    REQUIRE(rig.board->state() == RobotState::estop);
    CHECK(mode0() == std::vector<CanFrame>{std_frame(0x402, {0x02, 0x00, 0x02})});  // not allowed
    CHECK(rig.board->state() == RobotState::estop);
    CHECK(rig.reply_to("disarm") ==
          "error: ESTOP stays while an estop input is active (kill switch, CH6, IO console estop) [not_allowed]\n");
    CHECK(rig.board->state() == RobotState::estop);
  }
}
