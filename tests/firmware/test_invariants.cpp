// The safety invariants of the system reference, each one a named test that drives the real board logic through
// seeded randomized scenarios in simulated time (SAUL_FW_SCENARIOS per invariant, default 10000). A scenario that
// breaks an invariant fails the test with its seed and event trace; SAUL_FW_SEED=<seed> replays just that one.
//
// Each oracle below is written from the specification, not from the code: it watches what the boards put on their
// wires and pins (SET_RPM frames read by hand, PWM and enable pins, inter-board frames split by hand) and what the
// test itself delivered to them.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "fakes.hpp"

using namespace fwtest;
using saulcan::RobotState;
namespace fault = saulcan::fault;

namespace {

using Wheels = std::vector<std::pair<std::int32_t, std::int32_t>>;

bool is_armed(RobotState s) { return s == RobotState::balance || s == RobotState::manual; }
bool any_nonzero(const Wheels& w) {
  for (auto [l, r] : w)
    if (l != 0 || r != 0) return true;
  return false;
}
std::string name(RobotState s) { return saulcan::to_string(s); }

/// Runs every scenario of one invariant; body(rng, trace) returns "" when the invariant held, else what broke.
template <class Body>
void scenarios(std::uint64_t base, Body&& body) {
  const int n = scenario_count();
  int failures = 0;
  for (int i = 0; i < n && failures < 3; ++i) {
    Trace trace;
    trace.seed = scenario_seed(base, i);
    Rng rng(trace.seed);
    const std::string broke = body(rng, trace);
    if (!broke.empty()) {
      ++failures;
      FAIL_CHECK("invariant broken: " << broke << "\n" << trace.dump());
    }
  }
  CHECK(failures == 0);
}

/// One tick of a BALANCE rig; returns the SET_RPM pairs sent during it.
Wheels step(BalanceRig& rig) {
  const std::size_t mark = rig.can.tx.size();
  rig.tick();
  return rig.wheels_since(mark);
}

/// A BALANCE rig past power-on and armed through the IO board's fresh arming.
void arm_balance(BalanceRig& rig) {
  rig.run_ms(12);
  rig.arm_via_io();
}

/// The IO board's motor outputs never went on (no non-zero PWM, no enable written high) during the last tick.
bool io_wrote_no_drive(const IoRig& rig) {
  for (auto [c, v] : rig.pwm.log)
    if (c != PwmChannel::headlight && v != 0) return false;
  for (auto [p, on] : rig.gpio.log)
    if (p != OutputPin::fan && on) return false;
  return true;
}

std::uint16_t us_of(bool on) { return on ? 2000 : 1000; }

}  // namespace

// ---------------------------------------------------------------------------------------------------------------------

TEST_CASE("invariant: motors never spin after power-on without the 3 s button hold while upright (both boards)") {
  int armings = 0;
  scenarios(1, [&](Rng& rng, Trace& trace) -> std::string {
    IoRig io;
    BalanceRig bal;
    io.balance_on = false;  // the real BALANCE answers instead
    bal.io_on = false;      // the real IO board talks instead
    io.step_us = bal.step_us = 8000;  // coarse, to afford 10000 runs of up to 4.5 s; IMU still 1 kHz
    io.sticks[4] = us_of(rng.chance(85));
    io.sticks[6] = static_cast<std::uint16_t>(rng.range(988, 2012));
    bal.pitch = rng.chance(80) ? rng.uniform(-4.5F, 4.5F) : rng.uniform(-10.0F, 10.0F);
    float target = bal.pitch;
    const TimeUs end = io.now + static_cast<TimeUs>(rng.range(1500, 5000)) * 1000;

    bool pressed = false;
    TimeUs press_start = 0;
    TimeUs release_at = 0;
    bool press_ok = false;
    bool qualified_io = false;   // a qualifying hold completed in this tick
    bool qualified_bal = false;
    bool io_was_armed = false;
    RobotState bal_was = RobotState::off;

    while (io.now < end) {
      const TimeUs t = io.now + io.step_us;
      // ---- the world ----
      if (rng.below(1000) < 3) target = rng.chance(80) ? rng.uniform(-4.5F, 4.5F) : rng.uniform(-10.0F, 10.0F);
      bal.pitch += std::clamp(target - bal.pitch, -0.08F, 0.08F);  // at most 20 deg/s
      if (rng.below(10000) < 5) {
        io.sticks[4] = us_of(io.sticks[4] < 1500);
        trace.add(t, std::string("ARM switch ") + (io.sticks[4] > 1500 ? "on" : "off"));
      }
      if (rng.below(10000) < 5) {
        io.sticks[5] = us_of(io.sticks[5] < 1500);
        trace.add(t, std::string("CH6 ESTOP ") + (io.sticks[5] > 1500 ? "on" : "off"));
      }
      if (rng.below(1000) < 2) {  // the throttle stick: off centre now and then (arming needs it centred)
        io.sticks[1] = rng.chance(70) ? 1500 : static_cast<std::uint16_t>(rng.range(988, 2012));
        trace.add(t, "throttle " + std::to_string(io.sticks[1]) + " us");
      }
      if (rng.below(10000) < 3) {
        io.gpio.kill = !io.gpio.kill;
        trace.add(t, std::string("kill switch ") + (io.gpio.kill ? "on" : "off"));
      }
      if (rng.below(10000) < 3) {
        io.crsf_on = !io.crsf_on;
        trace.add(t, std::string("CRSF ") + (io.crsf_on ? "on" : "off"));
      }
      if (rng.below(500) < 1) {
        const auto mode = static_cast<std::uint8_t>(rng.range(0, 2));
        bal.can.rx.push_back(std_frame(0x302, {mode}));
        trace.add(t, "0x302 mode " + std::to_string(mode));
      }
      if (rng.below(100) < 2) {
        bal.can.rx.push_back(saulcan::encode(saulcan::VelocityCmd{
            static_cast<std::int16_t>(rng.range(-2000, 2000)), static_cast<std::int16_t>(rng.range(-500, 500))}));
      }
      if (!pressed && rng.chance(2)) {
        pressed = true;
        press_start = t;
        press_ok = true;
        const auto pick = rng.below(10);
        const TimeUs hold = static_cast<TimeUs>(pick < 4 ? rng.range(2950, 3050) : pick < 7 ? rng.range(3000, 4000)
                                                                                          : rng.range(0, 3000)) *
                            1000;
        release_at = t + hold;
        trace.add(t, "button down for " + std::to_string(hold / 1000) + " ms");
      } else if (pressed && t >= release_at) {
        pressed = false;
        trace.add(t, "button up");
      }
      io.gpio.button = pressed;

      // ---- one loop of each board, wired together ----
      io.tick();
      bal.link.feed(io.link.tx);
      io.link.tx.clear();
      const std::size_t mark = bal.can.tx.size();
      bal.tick();
      io.link.feed(bal.link.tx);
      bal.link.tx.clear();

      // ---- oracle ----
      // A qualifying hold: pressed continuously for 3 s, the ARM switch on, the throttle stick centred (within the
      // sticks' 5 us deadband) and BALANCE's own pitch estimate within 5 degrees (+1 for the STATE message's age)
      // the whole time.
      const bool upright = bal.board->pitch_valid() && std::fabs(bal.board->pitch_deg()) <= 6.0F;
      const bool centred = std::abs(static_cast<int>(io.sticks[1]) - 1500) <= 5;
      if (pressed && (!upright || io.sticks[4] < 1500 || !centred)) press_ok = false;
      if (pressed && press_ok && t - press_start >= 3'000'000 && t - press_start < 3'000'000 + io.step_us) {
        qualified_io = qualified_bal = true;
        trace.add(t, "qualifying hold complete");
      }
      const bool io_armed = io.board->armed();
      if (io_armed && !io_was_armed) {
        trace.add(t, "IO armed");
        if (!qualified_io) return "the IO board armed without a qualifying 3 s hold";
        qualified_io = false;
      }
      io_was_armed = io_armed;
      const RobotState st = bal.board->state();
      if (is_armed(st) && !is_armed(bal_was)) {
        trace.add(t, "BALANCE armed (" + name(st) + ")");
        if (!qualified_bal) return "BALANCE armed without a qualifying 3 s hold";
        ++armings;
        qualified_bal = false;
      }
      if (st != bal_was) trace.add(t, "BALANCE " + name(st));
      bal_was = st;
      qualified_io = qualified_bal = false;  // a hold arms in the tick it completes, or not at all
      if (any_nonzero(bal.wheels_since(mark)) && !is_armed(st)) return "a VESC got a non-zero SET_RPM while not armed";
      if (io.board->motors_enabled() && !io_armed) return "the BTS7960s were enabled while the IO board was not armed";
      for (auto [c, v] : io.pwm.log)
        if (c != PwmChannel::headlight && v != 0 && !io_armed) return "BTS7960 PWM while not armed";
    }
    return "";
  });
  CHECK(armings > scenario_count() / 20);  // the generator does reach arming
}

