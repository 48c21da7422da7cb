// The simulated robot must need balancing (issue 17): the plant's disturbances (QMI8658 noise and offsets, a stand
// that lets go slightly off balance, the floor) make it fall within 2 s with zero gains on every seed, the shipped
// sim gains hold it for 60 s on every seed, tilt/push move the body through the dynamics so the gyro sees them,
// BALANCE follows the Orin's 0x300 speed through its speed loop, and an out-of-range request saturates without
// tipping it. Both boards' real logic on firmware/sim's World, simulated time.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "saulproto/core/dispatch.hpp"
#include "saulsim/world.hpp"

using saul::CanFrame;
using saul::fw::TimeUs;
using saul::saulcan::RobotState;
namespace saulcan = saul::saulcan;
namespace sim = saul::sim;

namespace {

constexpr int kSeeds = 20;

/// Raises the speed cap to cap_pct (console, disarmed, one 10 % step at a time), then the 3 s button hold; returns
/// the time BALANCE was entered, or 0 when it was not.
TimeUs arm(sim::World& w, int cap_pct = 10) {
  w.run_until(1'000'000);  // BALANCE reports itself upright to IO first
  for (int pct = 20; pct <= cap_pct; pct += 10) {
    w.console_input("balance", "speed_limit " + std::to_string(pct) + "\n");
    w.run_until(w.now_us() + 20'000);
  }
  w.command("button down");
  const TimeUs give_up = w.now_us() + 4'000'000;
  while (w.balance().state() != RobotState::balance && w.now_us() < give_up) w.step();
  const TimeUs armed = w.balance().state() == RobotState::balance ? w.now_us() : 0;
  w.command("button up");
  return armed;
}

/// 0x400 speeds (mm/s) seen in the frames since the last call.
std::vector<int> telemetry_speeds(sim::World& w) {
  std::vector<int> out;
  for (const CanFrame& f : w.take_can_output()) {
    const auto m = saul::decode_bus_frame(f);
    if (!m) continue;
    if (const auto* a = std::get_if<saulcan::TelemetryA>(&m.value())) out.push_back(a->speed_mmps);
  }
  return out;
}

std::string seconds(TimeUs us) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", static_cast<double>(us) / 1e6);
  return buf;
}

}  // namespace

TEST_CASE("plant: with zero gains the robot falls within 2 s of the stand letting go, on every seed") {
  std::string times;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    sim::WorldConfig config;
    config.plant.seed = static_cast<std::uint32_t>(seed);
    config.balance.gains = {0.0F, 0.0F, 0.0F};
    sim::World w(config);
    const TimeUs armed = arm(w);
    REQUIRE(armed != 0);
    while (w.plant().on_stand() && w.now_us() < armed + 1'000'000) w.step();
    REQUIRE_FALSE(w.plant().on_stand());
    const TimeUs released = w.now_us();
    while (w.balance().state() == RobotState::balance && w.now_us() < released + 2'000'000) w.step();
    INFO("seed " << seed << ": " << w.status_line());
    CHECK(w.balance().state() == RobotState::tilt_cutoff);
    times += " " + std::to_string(seed) + ":" + seconds(w.now_us() - released);
  }
  WARN("zero gains, seconds from the stand letting go to TILT_CUTOFF per seed:" << times);
}

TEST_CASE("plant: the shipped sim gains hold balance for 60 s on every seed (|pitch| < 5 deg, within the 10 % cap)") {
  std::string report;
  const auto start = std::chrono::steady_clock::now();
  TimeUs simulated = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    sim::WorldConfig config;
    config.plant.seed = static_cast<std::uint32_t>(seed);
    sim::World w(config);
    const TimeUs armed = arm(w);
    REQUIRE(armed != 0);
    double worst_pitch = 0;
    double worst_speed = 0;
    while (w.balance().state() == RobotState::balance && w.now_us() < armed + 60'000'000) {
      w.step();
      worst_pitch = std::max(worst_pitch, std::fabs(w.plant().pitch_deg()));
      worst_speed = std::max(worst_speed, std::fabs(w.plant().speed_mps()));
      (void)w.take_can_output();
    }
    simulated += w.now_us();
    INFO("seed " << seed << ": " << w.status_line());
    CHECK(w.balance().state() == RobotState::balance);
    CHECK(w.now_us() >= armed + 60'000'000);
    CHECK(worst_pitch < 5.0);
    CHECK(worst_speed < 0.2);
    char line[96];
    std::snprintf(line, sizeof line, " %d:%.2fdeg/%.0fmm/s", seed, worst_pitch, worst_speed * 1000);
    report += line;
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  WARN("60 s held on every seed; worst |pitch| and |speed| per seed:" << report << "; simulated "
                                                                       << static_cast<double>(simulated) / 1e6
                                                                       << " s in " << wall << " s: "
                                                                       << static_cast<double>(simulated) / 1e6 / wall
                                                                       << "x real time (this build)");
}

