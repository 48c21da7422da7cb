// saulctl tune: the balance loop's tuning as a measurement. This file only makes the verb; its subcommands come
// from their own files (cmd_tune_report.cpp: report, compare).
#include "commands.hpp"

namespace saulctl {

void add_tune_command(CLI::App& app, Runner& run) {
  auto* tune = app.add_subcommand("tune", "The balance loop's tuning from a trace: step response, oscillation, noise");
  tune->require_subcommand(1);
  add_tune_report_commands(*tune, run);
}

}  // namespace saulctl