TEST_CASE("invariant: the RC_CMD armed flag rises only after a fresh, continuous 3 s hold (exact conditions)") {
  int rises = 0;
  scenarios(2, [&](Rng& rng, Trace& trace) -> std::string {
    IoRig rig;
    rig.step_us = 8000;  // the logic compares timestamps, so 8 ms steps test the same rule as 1 ms ones
    rig.sticks[4] = us_of(rng.chance(90));
    rig.state.pitch_x100 = static_cast<std::int16_t>(rng.range(-700, 700));
    rig.gpio.button = rng.chance(10);  // sometimes already held at power-on
    bool pressed = rig.gpio.button;
    bool press_ok = false;  // a press held since power-on never counts
    TimeUs press_start = rig.now;
    TimeUs release_at = rig.now + static_cast<TimeUs>(rng.range(0, 4000)) * 1000;
    bool flag = false;
    const TimeUs end = rig.now + static_cast<TimeUs>(rng.range(2500, 5000)) * 1000;
    while (rig.now < end) {
      const TimeUs t = rig.now + rig.step_us;
      if (rng.below(1000) < 2) {
        rig.state.pitch_x100 = static_cast<std::int16_t>(rng.chance(85) ? rng.range(-500, 500) : rng.range(-900, 900));
        trace.add(t, "STATE pitch_x100 " + std::to_string(rig.state.pitch_x100));
      }
      if (rng.below(10000) < 2) {
        rig.sticks[4] = us_of(rig.sticks[4] < 1500);
        trace.add(t, std::string("ARM switch ") + (rig.sticks[4] > 1500 ? "on" : "off"));
      }
      if (rng.below(10000) < 2) {
        rig.sticks[5] = us_of(rig.sticks[5] < 1500);
        trace.add(t, std::string("CH6 ") + (rig.sticks[5] > 1500 ? "on" : "off"));
      }
      if (rng.below(10000) < 1) {
        rig.gpio.kill = !rig.gpio.kill;
        trace.add(t, std::string("kill ") + (rig.gpio.kill ? "on" : "off"));
      }
      if (rng.below(10000) < 1) {
        rig.balance_on = !rig.balance_on;
        trace.add(t, std::string("STATE ") + (rig.balance_on ? "on" : "off"));
      }
      if (rng.below(10000) < 1) {
        rig.crsf_on = !rig.crsf_on;
        trace.add(t, std::string("CRSF ") + (rig.crsf_on ? "on" : "off"));
      }
      if (rng.below(1000) < 1) {
        rig.state.error_state = static_cast<std::uint8_t>(rng.range(0, 5));
        trace.add(t, "STATE error_state " + std::to_string(rig.state.error_state));
      }
      if (!pressed && rng.chance(1)) {
        pressed = true;
        press_ok = true;
        press_start = t;
        const auto pick = rng.below(10);
        release_at = t + static_cast<TimeUs>(pick < 4 ? rng.range(2950, 3050) : pick < 7 ? rng.range(3000, 4000)
                                                                                       : rng.range(0, 3000)) *
                             1000;
        trace.add(t, "button down until " + std::to_string(release_at / 1000));
      } else if (pressed && t >= release_at) {
        pressed = false;
        trace.add(t, "button up");
      }
      rig.gpio.button = pressed;
      const std::size_t mark = rig.link.tx.size();
      rig.tick();
      // The conditions, from what this test delivered: STATE at most 100 ms old with |pitch| <= 5.00 degrees, the
      // newest RC frame at most 100 ms old with the ARM switch on and CH6 off, the kill switch off.
      const auto& s = rig.state_last;
      const bool upright = s.seen && t - s.at <= 100'000 && std::abs(s.state.pitch_x100) <= 500;
      const auto& rx = rig.crsf_last.at >= rig.elrs_last.at ? rig.crsf_last : rig.elrs_last;
      const bool rc_ok = rig.alive(rx) && rx.us[4] > 1500 && rx.us[5] <= 1500;
      if (pressed && (!upright || !rc_ok || rig.gpio.kill)) press_ok = false;
      // the armed flag in the RC_CMD frames sent during this tick, read by hand
      const Bytes sent(rig.link.tx.begin() + static_cast<std::ptrdiff_t>(mark), rig.link.tx.end());
      for (const auto& f : split_ib(sent)) {
        if (f.type != 0x01) continue;
        const bool armed = (f.payload.at(4) & 0x01) != 0;
        if (armed && !flag) {
          trace.add(t, "RC_CMD armed flag rises");
          ++rises;
          if (!pressed || !press_ok || t - press_start < 3'000'000)
            return "the armed flag rose without a qualifying hold (held " + std::to_string((t - press_start) / 1000) +
                   " ms, conditions " + (press_ok ? "kept" : "broken") + ")";
        }
        if (!armed && flag) trace.add(t, "RC_CMD armed flag falls");
        flag = armed;
      }
    }
    return "";
  });
  CHECK(rises > scenario_count() / 20);  // the generator does reach arming
}

