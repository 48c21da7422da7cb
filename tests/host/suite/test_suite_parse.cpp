// Scripted bench tests: the parser, and the engine against a fake robot driven by simulated time.
#include <catch2/catch.hpp>

#include <deque>
#include <functional>
#include <sstream>

#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/suite/suite.hpp"

using namespace saul;
using namespace saul::host::suite;
namespace sc = saul::saulcan;

namespace {

Suite parse(const std::string& text) {
  std::istringstream in(text);
  return parse_suite(in, "t.saul");
}

/// The suite text must be refused with an error naming `part`.
void fails(const std::string& text, const std::string& part) {
  try {
    parse(text);
  } catch (const ParseError& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find(part) != std::string::npos);
    return;
  }
  FAIL("no error for: " << text);
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
  /// Telemetry A every 100 ms (default: pitch 1.20 deg, speed 0, the state; nullopt: silent that time), and B
  /// alongside it when set.
  std::function<std::optional<sc::TelemetryA>(std::uint64_t)> telemetry_a;
  std::function<std::optional<sc::TelemetryB>(std::uint64_t)> telemetry_b;

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
      if (telemetry_b)
        if (const auto b = telemetry_b(now)) pending.emplace_front(now, sc::encode(*b));
      const auto a = telemetry_a ? telemetry_a(now) : std::optional<sc::TelemetryA>(sc::TelemetryA{120, 0, 0, state});
      if (a) return sc::encode(*a);
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
      "expect telemetry_a state=BALANCE |pitch|<3 within 2s\n"
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

TEST_CASE("send config_cmd takes decode --json's names: tilt_limit in degrees or tilt_limit_raw") {
  // 0x303: tilt limit in 0.01 deg, u16 LE (1200 = B0 04), then the speed cap in mm/s (1500 = DC 05), by hand
  const auto s = parse(
      "send config_cmd tilt_limit=12 max_speed_mmps=1500\n"
      "send config_cmd tilt_limit_raw=1200 max_speed_mmps=1500\n"
      "send frame 303#B004DC05\n");
  REQUIRE(s.steps.size() == 3);
  CHECK(s.steps[0].frames[0] == s.steps[2].frames[0]);
  CHECK(s.steps[1].frames[0] == s.steps[2].frames[0]);
  fails("send config_cmd tilt_limit_x100=1200 max_speed_mmps=1500\n",
        "t.saul:1: config_cmd has no field 'tilt_limit_x100': use tilt_limit=DEG or tilt_limit_raw=N");
  fails("send config_cmd tilt_limit=12 tilt_limit_raw=1200 max_speed_mmps=1500\n", "unknown field 'tilt_limit'");
}

TEST_CASE("bench suite parse errors name the file and line") {
  fails("\n\nfly away\n", "t.saul:3: unknown step 'fly'");
  fails("expect telemetry_a state=BALANCE\n", "within");
  fails("expect telemetry_a pitch<abc within 1s\n", "not a number");
  CHECK(parse_condition("command=0x02", "t.saul", 1).number == 2.0);  // hex values, as in frames
  CHECK(parse_condition("erpm>-0x10", "t.saul", 1).number == -16.0);
  fails("expect telemetry_a pitch<0x within 1s\n", "not a number");
  // one name per signal: the struct's field name is refused, with the names the message has
  fails("\nexpect telemetry_a pitch_x100<3 within 1s\n",
        "t.saul:2: telemetry_a has no signal 'pitch_x100'; its signals: pitch, pitch_raw, pid_out, speed_mmps, state");
  fails("stable telemetry_a state=BALANCE and telemetry_b faults=0 for 5m within 20m\n",
        "telemetry_b has no signal 'faults'; its signals: vesc_l_rpm, vesc_r_rpm, battery, battery_raw, fault");
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
      "hold telemetry_a state=BALANCE |pitch_raw|<=120 |pitch|<=1.2 for 1s\n"
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
  const auto r = run_suite(parse("hold telemetry_a pitch<1 for 1s\n"), robot);
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

// ---- the tether rule: stable ... for ... within ..., and mean ... for ... ----

TEST_CASE("bench suites parse stable (clauses joined by 'and') and mean") {
  const auto s = parse(
      "stable telemetry_a state=BALANCE |pitch|<5 and telemetry_b fault=0 for 5m within 20m\n"
      "mean telemetry_a speed_mmps>=240 speed_mmps<=360 for 2s\n");
  REQUIRE(s.steps.size() == 2);
  CHECK(s.steps[0].kind == Step::Kind::stable);
  CHECK(s.steps[0].message == "telemetry_a");
  CHECK(s.steps[0].conditions.size() == 2);
  REQUIRE(s.steps[0].more.size() == 1);
  CHECK(s.steps[0].more[0].message == "telemetry_b");
  CHECK(s.steps[0].more[0].conditions[0].field == "fault");
  CHECK(s.steps[0].duration_us == 300'000'000);
  CHECK(s.steps[0].limit_us == 1'200'000'000);
  CHECK(s.steps[1].kind == Step::Kind::mean);
  CHECK(s.steps[1].conditions.size() == 2);
  CHECK(s.steps[1].duration_us == 2'000'000);
  fails("stable telemetry_a state=BALANCE for 5m\n", "for DURATION within DURATION");
  fails("stable telemetry_a for 5m within 1m\n", "0 < for <= within");
  fails("stable telemetry_a and for 5m within 10m\n", "needs a message name");
  fails("stable any for 5m within 10m\n", "not 'any'");
  fails("mean telemetry_a for 1s\n", "at least one condition");
  fails("mean telemetry_a speed_mmps>1 within 1s\n", "'within' is not a condition");
  fails("mean telemetry_a speed_mmps>1 for\n", "for DURATION");
  fails("mean telemetry_a speed_mmps>1 for 1s 2s\n", "unexpected words after the duration");
}

TEST_CASE("the engine: stable restarts its clock on every excursion and passes once it held long enough") {
  FakeRobot robot;
  // pitch 1.20 deg, except 2.0-2.2 s (three frames) at 9 deg
  robot.telemetry_a = [](std::uint64_t t) {
    const bool out = t >= 2'000'000 && t <= 2'200'000;
    return std::optional<sc::TelemetryA>(sc::TelemetryA{static_cast<std::int16_t>(out ? 900 : 120), 0, 0, sc::RobotState::balance});
  };
  const auto r = run_suite(parse("stable telemetry_a state=BALANCE |pitch|<5 for 5s within 20s\n"), robot);
  INFO(r.steps[0].message);
  CHECK(r.passed());
  CHECK(r.steps[0].message ==
        "stable for 5.000 s from 2.200 s on; longest stable stretch 5.000 s (needed 5.000 s), 3 restart(s), the last "
        "at 2.200 s: broken by 400#84030000000001");
  CHECK(robot.now == 7'200'000);  // done as soon as it held: not the whole 20 s
  const auto xml = junit_xml({r});
  CHECK(xml.find("<system-out>stable for 5.000 s from 2.200 s on; longest stable stretch 5.000 s") != std::string::npos);
}

TEST_CASE("the engine: stable fails at its limit and reports the longest stretch, in the JUnit report too") {
  FakeRobot robot;
  robot.telemetry_a = [](std::uint64_t t) {  // an excursion every 3 s
    const bool out = t % 3'000'000 == 0 && t > 0;
    return std::optional<sc::TelemetryA>(sc::TelemetryA{static_cast<std::int16_t>(out ? -900 : 120), 0, 0, sc::RobotState::balance});
  };
  const auto r = run_suite(parse("stable telemetry_a |pitch|<5 for 5s within 10s\n"), robot);
  CHECK_FALSE(r.passed());
  CHECK(r.steps[0].message ==
        "never stable for 5.000 s within 10.000 s: longest stable stretch 3.000 s (needed 5.000 s), 3 restart(s), the "
        "last at 9.000 s: broken by 400#7CFC0000000001");
  const auto xml = junit_xml({r});
  CHECK(xml.find("<failure message=\"never stable for 5.000 s within 10.000 s: longest stable stretch 3.000 s") !=
        std::string::npos);
  CHECK(xml.find("</failure>") == std::string::npos);
  CHECK(xml.find("<system-out>never stable") != std::string::npos);
}

TEST_CASE("the engine: stable counts silence as an excursion, and checks every clause joined by 'and'") {
  SECTION("telemetry A silent for 1.5 s") {
    FakeRobot robot;
    robot.telemetry_a = [](std::uint64_t t) {
      return t > 1'000'000 && t < 2'500'000 ? std::nullopt
                                            : std::optional<sc::TelemetryA>(sc::TelemetryA{120, 0, 0, sc::RobotState::balance});
    };
    const auto r = run_suite(parse("stable telemetry_a state=BALANCE for 3s within 10s\n"), robot);
    CHECK(r.passed());
    CHECK(r.steps[0].message.find("from 2.500 s on") != std::string::npos);
    CHECK(r.steps[0].message.find("telemetry_a silent for over 1.000 s") != std::string::npos);
  }
  SECTION("telemetry B with a fault bit for a while") {
    FakeRobot robot;
    robot.state = sc::RobotState::balance;
    robot.telemetry_b = [](std::uint64_t t) {
      const std::uint8_t faults = t >= 1'000'000 && t < 1'500'000 ? 0x80 : 0;
      return std::optional<sc::TelemetryB>(sc::TelemetryB{0, 0, 39000, faults});
    };
    const auto r = run_suite(parse("stable telemetry_a state=BALANCE and telemetry_b fault=0 for 3s within 10s\n"), robot);
    CHECK(r.passed());
    CHECK(r.steps[0].message.find("from 1.400 s on") != std::string::npos);
    const auto never = run_suite(parse("stable telemetry_a state=BALANCE and vesc_status_1 erpm=0 for 3s within 5s\n"), robot);
    CHECK_FALSE(never.passed());  // a message that never comes is never stable
  }
}

TEST_CASE("the engine: mean checks the fields' means over the window") {
  FakeRobot robot;
  robot.telemetry_a = [](std::uint64_t t) {  // 100 and 300 mm/s in turn: a mean of 200
    const auto speed = static_cast<std::int16_t>((t / 100'000) % 2 == 0 ? 100 : 300);
    return std::optional<sc::TelemetryA>(sc::TelemetryA{120, 0, speed, sc::RobotState::balance});
  };
  const auto ok = run_suite(parse("mean telemetry_a speed_mmps>=190 speed_mmps<=210 |pitch|<2 for 2s\n"), robot);
  INFO(ok.steps[0].message);
  CHECK(ok.passed());
  // 0.0 to 2.0 s, both ends: 11 frames at 100 mm/s and 10 at 300
  CHECK(ok.steps[0].message == "means over 21 frames: speed_mmps 195.24, |pitch| 1.20");
  const auto low = run_suite(parse("mean telemetry_a speed_mmps>=250 for 2s\n"), robot);
  CHECK_FALSE(low.passed());
  // the same robot, 2.1 to 4.0 s: 10 frames of each
  CHECK(low.steps[0].message == "speed_mmps mean 200.00 breaks the condition (means over 20 frames: speed_mmps 200.00)");
  const auto none = run_suite(parse("mean command_ack result=1 for 1s\n"), robot);
  CHECK_FALSE(none.passed());
  CHECK(none.steps[0].message == "no command_ack at all in 1.000 s");
}
