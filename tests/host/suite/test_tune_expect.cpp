// Bench suites' tuning steps: `trace [step|chirp|prbs A] for D` and `expect tune FIGURE OP VALUE...` parsed (units
// converted, wrong ones refused), and check_tune judging figures written here by hand (not by the analysis).
// The steps against the simulated robot, end to end: tests/cli/tune_suite.sh and tests/suites/tune_figures.saul.
#include <catch2/catch.hpp>

#include <sstream>

#include "saulproto/host/suite/tune_expect.hpp"

using namespace saul;
using namespace saul::host::suite;

namespace {

Suite parse(const std::string& text) {
  std::istringstream in(text);
  return parse_suite(in, "t.saul");
}

std::string parse_error(const std::string& text) {
  try {
    parse(text);
  } catch (const ParseError& e) {
    return e.what();
  }
  return "(no error)";
}

/// A report with a directly measured step response and the other figures as given.
host::tune::Report report(double overshoot, std::optional<double> settling) {
  host::tune::Report r;
  host::tune::DirectStep d;
  d.steps = 2;
  d.figures.overshoot_pct = overshoot;
  d.figures.settling_time_s = settling;
  d.figures.rise_time_s = 0.09;
  r.direct_step = d;
  r.spectra.resize(1);  // spectra computed, no oscillation among them
  r.saturation_pct = 0.5;
  return r;
}

}  // namespace

TEST_CASE("bench suites parse trace and expect tune, figures in their units") {
  const auto s = parse(
      "trace for 2s\n"
      "trace step 0.5 for 4s\n"
      "trace chirp 1deg for 10s\n"
      "expect tune overshoot<25% settling<600ms rise<=0.3s oscillation=none saturation<5 falls=0\n");
  REQUIRE(s.steps.size() == 4);
  CHECK(s.steps[0].kind == Step::Kind::trace);
  CHECK_FALSE(s.steps[0].excite);
  CHECK(s.steps[0].duration_us == 2'000'000);
  REQUIRE(s.steps[1].excite);
  CHECK(s.steps[1].excite->kind == trace::Excite::step);
  CHECK(s.steps[1].excite->amplitude_deg == 0.5F);
  CHECK(s.steps[2].excite->kind == trace::Excite::chirp);
  CHECK(s.steps[2].excite->amplitude_deg == 1.0F);
  const auto& c = s.steps[3].conditions;
  CHECK(s.steps[3].kind == Step::Kind::expect_tune);
  REQUIRE(c.size() == 6);
  CHECK(c[0].field == "overshoot");
  CHECK(*c[0].number == 25.0);
  CHECK(*c[1].number == 0.6);  // 600ms in seconds, the same double as 0.6
  CHECK(c[2].op == Condition::Op::le);
  CHECK(c[3].text == "none");
  CHECK(*c[4].number == 5.0);
}

TEST_CASE("expect tune refuses a wrong unit, an unknown figure, a word for a number, and trace its limits") {
  CHECK_THAT(parse_error("expect tune overshoot<0.6s\n"), Catch::Contains("t.saul:1: 'overshoot<0.6s': overshoot is in %, not s"));
  CHECK_THAT(parse_error("expect tune settling<5%\n"), Catch::Contains("settling is in s, not %"));
  CHECK_THAT(parse_error("expect tune wobble<3\n"), Catch::Contains("no tuning figure 'wobble' (overshoot, rise, settling"));
  CHECK_THAT(parse_error("expect tune |overshoot|<3\n"), Catch::Contains("no tuning figure"));
  CHECK_THAT(parse_error("expect tune rise=fast\n"), Catch::Contains("the value must be a number"));
  CHECK_THAT(parse_error("expect tune\n"), Catch::Contains("expect tune needs figures"));
  CHECK_THAT(parse_error("trace step 3 for 4s\n"), Catch::Contains("0 < |A| <= 2"));
  CHECK_THAT(parse_error("trace step for 4s\n"), Catch::Contains("0 < |A| <= 2"));
  CHECK_THAT(parse_error("trace wiggle 1 for 4s\n"), Catch::Contains("step|chirp|prbs"));
  CHECK_THAT(parse_error("trace for 500ms\n"), Catch::Contains("1 s to 10 min"));
  CHECK_THAT(parse_error("trace chirp 1\n"), Catch::Contains("'for DURATION'"));
}

