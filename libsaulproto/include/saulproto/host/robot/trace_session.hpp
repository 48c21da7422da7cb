// Recording BALANCE's loop trace through its USB console (`saulctl tune record --console-balance PORT`): switch the
// trace on (and a test signal, when asked), hand every byte the console sends to the caller for the duration, switch
// it off; or fetch the flight recorder (`trace dump`) and wait for its end. The bytes are the caller's to keep (a
// trace file); this only talks and listens. docs/protocol.md section 10.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "saulproto/core/trace.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

struct LiveTraceOptions {
  /// Of trace, on the robot's clock (ignored with dump): the caller's traced_s() says how much its records cover, so a
  /// simulator running slower or faster than real time still gives this much. The host waits at most 3x this + 5 s.
  std::chrono::milliseconds duration{10'000};
  std::uint16_t divider = 1;
  std::optional<trace::ExciteStart> excite;
  bool dump = false;  ///< fetch the flight recorder instead of a live trace
};

struct LiveTraceEnd {
  /// "duration", "interrupted", "done" (done() said so), "no records for the duration" (the records did not cover
  /// it within 3x its time + 5 s), "the flight recorder's dump ended", "no end of the dump within 30 s"
  std::string stopped;
};

/// Runs it on an open console port: `out` gets every byte, `done` (asked after each read) ends it early (the
/// caller's decoder saw a refusal or the dump's end), `traced_s` (asked likewise) is the robot time the records seen so
/// far cover (TraceStats::duration_s()). Throws SerialError when the port goes away.
LiveTraceEnd run_live_trace(SerialPort& console, const LiveTraceOptions& options,
                            const std::function<void(std::span<const std::uint8_t>)>& out,
                            const std::function<bool()>& interrupted, const std::function<bool()>& done,
                            const std::function<double()>& traced_s);

}  // namespace saul::host
