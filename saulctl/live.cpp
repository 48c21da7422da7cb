#include "live.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <fstream>
#include <iostream>

#include "commands.hpp"
#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saulctl {

std::atomic<bool> g_interrupted{false};

namespace {
void on_signal(int) { g_interrupted = true; }
}  // namespace

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking poll returns EINTR so loops notice at once
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

void add_link_option(CLI::App* cmd, std::string& link) {
  cmd->add_option("-l,--link", link,
                  "CAN link: can0 | socketcan:can0 | slcan:/dev/ttyACM0[@500000] (default: $SAUL_LINK, "
                  "else ~/.config/saulctl/link)");
}

saul::host::LinkSpec resolve_link(const std::string& link) {
  std::string text = link;
  if (text.empty()) {
    if (const char* env = std::getenv("SAUL_LINK")) text = env;
  }
  if (text.empty()) {
    if (const char* home = std::getenv("HOME")) {
      std::ifstream f(std::string(home) + "/.config/saulctl/link");
      std::getline(f, text);
    }
  }
  if (text.empty())
    throw CLI::ValidationError("--link",
                               "no link given: pass --link can0 or --link slcan:/dev/ttyACM0, or set SAUL_LINK "
                               "(saulctl ports lists serial adapters)");
  try {
    return saul::host::parse_link_spec(text);
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--link", e.what());
  }
}

bool confirm_motion(bool yes, const std::string& what) {
  if (yes) return true;
  if (!::isatty(STDIN_FILENO)) {
    fmt::print(stderr, "saulctl: refusing to {} without confirmation: this can make the motors move; add --yes\n",
               what);
    return false;
  }
  fmt::print(stderr, "This can make the motors move. Type 'yes' to {}: ", what);
  std::string answer;
  std::getline(std::cin, answer);
  if (answer == "yes") return true;
  fmt::print(stderr, "saulctl: not confirmed, nothing sent\n");
  return false;
}

std::chrono::milliseconds parse_duration(const std::string& text) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (...) {
    used = 0;
  }
  const std::string unit = text.substr(used);
  double ms = -1;
  if (used > 0) {
    if (unit.empty() || unit == "s") ms = v * 1000;
    else if (unit == "ms") ms = v;
    else if (unit == "m" || unit == "min") ms = v * 60'000;
  }
  if (ms < 0) throw CLI::ValidationError("duration", "bad duration '" + text + "' (use e.g. 500ms, 2s, 1.5, 1m)");
  return std::chrono::milliseconds(static_cast<long long>(ms));
}

int report_link_error(const std::exception& e) {
  fmt::print(stderr, "saulctl: {}\n", e.what());
  if (const auto* le = dynamic_cast<const saul::host::LinkError*>(&e)) {
    if (le->kind() == saul::host::LinkError::Kind::timeout) return kTimeout;
  }
  return kFailure;
}

}  // namespace saulctl
