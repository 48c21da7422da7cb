// How saulctl's verbs plug in: each cmd_*.cpp adds one CLI11 subcommand and, when chosen, sets the
// function main() runs. Exit codes and the error line are shared by all verbs.
#pragma once

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <exception>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

/// saulctl's version, for --version and the files it writes.
#ifndef SAULCTL_VERSION
#define SAULCTL_VERSION "unknown"  // CMake sets it to the project version (packaging/CMakeLists.txt)
#endif

namespace saulctl {

enum ExitCode : int {
  kOk = 0,
  kFailure = 1,   ///< the command ran and something failed (bad file, rejected command, ...)
  kUsage = 2,     ///< wrong arguments
  kTimeout = 3,   ///< no answer within the deadline
};

using Runner = std::function<int()>;

/// The one error style of every verb: says `e` (say) and gives its exit code: 2 for a check failing after parsing
/// (CLI::ValidationError), 3 for a link's timeout or a flash chip that never answered, else 1. main() calls it for
/// whatever a verb throws; verbs call it for an error they carry on after.
int report_error(const std::exception& e);
/// Runs `body`; an E it throws is said by report_error(), whose exit code is returned (kOk when nothing was thrown):
/// for a verb that still has its summary to print after an error.
template <class E = std::exception, class Body>
int report_errors(Body&& body) {
  try {
    body();
  } catch (const E& e) {
    return report_error(e);
  }
  return kOk;
}

/// Installs the handlers that set g_interrupted (live.hpp) on SIGINT and SIGTERM, and ignores SIGPIPE.
void install_signal_handlers();

/// Adds the verb `name` to `parent` with a new Options for its options; when it is chosen, `verb(options)` is what
/// main() runs (main() says what it throws: report_error). A live verb (the default) handles Ctrl-C itself
/// (install_signal_handlers); a file verb dies of it, and of SIGPIPE.
template <class Options, class Verb>
std::pair<CLI::App*, Options*> add_verb(CLI::App& parent, Runner& run, std::string name, std::string what, Verb verb,
                                        bool live = true) {
  auto options = std::make_shared<Options>();
  CLI::App* cmd = parent.add_subcommand(std::move(name), std::move(what));
  cmd->callback([options, &run, verb, live] {
    run = [options, verb, live] {
      if (live) install_signal_handlers();
      return verb(*options);
    };
  });
  return {cmd, options.get()};
}

/// The one way every verb tells the user something on stderr: one line "saulctl VERB: message" (VERB as typed:
/// "saulctl tune report: ..."; "saulctl: ..." until main() names the verb once the command line is parsed).
void set_say_verb(std::string verb_path);
void say_line(std::string_view message);
template <class... Args>
void say(fmt::format_string<Args...> format, Args&&... args) {
  say_line(fmt::format(format, std::forward<Args>(args)...));
}

void add_decode_command(CLI::App& app, Runner& run);
void add_convert_command(CLI::App& app, Runner& run);
void add_stats_command(CLI::App& app, Runner& run);
void add_record_command(CLI::App& app, Runner& run);
void add_replay_command(CLI::App& app, Runner& run);
void add_plot_command(CLI::App& app, Runner& run);
void add_command_commands(CLI::App& app, Runner& run);  // mode, estop, pid, config
void add_drive_command(CLI::App& app, Runner& run);
void add_sniff_command(CLI::App& app, Runner& run);
void add_monitor_command(CLI::App& app, Runner& run);
void add_ports_command(CLI::App& app, Runner& run);
void add_sim_command(CLI::App& app, Runner& run);
void add_test_command(CLI::App& app, Runner& run);
void add_flash_command(CLI::App& app, Runner& run);
void add_console_command(CLI::App& app, Runner& run);
void add_pride_command(CLI::App& app, Runner& run);
void add_doctor_command(CLI::App& app, Runner& run);
void add_completion_command(CLI::App& app, Runner& run);
void add_dbc_command(CLI::App& app, Runner& run);
void add_wireshark_command(CLI::App& app, Runner& run);
void add_tune_command(CLI::App& app, Runner& run);  // tune: its subcommands below
void add_tune_record_command(CLI::App& tune, Runner& run);   // tune record
void add_tune_auto_command(CLI::App& tune, Runner& run);     // tune auto
void add_tune_report_commands(CLI::App& tune, Runner& run);  // tune report, tune compare

}  // namespace saulctl
