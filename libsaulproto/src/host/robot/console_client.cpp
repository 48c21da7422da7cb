#include "saulproto/host/robot/console_client.hpp"

#include <fmt/core.h>

#include <array>

namespace saul::host {

using namespace std::chrono;

namespace {
constexpr std::size_t kMaxConsoleLine = 64 * 1024;
}  // namespace

ConsoleReply read_console_reply(SerialPort& port, const std::string& command, milliseconds timeout,
                                std::string& pending, const std::function<bool()>& interrupted) {
  ConsoleReply r;
  const auto deadline = steady_clock::now() + timeout;
  std::array<std::uint8_t, 512> buf{};
  while (!interrupted()) {
    std::size_t nl;
    while ((nl = pending.find('\n')) != std::string::npos) {
      std::string line = pending.substr(0, nl);
      pending.erase(0, nl + 1);
      while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
      if (line == command) continue;
      if (line == "ok" || line.starts_with("error:")) {
        r.end = line == "ok" ? ConsoleReply::End::ok : ConsoleReply::End::error;
        r.final_line = line;
        return r;
      }
      r.lines.push_back(line);
    }
    const auto now = steady_clock::now();
    if (now >= deadline) break;
    const std::size_t n = port.read(buf, ceil<milliseconds>(deadline - now));
    // A device that streams without a line end (a wrong port, a baud mismatch) is not let grow this without bound:
    // no console line is near 64 KiB, so an unended run that long is dropped (the reply then times out).
    if (pending.size() > kMaxConsoleLine) pending.clear();
    pending.append(reinterpret_cast<const char*>(buf.data()), n);
  }
  return r;
}

ConsoleReply console_command(SerialPort& port, const std::string& line, milliseconds timeout, std::string& pending,
                             const std::function<bool()>& interrupted) {
  port.write(line + "\r\n", milliseconds(1000));
  return read_console_reply(port, line, timeout, pending, interrupted);
}

std::optional<console::StatusReport> status_in(const ConsoleReply& reply) {
  for (const auto& line : reply.lines)
    if (line.starts_with("report=status"))
      if (auto r = console::parse_status(line)) return *r;
  return std::nullopt;
}

std::string pid_command(const saulcan::PidGains& gains) {
  return fmt::format("pid {} {} {}", gains.kp, gains.ki, gains.kd);
}

}  // namespace saul::host
