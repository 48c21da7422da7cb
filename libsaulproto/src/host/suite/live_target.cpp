#include "saulproto/host/suite/live_target.hpp"

#include <fmt/format.h>

namespace saul::host::suite {

using namespace std::chrono;

LiveTarget::LiveTarget(CanLink& link, std::map<std::string, std::unique_ptr<SerialPort>> consoles,
                       std::unique_ptr<SerialPort> sim_control)
    : link_(link), consoles_(std::move(consoles)), sim_control_(std::move(sim_control)) {}

std::uint64_t LiveTarget::now_us() {
  return static_cast<std::uint64_t>(duration_cast<microseconds>(steady_clock::now() - start_).count());
}

void LiveTarget::send(const CanFrame& frame) { link_.send(frame, milliseconds(100)); }

std::optional<CanFrame> LiveTarget::receive_until(std::uint64_t deadline_us) {
  const std::uint64_t now = now_us();
  if (now >= deadline_us) return std::nullopt;
  // Round the wait up so a sub-millisecond remainder does not turn into a busy loop.
  const auto wait = milliseconds((deadline_us - now + 999) / 1000);
  return link_.receive(wait);
}

std::string LiveTarget::exchange(SerialPort& port, const std::string& line, const std::string& until,
                                 std::uint64_t timeout_us) {
  // Drop whatever the board printed before (log lines), then send the command and collect the reply.
  std::array<std::uint8_t, 1024> buf{};
  while (port.read(buf, milliseconds(0)) > 0) {
  }
  port.write(line + "\n", milliseconds(200));
  std::string reply;
  const auto deadline = steady_clock::now() + microseconds(timeout_us);
  while (steady_clock::now() < deadline) {
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    const std::size_t n = port.read(buf, std::max(left, milliseconds(1)));
    reply.append(reinterpret_cast<const char*>(buf.data()), n);
    if (!until.empty() && reply.find(until) != std::string::npos) break;
    if (reply.find("error:") != std::string::npos && reply.back() == '\n') break;
  }
  return reply;
}

std::optional<std::string> LiveTarget::console(const std::string& board, const std::string& line,
                                               const std::string& until, std::uint64_t timeout_us) {
  const auto it = consoles_.find(board);
  if (it == consoles_.end()) return std::nullopt;
  return exchange(*it->second, line, until, timeout_us);
}

bool LiveTarget::console_type(const std::string& board, const std::string& bytes) {
  const auto it = consoles_.find(board);
  if (it == consoles_.end()) return false;
  it->second->write(bytes, milliseconds(200));
  return true;
}

std::optional<std::string> LiveTarget::console_take(const std::string& board) {
  const auto it = consoles_.find(board);
  if (it == consoles_.end()) return std::nullopt;
  // What has arrived, without waiting: a trace step calls this every 10 ms (390 bytes of 1 kHz trace records).
  std::array<std::uint8_t, 4096> buf{};
  std::string out;
  for (std::size_t n; (n = it->second->read(buf, milliseconds(0))) > 0;) out.append(reinterpret_cast<const char*>(buf.data()), n);
  return out;
}

bool LiveTarget::sim(const std::string& command, std::string& error) {
  if (!sim_control_) {
    error = "not a simulator (give --sim-control PATH to use a running saulctl sim)";
    return false;
  }
  const std::string reply = exchange(*sim_control_, command, "ok", 1'000'000);
  if (reply.find("ok") == std::string::npos) {
    error = "simulator refused '" + command + "': " + reply;
    return false;
  }
  return true;
}

std::string LiveTarget::describe() const {
  std::string s = link_.name();
  for (const auto& [board, port] : consoles_) s += fmt::format(", {} console {}", board, port->path());
  if (sim_control_) s += ", sim control " + sim_control_->path();
  return s;
}

}  // namespace saul::host::suite
