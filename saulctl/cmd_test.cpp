// saulctl test: run scripted bench suites (tests/suites/*.saul) against the simulator or the real robot.
#include <fmt/core.h>

#include <fstream>
#include <memory>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/suite/live_target.hpp"
#include "saulsim/sim_target.hpp"

namespace saulctl {
namespace {

namespace bt = saul::host::suite;

struct TestOptions {
  std::vector<std::string> suites;
  std::string link;
  std::string console_balance;
  std::string console_io;
  std::string sim_control;
  std::string junit;
  bool sim = false;
  std::uint32_t seed = 1;
};

std::unique_ptr<saul::host::SerialPort> open_console(const std::string& path) {
  if (path.empty()) return nullptr;
  return saul::host::open_serial(path, saul::host::SerialSettings{});  // 115200 8N1
}

void print_result(const bt::SuiteResult& r) {
  if (r.skipped) {
    fmt::print("SKIP {} ({})\n", r.name, r.skip_reason);
    return;
  }
  fmt::print("{} {} ({:.1f} s)\n", r.passed() ? "PASS" : "FAIL", r.name, static_cast<double>(r.elapsed_us) / 1e6);
  for (const auto& s : r.steps) {
    const char* mark = s.status == bt::StepResult::Status::passed   ? "  ok  "
                       : s.status == bt::StepResult::Status::failed ? "  FAIL"
                                                                    : "  skip";
    fmt::print("{} {}:{} {}{}\n", mark, r.path, s.line, s.source, s.message.empty() ? "" : "  -> " + s.message);
  }
}

int run_tests(const TestOptions& opt) {
  std::vector<bt::Suite> suites;
  for (const auto& path : opt.suites) {
    try {
      suites.push_back(bt::load_suite(path));
    } catch (const bt::ParseError& e) {  // a usage error (report_error: exit 2)
      throw CLI::ValidationError(e.what());
    }
  }
  std::vector<bt::SuiteResult> results;
  if (opt.sim) {
    // Each suite gets a freshly powered-on simulated robot, so suites do not depend on each other.
    fmt::print("saulctl test: {} suite(s) against the simulated robot (in-process, simulated time)\n", suites.size());
    for (const auto& s : suites) {
      if (g_interrupted) break;
      saul::sim::WorldConfig config;
      config.plant.seed = opt.seed;
      saul::sim::World world(config);
      saul::sim::SimTarget target(world);
      results.push_back(bt::run_suite(s, target));
      print_result(results.back());
    }
  } else {
    auto link = saul::host::open_can_link(resolve_link(opt.link));
    std::map<std::string, std::unique_ptr<saul::host::SerialPort>> consoles;
    if (auto p = open_console(opt.console_balance)) consoles["balance"] = std::move(p);
    if (auto p = open_console(opt.console_io)) consoles["io"] = std::move(p);
    bt::LiveTarget target(*link, std::move(consoles), open_console(opt.sim_control));
    fmt::print("saulctl test: {} suite(s) against {}\n", suites.size(), target.describe());
    for (const auto& s : suites) {
      if (g_interrupted) break;
      results.push_back(bt::run_suite(s, target));
      print_result(results.back());
    }
  }
  std::size_t passed = 0, failed = 0, skipped = 0;
  for (const auto& r : results) {
    if (r.skipped) ++skipped;
    else if (r.passed()) ++passed;
    else ++failed;
  }
  fmt::print("{} passed, {} failed, {} skipped\n", passed, failed, skipped);
  if (!opt.junit.empty()) {
    std::ofstream out(opt.junit);
    out << bt::junit_xml(results);
    if (!out) {
      say("cannot write JUnit file '{}'", opt.junit);
      return kFailure;
    }
  }
  return failed == 0 && !g_interrupted ? kOk : kFailure;
}

}  // namespace

void add_test_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<TestOptions>(
      app, run, "test", "Run scripted bench test suites (*.saul) against the robot or the simulator", run_tests);
  cmd->add_option("suites", o->suites, "suite files, e.g. tests/suites/*.saul")->required()->check(CLI::ExistingFile);
  add_link_option(cmd, o->link);
  cmd->add_option("--console-balance", o->console_balance, "BALANCE board USB console port (for 'console balance' steps)");
  cmd->add_option("--console-io", o->console_io, "IO board USB console port (for 'console io' steps)");
  cmd->add_option("--sim-control", o->sim_control, "control port of a running 'saulctl sim' (for 'sim' steps)");
  cmd->add_option("--junit", o->junit, "also write JUnit XML here");
  cmd->add_flag("--sim", o->sim, "run against a simulated robot in this process, on simulated time (no --link)");
  cmd->add_option("--seed", o->seed, "noise seed for --sim")->capture_default_str();
  cmd->footer(
      "\nA suite is one step per line (send, stream, stop, expect, hold, console, sim, wait, trace + expect tune);\n"
      "see docs/bench-tests.md.\n"
      "Steps that need something this target lacks (a console, the simulator) are skipped, not failed.\n"
      "\nExamples:\n  saulctl test --sim tests/suites/*.saul --junit results.xml     the simulator, fast and repeatable\n"
      "  saulctl sim & saulctl test tests/suites/*.saul --link slcan:CAN --console-balance BAL --sim-control CTL\n"
      "  saulctl test tests/suites/arm_and_balance.saul --link can0 --console-balance /dev/ttyACM1 --junit out.xml\n"
      "\nExit codes: 0 all passed (or skipped), 1 a suite failed, 2 a suite file has an error.\n");
}

}  // namespace saulctl