TEST_CASE("check_tune names the figure, its value and the limit, and what cannot be judged fails with the reason") {
  const auto conditions = [](const std::string& line) { return parse("expect tune " + line + "\n").steps[0].conditions; };
  CHECK(check_tune(conditions("overshoot<25% settling<0.6s rise<100ms oscillation=none saturation<1"),
                   report(12.0, 0.4)) == "");
  CHECK(check_tune(conditions("settling<1s overshoot<10%"), report(12.0, 0.4)) ==
        "overshoot 12 % breaks overshoot<10% (step response measured at 2 setpoint step(s))");
  CHECK(check_tune(conditions("settling<=300ms"), report(12.0, 0.4)) ==
        "settling 0.4 s breaks settling<=0.3s (step response measured at 2 setpoint step(s))");
  CHECK_THAT(check_tune(conditions("settling<5s"), report(12.0, std::nullopt)), Catch::Contains("never settles"));
  CHECK(check_tune(conditions("oscillation!=none"), report(1, 0.1)) == "oscillation none breaks oscillation!=none");
  CHECK(check_tune(conditions("oscillation>5Hz"), report(1, 0.1)) == "oscillation: none found, so oscillation>5Hz does not hold");

  auto ringing = report(1, 0.1);
  ringing.oscillation = host::tune::Oscillation{"rate_dps", 37.5, 120};
  CHECK(check_tune(conditions("oscillation>30Hz oscillation<40Hz"), ringing) == "");
  CHECK(check_tune(conditions("oscillation=none"), ringing) ==
        "oscillation 37.5 Hz breaks oscillation=none (in rate_dps, 120x its band's median)");

  host::tune::Report slow;  // 10 Hz telemetry: no step response, no spectra
  slow.step_reason = "10 Hz is too slow";
  slow.direct_step_reason = "no setpoint";
  slow.spectra_reason = "10 Hz is too slow";
  CHECK_THAT(check_tune(conditions("rise<1s"), slow), Catch::Contains("rise cannot be checked (rise<1s): no step response"));
  CHECK_THAT(check_tune(conditions("oscillation=none"), slow), Catch::Contains("no spectra: 10 Hz is too slow"));
}

TEST_CASE("the engine: trace and expect tune are skipped on a target without BALANCE's console") {
  struct NoConsole final : Target {
    std::uint64_t now = 0;
    std::uint64_t now_us() override { return now; }
    void send(const CanFrame&) override {}
    std::optional<CanFrame> receive_until(std::uint64_t deadline) override {
      now = deadline;
      return std::nullopt;
    }
    std::optional<std::string> console(const std::string&, const std::string&, const std::string&,
                                       std::uint64_t) override {
      return std::nullopt;
    }
    bool sim(const std::string&, std::string&) override { return true; }
    bool is_simulator() const override { return false; }
    std::string describe() const override { return "no console"; }
  } target;
  const auto r = run_suite(parse("trace chirp 1 for 10s\nexpect tune overshoot<25%\n"), target);
  REQUIRE(r.steps.size() == 2);
  CHECK(r.steps[0].status == StepResult::Status::skipped);
  CHECK(r.steps[1].status == StepResult::Status::skipped);
  CHECK(r.passed());
  const auto none = run_suite(parse("expect tune overshoot<25%\n"), target);
  CHECK_FALSE(none.passed());
  CHECK_THAT(none.steps[0].message, Catch::Contains("a 'trace ... for DURATION' step must come first"));
}
