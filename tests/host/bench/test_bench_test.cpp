// Scripted bench tests: the parser, and the engine against a fake robot driven by simulated time.
#include <catch2/catch.hpp>

#include <deque>
#include <sstream>

#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/bench/bench_test.hpp"

using namespace saul;
using namespace saul::host::benchtest;
namespace sc = saul::saulcan;

namespace {

Suite parse(const std::string& text) {
  std::istringstream in(text);
  return parse_suite(in, "t.saul");
}

// A robot in simulated time: answers mode commands with an ack, sends telemetry A every 100 ms with a state that
// follows the accepted mode, and records what it was sent.
class FakeRobot final : public Target {
 public:
  std::uint64_t now = 0;
  std::vector<CanFrame> sent;
  sc::RobotState state = sc::RobotState::off;
  bool armed = false;
  std::deque<std::pair<std::uint64_t, CanFrame>> pending;  // (due time, frame)
  std::uint64_t next_telemetry = 0;
  std::string console_log;

  std::uint64_t now_us() override { return now; }
  void send(const CanFrame& f) override {
    sent.push_back(f);
    if (auto m = sc::decode_mode_cmd(f)) {
      const bool moving = m->mode == sc::Mode::balance || m->mode == sc::Mode::manual;
      const auto result = moving && !armed ? sc::AckResult::not_allowed : sc::AckResult::applied;
      if (result == sc::AckResult::applied) state = static_cast<sc::RobotState>(m->mode);
      pending.emplace_back(now + 2'000, sc::encode(sc::CommandAck{0x02, 0, result}));
    }
  }
  std::optional<CanFrame> receive_until(std::uint64_t deadline) override {
    for (;;) {
      std::uint64_t next = std::min(next_telemetry, pending.empty() ? UINT64_MAX : pending.front().first);
      if (next > deadline) {
        now = std::max(now, deadline);
        return std::nullopt;
      }
      now = std::max(now, next);
      if (!pending.empty() && pending.front().first <= now) {
        auto f = pending.front().second;
        pending.pop_front();
        return f;
      }
      next_telemetry += 100'000;
      return sc::encode(sc::TelemetryA{120, 0, 0, state});
    }
  }
  std::optional<std::string> console(const std::string& board, const std::string& line, const std::string&,
                                     std::uint64_t) override {
    console_log += board + ":" + line + ";";
    if (line == "arm") {
      armed = true;
      return "armed\nok\n";
    }
    return "error: unknown command\n";
  }
  bool sim(const std::string& command, std::string& error) override {
    if (command == "push 5") return true;
    error = "unknown sim command";
    return false;
  }
  bool is_simulator() const override { return true; }
  std::string describe() const override { return "fake"; }
};

}  // namespace

TEST_CASE("bench suites parse every step kind") {
  const auto s = parse(
      "suite: arm and balance\n"
      "requires: sim\n"
      "# a comment\n"
      "send mode_cmd mode=balance   # trailing comment\n"
      "send frame 302#01\n"
      "send pid_set kp=1.5 ki=0.25 kd=0.05 sequence=9\n"
      "stream velocity_cmd speed_mmps=200 every 50ms\n"
      "stop\n"
      "expect command_ack command=2 result=applied within 300ms\n"
      "expect telemetry_a state=BALANCE |pitch_x100|<300 within 2s\n"
      "expect no velocity_cmd for 1s\n"
      "hold telemetry_a state=BALANCE for 3s\n"
      "console balance arm expect ok within 500ms\n"
      "sim push 8\n"
      "wait 1.5s\n");
  CHECK(s.name == "arm and balance");
  CHECK(s.requires_sim);
  REQUIRE(s.steps.size() == 12);
  CHECK(s.steps[0].kind == Step::Kind::send);
  CHECK(s.steps[0].frames[0] == sc::encode(sc::ModeCmd{sc::Mode::balance}));
  CHECK(s.steps[1].frames[0] == sc::encode(sc::ModeCmd{sc::Mode::balance}));  // the raw form of the same frame
  REQUIRE(s.steps[2].frames.size() == 3);
  CHECK(s.steps[2].frames[2] == sc::encode(sc::PidGain{sc::Gain::kd, 9, 0.05F}));
  CHECK(s.steps[3].period_us == 50'000);
  CHECK(s.steps[3].frames[0] == sc::encode(sc::VelocityCmd{200, 0}));
  CHECK(s.steps[5].conditions.size() == 2);
  CHECK(s.steps[5].duration_us == 300'000);
  CHECK(s.steps[6].conditions[1].absolute);
  CHECK(s.steps[6].conditions[1].op == Condition::Op::lt);
  CHECK(s.steps[7].kind == Step::Kind::expect_none);
  CHECK(s.steps[8].kind == Step::Kind::hold);
  CHECK(s.steps[9].board == "balance");
  CHECK(s.steps[9].text == "arm");
  CHECK(s.steps[9].expect_text == "ok");
  CHECK(s.steps[10].text == "push 8");
  CHECK(s.steps[11].duration_us == 1'500'000);
  CHECK(s.steps[4].line == 8);
}

TEST_CASE("bench suite parse errors name the file and line") {
  auto fails = [](const std::string& text, const std::string& part) {
    try {
      parse(text);
    } catch (const ParseError& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(part) != std::string::npos);
      return;
    }
    FAIL("no error for: " << text);
  };
  fails("\n\nfly away\n", "t.saul:3: unknown step 'fly'");
  fails("expect telemetry_a state=BALANCE\n", "within");
  fails("expect telemetry_a pitch_x100<abc within 1s\n", "not a number");
  fails("send mode_cmd mode=fast\n", "mode=off|balance|manual|estop");
  fails("send velocity_cmd speed_mmps=40000\n", "does not fit");
  fails("send velocity_cmd speedy=1\n", "unknown field 'speedy'");
  fails("wait soon\n", "bad duration");
  fails("send frame 3G0#01\n", "bad frame");
}

TEST_CASE("the engine: arm on the console, ack, telemetry, hold — in simulated time") {
  FakeRobot robot;
  const auto s = parse(
      "send mode_cmd mode=balance\n"
      "expect command_ack command=2 result=rejected_not_allowed within 100ms\n"
      "console balance arm expect ok\n"
      "send mode_cmd mode=balance\n"
      "expect command_ack result=applied within 100ms\n"
      "expect telemetry_a state=BALANCE within 300ms\n"
      "hold telemetry_a state=BALANCE |pitch_x100|<=120 for 1s\n"
      "sim push 5\n");
  const auto r = run_suite(s, robot);
  for (const auto& st : r.steps) INFO(st.line << " " << st.message);
  CHECK(r.passed());
  REQUIRE(r.steps.size() == 8);
  CHECK(r.steps[6].message == "held over 10 frames");
  CHECK(robot.console_log == "balance:arm;");
  CHECK(robot.now >= 1'000'000);
}

TEST_CASE("the engine: a failing expect stops the suite and reports why; later steps are skipped") {
  FakeRobot robot;
  const auto s = parse(
      "expect telemetry_a state=BALANCE within 250ms\n"
      "send mode_cmd mode=off\n");
  const auto r = run_suite(s, robot);
  CHECK_FALSE(r.passed());
  CHECK(r.steps[0].status == StepResult::Status::failed);
  CHECK(r.steps[0].message == "no matching telemetry_a within 0.250 s");
  CHECK(r.steps[1].status == StepResult::Status::skipped);
  CHECK(robot.sent.empty());
  CHECK(robot.now == 250'000);  // waited exactly the window, in simulated time
}

TEST_CASE("the engine: hold fails on the first frame that breaks the condition") {
  FakeRobot robot;
  const auto r = run_suite(parse("hold telemetry_a pitch_x100<100 for 1s\n"), robot);
  CHECK_FALSE(r.passed());
  CHECK(r.steps[0].message.find("condition broken after 0.000 s by 400#78000000000000") != std::string::npos);
}

TEST_CASE("the engine: a background stream is sent on its period while other steps wait") {
  FakeRobot robot;
  const auto r = run_suite(parse("stream velocity_cmd speed_mmps=100 every 50ms\nwait 1s\nstop\nwait 500ms\n"), robot);
  CHECK(r.passed());
  const auto vel = sc::encode(sc::VelocityCmd{100, 0});
  const auto n = std::count(robot.sent.begin(), robot.sent.end(), vel);
  CHECK(n == 20);  // at 0, 50, ..., 950 ms; none after stop
}

TEST_CASE("the engine: expect no ... fails when a matching frame arrives") {
  FakeRobot robot;
  const auto r = run_suite(parse("expect no telemetry_a for 1s\n"), robot);
  CHECK_FALSE(r.passed());
}

TEST_CASE("a suite that requires the simulator is skipped on a real robot") {
  struct Real final : Target {
    std::uint64_t now_us() override { return 0; }
    void send(const CanFrame&) override {}
    std::optional<CanFrame> receive_until(std::uint64_t) override { return std::nullopt; }
    std::optional<std::string> console(const std::string&, const std::string&, const std::string&,
                                       std::uint64_t) override {
      return std::nullopt;
    }
    bool sim(const std::string&, std::string& e) override {
      e = "not a simulator";
      return false;
    }
    bool is_simulator() const override { return false; }
    std::string describe() const override { return "real"; }
  } real;
  const auto r = run_suite(parse("requires: sim\nsim push 5\n"), real);
  CHECK(r.skipped);
  CHECK(r.passed());
  const auto xml = junit_xml({r});
  CHECK(xml.find("<skipped message=\"needs the simulator (requires: sim)\"/>") != std::string::npos);
}

TEST_CASE("JUnit XML lists every step with failures escaped") {
  FakeRobot robot;
  const auto r = run_suite(parse("suite: a<b\nexpect telemetry_a state=BALANCE within 150ms\n"), robot);
  const auto xml = junit_xml({r});
  CHECK(xml.find("<testsuite name=\"a&lt;b\" tests=\"1\" failures=\"1\" skipped=\"0\"") != std::string::npos);
  CHECK(xml.find("<failure message=\"no matching telemetry_a within 0.150 s\"/>") != std::string::npos);
}