TEST_CASE("invariant: a tilt beyond the limit zeroes the motors in the same iteration and stays latched until a "
          "fresh arming") {
  int cutoffs = 0;
  scenarios(3, [&](Rng& rng, Trace& trace) -> std::string {
    BalanceRig rig;
    const auto limit = static_cast<std::uint16_t>(rng.range(500, 2500));
    rig.can.rx.push_back(std_frame(0x303, cat({le16(limit), le16(2000)})));
    trace.add(rig.now, "tilt limit " + std::to_string(limit));
    arm_balance(rig);
    if (rig.board->state() != RobotState::balance) return "could not arm";
    if (rng.chance(50)) {
      rig.can.rx.push_back(std_frame(0x302, {2}));
      rig.orin_on = true;
      rig.velocity = {static_cast<std::int16_t>(rng.range(-1500, 1500)), 0};
    }
    bool latched = false;
    bool disarmed_since = false;
    float target = 0.0F;
    const int ticks = static_cast<int>(rng.range(100, 700));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      if (rng.below(1000) < 5) target = rng.chance(40) ? rng.uniform(-4.0F, 4.0F) : rng.uniform(-80.0F, 80.0F);
      const float move = std::clamp(target - rig.pitch, -0.5F, 0.5F);  // up to 500 deg/s, gyro consistent
      rig.pitch += move;
      rig.rate = move * 1000.0F + (rng.chance(5) ? rng.uniform(-100.0F, 100.0F) : 0.0F);
      const std::uint64_t unarmed_before = rig.rc_sent_unarmed;
      bool disarm_input = false;
      bool explicit_disarm = false;  // 0x302 mode 0 or a console disarm (not the IO armed flag)
      if (rng.below(1000) < 3) {
        rig.rc.flags = static_cast<std::uint8_t>(rig.rc.flags ^ interboard::RcCmd::kArmed);
        trace.add(t, std::string("IO armed flag ") + (rig.rc.armed() ? "1" : "0"));
      }
      if (rng.below(1000) < 2) {
        const bool arm = rng.chance(50);
        rig.type(arm ? "arm" : "disarm");
        disarm_input = !arm;
        explicit_disarm = !arm;
        trace.add(t, arm ? "console arm" : "console disarm");
      }
      if (rng.below(1000) < 2) {
        const auto mode = static_cast<std::uint8_t>(rng.range(0, 2));
        rig.can.rx.push_back(std_frame(0x302, {mode}));
        disarm_input = disarm_input || mode == 0;
        explicit_disarm = explicit_disarm || mode == 0;
        trace.add(t, "0x302 mode " + std::to_string(mode));
      }
      const RobotState before = rig.board->state();
      const Wheels wheels = step(rig);
      disarm_input = disarm_input || rig.rc_sent_unarmed != unarmed_before;
      const RobotState st = rig.board->state();
      const float est = rig.board->pitch_deg();
      const bool beyond = std::fabs(est) * 100.0F > static_cast<float>(limit);
      if (st != before) trace.add(t, name(before) + " -> " + name(st) + " at pitch " + std::to_string(est));
      if (is_armed(before) && beyond) {
        const bool disarmed_first = disarm_input && st == RobotState::off;  // a disarm earlier in the same step
        if (st != RobotState::tilt_cutoff && !disarmed_first)
          return "pitch beyond the limit while armed, but state " + name(st);
        if (wheels.empty() || any_nonzero(wheels)) return "the cutoff step did not send SET_RPM 0 to both wheels";
      }
      if (st == RobotState::tilt_cutoff && before != RobotState::tilt_cutoff) {
        if (!beyond || !is_armed(before)) return "TILT_CUTOFF without a tilt beyond the limit while armed";
        latched = true;
        disarmed_since = false;
        ++cutoffs;
      } else if (latched && disarm_input && (st == RobotState::tilt_cutoff || st == RobotState::off)) {
        disarmed_since = true;
      }
      // An explicit disarm takes TILT_CUTOFF to OFF (the safety decisions of docs/protocol.md); nothing else does.
      if (before == RobotState::tilt_cutoff && st == RobotState::off && !explicit_disarm)
        return "left TILT_CUTOFF for OFF without an explicit disarm";
      if (latched && is_armed(st)) {
        if (!disarmed_since) return "left TILT_CUTOFF without a disarm first";
        if (std::fabs(est) > 5.0F) return "re-armed while not upright";
        latched = false;
      }
      if (latched && any_nonzero(wheels)) return "non-zero SET_RPM while latched in TILT_CUTOFF";
      if (!is_armed(st) && any_nonzero(wheels)) return "non-zero SET_RPM while not armed";
    }
    return "";
  });
  CHECK(cutoffs > scenario_count() / 4);
}

