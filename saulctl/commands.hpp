// How saulctl's verbs plug in: each cmd_*.cpp adds one CLI11 subcommand and, when chosen, sets the
// function main() runs. Exit codes are shared by all verbs.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace saulctl {

enum ExitCode : int {
  kOk = 0,
  kFailure = 1,   ///< the command ran and something failed (bad file, rejected command, ...)
  kUsage = 2,     ///< wrong arguments
  kTimeout = 3,   ///< no answer within the deadline
};

using Runner = std::function<int()>;

void add_decode_command(CLI::App& app, Runner& run);

}  // namespace saulctl
