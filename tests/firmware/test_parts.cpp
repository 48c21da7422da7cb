// The small parts of the firmware logic: schedules, the complementary filter, the balance PID, LED patterns, tones
// and console line assembly.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "fakes.hpp"

using namespace fwtest;

TEST_CASE("Every is due once per period, at once the first time, and drops missed slots") {
  Every e(10'000);
  CHECK(e.due(5'000));
  CHECK_FALSE(e.due(5'001));
  CHECK_FALSE(e.due(14'999));
  CHECK(e.due(15'000));
  CHECK(e.due(100'000));  // far behind: one, not nine
  CHECK_FALSE(e.due(100'001));
  CHECK(e.due(110'000));
  e.trigger();
  CHECK(e.due(110'001));
}

TEST_CASE("complementary filter: starts from the accelerometer, tracks the gyro, converges to gravity") {
  ComplementaryFilter f(0.5F);
  CHECK_FALSE(f.valid());
  REQUIRE(f.update(imu_at(1000, 10.0F)));
  CHECK(f.valid());
  CHECK(f.pitch_deg() == Approx(10.0F).margin(1e-4));

  // 100 ms of a pure 20 deg/s nose-up rotation with a lying accelerometer (still saying 10 deg): the gyro wins
  // in the short run (the filter moves most of the 2 degrees).
  TimeUs t = 1000;
  for (int i = 0; i < 100; ++i) {
    t += 1000;
    ImuSample s = imu_at(t, 10.0F, 20.0F);
    REQUIRE(f.update(s));
  }
  CHECK(f.pitch_deg() > 11.5F);
  CHECK(f.rate_dps() == Approx(20.0F));
  // then still: converges back to what gravity says, with time constant 0.5 s
  for (int i = 0; i < 5000; ++i) {
    t += 1000;
    REQUIRE(f.update(imu_at(t, 10.0F)));
  }
  CHECK(f.pitch_deg() == Approx(10.0F).margin(0.01));
}

TEST_CASE("complementary filter: sign convention is nose up positive, rate = -gy") {
  ComplementaryFilter f;
  ImuSample s;
  s.t_us = 10;
  s.ax = -0.5F;  // body x leaning toward the ground: nose down
  s.az = 0.866F;
  s.gy = 5.0F;   // positive rotation about y (left) pitches the nose down
  REQUIRE(f.update(s));
  CHECK(f.pitch_deg() == Approx(-30.0F).margin(0.01));
  CHECK(f.rate_dps() == Approx(-5.0F));
}

TEST_CASE("complementary filter: rejects non-finite samples and does not start from a bad accelerometer") {
  ComplementaryFilter f;
  ImuSample bad = imu_at(1000, 0.0F);
  bad.gx = std::numeric_limits<float>::quiet_NaN();
  CHECK_FALSE(f.update(bad));
  CHECK_FALSE(f.valid());
  ImuSample falling = imu_at(1000, 0.0F);
  falling.ax = falling.az = 0.0F;  // free fall: no "down"
  CHECK_FALSE(f.update(falling));
  REQUIRE(f.update(imu_at(2000, 3.0F)));
  ImuSample inf = imu_at(3000, 3.0F);
  inf.az = std::numeric_limits<float>::infinity();
  CHECK_FALSE(f.update(inf));
  CHECK(f.pitch_deg() == Approx(3.0F).margin(1e-4));
  // the same timestamp twice is ignored; a long gap restarts from the accelerometer
  CHECK_FALSE(f.update(imu_at(2000, 50.0F)));
  REQUIRE(f.update(imu_at(2000 + ComplementaryFilter::kMaxGapUs + 1, -7.0F)));
  CHECK(f.pitch_deg() == Approx(-7.0F).margin(1e-4));
}

TEST_CASE("complementary filter: a bump (|a| far from 1 g) does not move the pitch") {
  ComplementaryFilter f;
  REQUIRE(f.update(imu_at(1000, 2.0F)));
  ImuSample bump = imu_at(2000, 0.0F);
  bump.ax = 3.0F;  // 3 g sideways kick along x
  REQUIRE(f.update(bump));
  CHECK(f.pitch_deg() == Approx(2.0F).margin(1e-4));  // gyro only (rate 0)
}

TEST_CASE("PID: P, I and D terms in permille, D on the measured rate") {
  BalancePid pid({10.0F, 2.0F, 0.5F}, 300.0F);
  // e = 3 deg, rate 4 deg/s, dt 0.1 s: P 30, I 0.6, D -2
  CHECK(pid.update(3.0F, 4.0F, 0.1F) == Approx(30.0F + 0.6F - 2.0F));
  CHECK(pid.integral() == Approx(0.6F));
  pid.reset();
  CHECK(pid.integral() == 0.0F);
}

TEST_CASE("PID: output saturates at +-1000 permille") {
  BalancePid pid({100.0F, 0.0F, 0.0F});
  CHECK(pid.update(25.0F, 0.0F, 0.001F) == 1000.0F);
  CHECK(pid.update(-25.0F, 0.0F, 0.001F) == -1000.0F);
}

TEST_CASE("PID: anti-windup clamps the integral and freezes it while saturated") {
  BalancePid clamp({0.0F, 1000.0F, 0.0F}, 300.0F);
  for (int i = 0; i < 100; ++i) (void)clamp.update(5.0F, 0.0F, 0.01F);
  CHECK(clamp.integral() == Approx(300.0F));  // clamped, not 5000

  BalancePid frozen({200.0F, 10.0F, 0.0F}, 300.0F);
  for (int i = 0; i < 1000; ++i) CHECK(frozen.update(10.0F, 0.0F, 0.01F) == 1000.0F);  // P alone saturates
  CHECK(frozen.integral() == 0.0F);  // nothing wound up while saturated
  // so the output leaves saturation as soon as the error turns
  CHECK(frozen.update(-1.0F, 0.0F, 0.01F) == Approx(-200.0F - 0.1F));
}

TEST_CASE("PID: a non-finite result gives 0 and resets") {
  BalancePid pid({std::numeric_limits<float>::infinity(), 0.0F, 0.0F});
  CHECK(pid.update(0.0F, 0.0F, 0.01F) == 0.0F);  // inf * 0 = NaN
}

TEST_CASE("LED patterns for the states, and how they render") {
  using saulcan::RobotState;
  CHECK(led_for_state(RobotState::off) == LedCommand{LedPattern::breathe, {0, 0, 255}});
  CHECK(led_for_state(RobotState::balance) == LedCommand{LedPattern::solid, {0, 255, 0}});
  CHECK(led_for_state(RobotState::estop) == LedCommand{LedPattern::blink, {255, 0, 0}});
  CHECK(led_for_state(RobotState::tilt_cutoff).pattern == LedPattern::blink);
  CHECK(led_for_state(RobotState::fault).pattern == LedPattern::blink);

  std::vector<Rgb> px(4);
  const Rgb red{255, 0, 0};
  render(LedPattern::solid, red, 0, px);
  CHECK(px[3] == red);
  render(LedPattern::blink, red, 100'000, px);
  CHECK(px[0] == red);
  render(LedPattern::blink, red, 300'000, px);
  CHECK(px[0] == Rgb{});
  render(LedPattern::chase, red, 50'000, px);
  CHECK(px[0] == Rgb{});
  CHECK(px[1] == red);
  render(LedPattern::breathe, {0, 0, 255}, 1'000'000, px);  // top of the ramp
  CHECK(px[2] == Rgb{0, 0, 255});
  render(LedPattern::breathe, {0, 0, 255}, 0, px);  // bottom: dim, never dark
  CHECK(px[2] == Rgb{0, 0, 16});
  render(LedPattern::off, red, 0, px);
  CHECK(px[0] == Rgb{});
  render(static_cast<LedPattern>(99), red, 0, px);  // unknown: solid
  CHECK(px[1] == red);
}

TEST_CASE("tones") {
  CHECK(tone_hz(0) == 0);
  CHECK(tone_hz(1) == 2000);
  CHECK(tone_hz(2) == 1000);
  CHECK(tone_hz(3) == 3000);
  CHECK(tone_hz(42) == 1500);
}

TEST_CASE("console lines: CR, LF and CRLF end a line, empty lines vanish, overlong lines are flagged once") {
  LineAssembler a;
  std::vector<std::pair<std::string, bool>> lines;
  const auto feed = [&](const std::string& s) {
    for (char c : s) a.push(static_cast<std::uint8_t>(c), [&](std::string_view l, bool o) { lines.emplace_back(std::string(l), o); });
  };
  feed("status\r\n\n\rarm\n");
  REQUIRE(lines.size() == 2);
  CHECK(lines[0] == std::make_pair(std::string("status"), false));
  CHECK(lines[1] == std::make_pair(std::string("arm"), false));
  lines.clear();
  feed(std::string(LineAssembler::kMaxLine + 10, 'x') + "\nhelp\n");
  REQUIRE(lines.size() == 2);
  CHECK(lines[0].second);
  CHECK(lines[1] == std::make_pair(std::string("help"), false));
}
