// A missing sensor is a FAULT, not a reboot loop: a missing or silent IMU, and an IO board not heard from since
// power-on, latch FAULT with the wheels stopped, say why on the console (once), in the LCD view and in 0x401, and the
// board keeps feeding its watchdog and answering its console (issue 17).
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "fakes.hpp"
#include "saulsim/world.hpp"

using namespace fwtest;
using saulcan::RobotState;
namespace fault = saulcan::fault;

namespace {

bool all_zero(const std::vector<std::pair<std::int32_t, std::int32_t>>& wheels) {
  for (auto [l, r] : wheels)
    if (l != 0 || r != 0) return false;
  return true;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

/// The faults byte of the newest 0x401 sent since frame index `from`.
int faults_401(const BalanceRig& rig, std::size_t from = 0) {
  const auto frames = rig.frames_with_id(0x401, from);
  return frames.empty() ? -1 : frames.back().data[6];
}

}  // namespace

TEST_CASE("no IMU at power-on: FAULT after imu_startup_us, why on the console, LCD and 0x401, watchdog fed, console "
          "answering") {
  BalanceRig rig;
  rig.imu_on = false;
  rig.run_ms(501);  // the grace the chip gets to start (500 ms after the first loop)
  CHECK(rig.board->state() == RobotState::off);
  CHECK(rig.console.text().empty());
  rig.run_ms(2);
  CHECK(rig.board->state() == RobotState::fault);
  CHECK(rig.board->fault_reason() == FaultReason::imu_missing);
  CHECK(rig.console.text() == "FAULT: no IMU: not one sample since power-on (missing or not started) (motors off)\n");
  rig.run_ms(2000);
  CHECK(rig.watchdog.feeds == 2503);  // every loop: the board stays alive, no reboot loop
  CHECK(count(rig.console.text(), "FAULT:") == 1);  // said once, not every loop
  CHECK(rig.display.last.state == RobotState::fault);
  CHECK(rig.display.last.fault_reason == FaultReason::imu_missing);
  CHECK((rig.display.last.faults & fault::kWatchdogReset) != 0);
  CHECK((faults_401(rig) & fault::kWatchdogReset) != 0);
  CHECK(all_zero(rig.wheels_since(0)));
  // the console still answers, and arming says why not
  CHECK(rig.reply_to("status").find("state=FAULT") != std::string::npos);
  CHECK(rig.reply_to("arm").find("latched: disarm first") != std::string::npos);
  CHECK(rig.reply_to("disarm") == "ok\n");  // to OFF: then arming says what is missing
  CHECK(rig.reply_to("arm") == "error: no pitch from the IMU [not_allowed]\n");
  rig.arm_via_io();
  CHECK(rig.board->state() == RobotState::off);
}

TEST_CASE("an IMU that stops while armed: FAULT and SET_RPM 0 in the step that sees it, the reason kept until a fresh "
          "arming") {
  BalanceRig rig;
  rig.run_ms(12);
  rig.arm_via_io();
  REQUIRE(rig.board->state() == RobotState::balance);
  rig.console.tx.clear();
  rig.imu_on = false;
  rig.run_ms(10);  // 10 ms without a sample: still within imu_stall_us
  CHECK(rig.board->state() == RobotState::balance);
  const std::size_t mark = rig.can.tx.size();
  rig.tick();
  CHECK(rig.board->state() == RobotState::fault);
  CHECK(rig.wheels_since(mark) == std::vector<std::pair<std::int32_t, std::int32_t>>{{0, 0}});
  CHECK(rig.board->fault_reason() == FaultReason::imu_silent);
  CHECK(rig.console.text() == "FAULT: IMU silent: its samples stopped (motors off)\n");
  rig.run_ms(300);
  CHECK(rig.display.last.fault_reason == FaultReason::imu_silent);
  CHECK((faults_401(rig, mark) & fault::kWatchdogReset) != 0);
  CHECK(all_zero(rig.wheels_since(mark)));
  // back: the latch stays (and says why) until a disarm and a fresh arming
  rig.imu_on = true;
  rig.run_ms(300);
  CHECK(rig.board->state() == RobotState::fault);
  CHECK(rig.board->fault_reason() == FaultReason::imu_silent);
  rig.arm_via_io();  // a hold alone does not leave the latch
  CHECK(rig.board->state() == RobotState::fault);
  CHECK(rig.reply_to("disarm") == "ok\n");
  rig.arm_via_io();
  CHECK(rig.board->state() == RobotState::balance);
  CHECK(rig.board->fault_reason() == FaultReason::none);
  CHECK(rig.board->faults() == fault::kOrinTimeout);
}

TEST_CASE("an IMU that stops while disarmed is a FAULT too, said once per stall") {
  BalanceRig rig;
  rig.run_ms(100);
  rig.imu_on = false;
  rig.run_ms(20);
  CHECK(rig.board->state() == RobotState::fault);
  CHECK(rig.board->fault_reason() == FaultReason::imu_silent);
  rig.imu_on = true;
  rig.run_ms(50);
  rig.imu_on = false;
  rig.run_ms(20);
  CHECK(count(rig.console.text(), "FAULT: IMU silent") == 2);  // two stalls, two lines
}

TEST_CASE("an IO board silent since power-on: FAULT (io_link_loss) after io_startup_us, and why") {
  BalanceRig rig;
  rig.io_on = false;
  rig.run_ms(1001);
  CHECK(rig.board->state() == RobotState::off);
  rig.run_ms(2);
  CHECK(rig.board->state() == RobotState::fault);
  CHECK(rig.board->fault_reason() == FaultReason::io_link_silent);
  CHECK(rig.console.text() == "FAULT: no IO board: not one RC_CMD since power-on (motors off)\n");
  rig.run_ms(200);
  CHECK(rig.display.last.fault_reason == FaultReason::io_link_silent);
  CHECK((faults_401(rig) & fault::kIoLinkLoss) != 0);
  CHECK(rig.watchdog.feeds == 1203);
  // the IO board turns up: still FAULT, also after a hold, until a disarm and a fresh arming
  rig.io_on = true;
  rig.run_ms(100);
  CHECK(rig.board->state() == RobotState::fault);
  rig.arm_via_io();
  CHECK(rig.board->state() == RobotState::fault);
  CHECK(rig.reply_to("disarm") == "ok\n");
  rig.arm_via_io();
  CHECK(rig.board->state() == RobotState::balance);
}

TEST_CASE("an IO board that is there at power-on is no FAULT, however long the robot then stays disarmed") {
  BalanceRig rig;
  rig.run_ms(5000);
  CHECK(rig.board->state() == RobotState::off);
  CHECK(rig.board->fault_reason() == FaultReason::none);
  CHECK(rig.console.text().empty());
}

// ---- the same in the simulator (both boards on the plant; `imu off` pulls the IMU, `saulctl sim --no-imu`) ----

TEST_CASE("simulator: an IMU pulled at power-on or while balancing is a FAULT that says why, never a watchdog reset "
          "loop") {
  SECTION("pulled before power-on (saulctl sim --no-imu)") {
    saul::sim::World w;
    REQUIRE(w.command("imu off") == "ok\n");
    w.run_until(10'000'000);
    CHECK(w.balance().state() == RobotState::fault);
    CHECK(w.balance().fault_reason() == FaultReason::imu_missing);
    CHECK(w.balance_resets() == 0);
    CHECK(w.take_console_output("balance").find("FAULT: no IMU") != std::string::npos);
  }
  SECTION("pulled while balancing, then plugged back") {
    saul::sim::World w;
    w.run_until(1'000'000);
    w.command("button down");
    w.run_until(4'300'000);
    w.command("button up");
    REQUIRE(w.balance().state() == RobotState::balance);
    (void)w.take_console_output("balance");
    REQUIRE(w.command("imu off") == "ok\n");
    w.run_until(w.now_us() + 11'000);
    CHECK(w.balance().state() == RobotState::fault);
    w.run_until(w.now_us() + 10'000'000);
    CHECK(w.balance().state() == RobotState::fault);
    CHECK(w.balance().fault_reason() == FaultReason::imu_silent);
    CHECK(w.balance_resets() == 0);
    CHECK(w.take_console_output("balance") == "FAULT: IMU silent: its samples stopped (motors off)\n");
    CHECK(std::fabs(w.plant().speed_mps()) < 0.01);  // wheels stopped (the robot lies on its frame)
    w.console_input("balance", "status\n");
    w.run_until(w.now_us() + 10'000);
    CHECK(w.take_console_output("balance").find("state=FAULT") != std::string::npos);  // still answering
    REQUIRE(w.command("imu on") == "ok\n");
    w.run_until(w.now_us() + 1'000'000);
    CHECK(w.balance().state() == RobotState::fault);  // latched until a disarm and a fresh arming
  }
}
