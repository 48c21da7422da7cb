// Loop traces (core/trace.hpp) in words: one line per record (text, JSON with physical units, CSV) and the stats of
// a whole trace (records, gaps, loop period and its jitter). The CSV columns are what `saulctl tune report` and
// other tools read:
//   time_s, seq, pitch_deg, rate_dps, setpoint_deg, p_term, i_term, d_term, output, erpm_left, erpm_right,
//   wheel_mmps, request_mmps, state, faults, excite, excite_deg
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>

#include <nlohmann/json.hpp>

#include "saulproto/core/trace.hpp"
#include "saulproto/host/report/plot.hpp"

namespace saul::host {

/// Unwraps the records' 32-bit microsecond time stamps (they wrap after 71.6 min) into seconds since 0.
class TraceClock {
 public:
  double seconds(std::uint32_t time_us);

 private:
  bool started_ = false;
  std::uint32_t last_ = 0;
  std::uint64_t high_ = 0;
};

/// The CSV header line (with its '\n') and one record's row.
std::string trace_csv_header();
std::string trace_csv_row(const trace::LoopTrace& r, double time_s);
/// One record in physical units, the CSV's keys (state and excite by name).
nlohmann::json trace_json(const trace::LoopTrace& r, double time_s);
/// The JSON Schema of trace_json()'s objects (each field's meaning and unit in its description): the schema of the
/// MCAP channel "/saul/loop_trace" that `saulctl convert run.trace run.mcap` writes.
std::string trace_json_schema();
/// One greppable line: "  1.000000  seq 1000  pitch -1.23 deg  rate 45.6 deg/s ..." (no newline).
std::string trace_text(const trace::LoopTrace& r, double time_s);

/// The stats of a trace, record by record in file order. O(1) per record; memory bounded by kMaxSteps.
class TraceStats {
 public:
  static constexpr std::size_t kMaxSteps = 4096;  ///< distinct seq steps kept (more are counted as irregular)

  void add(const trace::LoopTrace& r);
  /// The decoder's counters at the end (corrupt records, text).
  void finish(const trace::Counters& counters) { counters_ = counters; }

  [[nodiscard]] std::uint64_t records() const { return records_; }
  /// The seq step of the trace (`trace on N`): the smallest forward step seen (1 when fewer than 2 records).
  [[nodiscard]] std::uint32_t divider() const;
  /// Places where records are missing (a seq step larger than the divider), and how many are missing in all.
  [[nodiscard]] std::uint64_t gaps() const;
  [[nodiscard]] std::uint64_t missing() const;
  /// Steps that went back or stood still (a device restart, records out of order).
  [[nodiscard]] std::uint64_t backwards() const { return backwards_; }
  [[nodiscard]] double duration_s() const { return records_ < 2 ? 0.0 : last_s_ - first_s_; }
  [[nodiscard]] double rate_hz() const { return duration_s() > 0 ? static_cast<double>(records_ - 1) / duration_s() : 0; }

  std::string text(const std::string& file) const;
  nlohmann::json json(const std::string& file) const;

 private:
  TraceClock clock_;
  std::uint64_t records_ = 0;
  std::uint32_t last_seq_ = 0;
  double first_s_ = 0, last_s_ = 0;
  // loop period (time between consecutive records), Welford
  std::uint64_t periods_ = 0;
  double mean_ = 0, m2_ = 0, min_ = 0, max_ = 0;
  std::map<std::uint32_t, std::uint64_t> steps_;  // seq step -> count
  std::uint64_t irregular_ = 0;                   // steps beyond kMaxSteps distinct ones
  std::uint64_t backwards_ = 0;
  std::uint64_t excited_ = 0;
  std::map<std::uint8_t, std::uint64_t> states_;
  trace::Counters counters_{};
};

/// The plot of a trace file (`saulctl plot run.trace`): pitch with its setpoint and the excitation, the rate, the
/// PID's terms and output, the wheel speed with the request; state changes as markers. Reads the file twice (the
/// time range, then the points, binned into `columns`). Throws std::runtime_error as read_trace_file does.
PlotDocument trace_plot_document(const std::string& path, std::size_t columns);

/// A BALANCE console's bytes as they arrive (a recording): the records into TraceStats, and the console's lines
/// looked at for what a recorder waits for (a refusal, the end of a dump).
class TraceTap {
 public:
  void push(std::span<const std::uint8_t> bytes);
  /// The stream ended (a cut record at the end is counted).
  void finish();
  [[nodiscard]] const TraceStats& stats() const { return stats_; }
  [[nodiscard]] const trace::Counters& counters() const { return decoder_.counters(); }
  /// The first "error: ..." line seen (empty when none), and whether "trace dump end: ..." came.
  [[nodiscard]] const std::string& refusal() const { return refusal_; }
  [[nodiscard]] bool dump_ended() const { return dump_ended_; }

  // the decoder's sink
  void record(const trace::LoopTrace& r, std::uint64_t) { stats_.add(r); }
  void line(std::string_view text, bool);
  void rejected(Reason, std::uint64_t) {}

 private:
  trace::ConsoleDecoder decoder_;
  TraceStats stats_;
  std::string refusal_;
  bool dump_ended_ = false;
};

}  // namespace saul::host
