// saulctl tune: the balance loop's tuning tools, one subcommand each (record: cmd_tune_record.cpp).
#include "commands.hpp"

namespace saulctl {

void add_tune_command(CLI::App& app, Runner& run) {
  auto* tune = app.add_subcommand("tune", "Tune the balance loop: record its 1 kHz trace, excite it, analyse it");
  tune->require_subcommand(1);
  add_tune_record_command(*tune, run);
}

}  // namespace saulctl
