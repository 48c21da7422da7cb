// What every saulctl verb that touches a live robot shares: choosing the link, asking before anything that
// can move a motor, and stopping cleanly on Ctrl-C.
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <string>

#include "saulproto/host/link/link_spec.hpp"

namespace saulctl {

/// Set by SIGINT/SIGTERM. Blocking waits return early (the handler does not restart system calls).
extern std::atomic<bool> g_interrupted;
void install_signal_handlers();

/// Adds --link to a subcommand. The default comes from $SAUL_LINK, else ~/.config/saulctl/link (one line).
void add_link_option(CLI::App* cmd, std::string& link);
/// Resolves the link text (option, environment, config file) or throws CLI::ValidationError-like usage errors.
saul::host::LinkSpec resolve_link(const std::string& link);

/// Asks "type yes" on a terminal; with --yes, or when stdin is no terminal and --yes is missing, decides without
/// asking (true / false). Prints why it refused.
bool confirm_motion(bool yes, const std::string& what);

/// Parses "2s", "500ms", "1.5" (seconds), "1m". Throws CLI::ValidationError.
std::chrono::milliseconds parse_duration(const std::string& text);

/// Maps a LinkError to saulctl's exit code and prints it as one line.
int report_link_error(const std::exception& e);

}  // namespace saulctl
