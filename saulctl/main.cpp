// saulctl: the bench tool for the SAUL-TEE robot. This file only parses arguments and hands over to a verb.
#include <fmt/core.h>

#include <string_view>
#include <utility>

#include "commands.hpp"
#include "usage.hpp"

#ifndef SAULCTL_VERSION
#define SAULCTL_VERSION "unknown"  // CMake sets it to the project version (packaging/CMakeLists.txt)
#endif

namespace {

using Adder = void (*)(CLI::App&, saulctl::Runner&);
// Every verb and what adds it, in the order saulctl --help lists them (add_command_commands adds four).
constexpr std::pair<std::string_view, Adder> kVerbs[] = {
    {"decode", saulctl::add_decode_command}, {"convert", saulctl::add_convert_command},
    {"stats", saulctl::add_stats_command},   {"record", saulctl::add_record_command},
    {"replay", saulctl::add_replay_command}, {"plot", saulctl::add_plot_command},
    {"sniff", saulctl::add_sniff_command},   {"monitor", saulctl::add_monitor_command},
    {"mode", saulctl::add_command_commands}, {"estop", saulctl::add_command_commands},
    {"pid", saulctl::add_command_commands},  {"config", saulctl::add_command_commands},
    {"drive", saulctl::add_drive_command},   {"ports", saulctl::add_ports_command},
    {"sim", saulctl::add_sim_command},       {"test", saulctl::add_test_command},
    {"flash", saulctl::add_flash_command},   {"console", saulctl::add_console_command},
    {"pride", saulctl::add_pride_command},   {"doctor", saulctl::add_doctor_command},
    {"completion", saulctl::add_completion_command},
    {"dbc", saulctl::add_dbc_command},       {"wireshark", saulctl::add_wireshark_command},
    {"tune", saulctl::add_tune_command}};

// Parses the command line with every verb and runs the one it names.
int run_saulctl(int argc, char** argv) {
  CLI::App app{
      "saulctl - bench tool for the SAUL-TEE robot: decode, sniff and drive its CAN bus and serial links.\n"
      "\n"
      "Examples:\n"
      "  saulctl decode captures/robot_bus.log          decode every frame of a candump log\n"
      "  saulctl decode --json run.log | jq .           one JSON object per frame, for scripts\n"
      "  saulctl decode --id 400,401 run.log            only telemetry (ids are hex, as candump writes them)\n"
      "  saulctl sniff --link can0 --duration 10s       live, for ten seconds\n"
      "\n"
      "Every verb speaks one grammar (docs/cli.md): the link is --link L (default $SAUL_LINK), CAN ids are hex\n"
      "(--id 400 = 0x400, ID:MASK, FIRST-LAST), durations take units (--duration 500ms, 10s, 2m), verbs whose\n"
      "output is data take --json.\n"
      "Exit codes: 0 ok, 1 failure, 2 usage error, 3 timeout or no answer.",
      "saulctl"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "saulctl " SAULCTL_VERSION);

  saulctl::Runner run;
  Adder last = nullptr;
  for (const auto& [name, add] : kVerbs) {
    if (add != last) add(app, run);  // once for the four of add_command_commands
    last = add;
  }

  try {
    auto args = saulctl::expand_help_verb(app, argc, argv);  // "saulctl help VERB" is "saulctl VERB --help"
    std::vector<char*> argp;
    for (auto& a : args) argp.push_back(a.data());
    app.parse(static_cast<int>(argp.size()), argp.data());
  } catch (const CLI::CallForHelp&) {
    fmt::print("{}", app.help());
    return saulctl::kOk;
  } catch (const CLI::CallForAllHelp&) {
    fmt::print("{}", app.help("", CLI::AppFormatMode::All));
    return saulctl::kOk;
  } catch (const CLI::CallForVersion& e) {
    fmt::print("{}\n", e.what());
    return saulctl::kOk;
  } catch (const CLI::ParseError& e) {
    // Subcommand help (--help after a verb) arrives here as CallForHelp of the subcommand too.
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    return saulctl::report_usage_error(app, e);  // names the verb, suggests the nearest word, points to its help
  }
  if (!run) {
    fmt::print(stderr, "saulctl: no verb to run (see saulctl --help)\n");
    return saulctl::kUsage;
  }
  const std::string verb = saulctl::verb_path(app);
  saulctl::set_say_verb(verb);
  try {
    const int rc = run();
    // A verb's own usage errors (its checks after parsing) point to its help too.
    if (rc == saulctl::kUsage) saulctl::say("see '{} --help'", verb);
    return rc;
  } catch (const std::exception& e) {
    saulctl::say("{}", e.what());
    return saulctl::kFailure;
  }
}

}  // namespace

// Every verb is built on every start (~0.3 ms: building only the one named saved that, under 1 % of decoding or
// counting a 1 M-frame log; bench/README.md).
int main(int argc, char** argv) { return run_saulctl(argc, argv); }