TEST_CASE("invariant: a hang longer than 50 ms cuts the motors (watchdog); every loop that ran feeds it, and a "
          "silent IMU is a latched FAULT, not a reboot loop") {
  int resets = 0;
  int hang_latches = 0;
  scenarios(4, [&](Rng& rng, Trace& trace) -> std::string {
    BalanceRig rig;
    const bool hardware_watchdog = rng.chance(70);  // else: a simulator without one, the logic must cope alone
    arm_balance(rig);
    if (rng.chance(50)) {
      rig.can.rx.push_back(std_frame(0x302, {2}));
      rig.orin_on = true;
      rig.velocity = {static_cast<std::int16_t>(rng.range(-1500, 1500)), 0};
    }
    bool rebooted = false;
    bool latched_fault = false;
    TimeUs imu_back_at = 0;
    bool starting = false;  // after a reset, until the IMU's first sample: BalanceConfig::imu_startup_us of grace
    TimeUs boot_at = 0;
    const auto reboot = [&](TimeUs at) {
      trace.add(at, "watchdog fires: reset");
      ++resets;
      rig.idle(static_cast<TimeUs>(rng.range(5, 60)) * 1000);  // boot time; FIFOs are lost in a reset
      rig.imu.queue.clear();
      rig.link.rx.clear();
      rig.can.rx.clear();
      rig.boot(ResetReason::watchdog);
      rig.watchdog.last_feed = rig.now;  // the watchdog restarts with the chip
      rebooted = true;
      starting = true;
      boot_at = rig.now;
    };
    const int ticks = static_cast<int>(rng.range(100, 500));
    for (int i = 0; i < ticks; ++i) {
      TimeUs t = rig.now + 1000;
      if (rng.below(1000) < 15) {  // the loop hangs
        const auto hang = static_cast<TimeUs>(rng.range(1, 150)) * 1000;
        trace.add(t, "loop hangs " + std::to_string(hang / 1000) + " ms");
        const bool was_armed = is_armed(rig.board->state());
        const TimeUs hang_start = rig.now;
        for (TimeUs ms = 0; ms < hang; ms += 1000) {
          rig.idle(1000);
          if (hardware_watchdog && rig.now - rig.watchdog.last_feed > 50'000) {
            reboot(rig.now);
            break;
          }
        }
        t = rig.now + 1000;
        if (!hardware_watchdog && !rebooted && was_armed && t - hang_start > 50'000) {
          const Wheels w = step(rig);
          if (rig.board->state() != RobotState::fault) return "a 50+ ms hang was not latched as FAULT";
          if (w.empty() || any_nonzero(w)) return "the step after a 50+ ms hang did not send SET_RPM 0";
          latched_fault = true;
          ++hang_latches;
          continue;
        }
      }
      if (rng.below(1000) < 15 && rig.imu_on) {
        imu_back_at = t + static_cast<TimeUs>(rng.range(1, 150)) * 1000;
        rig.imu_on = false;
        trace.add(t, "IMU silent until " + std::to_string(imu_back_at / 1000));
      }
      if (!rig.imu_on && t >= imu_back_at) {
        rig.imu_on = true;
        trace.add(t, "IMU back");
      }
      if (rebooted && rng.below(1000) < 5) {
        trace.add(t, "fresh arming attempt");
        rig.arm_via_io();
        if (is_armed(rig.board->state())) rebooted = latched_fault = false;
        continue;
      }
      const std::uint64_t feeds = rig.watchdog.feeds;
      const Wheels w = step(rig);
      const bool imu_silent = rig.now - rig.last_imu_us > 10'000 || !rig.imu_on;
      const bool fed = rig.watchdog.feeds != feeds;
      if (starting && rig.imu_on) starting = false;
      const bool grace = starting && rig.now - boot_at <= 500'000;
      if (!fed) return "a loop that ran did not feed the watchdog";
      if (!grace && rig.now - rig.last_imu_us > 10'000) {  // silent for over imu_stall_us: FAULT, latched, says why
        const RobotState st = rig.board->state();
        if (st != RobotState::fault && st != RobotState::estop && st != RobotState::tilt_cutoff)
          return "the IMU silent for over 10 ms, yet state " + name(st);
        if ((rig.board->faults() & fault::kWatchdogReset) == 0) return "the IMU silent, yet no watchdog_reset bit";
      }
      if (imu_silent && !grace && rig.now - rig.last_imu_us > 10'000 && any_nonzero(w))
        return "non-zero SET_RPM while the IMU is silent";
      if ((rebooted || latched_fault) && any_nonzero(w)) return "non-zero SET_RPM after a hang, before a fresh arming";
      if (rebooted && !is_armed(rig.board->state())) {
        if (rig.board->state() != RobotState::fault && rig.board->state() != RobotState::off)
          return "after the watchdog reset the state is " + name(rig.board->state());
        if (rig.board->state() == RobotState::fault && (rig.board->faults() & fault::kWatchdogReset) == 0)
          return "watchdog_reset bit missing after the reset";
      }
      if (hardware_watchdog && rig.now - rig.watchdog.last_feed > 50'000) reboot(rig.now);
    }
    return "";
  });
  CHECK(resets > scenario_count() / 10);
  CHECK(hang_latches > scenario_count() / 20);
}

TEST_CASE("invariant: ESTOP (RC kill flag, FAULT estop, CAN mode 3, console) wins over every other input, every "
          "iteration (BALANCE)") {
  int stops_while_armed = 0;
  scenarios(5, [&](Rng& rng, Trace& trace) -> std::string {
    BalanceRig rig;
    if (rng.chance(80)) arm_balance(rig);
    rig.orin_on = rng.chance(50);
    rig.velocity = {static_cast<std::int16_t>(rng.range(-1500, 1500)), static_cast<std::int16_t>(rng.range(-300, 300))};
    rig.rc.throttle = static_cast<std::int16_t>(rng.range(-1000, 1000));
    bool in_estop = false;
    bool disarmed_since = false;
    const int ticks = static_cast<int>(rng.range(100, 500));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      bool console_estop = false;
      bool mode3 = false;
      bool disarm_input = false;
      bool explicit_disarm = false;  // 0x302 mode 0 or a console disarm (not the IO armed flag)
      const std::uint64_t kills = rig.rc_sent_kill;  // counted from before this iteration's inputs
      const std::uint64_t fault_estops = rig.fault_sent_estop;
      const std::uint64_t unarmed = rig.rc_sent_unarmed;
      if (rng.below(1000) < 20) {
        rig.rc.flags = static_cast<std::uint8_t>(rig.rc.flags ^ interboard::RcCmd::kArmed);
        trace.add(t, std::string("IO armed flag ") + (rig.rc.armed() ? "1" : "0"));
        if (rng.chance(50)) rig.send_rc(rig.rc);
      }
      if (rng.below(1000) < 5) {
        rig.rc.flags = static_cast<std::uint8_t>(rig.rc.flags | interboard::RcCmd::kKill);
        trace.add(t, "RC kill on");
      } else if (rig.rc.kill() && rng.below(1000) < 30) {
        rig.rc.flags = static_cast<std::uint8_t>(rig.rc.flags & ~interboard::RcCmd::kKill);
        trace.add(t, "RC kill off");
      }
      if (rng.below(1000) < 5) {
        rig.io_faults = static_cast<std::uint8_t>(rig.io_faults ^ interboard::Fault::kEstop);
        trace.add(t, std::string("FAULT estop bit ") + ((rig.io_faults & 4) ? "1" : "0"));
        rig.send_fault(rig.io_faults);
      }
      if (rng.below(1000) < 10) {
        const auto mode = static_cast<std::uint8_t>(rng.range(0, 4));
        rig.can.rx.push_back(std_frame(0x302, {mode}));
        mode3 = mode3 || mode == 3;
        disarm_input = disarm_input || mode == 0;
        explicit_disarm = explicit_disarm || mode == 0;
        trace.add(t, "0x302 mode " + std::to_string(mode));
      }
      if (rng.below(1000) < 10) {
        static const char* const kLines[] = {"arm", "disarm", "estop", "status", "speed_limit 20", "pid 1 0 0"};
        const std::string line = kLines[rng.below(6)];
        rig.type(line);
        console_estop = console_estop || line == "estop";
        disarm_input = disarm_input || line == "disarm";
        explicit_disarm = explicit_disarm || line == "disarm";
        trace.add(t, "console " + line);
      }
      if (rng.below(100) < 3) rig.pitch = rng.uniform(-4.0F, 4.0F);
      const RobotState before = rig.board->state();
      const bool disarmed_before = disarmed_since;
      const Wheels w = step(rig);
      const RobotState st = rig.board->state();
      if (st != before) trace.add(t, name(before) + " -> " + name(st));
      const bool estop_input =
          console_estop || mode3 || rig.rc_sent_kill != kills || rig.fault_sent_estop != fault_estops;
      disarm_input = disarm_input || rig.rc_sent_unarmed != unarmed;
      const bool estop_level = rig.last_rc_kill || rig.last_fault_estop;  // what BALANCE has been told last
      if (estop_input) {
        if (st != RobotState::estop) return "an estop input in this iteration, yet state " + name(st);
        if (any_nonzero(w)) return "non-zero SET_RPM in an iteration with an estop input";
        if (is_armed(before) && w.empty()) return "armed before the estop, but no SET_RPM 0 in that iteration";
        in_estop = true;
        disarmed_since = disarm_input;  // a disarm in the same iteration may have come after the estop
        if (is_armed(before)) ++stops_while_armed;
      } else if (in_estop && disarm_input) {
        disarmed_since = true;
      }
      if (estop_level && is_armed(st)) return "armed while an estop input is still active";
      if (in_estop && is_armed(st)) {
        if (!disarmed_since) return "left ESTOP without a disarm";
        in_estop = false;
      }
      // An explicit disarm (0x302 mode 0, console disarm) takes ESTOP to OFF when no estop input is active any more
      // (the safety decisions of docs/protocol.md); or an arming and a disarm within this one iteration.
      if (in_estop && st == RobotState::off && !estop_input && !estop_level &&
          (explicit_disarm || (disarm_input && disarmed_before)))
        in_estop = false;
      if (in_estop && st != RobotState::estop) return "ESTOP left for " + name(st) + " without an arming";
      if (!is_armed(st) && any_nonzero(w)) return "non-zero SET_RPM while not armed";
    }
    return "";
  });
  CHECK(stops_while_armed > scenario_count() / 4);
}

TEST_CASE("invariant: ESTOP (kill switch, CH6 of any live receiver, console) is checked first in every iteration "
          "(IO)") {
  int stops_while_driving = 0;
  scenarios(6, [&](Rng& rng, Trace& trace) -> std::string {
    IoRig rig;
    rig.sticks[4] = 2000;
    rig.sticks[6] = static_cast<std::uint16_t>(rng.range(988, 2012));
    rig.elrs_on = rng.chance(50);
    rig.run_ms(50);
    if (rng.chance(70)) {  // armed and driving
      rig.sticks[1] = static_cast<std::uint16_t>(rng.range(988, 2012));
      if (!rig.arm_quickly()) return "could not arm";
    }
    bool was_estop = false;
    TimeUs console_estop_at = 0;
    bool console_estop = false;
    const int ticks = static_cast<int>(rng.range(100, 600));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      if (rng.below(1000) < 5) {
        rig.gpio.kill = !rig.gpio.kill;
        trace.add(t, std::string("kill ") + (rig.gpio.kill ? "on" : "off"));
      }
      if (rng.below(1000) < 5) {
        rig.sticks[5] = us_of(rig.sticks[5] < 1500);
        trace.add(t, std::string("CH6 ") + (rig.sticks[5] > 1500 ? "on" : "off"));
      }
      if (rng.below(100) < 3) {
        rig.sticks[1] = static_cast<std::uint16_t>(rng.range(988, 2012));
        rig.sticks[0] = static_cast<std::uint16_t>(rng.range(988, 2012));
      }
      if (rng.below(1000) < 3) {
        rig.crsf_on = !rig.crsf_on;
        trace.add(t, std::string("CRSF ") + (rig.crsf_on ? "on" : "off"));
      }
      if (rng.below(1000) < 3) {
        rig.elrs_on = !rig.elrs_on;
        trace.add(t, std::string("ELRS ") + (rig.elrs_on ? "on" : "off"));
      }
      if (rng.below(1000) < 10) {
        rig.gpio.button = !rig.gpio.button;
        trace.add(t, std::string("button ") + (rig.gpio.button ? "down" : "up"));
      }
      if (rng.below(1000) < 2) {
        rig.console.feed(std::string("estop\n"));
        console_estop = true;
        console_estop_at = t;
        trace.add(t, "console estop");
      }
      const std::size_t mark = rig.link.tx.size();
      const bool driving = rig.board->motors_enabled();
      rig.tick();
      if (console_estop && t - console_estop_at > 500'000) console_estop = false;
      const bool ch6 = (rig.alive(rig.crsf_last) && rig.crsf_last.us[5] > 1500) ||
                       (rig.alive(rig.elrs_last) && rig.elrs_last.us[5] > 1500);
      const bool estop = rig.gpio.kill || ch6 || console_estop;
      if (estop) {
        if (!rig.motors_off()) return "ESTOP active but the BTS7960 outputs are on";
        if (!io_wrote_no_drive(rig)) return "a drive output was written in an iteration with ESTOP active";
        if (rig.board->armed()) return "still armed during ESTOP";
        if (!was_estop) {
          // The kill switch and CH6 are looked at before anything else is sent: FAULT(estop) is the first frame.
          // A console estop is read later in the iteration: FAULT(estop) in it, and no RC_CMD after it without kill.
          const Bytes sent(rig.link.tx.begin() + static_cast<std::ptrdiff_t>(mark), rig.link.tx.end());
          const auto frames = split_ib(sent);
          const auto is_estop_fault = [](const IbFrame& f) { return f.type == 0x03 && (f.payload.at(0) & 0x04) != 0; };
          if (rig.gpio.kill || ch6) {
            if (frames.empty() || !is_estop_fault(frames[0]))
              return "the first frame to BALANCE in the ESTOP iteration is not FAULT(estop)";
          } else {
            bool fault_seen = false;
            for (const auto& f : frames) {
              fault_seen = fault_seen || is_estop_fault(f);
              if (fault_seen && f.type == 0x01 && (f.payload.at(4) & 0x02) == 0)
                return "an RC_CMD without the kill flag after FAULT(estop)";
            }
            if (!fault_seen) return "no FAULT(estop) in the console estop iteration";
          }
          trace.add(t, "ESTOP");
          if (driving) ++stops_while_driving;
        }
      }
      was_estop = estop;
    }
    return "";
  });
  CHECK(stops_while_driving > scenario_count() / 10);
}

TEST_CASE("invariant: 500 ms without 0x300 -> orin_timeout and RC-only driving, the Orin drives while fresh") {
  scenarios(7, [](Rng& rng, Trace& trace) -> std::string {
    BalanceRig rig;
    arm_balance(rig);
    rig.can.rx.push_back(std_frame(0x302, {2}));  // MANUAL: the wheel speed is the drive command itself
    rig.rc.throttle = static_cast<std::int16_t>(rng.range(-100, 100));
    rig.run_ms(2);
    if (rig.board->state() != RobotState::manual) return "could not reach MANUAL";
    bool seen = false;
    TimeUs last = 0;
    std::int16_t speed = 0;
    bool chatty = rng.chance(50);
    TimeUs switch_at = rig.now + static_cast<TimeUs>(rng.range(10, 800)) * 1000;
    const int ticks = static_cast<int>(rng.range(200, 1500));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      if (t >= switch_at) {
        chatty = !chatty;
        switch_at = t + static_cast<TimeUs>(rng.range(10, 800)) * 1000;
        trace.add(t, chatty ? "Orin talks" : "Orin silent");
      }
      if (chatty && rng.chance(5)) {
        speed = static_cast<std::int16_t>(rng.range(-300, 300));
        rig.can.rx.push_back(saulcan::encode(saulcan::VelocityCmd{speed, 0}));
        seen = true;
        last = t;
      }
      if (rng.below(1000) < 5) {
        rig.rc.throttle = static_cast<std::int16_t>(rng.range(-150, 150));
        trace.add(t, "RC throttle " + std::to_string(rig.rc.throttle));
      }
      const std::size_t mark = rig.can.tx.size();
      const Wheels w = step(rig);
      const bool fresh = seen && t - last <= 500'000;
      if (rig.board->orin_active() != fresh)
        return std::string("orin_active ") + (fresh ? "expected" : "not expected") + " at " +
               std::to_string((t - last) / 1000) + " ms after the last 0x300";
      for (const auto& f : rig.frames_with_id(0x401, mark))
        if (((f.data[6] & fault::kOrinTimeout) != 0) == fresh) return "0x401 orin_timeout bit wrong";
      // the wheels follow the Orin while fresh, else the RC throttle (permille of 2000 mm/s); cap 200 mm/s
      std::int32_t mmps = fresh ? speed : rig.rc.throttle * 2;
      mmps = std::clamp(mmps, -200, 200);
      const std::int32_t erpm = mmps * 60 * 7 / 628;
      for (auto [l, r] : w)
        if (l != erpm || r != erpm)
          return "SET_RPM " + std::to_string(l) + "/" + std::to_string(r) + ", expected " + std::to_string(erpm) +
                 (fresh ? " (Orin)" : " (RC only)");
      if (rig.board->state() != RobotState::manual) return "left MANUAL: " + name(rig.board->state());
    }
    return "";
  });
}