TEST_CASE("plant: QMI8658 noise and per-seed offsets as the datasheet gives them, the stand slightly off balance") {
  sim::PlantConfig config;
  config.floor_accel_sd_radps2 = 0.0;
  double stand_sum = 0;
  for (std::uint32_t seed = 1; seed <= 10; ++seed) {
    config.seed = seed;
    sim::Plant p(config);
    CHECK(std::fabs(p.gyro_offset_y_dps()) <= 1.0);
    CHECK(std::fabs(p.accel_offset_x_g()) <= 0.02);
    CHECK(std::fabs(p.stand_deg()) >= 0.2);
    CHECK(std::fabs(p.stand_deg()) <= 1.0);
    stand_sum += p.stand_deg();
    // on the stand: every sample is the offset plus white noise of density x sqrt(500 Hz)
    double sum = 0, sum2 = 0, asum = 0, asum2 = 0;
    const int n = 20000;
    for (int i = 1; i <= n; ++i) {
      p.step(0.001, i * 0.001);
      const auto s = p.imu_sample(static_cast<TimeUs>(i) * 1000);
      sum += s.gy;
      sum2 += static_cast<double>(s.gy) * s.gy;
      asum += s.ay;
      asum2 += static_cast<double>(s.ay) * s.ay;
    }
    const double mean = sum / n;
    const double sd = std::sqrt(sum2 / n - mean * mean);
    const double asd = std::sqrt(asum2 / n - (asum / n) * (asum / n));
    CHECK(mean == Approx(p.gyro_offset_y_dps()).margin(0.02));  // at rest: gy is the offset
    CHECK(sd == Approx(0.015 * std::sqrt(500.0)).epsilon(0.05));   // 15 mdps/sqrt(Hz): 0.335 deg/s
    CHECK(asd == Approx(200e-6 * std::sqrt(500.0)).epsilon(0.05));  // 200 ug/sqrt(Hz): 4.5 mg
  }
  CHECK(std::fabs(stand_sum) < 10 * 1.0);  // both sides occur (not all the same sign)
}

TEST_CASE("plant: push and tilt move the body through the dynamics, and the gyro sees every degree of it") {
  sim::PlantConfig config;
  config.floor_accel_sd_radps2 = 0.0;
  config.gyro_offset_max_dps = 0.0;
  config.gyro_noise_density_dps = 0.0;
  config.gyro_lsb_dps = 0.0;
  sim::Plant p(config);
  // Integrate -gy (the nose-up rate) over every sample and compare with the pitch it moved.
  double integrated = p.pitch_deg();
  double t = 0;
  const auto run = [&](double seconds_to_run) {
    for (double end = t + seconds_to_run; t < end - 1e-9;) {
      t += 0.001;
      const double before = p.pitch_deg();
      p.step(0.001, t);
      const auto s = p.imu_sample(static_cast<TimeUs>(std::lround(t * 1e6)));
      integrated += -s.gy * 0.001;
      CHECK(std::fabs(p.pitch_deg() - before) < 0.5);  // never a jump: at most 500 deg/s over one ms
    }
  };
  p.tilt(10.0);
  CHECK_FALSE(p.on_stand());
  run(0.125);
  CHECK(p.pitch_deg() > 3.0);  // half way there along the path, not jumped
  CHECK(p.pitch_deg() < 7.0);
  run(0.125);
  CHECK(p.pitch_deg() == Approx(10.0).margin(0.01));
  CHECK(integrated == Approx(p.pitch_deg()).margin(0.3));
  p.upright();  // the hands bring it back to the stand along a path too
  run(0.25);
  CHECK(p.on_stand());
  CHECK(p.pitch_deg() == Approx(p.stand_deg()).margin(0.01));
  CHECK(integrated == Approx(p.pitch_deg()).margin(0.3));
  const double rate_before = p.pitch_rate_dps();
  p.push(50.0);
  run(0.005);
  CHECK(p.pitch_rate_dps() - rate_before < 30.0);  // a shove takes its 20 ms, it is not a jump in rate
  run(0.015);
  CHECK(p.pitch_rate_dps() - rate_before == Approx(50.0).margin(3.0));
  CHECK(integrated == Approx(p.pitch_deg()).margin(0.3));
}

