// saulctl: the bench tool for the SAUL-TEE robot. This file only parses arguments and hands over to a verb.
#include <vector>

#include "commands.hpp"
#include "usage.hpp"

int main(int argc, char** argv) {
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

  // Every verb, in the order saulctl --help lists them (add_command_commands adds mode, estop, pid and config).
  saulctl::Runner run;
  using namespace saulctl;
  for (auto* add : {add_decode_command, add_convert_command, add_stats_command, add_record_command,
                    add_replay_command, add_plot_command, add_sniff_command, add_monitor_command,
                    add_command_commands, add_drive_command, add_ports_command, add_sim_command, add_test_command,
                    add_flash_command, add_console_command, add_pride_command, add_doctor_command,
                    add_completion_command, add_dbc_command, add_wireshark_command, add_tune_command})
    add(app, run);

  try {
    auto args = saulctl::expand_help_verb(app, argc, argv);  // "saulctl help VERB" is "saulctl VERB --help"
    std::vector<char*> argp;
    for (auto& a : args) argp.push_back(a.data());
    app.parse(static_cast<int>(argp.size()), argp.data());
  } catch (const CLI::ParseError& e) {
    // --help (of saulctl or a verb), --help-all and --version: printed on stdout, exit 0.
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    return saulctl::report_usage_error(app, e);  // names the verb, suggests the nearest word, points to its help
  }
  if (!run) {
    saulctl::say("no verb to run (see saulctl --help)");  // "saulctl: ...": no verb named yet
    return saulctl::kUsage;
  }
  const std::string verb = saulctl::verb_path(app);
  saulctl::set_say_verb(verb);
  int rc = saulctl::kFailure;
  try {
    rc = run();
  } catch (const std::exception& e) {
    rc = saulctl::report_error(e);
  }
  // A verb's own usage errors (its checks after parsing) point to its help too.
  if (rc == saulctl::kUsage) saulctl::say("see '{} --help'", verb);
  return rc;
}

