// RobotClient (host/robot/robot_client.hpp): after an acknowledged mode change, what 0x400 shows. Frames written out
// by hand from docs/protocol.md: 0x400 is int16 pitch, int16 pid_out, int16 speed, uint8 state (7 bytes).
#include <catch2/catch.hpp>

#include <deque>
#include <thread>

#include "saulproto/host/robot/robot_client.hpp"

using namespace std::chrono;
using saul::CanFrame;
using saul::host::RobotClient;
using saul::host::StateCheck;
using saul::saulcan::RobotState;

namespace {

/// Frames to hand out in order; when none is left, a receive waits out its timeout (as a quiet bus would).
struct QueueLink final : saul::host::CanLink {
  std::deque<CanFrame> rx;
  std::vector<CanFrame> sent;
  std::string n = "queue";
  void send(const CanFrame& f, milliseconds) override { sent.push_back(f); }
  std::optional<CanFrame> receive(milliseconds timeout) override {
    if (rx.empty()) {
      std::this_thread::sleep_for(timeout);  // a quiet bus; nothing to synchronise with
      return std::nullopt;
    }
    CanFrame f = rx.front();
    rx.pop_front();
    return f;
  }
  void set_filters(const std::vector<saul::host::CanFilter>&) override {}
  saul::host::LinkStats stats() const override { return {}; }
  const std::string& name() const override { return n; }
  saul::host::TimestampSource timestamp_source() const override { return saul::host::TimestampSource::host_read; }
};

CanFrame telemetry_a(std::uint8_t state) {
  CanFrame f;
  f.id = 0x400;
  f.dlc = 7;
  f.data = {0xF4, 0x01, 0x0A, 0x00, 0x00, 0x00, state, 0};  // 5.00 deg, pid 10, speed 0, state
  return f;
}

CanFrame other() {
  CanFrame f;
  f.id = 0x401;
  f.dlc = 7;
  return f;
}

}  // namespace

TEST_CASE("robot client: the state 0x400 shows after an acknowledged mode change", "[robot]") {
  QueueLink link;
  int observed = 0;
  RobotClient client(link, [&](const CanFrame&) { ++observed; });

  SECTION("the old state first, then the one asked for: confirmed") {
    link.rx = {telemetry_a(0), other(), telemetry_a(1)};
    const auto c = client.confirm_state(RobotState::balance, milliseconds(200));
    CHECK(c.result == StateCheck::Result::confirmed);
    CHECK(c.seen == RobotState::balance);
    CHECK(observed == 3);
    CHECK_THAT(c.text(), Catch::StartsWith("robot state BALANCE ("));
  }
  SECTION("acknowledged, but the robot tilted past its limit: differs, and says what to do") {
    link.rx = {telemetry_a(0), telemetry_a(4)};
    const auto c = client.confirm_state(RobotState::balance, milliseconds(50));
    CHECK(c.result == StateCheck::Result::differs);
    CHECK(c.seen == RobotState::tilt_cutoff);
    CHECK_THAT(c.text(), Catch::Contains("reports TILT_CUTOFF instead of BALANCE") &&
                             Catch::Contains("stand it upright, disarm, then arm again"));
  }
  SECTION("a latched fault") {
    link.rx = {telemetry_a(5)};
    const auto c = client.confirm_state(RobotState::manual, milliseconds(50));
    CHECK(c.result == StateCheck::Result::differs);
    CHECK_THAT(c.text(), Catch::Contains("reports FAULT") && Catch::Contains("'saulctl monitor' shows which"));
  }
  SECTION("back to OFF after balance: armed?") {
    link.rx = {telemetry_a(0)};
    const auto c = client.confirm_state(RobotState::balance, milliseconds(50));
    CHECK(c.result == StateCheck::Result::differs);
    CHECK_THAT(c.text(), Catch::Contains("fell back to OFF: is it still armed"));
  }
  SECTION("no telemetry at all") {
    link.rx = {other()};
    const auto c = client.confirm_state(RobotState::estop, milliseconds(50));
    CHECK(c.result == StateCheck::Result::no_telemetry);
    CHECK_FALSE(c.seen);
    CHECK_THAT(c.text(), Catch::Contains("no 0x400 telemetry within"));
  }
}

TEST_CASE("robot client: mode values name the states", "[robot]") {
  using saul::saulcan::Mode;
  CHECK(saul::host::state_for(Mode::off) == RobotState::off);
  CHECK(saul::host::state_for(Mode::balance) == RobotState::balance);
  CHECK(saul::host::state_for(Mode::manual) == RobotState::manual);
  CHECK(saul::host::state_for(Mode::estop) == RobotState::estop);
}