namespace {

/// Arms with the cap at cap_pct, waits settle_ms, then streams 0x300 speed at 20 Hz for run_s; returns the 0x400
/// speeds seen after the request started, one per 100 ms. Fails the test if BALANCE is left.
std::vector<int> drive(std::uint32_t seed, int cap_pct, int request, double run_s, int settle_ms = 2000) {
  sim::WorldConfig config;
  config.plant.seed = seed;
  sim::World w(config);
  const TimeUs armed = arm(w, cap_pct);
  REQUIRE(armed != 0);
  REQUIRE(w.balance().speed_limit_pct() == cap_pct);
  const TimeUs start = armed + static_cast<TimeUs>(settle_ms) * 1000;
  std::vector<int> speeds;
  TimeUs next = w.now_us();
  while (w.now_us() < start + static_cast<TimeUs>(run_s * 1e6)) {
    if (w.now_us() >= next) {
      const bool on = w.now_us() >= start;
      w.send_can(saulcan::encode(saulcan::VelocityCmd{static_cast<std::int16_t>(on ? request : 0), 0}));
      next += 50'000;
    }
    w.step();
    const auto seen = telemetry_speeds(w);
    if (w.now_us() > start) speeds.insert(speeds.end(), seen.begin(), seen.end());
    if (w.balance().state() != RobotState::balance) FAIL("left BALANCE: seed " << seed << ": " << w.status_line());
  }
  return speeds;
}

/// The worst 2 s mean of speeds (10 per second) from 3 s on, as a fraction of the request away from it.
double worst_window_error(const std::vector<int>& speeds, int request) {
  double worst = 0;
  for (std::size_t from = 30; from + 20 <= speeds.size(); from += 20) {
    double sum = 0;
    for (std::size_t i = from; i < from + 20; ++i) sum += speeds[i];
    worst = std::max(worst, std::fabs(sum / 20 - request) / std::fabs(static_cast<double>(request)));
  }
  return worst;
}

}  // namespace

TEST_CASE("speed loop: BALANCE tracks 0x300 +-150 and +-300 mm/s within 20 % from 3 s after the request") {
  // The request may use speed_request_share (40 %) of the cap: 150 mm/s needs the cap at 20 %, 300 mm/s at 40 %.
  struct Case {
    int request;
    int cap_pct;
  };
  std::string report;
  for (const Case c : {Case{150, 20}, Case{-150, 20}, Case{300, 40}, Case{-300, 40}}) {
    for (std::uint32_t seed = 1; seed <= 5; ++seed) {
      const auto speeds = drive(seed, c.cap_pct, c.request, 9.0);
      REQUIRE(speeds.size() >= 80);
      const double error = worst_window_error(speeds, c.request);
      INFO(c.request << " mm/s, seed " << seed);
      CHECK(error <= 0.20);
      report += " " + std::to_string(c.request) + "/" + std::to_string(seed) + ":" +
                std::to_string(static_cast<int>(std::lround(error * 100))) + "%";
    }
  }
  WARN("worst 2 s mean from 3 s to 9 s after the request, away from it (request/seed):" << report);
}

TEST_CASE("speed loop: an out-of-range request (+-30000 mm/s) saturates at its share of the cap and never tips the "
          "robot, even sent from the moment of arming") {
  for (const int request : {30000, -30000}) {
    for (std::uint32_t seed = 1; seed <= 10; ++seed) {
      const auto speeds = drive(seed, 10, request, 10.0, 0);  // 10 % cap: 200 mm/s, 80 mm/s for the request
      double sum = 0;
      for (std::size_t i = 50; i < speeds.size(); ++i) sum += speeds[i];
      const double mean = sum / static_cast<double>(speeds.size() - 50);
      INFO(request << " mm/s, seed " << seed);
      CHECK(std::fabs(mean) == Approx(80.0).margin(20.0));
      CHECK(mean * request > 0);
      for (int s : speeds) CHECK(std::abs(s) <= 200);
    }
  }
}