TEST_CASE("invariant: RC silent for more than 100 ms -> the IO board cuts its drivers and sends FAULT(rc_loss) in "
          "that iteration") {
  scenarios(8, [](Rng& rng, Trace& trace) -> std::string {
    IoRig rig;
    rig.sticks[4] = 2000;
    rig.sticks[6] = 2012;
    rig.sticks[1] = 1759;
    rig.elrs_on = rng.chance(60);
    rig.run_ms(50);
    if (!rig.arm_quickly()) return "could not arm";
    bool was_loss = false;
    const int ticks = static_cast<int>(rng.range(100, 800));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      if (rng.below(1000) < 8) {
        rig.crsf_on = !rig.crsf_on;
        trace.add(t, std::string("CRSF ") + (rig.crsf_on ? "on" : "off"));
      }
      if (rng.below(1000) < 8) {
        rig.elrs_on = !rig.elrs_on;
        trace.add(t, std::string("ELRS ") + (rig.elrs_on ? "on" : "off"));
      }
      const std::size_t mark = rig.link.tx.size();
      rig.tick();
      const bool loss = !rig.alive(rig.crsf_last) && !rig.alive(rig.elrs_last);
      if (rig.board->rc_loss() != loss) return std::string("rc_loss ") + (loss ? "expected" : "not expected");
      if (loss) {
        if (!rig.motors_off()) return "RC lost but the BTS7960 outputs are on";
        if (rig.board->armed()) return "RC lost but still armed";
        if (!was_loss) {
          trace.add(t, "RC lost");
          const Bytes sent(rig.link.tx.begin() + static_cast<std::ptrdiff_t>(mark), rig.link.tx.end());
          bool reported = false;
          for (const auto& f : split_ib(sent))
            if (f.type == 0x03 && (f.payload.at(0) & 0x01) != 0) reported = true;
          if (!reported) return "no FAULT(rc_loss) in the iteration that saw the loss";
        }
      }
      was_loss = loss;
    }
    return "";
  });
}

