// Scripted bench tests: human-writable test files run against the simulated robot or the real one.
//
// A suite file (*.saul) is one step per line; '#' starts a comment. Durations are like 500ms, 2s, 1.5s, 1m.
//
//   suite: arm and balance                          name shown in reports (optional, default: file name)
//   requires: sim                                   skip (not fail) on a target that is not the simulator
//   send mode_cmd mode=balance                      one frame: velocity_cmd, mode_cmd, config_cmd, pid_gain,
//   send frame 302#01                               or a raw frame in candump syntax
//   send pid_set kp=1.5 ki=0.25 kd=0.05 sequence=9  the three 0x301 frames of one set
//   stream velocity_cmd speed_mmps=200 every 50ms   keep sending in the background (until 'stop' or the end)
//   stop                                            end the background stream
//   expect command_ack command=2 result=applied within 300ms
//   expect telemetry_a state=BALANCE |pitch|<3 within 2s
//   expect no velocity_cmd for 1s                   nothing matching may arrive (conditions optional)
//   hold telemetry_a state=BALANCE for 3s           every matching frame in the window satisfies it; >= 1 seen
//   mean telemetry_a speed_mmps>=240 speed_mmps<=360 for 2s   the fields' means over the window satisfy it
//   stable telemetry_a state=BALANCE |pitch|<5 and telemetry_b fault=0 for 5m within 20m
//                                                   every frame of each message holds its conditions for 5 minutes
//                                                   on end; a frame that breaks them, or a message silent for more
//                                                   than 1 s, restarts the clock; fails at 'within' (the report
//                                                   gives the longest stable stretch)
//   console balance arm expect ok within 500ms      a USB console command and a text its reply must contain
//   sim push 8                                      a simulator control command (fault injection, radio, ...)
//   wait 1s
//   trace step 0.5 for 4s                           BALANCE's 1 kHz loop trace for 4 s, with a test signal (step,
//                                                   chirp or prbs, amplitude in degrees; none: plain `trace for 4s`)
//   expect tune overshoot<25% settling<0.6s oscillation=none   tuning figures of the last trace (tune_expect.hpp)
//
// Conditions: SIGNAL OP VALUE with OP one of = != < <= > >=, and |SIGNAL| for the absolute value. Signals are named
// as `saulctl decode --json` keys them (docs/cli.md "Signal names and units"): pitch in degrees, pitch_raw the wire
// integer, named values by name (state=BALANCE) or number; a name the message lacks is an error listing its names.
//
// Time comes from the Target, so a simulator target can run the same suite faster than real time.
#pragma once

#include <cstdint>
#include <istream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/dispatch.hpp"
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
      : std::runtime_error(path + ":" + std::to_string(line) + ": " + what), line_(line) {}
  [[nodiscard]] int line() const { return line_; }

 private:
  int line_;
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

/// Evaluates conditions against a frame: true when the frame decodes to `message` (or any message when empty)
/// and every condition holds. Exposed for tests.
bool matches(const CanFrame& frame, const std::string& message, const std::vector<Condition>& conditions);

}  // namespace saul::host::suite