TEST_CASE("excite: the speed loop's lean is held while a test signal runs, which ends at half the speed cap") {
  // The held lean makes a step measure the pitch loop alone (docs/tuning.md, "Estimate and direct step"); nothing but
  // the signal then keeps the robot's speed, so at the 50 % cap (1000 mm/s; BALANCE refuses a signal below it) a
  // 1 deg step held 20 s must end once the filtered speed passes 500 mm/s (measured: within 3.5 s on every seed),
  // and leave the robot balancing while the speed loop brings it back. Without the hold the setpoint minus the
  // signal moves; without the speed guard the step runs its 20 s into the cap and the robot falls.
  for (int seed = 1; seed <= 3; ++seed) {
    sim::WorldConfig config;
    config.plant.seed = static_cast<std::uint32_t>(seed);
    sim::World w(config);
    REQUIRE(arm(w, saul::trace::kExciteMinCapPct) != 0);
    w.run_until(w.now_us() + 2'500'000);
    REQUIRE(w.balance().state() == RobotState::balance);
    w.console_input("balance", seed == 2 ? "excite step -1 20\n" : "excite step 1 20\n");
    w.run_until(w.now_us() + 5'000);
    REQUIRE(w.balance().excitation() == saul::trace::Excite::step);
    const auto lean = [&] { return w.balance().last_trace().setpoint_x100 - w.balance().last_trace().excite_x100; };
    const int held = lean();
    const TimeUs started = w.now_us();
    int moved = 0;
    while (w.balance().excitation() != saul::trace::Excite::none && w.now_us() < started + 20'000'000) {
      w.step();
      if (w.balance().excitation() != saul::trace::Excite::none) moved = std::max(moved, std::abs(lean() - held));
    }
    INFO("seed " << seed << ": the step ran " << seconds(w.now_us() - started) << " s; " << w.status_line());
    CHECK(moved <= 1);  // 0.01 deg: the setpoint's rounding
    CHECK(w.now_us() - started < 6'000'000);
    w.run_until(w.now_us() + 8'000'000);  // the speed loop brings the robot back
    CHECK(w.balance().state() == RobotState::balance);
  }
}

TEST_CASE("excite: a 2 deg step held 20 s at the lowest and the highest cap BALANCE allows leaves the robot "
          "balancing; at the full cap, which BALANCE refuses, it fell") {
  // Why trace::kExciteMaxCapPct is 90: seeds 1-20, both signs, the robot fell in 16 of 40 runs at 100 % (measured
  // with the refusal taken out) and in none at 50, 60, 70, 80 or 90 %. Here the two ends of the window, seeds 1-10.
  int falls = 0;
  std::string fell;
  for (const int cap : {static_cast<int>(saul::trace::kExciteMinCapPct), static_cast<int>(saul::trace::kExciteMaxCapPct)}) {
    for (std::uint32_t seed = 1; seed <= 10; ++seed) {
      for (const char* line : {"excite step 2 20\n", "excite step -2 20\n"}) {
        sim::WorldConfig config;
        config.plant.seed = seed;
        sim::World w(config);
        REQUIRE(arm(w, cap) != 0);
        w.run_until(w.now_us() + 2'500'000);
        w.console_input("balance", line);
        w.run_until(w.now_us() + 5'000);
        REQUIRE(w.balance().excitation() == saul::trace::Excite::step);
        w.run_until(w.now_us() + 25'000'000);  // the step (it ends at half the cap) and the way back
        if (w.balance().state() != RobotState::balance) {
          ++falls;
          fell += " cap " + std::to_string(cap) + " seed " + std::to_string(seed) + " " + line;
        }
      }
    }
  }
  INFO("fell:" << fell);
  CHECK(falls == 0);
  // At the full cap BALANCE refuses the signal: the robot stays as it was.
  sim::World w;
  REQUIRE(arm(w, 100) != 0);
  w.run_until(w.now_us() + 2'500'000);
  w.console_input("balance", "excite step 2 20\n");
  w.run_until(w.now_us() + 5'000);
  CHECK(w.balance().excitation() == saul::trace::Excite::none);
}
