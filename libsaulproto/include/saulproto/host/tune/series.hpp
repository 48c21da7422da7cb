// The balance loop over time, as the tuning analysis (analysis.hpp) reads it: one column per quantity, one row
// per loop iteration (1 kHz from the BALANCE board's loop trace) or per telemetry frame (10 Hz from 0x400 in a CAN
// capture). The readers here fill it from a CSV of named columns (what `saulctl convert run.trace out.csv` writes,
// or data from elsewhere) and from a CAN capture; a bad row is left out and told (file:line and why), never turned
// into a number.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace saul::host::tune {

/// The gains a trace ran with, when the file says (a CSV comment "# kp=30 ki=2 kd=1.5").
struct Gains {
  std::optional<double> kp, ki, kd;
  [[nodiscard]] bool known() const { return kp || ki || kd; }
};

/// Where the rows came from: what a rate can say depends on it.
enum class SeriesSource : std::uint8_t { loop_trace, telemetry };

struct Series {
  std::string name;  ///< the file, for messages
  SeriesSource source = SeriesSource::loop_trace;
  // Columns, all of the same length when present; an optional column absent from the input is empty.
  std::vector<double> time_s;        ///< strictly increasing
  std::vector<double> setpoint_deg;  ///< the balance PID's pitch setpoint (empty: telemetry has none)
  std::vector<double> pitch_deg;     ///< + nose up
  std::vector<double> rate_dps;      ///< pitch rate, deg/s
  std::vector<double> p_term, i_term, d_term;  ///< the PID's terms, permille
  std::vector<double> output;        ///< the PID's output, permille (saturated at +-1000)
  std::vector<double> seq;           ///< the loop's iteration counter, when the trace has one
  std::vector<std::uint8_t> excite;  ///< 1 while a deliberate excitation runs
  std::vector<std::uint8_t> state;   ///< saulcan::RobotState values (1 = BALANCE, 4 = TILT_CUTOFF)
  std::vector<std::uint64_t> line;   ///< the row's line (CSV), frame number (capture) or byte offset (trace)
  Gains gains;
  /// Rows (or frames) read but left out, each "FILE:LINE: why (row left out)"; at most kMaxProblems kept.
  std::vector<std::string> problems;
  std::uint64_t problems_total = 0;
  /// True when the reader stopped at kMaxRecords.
  bool truncated = false;

  [[nodiscard]] std::size_t size() const { return time_s.size(); }
  /// Adds a problem message (counted always, kept up to kMaxProblems).
  void problem(std::string message);
};

/// Rows kept at most: two million (33 minutes at 1 kHz, ~180 MB): memory stays bounded whatever the file.
inline constexpr std::size_t kMaxRecords = 2'000'000;
/// Problem messages kept (the rest are counted).
inline constexpr std::size_t kMaxProblems = 20;

/// An input that cannot be analysed at all: unreadable, no header, a needed column missing. The message names the
/// file and what to do.
class SeriesError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads a CSV whose header names the columns (any order, extra columns ignored): time_s, setpoint_deg and
/// pitch_deg are needed; rate_dps, p_term, i_term, d_term, output, seq, excite and state (a number or a state
/// name) are used when present. Lines starting with '#' are comments; one saying "kp=30 ki=2 kd=1.5" gives the gains.
/// A row with a missing or non-numeric value, or a time that does not move forward, is left out and told.
/// Throws SeriesError when the file cannot be read or the header lacks a needed column.
Series read_csv_series(const std::string& path);

/// Reads the telemetry (0x400: pitch, PID output, state) of a CAN capture in any format the capture readers know:
/// a 10 Hz series without setpoint. Corrupt frames are told and skipped. Throws SeriesError when the file is not a
/// capture or holds no telemetry.
Series read_capture_series(const std::string& path);

/// Reads a loop trace file (`saulctl tune record`, "SAULTRACE 1" header): one row per record, time from time_us with
/// its 32-bit wrap unwrapped, seq kept (its gaps become the report's seq_missing), excite and state per record. A
/// corrupt or cut record is told with its byte offset and the rest is read. Throws SeriesError when the file cannot
/// be read or holds no record.
Series read_trace_series(const std::string& path);
/// The same from a trace's console bytes in memory (no header): what a bench suite's `trace` step captured. `name`
/// stands for the file in messages. Throws SeriesError when the bytes hold no record.
Series read_trace_bytes_series(std::span<const std::uint8_t> bytes, const std::string& name);

/// By content: a loop trace file (SAULTRACE header); a CSV of named columns when the first line that is not a
/// comment has "time_s"; else a capture.
Series read_series(const std::string& path);

}  // namespace saul::host::tune
