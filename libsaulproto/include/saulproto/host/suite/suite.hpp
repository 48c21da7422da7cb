// Scripted bench tests: human-writable test files (*.saul, one step per line) run against the simulated robot or
// the real one. The format, its steps and conditions are documented in docs/bench-tests.md ("The format"); a
// condition names a signal as `saulctl decode --json` keys it (docs/cli.md "Signal names and units").
//
// Time comes from the Target, so a simulator target can run the same suite faster than real time.
#pragma once

#include <cstdint>
#include <istream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/trace.hpp"

namespace saul::host::suite {

struct Condition {
  enum class Op { eq, ne, lt, le, gt, ge };
  std::string field;
  Op op = Op::eq;
  bool absolute = false;
  std::string text;  ///< the value as written
  std::optional<double> number;
};

struct Step {
  enum class Kind { send, stream, stop, expect, expect_none, hold, mean, stable, console, sim, wait, trace, expect_tune };
  /// stable: a further message and its conditions ('... and telemetry_b faults=0 ...').
  struct Clause {
    std::string message;
    std::vector<Condition> conditions;
  };
  Kind kind = Kind::wait;
  int line = 0;
  std::string source;                 ///< the line as written, for reports
  std::vector<CanFrame> frames;       ///< send / stream
  std::string message;                ///< expect / hold: message name ("" = any)
  std::vector<Condition> conditions;  ///< expect / hold
  std::vector<Clause> more;           ///< stable: the clauses after the first
  std::uint64_t duration_us = 0;      ///< within / for / wait
  std::uint64_t limit_us = 0;         ///< stable: within
  std::uint64_t period_us = 0;        ///< stream
  std::string board;                  ///< console
  std::string text;                   ///< console command, sim command
  std::string expect_text;            ///< console
  std::optional<trace::ExciteStart> excite;  ///< trace: the test signal (its duration set when it starts)
};

struct Suite {
  std::string name;
  std::string path;
  bool requires_sim = false;
  std::vector<Step> steps;
};

class ParseError : public std::runtime_error {
 public:
  ParseError(const std::string& path, int line, const std::string& what)
      : std::runtime_error(path + ":" + std::to_string(line) + ": " + what) {}
};

/// Parses a suite; throws ParseError naming the file and line.
Suite parse_suite(std::istream& in, const std::string& path);
Suite load_suite(const std::string& path);

/// What a suite runs against.
class Target {
 public:
  virtual ~Target() = default;
  [[nodiscard]] virtual std::uint64_t now_us() = 0;
  virtual void send(const CanFrame& frame) = 0;
  /// The next frame received before deadline_us (target time), or nullopt at the deadline.
  virtual std::optional<CanFrame> receive_until(std::uint64_t deadline_us) = 0;
  /// Sends a console line to a board ("balance" / "io") and returns everything it replied by the time the reply
  /// contained `until` or timeout passed; nullopt when this target has no console for that board.
  virtual std::optional<std::string> console(const std::string& board, const std::string& line,
                                             const std::string& until, std::uint64_t timeout_us) = 0;
  /// Types bytes (a whole line, its newline included) on a board's console without waiting for a reply; false when
  /// this target has no console for that board. With console_take, what a `trace` step reads the loop trace with.
  virtual bool console_type(const std::string& /*board*/, const std::string& /*bytes*/) { return false; }
  /// Everything the board's console printed since the last call (text and binary records alike); nullopt when this
  /// target has no console for that board.
  virtual std::optional<std::string> console_take(const std::string& /*board*/) { return std::nullopt; }
  /// Runs a simulator control command; false with a reason when not possible (e.g. a real robot).
  virtual bool sim(const std::string& command, std::string& error) = 0;
  [[nodiscard]] virtual bool is_simulator() const = 0;
  [[nodiscard]] virtual std::string describe() const = 0;
};

struct StepResult {
  enum class Status { passed, failed, skipped };
  Status status = Status::passed;
  int line = 0;
  std::string source;
  std::string message;       ///< why it failed, or what it saw
  std::string output;        ///< what the step measured, kept in the JUnit report (<system-out>): stable, mean
  std::uint64_t elapsed_us = 0;
};

struct SuiteResult {
  std::string name;
  std::string path;
  bool skipped = false;
  std::string skip_reason;
  std::vector<StepResult> steps;
  std::uint64_t elapsed_us = 0;
  [[nodiscard]] bool passed() const;
};

/// A stable step's clock restarts when one of its messages has been silent for longer than this.
inline constexpr std::uint64_t kStableMaxGapUs = 1'000'000;

/// Runs every step in order; stops at the first failed step (the rest are reported as skipped).
SuiteResult run_suite(const Suite& suite, Target& target);

/// JUnit XML for CI systems: one <testsuite> per suite, one <testcase> per step (with <system-out> when the step
/// measured something: a stable step's longest stretch, a mean step's means).
std::string junit_xml(const std::vector<SuiteResult>& results);

/// Parses one condition word (FIELD OP VALUE, |FIELD| OP VALUE); throws ParseError naming the file and line.
Condition parse_condition(const std::string& word, const std::string& path, int line);

/// A value a condition is checked against (a signal's, report/signal_rows.hpp signal_value): a number, or a text
/// (value names, "none").
struct FieldValue {
  std::optional<double> number;
  std::string text;
};
/// True when the value satisfies the condition (numbers compare as numbers, texts by name without case).
bool holds(const Condition& condition, const FieldValue& value);

}  // namespace saul::host::suite
