// RC channel map and receiver selection (docs/protocol.md, CRSF: RC map and receiver rule).
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <vector>

#include "saulproto/core/crsf.hpp"
#include "saulproto/core/rc_input.hpp"

using namespace saul;
using namespace saul::rc;

namespace {

constexpr std::uint64_t kMs = 1000;

// All channels centred, arm and estop off (1000 us), speed cap at its lowest.
Channels idle() {
  Channels c{};
  c.fill(1500);
  c[kArmChannel] = 1000;
  c[kEstopChannel] = 1000;
  c[kSpeedChannel] = 988;
  return c;
}

Channels with(std::size_t index, std::uint16_t us, Channels c = idle()) {
  c[index] = us;
  return c;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// Channel map

TEST_CASE("RC map: CH5 arms strictly above 1500 us") {
  CHECK_FALSE(map_channels(with(kArmChannel, 1499)).armed);
  CHECK_FALSE(map_channels(with(kArmChannel, 1500)).armed);
  CHECK(map_channels(with(kArmChannel, 1501)).armed);
  CHECK(map_channels(with(kArmChannel, 2012)).armed);
  CHECK_FALSE(map_channels(with(kArmChannel, 988)).armed);
}

TEST_CASE("RC map: CH6 estops strictly above 1500 us") {
  CHECK_FALSE(map_channels(with(kEstopChannel, 1499)).estop);
  CHECK_FALSE(map_channels(with(kEstopChannel, 1500)).estop);
  CHECK(map_channels(with(kEstopChannel, 1501)).estop);
  CHECK(map_channels(with(kEstopChannel, 2012)).estop);
}

TEST_CASE("RC map: estop is evaluated first and zeroes throttle and steer") {
  Channels c = idle();
  c[kThrottleChannel] = 2012;
  c[kSteerChannel] = 988;
  c[kSpeedChannel] = 2012;
  c[kArmChannel] = 2012;
  const Command driving = map_channels(c);
  CHECK(driving == Command{1000, 1000, 100, true, false});

  c[kEstopChannel] = 1501;
  const Command stopped = map_channels(c);
  CHECK(stopped.estop);
  CHECK(stopped.throttle == 0);
  CHECK(stopped.steer == 0);
  CHECK(stopped.armed);  // CH5 reported as it is, so releasing estop is not a fresh arming
  CHECK(stopped.speed_cap_pct == 100);

  c[kEstopChannel] = 1500;  // exactly 1500 is not estop
  CHECK(map_channels(c) == driving);
}

TEST_CASE("RC map: CH7 speed cap at 988 / 1500 / 2012 us and the throttle after it") {
  Channels c = idle();
  c[kThrottleChannel] = 2012;
  c[kSteerChannel] = 988;  // stick full left = steer +1000 before the cap
  c[kSpeedChannel] = 988;
  CHECK(map_channels(c) == Command{100, 100, 10, false, false});
  c[kSpeedChannel] = 1500;
  CHECK(map_channels(c) == Command{500, 500, 50, false, false});
  c[kSpeedChannel] = 2012;
  CHECK(map_channels(c) == Command{1000, 1000, 100, false, false});
  // Reverse and right, capped the same way.
  c[kThrottleChannel] = 988;
  c[kSteerChannel] = 2012;
  c[kSpeedChannel] = 1500;
  CHECK(map_channels(c) == Command{-500, -500, 50, false, false});
}

TEST_CASE("RC map: speed cap steps and rounding") {
  CHECK(speed_cap_pct(988) == 10);
  CHECK(speed_cap_pct(1500) == 50);  // 55 % exactly: the tie goes to the lower cap
  CHECK(speed_cap_pct(2012) == 100);
  CHECK(speed_cap_pct(1044) == 10);
  CHECK(speed_cap_pct(1045) == 20);
  CHECK(speed_cap_pct(1955) == 90);
  CHECK(speed_cap_pct(1956) == 100);
  CHECK(speed_cap_pct(0) == 10);
  CHECK(speed_cap_pct(881) == 10);
  CHECK(speed_cap_pct(2159) == 100);
  CHECK(speed_cap_pct(65535) == 100);
  std::uint8_t previous = 10;
  for (std::uint16_t us = 900; us <= 2100; ++us) {
    const std::uint8_t p = speed_cap_pct(us);
    REQUIRE(p % 10 == 0);
    REQUIRE(p >= 10);
    REQUIRE(p <= 100);
    REQUIRE(p >= previous);
    previous = p;
  }
}

TEST_CASE("RC map: stick to permille, deadband and clamping") {
  CHECK(stick_permille(988) == -1000);
  CHECK(stick_permille(1500) == 0);
  CHECK(stick_permille(2012) == 1000);
  CHECK(stick_permille(1495) == 0);
  CHECK(stick_permille(1505) == 0);
  CHECK(stick_permille(1494) == -1);
  CHECK(stick_permille(1506) == 1);
  CHECK(stick_permille(1756) == 495);  // (256 - 5) * 1000 / 507 = 495.07
  CHECK(stick_permille(800) == -1000);
  CHECK(stick_permille(2200) == 1000);
  for (std::uint16_t d = 0; d <= 600; ++d) {
    const auto up = static_cast<std::uint16_t>(1500 + d);
    const auto down = static_cast<std::uint16_t>(1500 - d);
    REQUIRE(stick_permille(up) == -stick_permille(down));
    if (d > 0) REQUIRE(stick_permille(up) >= stick_permille(static_cast<std::uint16_t>(up - 1)));
  }
}

TEST_CASE("RC map: centred sticks give a zero command; steer is + left") {
  CHECK(map_channels(idle()) == Command{0, 0, 10, false, false});
  Channels c = idle();
  c[kSpeedChannel] = 2012;
  c[kSteerChannel] = 2012;  // stick right
  CHECK(map_channels(c).steer == -1000);
  c[kSteerChannel] = 988;   // stick left
  CHECK(map_channels(c).steer == 1000);
  c[kThrottleChannel] = 1700;  // (200 - 5) * 1000 / 507 = 384.6
  CHECK(map_channels(c).throttle == 384);
  c[kSpeedChannel] = 1045;  // 20 %: 384 * 20 / 100 = 76.8, truncated
  CHECK(map_channels(c).throttle == 76);
}

TEST_CASE("RC map: straight from a CRSF frame") {
  crsf::RcChannels frame;
  frame.ticks.fill(crsf::kTicksMid);
  frame.ticks[kThrottleChannel] = crsf::kTicksMax;
  frame.ticks[kSpeedChannel] = crsf::kTicksMax;
  frame.ticks[kArmChannel] = crsf::kTicksMax;
  frame.ticks[kEstopChannel] = crsf::kTicksMin;
  CHECK(map_channels(crsf::channels_us(frame)) == Command{1000, 0, 100, true, false});
  frame.ticks[kEstopChannel] = 993;  // 1501 us
  CHECK(map_channels(crsf::channels_us(frame)) == Command{0, 0, 100, true, true});
  frame.ticks[kEstopChannel] = crsf::kTicksMid;  // exactly 1500 us
  CHECK_FALSE(map_channels(crsf::channels_us(frame)).estop);
}

TEST_CASE("RC map: the inter-board RC_CMD") {
  CHECK(to_rc_cmd(Command{300, -200, 30, true, false}) == interboard::RcCmd{300, -200, interboard::RcCmd::kArmed});
  CHECK(to_rc_cmd(Command{0, 0, 30, true, true}) ==
        interboard::RcCmd{0, 0, interboard::RcCmd::kArmed | interboard::RcCmd::kKill});
  CHECK(to_rc_cmd(Command{0, 0, 10, false, true}) == interboard::RcCmd{0, 0, interboard::RcCmd::kKill});
  CHECK(to_rc_cmd(Command{}) == interboard::RcCmd{0, 0, 0});
}

TEST_CASE("RC map: the worked example of docs/sections/crsf.md, down to the RC_CMD bytes") {
  Channels c = idle();
  c[kSteerChannel] = 988;
  c[kThrottleChannel] = 2012;
  c[kArmChannel] = 2012;
  c[kEstopChannel] = 988;
  c[kSpeedChannel] = 1500;
  std::array<std::uint8_t, interboard::kMaxFrameSize> buf{};
  auto n = interboard::encode(to_rc_cmd(map_channels(c)), buf);
  REQUIRE(n.ok());
  // CRCs from a bitwise CRC-8/MAXIM in Python.
  CHECK(std::vector<std::uint8_t>(buf.begin(), buf.begin() + 9) ==
        std::vector<std::uint8_t>{0xAA, 0x05, 0x01, 0xF4, 0x01, 0xF4, 0x01, 0x01, 0x88});
  c[kEstopChannel] = 1501;
  n = interboard::encode(to_rc_cmd(map_channels(c)), buf);
  REQUIRE(n.ok());
  CHECK(std::vector<std::uint8_t>(buf.begin(), buf.begin() + 9) ==
        std::vector<std::uint8_t>{0xAA, 0x05, 0x01, 0x00, 0x00, 0x00, 0x00, 0x03, 0xD5});
}

// ---------------------------------------------------------------------------------------------------------
// Receiver selection

TEST_CASE("RC selector: nothing received is rc_loss") {
  ReceiverSelector s;
  CHECK(s.rc_loss());
  CHECK(s.active() == Source::none);
  s.update(0);
  s.update(10 * kMs);
  CHECK(s.rc_loss());
  s.on_frame(Source::none, 0);  // ignored
  CHECK(s.rc_loss());
  CHECK(std::string_view(to_string(Source::elrs)) == "elrs");
}

TEST_CASE("RC selector: CRSF is primary as soon as it sends") {
  ReceiverSelector s;
  s.on_frame(Source::crsf, 5 * kMs);
  CHECK(s.active() == Source::crsf);
  CHECK_FALSE(s.rc_loss());
  s.on_frame(Source::elrs, 6 * kMs);
  CHECK(s.active() == Source::crsf);  // both alive: CRSF
}

TEST_CASE("RC selector: failover to ELRS after CRSF is silent for more than 100 ms") {
  for (std::uint64_t after_ms : {99, 100, 101}) {
    INFO("CRSF silent for " << after_ms << " ms");
    ReceiverSelector s;
    const std::uint64_t last_crsf = 1000 * kMs;
    for (std::uint64_t t = 0; t <= last_crsf; t += 10 * kMs) s.on_frame(Source::crsf, t);
    // ELRS keeps sending every millisecond, right up to the moment of the check.
    for (std::uint64_t t = last_crsf; t <= last_crsf + after_ms * kMs; t += kMs) s.on_frame(Source::elrs, t);
    s.update(last_crsf + after_ms * kMs);
    CHECK(s.active() == (after_ms > 100 ? Source::elrs : Source::crsf));
    CHECK_FALSE(s.rc_loss());
  }
}

TEST_CASE("RC selector: rc_loss when both are silent for more than 100 ms") {
  for (std::uint64_t after_ms : {99, 100, 101}) {
    INFO("both silent for " << after_ms << " ms");
    ReceiverSelector s;
    for (std::uint64_t t = 0; t <= 500 * kMs; t += 10 * kMs) {
      s.on_frame(Source::crsf, t);
      s.on_frame(Source::elrs, t);
    }
    s.update(500 * kMs + after_ms * kMs);
    CHECK(s.rc_loss() == (after_ms > 100));
    CHECK(s.active() == (after_ms > 100 ? Source::none : Source::crsf));
  }
  // CRSF alone: no ELRS fitted.
  ReceiverSelector s;
  s.on_frame(Source::crsf, 0);
  s.update(100 * kMs);
  CHECK(s.active() == Source::crsf);
  s.update(100 * kMs + 1);
  CHECK(s.rc_loss());
}

TEST_CASE("RC selector: rc_loss from ELRS when it goes silent too, at the same boundary") {
  for (std::uint64_t after_ms : {99, 100, 101}) {
    INFO("ELRS silent for " << after_ms << " ms");
    ReceiverSelector s;
    s.on_frame(Source::crsf, 0);
    for (std::uint64_t t = 0; t <= 300 * kMs; t += 10 * kMs) s.on_frame(Source::elrs, t);
    s.update(300 * kMs);
    REQUIRE(s.active() == Source::elrs);
    s.update(300 * kMs + after_ms * kMs);
    CHECK(s.rc_loss() == (after_ms > 100));
  }
}

TEST_CASE("RC selector: recovery from rc_loss is immediate, CRSF first") {
  ReceiverSelector s;
  s.on_frame(Source::crsf, 0);
  s.update(200 * kMs);
  REQUIRE(s.rc_loss());
  s.on_frame(Source::crsf, 250 * kMs);
  CHECK(s.active() == Source::crsf);
  CHECK_FALSE(s.rc_loss());

  ReceiverSelector e;
  e.update(0);
  e.on_frame(Source::elrs, 50 * kMs);
  CHECK(e.active() == Source::elrs);
  CHECK_FALSE(e.rc_loss());
}

TEST_CASE("RC selector: back to CRSF once it has been back for 100 ms (the hysteresis)") {
  for (std::uint64_t held_ms : {99, 100, 101}) {
    INFO("CRSF back for " << held_ms << " ms");
    ReceiverSelector s;
    s.on_frame(Source::crsf, 0);
    for (std::uint64_t t = 0; t <= 200 * kMs; t += 10 * kMs) s.on_frame(Source::elrs, t);
    REQUIRE(s.active() == Source::elrs);  // CRSF silent since 0
    const std::uint64_t back = 300 * kMs;
    for (std::uint64_t t = 200 * kMs; t <= back + held_ms * kMs; t += kMs) {
      s.on_frame(Source::elrs, t);
      if (t >= back && (t - back) % (10 * kMs) == 0) s.on_frame(Source::crsf, t);
      s.update(t);
    }
    CHECK(s.active() == (held_ms >= 100 ? Source::crsf : Source::elrs));
  }
}

TEST_CASE("RC selector: a CRSF that keeps dropping out does not take over from a healthy ELRS") {
  ReceiverSelector s;
  for (std::uint64_t t = 0; t <= 2000 * kMs; t += 5 * kMs) {
    s.on_frame(Source::elrs, t);
    if (t % (150 * kMs) == 0) s.on_frame(Source::crsf, t);  // one CRSF frame every 150 ms
    s.update(t);
    if (t > 0) REQUIRE(s.active() == Source::elrs);
  }
}

TEST_CASE("RC selector: CRSF back while ELRS is silent takes over at once") {
  ReceiverSelector s;
  s.on_frame(Source::crsf, 0);
  s.on_frame(Source::elrs, 150 * kMs);
  REQUIRE(s.active() == Source::elrs);
  s.on_frame(Source::crsf, 251 * kMs);  // ELRS last seen 101 ms ago: dead
  CHECK(s.active() == Source::crsf);
}

TEST_CASE("RC selector: a timestamp that goes backwards counts as age zero") {
  ReceiverSelector s;
  s.on_frame(Source::crsf, 1000 * kMs);
  s.update(900 * kMs);
  CHECK(s.active() == Source::crsf);
}
