// One command on a board's USB console (core/console.hpp) and its reply: the line goes out, reply lines come back
// until the board's "ok" or "error: ..." line, or a deadline. `saulctl console` and `saulctl tune auto --yes` (which
// sets the balance gains with `pid`, reads them back with `status` and restores them) talk through it.
#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "saulproto/core/console.hpp"
#include "saulproto/core/pid_stager.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

struct ConsoleReply {
  enum class End { ok, error, none } end = End::none;  ///< none: no final line before the deadline (or interrupted)
  std::vector<std::string> lines;  ///< everything before the final line
  std::string final_line;          ///< "ok" or "error: ..."
};

/// Reads reply lines until "ok" / "error: ..." or the deadline; lines equal to `command` (a board or terminal echoing
/// what was typed) are left out. `pending` holds bytes read past the reply (kept for the next call) and may start
/// with leftovers. interrupted() is asked between reads and ends the wait early.
ConsoleReply read_console_reply(SerialPort& port, const std::string& command, std::chrono::milliseconds timeout,
                                std::string& pending, const std::function<bool()>& interrupted);

/// Sends `line` (with CR LF) and reads its reply.
ConsoleReply console_command(SerialPort& port, const std::string& line, std::chrono::milliseconds timeout,
                             std::string& pending, const std::function<bool()>& interrupted);

/// The status report in a `status` reply (its "report=status ..." line), if there is one that reads.
std::optional<console::StatusReport> status_in(const ConsoleReply& reply);

/// "pid <kp> <ki> <kd>" with each gain in the shortest form that reads back exactly.
std::string pid_command(const saulcan::PidGains& gains);

}  // namespace saul::host
