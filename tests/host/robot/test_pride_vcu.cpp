// PrideVcu (host/pride_vcu.hpp) on a fake clock and a fake one-wire port. Frame bytes written out by hand:
//   FE 54 03 14 F6 CS: FE+54+03+14+F6 = 0x25F, low byte 5F, CS = ~5F = A0 (speed level 3, FB +20, LR -10)
//   FE 54 03 00 00 CS: FE+54+03 = 0x155, low byte 55, CS = ~55 = AA  (neutral at speed level 3)
//   4A 01 02 5A 00 CS: 4A+01+02+5A = 0xA7, CS = ~A7 = 58               (controller: ready, battery 0x5A)
#include <catch2/catch.hpp>

#include <deque>
#include <functional>
#include <vector>

#include "saulproto/host/robot/pride_vcu.hpp"

using namespace std::chrono;
using saul::host::PrideVcu;
using Bytes = std::vector<std::uint8_t>;

namespace {

struct FakeClock {
  using TimePoint = steady_clock::time_point;
  TimePoint t{};
  TimePoint operator()() const { return t; }
  void advance(microseconds d) { t += d; }
};

/// One wire: what is written comes straight back (when echo is on), then whatever the test queued.
struct FakePort final : saul::host::SerialPort {
  explicit FakePort(FakeClock& c) : clock(c) {}
  FakeClock& clock;
  bool echo = true;
  std::vector<Bytes> writes;
  std::vector<FakeClock::TimePoint> write_times;
  std::deque<std::uint8_t> rx;
  Bytes answer;          ///< the controller's frame, sent right after our echo
  int answers_left = 0;
  saul::host::SerialSettings s;
  std::string p = "fake";

  std::size_t read(std::span<std::uint8_t> buf, milliseconds timeout) override {
    if (rx.empty()) {
      clock.advance(timeout);  // nothing came: the whole wait passes
      return 0;
    }
    std::size_t n = 0;
    while (n < buf.size() && !rx.empty()) {
      buf[n++] = rx.front();
      rx.pop_front();
    }
    return n;
  }
  void write(std::span<const std::uint8_t> data, milliseconds) override {
    writes.emplace_back(data.begin(), data.end());
    write_times.push_back(clock.t);
    if (echo) rx.insert(rx.end(), data.begin(), data.end());
    if (answers_left > 0) {
      --answers_left;
      queue(answer);
    }
  }
  void set_modem_lines(bool, bool) override {}
  const std::string& path() const override { return p; }
  const saul::host::SerialSettings& settings() const override { return s; }
  const char* backend() const override { return "fake"; }
  void queue(const Bytes& b) { rx.insert(rx.end(), b.begin(), b.end()); }
};

saul::pride::VcuCommand drive() {
  saul::pride::VcuCommand c;
  c.speed_level = 3;
  c.forward_back = 20;
  c.left_right = -10;
  return c;
}

const Bytes kDrive{0xFE, 0x54, 0x03, 0x14, 0xF6, 0xA0};
const Bytes kNeutral{0xFE, 0x54, 0x03, 0x00, 0x00, 0xAA};
const Bytes kController{0x4A, 0x01, 0x02, 0x5A, 0x00, 0x58};

}  // namespace

TEST_CASE("pride vcu: a frame every 5 ms on absolute deadlines, exact bytes") {
  FakeClock clock;
  FakePort port(clock);
  PrideVcu vcu(port, std::ref(clock), drive());
  for (int i = 0; i < 10; ++i) vcu.step();
  REQUIRE(port.writes.size() == 10);
  for (std::size_t i = 0; i < port.writes.size(); ++i) {
    CHECK(port.writes[i] == kDrive);
    CHECK(port.write_times[i] - FakeClock::TimePoint{} == milliseconds(5 * static_cast<int>(i)));
  }
  CHECK(vcu.counters().missed_slots == 0);
}

TEST_CASE("pride vcu: a late step keeps the grid and skips whole missed slots") {
  FakeClock clock;
  FakePort port(clock);
  port.echo = false;
  PrideVcu vcu(port, std::ref(clock), drive());
  vcu.step();  // t = 0, then waits to 5 ms
  clock.advance(milliseconds(2));  // the process was late: 7 ms
  vcu.step();  // sends at 7 ms, next deadline 10 ms (not 12)
  CHECK(port.write_times.back() - FakeClock::TimePoint{} == milliseconds(7));
  CHECK(vcu.next_deadline() - FakeClock::TimePoint{} == milliseconds(10));
  CHECK(clock.t - FakeClock::TimePoint{} == milliseconds(10));
  clock.advance(milliseconds(12));  // 22 ms: the 10, 15 and 20 ms slots are gone; send once, next at 25 ms
  vcu.step();
  CHECK(port.writes.size() == 3);
  CHECK(vcu.counters().missed_slots == 2);
  CHECK(vcu.next_deadline() - FakeClock::TimePoint{} == milliseconds(25));
}