TEST_CASE("invariant: FAULT(rc_loss) while armed -> BALANCE latches FAULT and zeroes the wheels in that iteration") {
  scenarios(9, [](Rng& rng, Trace& trace) -> std::string {
    BalanceRig rig;
    const bool armed = rng.chance(80);
    if (armed) arm_balance(rig);
    rig.orin_on = true;
    rig.velocity = {static_cast<std::int16_t>(rng.range(-1500, 1500)), static_cast<std::int16_t>(rng.range(-300, 300))};
    rig.run_ms(static_cast<int>(rng.range(1, 200)));
    const RobotState before = rig.board->state();
    trace.add(rig.now + 1000, "FAULT(rc_loss) in state " + name(before));
    rig.io_faults = interboard::Fault::kRcLoss;
    rig.send_fault(rig.io_faults);
    Wheels w = step(rig);
    if (is_armed(before)) {
      if (rig.board->state() != RobotState::fault) return "not FAULT after rc_loss while armed";
      if ((rig.board->faults() & fault::kRcLoss) == 0) return "rc_loss bit missing";
      if (w.empty() || any_nonzero(w)) return "no SET_RPM 0 in the iteration that saw rc_loss";
    }
    for (int i = 0; i < 200; ++i) {
      if (rng.chance(2)) {
        rig.io_faults = 0;  // RC back: still latched
        rig.send_fault(0);
      }
      w = step(rig);
      if (any_nonzero(w)) return "non-zero SET_RPM after rc_loss without a fresh arming";
    }
    return "";
  });
}

