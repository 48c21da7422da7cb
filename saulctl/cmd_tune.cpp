// saulctl tune: the balance loop's tuning as a measurement. This file only makes the verb; its subcommands come
// from their own files (cmd_tune_record.cpp: record; cmd_tune_report.cpp: report, compare).
#include "commands.hpp"

namespace saulctl {

void add_tune_command(CLI::App& app, Runner& run) {
  auto* tune = app.add_subcommand(
      "tune", "Tune the balance loop: record its 1 kHz trace and excite it, then its step response, oscillation, noise");
  tune->require_subcommand(1);
  add_tune_record_command(*tune, run);
  add_tune_report_commands(*tune, run);
  add_tune_auto_command(*tune, run);
}

}  // namespace saulctl