TEST_CASE("pride vcu: own echo dropped, controller frames decoded") {
  FakeClock clock;
  FakePort port(clock);
  PrideVcu vcu(port, std::ref(clock), drive());
  std::vector<saul::pride::ControllerStatus> seen;
  port.answer = kController;
  port.answers_left = 4;
  for (int i = 0; i < 5; ++i) vcu.step([&](const saul::pride::ControllerStatus& s) { seen.push_back(s); });
  REQUIRE(seen.size() == 4);
  CHECK(seen[0].error_byte == 0x02);
  CHECK(seen[0].battery_charge == 0x5A);
  CHECK(vcu.last_status()->ready());
  CHECK(vcu.counters().foreign_vcu_frames == 0);
  CHECK(vcu.counters().controller_frames == 4);
  CHECK(vcu.echo_counters().echoes_dropped == 5 * 6);
  CHECK(vcu.echo_counters().mismatches == 0);
  CHECK(vcu.decoder_counters().bytes_skipped == 0);
}

TEST_CASE("pride vcu: a late echo is still recognised as ours") {
  FakeClock clock;
  FakePort port(clock);
  port.echo = false;
  PrideVcu vcu(port, std::ref(clock), drive());
  vcu.step();
  vcu.step();  // two frames out, no echo yet
  port.queue(kDrive);
  port.queue(kDrive);
  vcu.step();
  CHECK(vcu.counters().foreign_vcu_frames == 0);
  CHECK(vcu.echo_counters().echoes_dropped == 12);
}

TEST_CASE("pride vcu: hardware without an echo: the missing echo is forgotten, the controller still heard") {
  FakeClock clock;
  FakePort port(clock);
  port.echo = false;
  PrideVcu vcu(port, std::ref(clock), drive());
  for (int i = 0; i < 4; ++i) vcu.step();  // 0..15 ms: four echoes still expected (a late echo may yet come)
  CHECK(vcu.echo_counters().lost == 0);
  CHECK(vcu.echo_counters().overflows == 0);
  vcu.step();  // 20 ms: nothing for more than 15 ms: forgotten before the fifth frame
  CHECK(vcu.echo_counters().lost == 24);

  port.queue(kController);  // differs from the expected echo at its first byte: passed on
  std::vector<saul::pride::ControllerStatus> seen;
  vcu.step([&](const saul::pride::ControllerStatus& s) { seen.push_back(s); });
  REQUIRE(seen.size() == 1);
  CHECK(seen[0].battery_charge == 0x5A);
  CHECK(vcu.echo_counters().mismatches == 1);
}

TEST_CASE("pride vcu: neutral for 100 ms before finishing, then nothing more") {
  FakeClock clock;
  FakePort port(clock);
  PrideVcu vcu(port, std::ref(clock), drive());
  for (int i = 0; i < 3; ++i) vcu.step();
  vcu.begin_neutral();
  int steps = 0;
  while (!vcu.finished() && steps < 100) {
    vcu.step();
    ++steps;
  }
  REQUIRE(vcu.finished());
  CHECK(vcu.counters().neutral_frames_sent == 20);
  REQUIRE(port.writes.size() == 23);
  for (std::size_t i = 0; i < 3; ++i) CHECK(port.writes[i] == kDrive);
  for (std::size_t i = 3; i < 23; ++i) CHECK(port.writes[i] == kNeutral);
  CHECK(port.write_times.back() - port.write_times[3] == milliseconds(95));
  vcu.step();  // finished: no more frames
  CHECK(port.writes.size() == 23);
}

TEST_CASE("pride vcu: commands outside the manual's ranges are refused") {
  FakeClock clock;
  FakePort port(clock);
  auto bad = drive();
  bad.forward_back = 101;
  CHECK_THROWS_AS(PrideVcu(port, std::ref(clock), bad), std::invalid_argument);
  bad = drive();
  bad.speed_level = 15;
  CHECK_THROWS_AS(PrideVcu(port, std::ref(clock), bad), std::invalid_argument);
  CHECK(port.writes.empty());
}