TEST_CASE("invariant: no RC_CMD for more than 100 ms (IO link loss) -> FAULT latched and wheels zero in that "
          "iteration") {
  scenarios(10, [](Rng& rng, Trace& trace) -> std::string {
    BalanceRig rig;
    arm_balance(rig);
    rig.orin_on = rng.chance(50);
    rig.velocity = {static_cast<std::int16_t>(rng.range(-1500, 1500)), 0};
    bool latched = false;
    TimeUs switch_at = rig.now + static_cast<TimeUs>(rng.range(10, 300)) * 1000;
    const int ticks = static_cast<int>(rng.range(100, 600));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      if (t >= switch_at) {
        rig.io_on = !rig.io_on;
        switch_at = t + static_cast<TimeUs>(rng.range(1, 250)) * 1000;
        trace.add(t, std::string("IO link ") + (rig.io_on ? "up" : "down"));
      }
      const RobotState before = rig.board->state();
      const Wheels w = step(rig);
      const RobotState st = rig.board->state();
      const TimeUs silent = t - rig.last_rc_sent;
      if (is_armed(before) && silent > 100'000) {
        if (st != RobotState::fault) return "no RC_CMD for " + std::to_string(silent / 1000) + " ms, state " + name(st);
        if ((rig.board->faults() & fault::kIoLinkLoss) == 0) return "io_link_loss bit missing";
        if (w.empty() || any_nonzero(w)) return "no SET_RPM 0 in the iteration that saw the link loss";
        trace.add(t, "FAULT");
        latched = true;
      }
      if (st == RobotState::fault && before != RobotState::fault && silent <= 100'000)
        return "FAULT with an RC_CMD only " + std::to_string(silent / 1000) + " ms old";
      if (latched && any_nonzero(w)) return "non-zero SET_RPM after the link loss without a fresh arming";
    }
    return "";
  });
}

TEST_CASE("invariant: the wheel speed never exceeds the cap (10 % at power-on, raised 10 % at a time, lowered by "
          "0x303)") {
  scenarios(11, [](Rng& rng, Trace& trace) -> std::string {
    BalanceConfig config;
    config.gains = {rng.uniform(0.0F, 400.0F), rng.uniform(0.0F, 50.0F), rng.uniform(0.0F, 20.0F)};
    BalanceRig rig(config);
    if (rig.board->speed_limit_pct() != 10) return "speed limit not 10 % at power-on";
    arm_balance(rig);
    if (rng.chance(50)) rig.can.rx.push_back(std_frame(0x302, {2}));
    rig.orin_on = rng.chance(60);
    int pct = 10;
    int orin_max = 0xFFFF;
    const int ticks = static_cast<int>(rng.range(100, 600));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      std::string line;
      if (rng.below(1000) < 10) {  // disarm, or a fresh arming by the IO board
        rig.rc.flags = static_cast<std::uint8_t>(rig.rc.flags ^ interboard::RcCmd::kArmed);
        rig.send_rc(rig.rc);
        trace.add(t, std::string("IO armed flag ") + (rig.rc.armed() ? "1" : "0"));
      }
      if (rng.below(1000) < 20) {
        line = "speed_limit " + std::to_string(10 * rng.range(1, 10));
        rig.type(line);
      }
      int requested_max = -1;
      if (rng.below(1000) < 5) {
        requested_max = static_cast<int>(rng.range(0, 3000));
        rig.can.rx.push_back(std_frame(0x303, cat({le16(2500), le16(requested_max)})));
        trace.add(t, "0x303 max speed " + std::to_string(requested_max));
      }
      if (rng.below(100) < 5) {
        rig.velocity = {static_cast<std::int16_t>(rng.range(-32768, 32767)),
                        static_cast<std::int16_t>(rng.range(-2000, 2000))};
      }
      if (rng.below(100) < 3) {
        rig.rc.throttle = static_cast<std::int16_t>(rng.range(-1000, 1000));
        rig.rc.steer = static_cast<std::int16_t>(rng.range(-1000, 1000));
      }
      if (rng.below(100) < 3) rig.pitch = rng.uniform(-4.5F, 4.5F);
      rig.rate = rng.chance(10) ? rng.uniform(-200.0F, 200.0F) : 0.0F;
      rig.console.tx.clear();
      const std::size_t mark = rig.can.tx.size();
      const Wheels w = step(rig);
      if (!line.empty()) {
        const int asked = std::stoi(line.substr(12));
        const bool ok = rig.console.text() == "ok\n";
        const bool armed = is_armed(rig.board->state());  // nothing changes the state after the console
        trace.add(t, line + (ok ? " -> ok" : " -> refused") + (armed ? " (armed)" : " (disarmed)"));
        if (ok && asked > pct + 10) return "the speed limit rose by more than one 10 % step";
        if (ok && asked > pct && armed) return "the speed limit rose while armed";
        if (!ok && (asked <= pct || (asked <= pct + 10 && !armed))) return "a legal speed limit was refused";
        if (ok) pct = asked;
      }
      if (requested_max >= 0 && !rig.frames_with_id(0x402, mark).empty()) orin_max = requested_max;
      if (rig.board->speed_limit_pct() != pct) return "speed limit percentage differs from what was accepted";
      const int cap = std::min(2000 * pct / 100, orin_max);
      const std::int32_t cap_erpm = static_cast<std::int32_t>(static_cast<std::int64_t>(cap) * 60 * 7 / 628);
      for (auto [l, r] : w)
        if (std::abs(l) > cap_erpm || std::abs(r) > cap_erpm)
          return "SET_RPM " + std::to_string(l) + "/" + std::to_string(r) + " above the cap of " +
                 std::to_string(cap_erpm) + " ERPM (" + std::to_string(cap) + " mm/s)";
    }
    return "";
  });
}

