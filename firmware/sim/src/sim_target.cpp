#include "saulsim/sim_target.hpp"

namespace saul::sim {

void SimTarget::step() {
  world_.step();
  for (auto& f : world_.take_can_output()) pending_.push_back(f);
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
  const std::string reply = world_.command(command);
  if (reply.rfind("error:", 0) == 0) {
    error = reply.substr(0, reply.find('\n'));
    return false;
  }
  return true;
}

}  // namespace saul::sim
