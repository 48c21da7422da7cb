#include "saulsim/sim_target.hpp"

#include <algorithm>
#include <cstdlib>

namespace saul::sim {

void SimTarget::step() {
  world_.step();
  for (auto& f : world_.take_can_output()) pending_.push_back(f);
  io_duty_peak_ = std::max(io_duty_peak_, world_.io_drive_duty());
}

bool SimTarget::check(const std::string& condition, std::string& error) const {
  static const char* const kOps[] = {"<=", ">=", "!=", "=", "<", ">"};
  for (const char* op : kOps) {
    const auto at = condition.find(op);
    if (at == std::string::npos || at == 0) continue;
    const std::string field = condition.substr(0, at);
    const std::string text = condition.substr(at + std::char_traits<char>::length(op));
    char* end = nullptr;
    const double want = std::strtod(text.c_str(), &end);
    if (text.empty() || end == nullptr || *end != '\0') break;
    double have = 0;
    if (field == "io_duty") {
      have = world_.io_drive_duty();
    } else if (field == "io_duty_peak") {
      have = io_duty_peak_;
    } else if (field == "io_armed") {
      have = world_.io().armed() ? 1 : 0;
    } else {
      error = "error: check: unknown field '" + field + "' (io_duty, io_duty_peak, io_armed)";
      return false;
    }
    const std::string o = op;
    const bool holds = o == "<=" ? have <= want : o == ">=" ? have >= want : o == "!=" ? have != want
                       : o == "="  ? have == want : o == "<"  ? have < want : have > want;
    if (!holds)
      error = "error: check " + condition + " failed: " + field + "=" + std::to_string(static_cast<long long>(have));
    return holds;
  }
  error = "error: check needs FIELD OP NUMBER, e.g. io_duty_peak<=100";
  return false;
}

std::optional<CanFrame> SimTarget::receive_until(std::uint64_t deadline_us) {
  for (;;) {
    if (!pending_.empty()) {
      CanFrame f = pending_.front();
      pending_.pop_front();
      return f;
    }
    if (world_.now_us() >= deadline_us) return std::nullopt;
    step();
  }
}

std::optional<std::string> SimTarget::console(const std::string& board, const std::string& line,
                                              const std::string& until, std::uint64_t timeout_us) {
  (void)world_.take_console_output(board);  // what the board printed before is not the reply
  world_.console_input(board, line + "\n");
  std::string reply;
  const std::uint64_t deadline = world_.now_us() + timeout_us;
  while (world_.now_us() < deadline) {
    step();  // frames seen meanwhile stay queued for later expect steps
    reply += world_.take_console_output(board);
    if (!until.empty() && reply.find(until) != std::string::npos) break;
    if (reply.find("error:") != std::string::npos && reply.back() == '\n') break;
  }
  return reply;
}

bool SimTarget::sim(const std::string& command, std::string& error) {
  if (command.rfind("check ", 0) == 0) return check(command.substr(6), error);
  if (command.rfind("type ", 0) == 0) {  // a console line typed now, its reply not awaited
    const auto sp = command.find(' ', 5);
    const std::string board = command.substr(5, sp == std::string::npos ? std::string::npos : sp - 5);
    if ((board != "balance" && board != "io") || sp == std::string::npos) {
      error = "error: type BOARD LINE: board balance or io";
      return false;
    }
    world_.console_input(board, command.substr(sp + 1) + "\n");
    return true;
  }
  if (command == "peak reset") {
    io_duty_peak_ = 0;
    return true;
  }
  const std::string reply = world_.command(command);
  if (reply.rfind("error:", 0) == 0) {
    error = reply.substr(0, reply.find('\n'));
    return false;
  }
  return true;
}

}  // namespace saul::sim