TEST_CASE("invariant: out-of-range or non-finite tuning and config are rejected, whole") {
  scenarios(12, [](Rng& rng, Trace& trace) -> std::string {
    BalanceRig rig;
    rig.run_ms(10);
    const auto random_gain = [&]() -> float {
      switch (rng.below(8)) {
        case 0: return std::numeric_limits<float>::quiet_NaN();
        case 1: return std::numeric_limits<float>::infinity();
        case 2: return -std::numeric_limits<float>::infinity();
        case 3: return -rng.uniform(0.0F, 100.0F) - 1e-6F;
        case 4: return 0.0F;
        default: return rng.uniform(0.0F, 100.0F);
      }
    };
    const auto good = [](float g) { return std::isfinite(g) && g >= 0.0F; };
    // every value sent per (sequence, index) since the set began: a set is "clean" if all were good
    std::array<std::array<float, 3>, 256> sent{};
    std::array<std::uint8_t, 256> have{};
    auto gains = rig.board->gains();
    auto tilt = rig.board->tilt_limit_x100();
    std::uint8_t seq = static_cast<std::uint8_t>(rng.below(256));
    const int ticks = static_cast<int>(rng.range(50, 400));
    for (int i = 0; i < ticks; ++i) {
      const TimeUs t = rig.now + 1000;
      if (rng.below(100) < 10) {
        if (rng.chance(30)) {
          seq = static_cast<std::uint8_t>(seq + 1);
          have[seq] = 0;
        }
        const auto index = static_cast<std::uint8_t>(rng.below(3));
        const float g = random_gain();
        sent[seq][index] = g;
        have[seq] = static_cast<std::uint8_t>(have[seq] | (1U << index));
        rig.can.rx.push_back(saulcan::encode(saulcan::PidGain{static_cast<saulcan::Gain>(index), seq, g}));
        trace.add(t, "0x301 seq " + std::to_string(seq) + " index " + std::to_string(index) + " = " + std::to_string(g));
      }
      int tilt_sent = -1;
      if (rng.below(100) < 3) {
        tilt_sent = static_cast<int>(rng.chance(50) ? rng.range(0, 3000) : rng.range(0, 65535));
        rig.can.rx.push_back(std_frame(0x303, cat({le16(tilt_sent), le16(1000)})));
        trace.add(t, "0x303 tilt " + std::to_string(tilt_sent));
      }
      std::string line;
      if (rng.below(100) < 2) {
        static const char* const kWords[] = {"1.5", "0", "-0.5", "nan", "inf", "1e39", "-inf", "2e-3", "abc"};
        line = std::string("pid ") + kWords[rng.below(9)] + " " + kWords[rng.below(9)] + " " + kWords[rng.below(9)];
      } else if (rng.below(100) < 2) {
        static const char* const kTilts[] = {"4.99", "5", "12.345", "25", "25.01", "nan", "-10", "30"};
        line = std::string("tilt_limit ") + kTilts[rng.below(8)];
      }
      if (!line.empty()) {
        rig.type(line);
        trace.add(t, "console " + line);
      }
      rig.console.tx.clear();
      const std::size_t mark = rig.can.tx.size();
      rig.tick();
      const bool console_ok = rig.console.text() == "ok\n";
      // acknowledgements of 0x301: applied only for a set whose every value was finite and not negative
      bool applied = false;
      for (const auto& ack : rig.frames_with_id(0x402, mark)) {
        if (ack.data[0] == 0x01 && ack.data[2] == 0x00) {
          const std::uint8_t s = ack.data[1];
          if (have[s] != 0x7) return "0x301 set " + std::to_string(s) + " applied without all three gains";
          for (float g : sent[s])
            if (!good(g)) return "0x301 set " + std::to_string(s) + " applied with a bad gain";
          applied = true;
          gains = {sent[s][0], sent[s][1], sent[s][2]};
        }
        if (ack.data[0] == 0x03) {
          const bool in_range = tilt_sent >= 500 && tilt_sent <= 2500;
          if ((ack.data[2] == 0x00) != in_range) return "0x303 tilt " + std::to_string(tilt_sent) + " wrongly acked";
          if (in_range) tilt = static_cast<std::uint16_t>(tilt_sent);
        }
      }
      if (line.rfind("pid", 0) == 0 && console_ok) {
        gains = rig.board->gains();
        if (!good(gains.kp) || !good(gains.ki) || !good(gains.kd)) return "console pid applied a bad gain";
      }
      if (line.rfind("tilt_limit", 0) == 0 && console_ok) tilt = rig.board->tilt_limit_x100();
      if (!(rig.board->gains() == gains)) return applied ? "applied gains differ from the set" : "gains changed without an ack";
      if (rig.board->tilt_limit_x100() != tilt) return "tilt limit changed without being accepted";
      if (tilt < 500 || tilt > 2500) return "tilt limit outside 5..25 degrees";
    }
    return "";
  });
}
