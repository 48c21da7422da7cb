#include "saulproto/host/robot/trace_session.hpp"

namespace saul::host {

namespace {

using Clock = std::chrono::steady_clock;
constexpr std::chrono::milliseconds kWrite{500};
constexpr std::chrono::milliseconds kStatusReply{200};  // BALANCE answers status within a loop or two

void send(SerialPort& port, const trace::Command& command) {
  char line[64];
  const auto n = trace::format_command(command, line);
  port.write(std::string(line, n.ok() ? *n : 0), kWrite);
}

}  // namespace

LiveTraceEnd run_live_trace(SerialPort& console, const LiveTraceOptions& options,
                            const std::function<void(std::span<const std::uint8_t>)>& out,
                            const std::function<bool()>& interrupted, const std::function<bool()>& done,
                            const std::function<double()>& traced_s) {
  std::uint8_t buffer[4096];
  // Reads until `until` or done(); false when interrupted.
  const auto pump = [&](Clock::time_point until, const std::function<bool()>& stop) {
    while (Clock::now() < until && !stop()) {
      if (interrupted()) return false;
      const std::size_t n = console.read(buffer, std::chrono::milliseconds(20));
      const std::span<const std::uint8_t> bytes(buffer, n);
      out(bytes);
    }
    return true;
  };
  LiveTraceEnd end;
  const auto never = [] { return false; };
  if (options.dump) {
    send(console, trace::TraceDump{});
    const bool ok = pump(Clock::now() + std::chrono::seconds(30), done);
    end.stopped = !ok ? "interrupted" : done() ? "the flight recorder's dump ended" : "no end of the dump within 30 s";
  } else {
    // BALANCE's status first: its "report=status ... kp= ki= kd=" line in the file says which gains the trace ran
    // with (docs/captures.md, "Loop traces").
    console.write("status\n", kWrite);
    if (!pump(Clock::now() + kStatusReply, never)) return {"interrupted"};
    send(console, trace::TraceOn{options.divider});
    if (options.excite) send(console, *options.excite);
    const double want_s = std::chrono::duration<double>(options.duration).count();
    const auto traced = [&] { return traced_s() >= want_s; };
    const bool ok = pump(Clock::now() + 3 * options.duration + std::chrono::seconds(5), [&] { return done() || traced(); });
    send(console, trace::TraceOff{});
    if (options.excite) send(console, trace::ExciteOff{});
    (void)pump(Clock::now() + std::chrono::milliseconds(100), never);  // the records still on their way
    end.stopped = !ok ? "interrupted" : done() ? "done" : traced() ? "duration" : "no records for the duration";
  }
  return end;
}

}  // namespace saul::host
