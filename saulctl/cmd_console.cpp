// saulctl console: the boards' USB debug console (core/console.hpp): one command line out, reply lines back
// until the board's "ok" or "error: ..." line.
#include <fmt/core.h>
#include <fmt/format.h>
#include <unistd.h>

#include <iostream>
#include <nlohmann/json.hpp>
#include <type_traits>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/core/console.hpp"
#include "saulproto/host/link/serial_port.hpp"
#include "saulproto/host/link/shared_link.hpp"
#include "saulproto/host/robot/console_client.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;

struct ConsoleOptions {
  std::string port;
  std::vector<std::string> command;
  std::string timeout = "2s";
  std::uint32_t baud = 115200;
  bool json = false;
};

using Reply = saul::host::ConsoleReply;

template <class Report>
nlohmann::json report_json(const Report& report) {
  nlohmann::json j = nlohmann::json::object();
  report.fields([&](const char* key, const auto& v) {
    using T = std::decay_t<decltype(v)>;
    if constexpr (std::is_same_v<T, saul::console::Board>) j[key] = saul::console::to_string(v);
    else if constexpr (std::is_same_v<T, saul::saulcan::RobotState>) j[key] = saul::saulcan::to_string(v);
    else j[key] = v;
  });
  return j;
}

/// The report line of a status / can_stats / uart_stats reply as JSON, or a JSON error object; null for other verbs.
nlohmann::json parse_report(saul::console::Verb verb, const Reply& reply) {
  using saul::console::Verb;
  const auto json = [](const auto& r, const std::string& line) -> nlohmann::json {
    if (r) return report_json(*r);
    return {{"parse_error", saul::to_string(r.reason())}, {"line", line}};
  };
  for (const auto& line : reply.lines) {
    if (line.rfind("report=", 0) != 0) continue;
    if (verb == Verb::status) return json(saul::console::parse_status(line), line);
    if (verb == Verb::can_stats) return json(saul::console::parse_can_stats(line), line);
    if (verb == Verb::uart_stats) return json(saul::console::parse_uart_stats(line), line);
  }
  return nullptr;
}

/// Sends one line, prints the reply; returns the exit code.
int one_command(const ConsoleOptions& opt, saul::host::SerialPort& port, const std::string& line,
                milliseconds timeout, std::string& pending) {
  port.write(line + "\r\n", milliseconds(1000));
  const Reply reply =
      saul::host::read_console_reply(port, line, timeout, pending, interrupted);
  const auto parsed = saul::console::parse(line);
  if (opt.json) {
    nlohmann::json j{{"command", line}, {"port", port.path()}};
    j["status"] = reply.end == Reply::End::ok ? "ok" : reply.end == Reply::End::error ? "error" : "no_answer";
    j["lines"] = reply.lines;
    if (reply.end == Reply::End::error) j["error"] = reply.final_line.substr(6 + (reply.final_line.size() > 6));
    if (auto rep = parsed ? parse_report(saul::console::verb_of(parsed.command), reply) : nullptr; !rep.is_null())
      j["report"] = rep;
    fmt::print("{}\n", j.dump());
  } else {
    for (const auto& l : reply.lines) fmt::print("{}\n", l);
    if (reply.end == Reply::End::ok) fmt::print("ok\n");
    else if (reply.end == Reply::End::error) say("{}: {}", port.path(), reply.final_line);
    else
      say("{}: no 'ok' or 'error:' reply to '{}' within {} ms (is this the board's USB console, "
          "and is the board running? try 'saulctl ports')",
          port.path(), line, timeout.count());
  }
  std::fflush(stdout);
  return reply.end == Reply::End::ok ? kOk : reply.end == Reply::End::error ? kFailure : kTimeout;
}

int run_console(const ConsoleOptions& opt) {
  const auto timeout = parse_duration(opt.timeout);
  auto port = saul::host::open_shared_serial(opt.port, {.baud = opt.baud});
  std::string pending;
  if (!opt.command.empty())
    return one_command(opt, *port, fmt::format("{}", fmt::join(opt.command, " ")), timeout, pending);

  // A line loop: interactive on a terminal (with a prompt), else one command per stdin line.
  const bool tty = ::isatty(STDIN_FILENO) != 0;
  if (tty) fmt::print(stderr, "console on {} ({} baud); 'help' lists commands, Ctrl-D leaves\n", port->path(), opt.baud);
  int worst = kOk;
  std::string line;
  while (!g_interrupted) {
    if (tty) {
      fmt::print(stderr, "> ");
      std::fflush(stderr);
    }
    if (!std::getline(std::cin, line)) break;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (line.empty()) continue;
    if (tty && (line == "quit" || line == "exit")) break;
    const int code = one_command(opt, *port, line, timeout, pending);
    if (code > worst) worst = code;
  }
  if (tty) fmt::print(stderr, "\n");
  return tty ? kOk : worst;
}

}  // namespace

void add_console_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<ConsoleOptions>(
      app, run, "console", "The boards' USB debug console: one command, or a line loop", run_console);
  cmd->add_option("port", o->port, "the board's USB serial device, e.g. /dev/ttyACM1")->required();
  cmd->add_option("command", o->command, "command line to send (help, status, pid 1.5 0.2 0.05, ...)");
  cmd->add_option("--timeout", o->timeout, "how long to wait for the 'ok' / 'error:' line")->capture_default_str()->check(duration_check());
  cmd->add_option("--baud", o->baud, "baud rate")->capture_default_str();
  cmd->add_flag("--json", o->json, "one JSON object per command; status, can_stats, uart_stats reports parsed");
  cmd->footer(
      "\nWith a COMMAND: sends it, prints the reply up to the board's 'ok' or 'error: ...' line. Without one: a line\n"
      "loop (a prompt on a terminal; one command per line from a pipe).\n"
      "\nExamples:\n  saulctl console /dev/ttyACM1 status\n  saulctl console /dev/ttyACM1 status --json | jq .report\n"
      "  saulctl console /dev/ttyACM1 pid 1.5 0.25 0.05\n  saulctl console /dev/ttyACM1\n"
      "\nExit codes: 0 ok, 1 error reply or port error, 2 usage, 3 no answer within --timeout.\n");
}

}  // namespace saulctl
