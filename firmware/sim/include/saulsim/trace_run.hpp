// A loop trace from the simulated robot, in-process and on simulated time (`saulctl tune record --sim`): power on,
// arm with the 3 s button hold as the bench suites do (`saulctl test --sim`), let it find its balance, then
// `trace on` (and an `excite ...` when asked) on BALANCE's console, and hand every console byte to the caller until
// the duration has passed. As fast as the machine steps the world (a few hundred times real time).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "saulfw/hal.hpp"
#include "saulproto/core/pid_stager.hpp"
#include "saulproto/core/trace.hpp"

namespace saul::sim {

struct TraceRunOptions {
  std::uint32_t seed = 1;
  fw::TimeUs duration_us = 10'000'000;       ///< of trace, from `trace on`
  std::uint16_t divider = 1;                 ///< `trace on N`
  std::optional<trace::ExciteStart> excite;  ///< sent with `trace on` (its duration at most 20 s)
  /// Instead of a live trace: balance untraced for the duration, tilt the body beyond the cutoff, then `trace dump`
  /// (the flight recorder's 5 s before the latch); records and gaps are then the dump's.
  bool dump = false;
  /// The balance PID's power-on gains instead of the firmware's (BalanceConfig::gains): comparing gain sets.
  std::optional<saulcan::PidGains> gains;
};

struct TraceRunResult {
  std::uint64_t records = 0;       ///< records seen in the bytes handed over
  std::uint64_t missing = 0;       ///< records lost (seq steps beyond the divider)
  std::uint64_t gaps = 0;          ///< places where records were lost
  std::uint64_t dump_records = 0;  ///< records of the flight recorder's dump (with `dump`)
  double simulated_s = 0;          ///< simulated time of the whole run (power-on to the end)
  std::string stopped;             ///< why it stopped: "duration", "interrupted", "not armed: ...", ...
  bool ok = false;                 ///< armed and traced for the whole duration
};

/// Runs it. `out` gets BALANCE's console bytes as they come (text and records), `interrupted` is asked every
/// simulated 10 ms. Throws nothing of its own.
TraceRunResult run_sim_trace(const TraceRunOptions& options, const std::function<void(std::span<const std::uint8_t>)>& out,
                             const std::function<bool()>& interrupted);

}  // namespace saul::sim
