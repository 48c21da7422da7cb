// The USB serial console of both boards (system reference, "USB Debug Commands"): one command per line in,
// reply lines out. The same code parses on the board and formats/parses replies in saulctl.
//
// Command lines:  help | status | pid <Kp> <Ki> <Kd> | arm | disarm | estop | tilt_limit <deg> |
//                 speed_limit <pct> | can_stats | uart_stats | reboot
// Words are separated by spaces or tabs; a trailing CR/LF is ignored; the command word is matched without
// regard to ASCII case. Arguments are validated here, so the firmware only ever sees values it may apply:
//   Kp Ki Kd   decimal numbers (optional sign, fraction, exponent), finite and not negative;
//   deg        5..25 (docs/protocol.md, limits): above 25 is rejected, never clamped; kept in 0.01 degree steps;
//   pct        10..100 in steps of 10.
// A bad line gives a ParseError: a Reason, a short static message, and which word was wrong.
//
// Replies: human-readable lines, and for status, can_stats and uart_stats one machine-readable line
//   report=<name> key=value key=value ...
// that parse_*() read back (saulctl uses them). Formatting writes into the caller's char buffer, never
// allocates, never calls printf; numbers are written by hand (floats: shortest form that reads back exactly).
// Parsing a command line is O(length); every formatter is O(output).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <variant>

#include "saulproto/core/interboard.hpp"
#include "saulproto/core/result.hpp"
#include "saulproto/core/saul_can.hpp"

namespace saul::console {

// ---- commands -----------------------------------------------------------------------------------------------

/// Commands in the order of the system reference; also the index of each in Command.
enum class Verb : std::uint8_t {
  help, status, pid, arm, disarm, estop, tilt_limit, speed_limit, can_stats, uart_stats, reboot,
};

/// One row of the grammar table.
struct CommandSpec {
  Verb verb;
  const char* name;     ///< the command word
  const char* usage;    ///< e.g. "pid <Kp> <Ki> <Kd>"
  const char* summary;  ///< one line for help
  std::uint8_t arguments;
};

/// THE grammar table: help prints it, the parser reads names and argument counts from it.
inline constexpr std::array<CommandSpec, 11> kCommands{{
    {Verb::help, "help", "help", "list commands", 0},
    {Verb::status, "status", "status", "pitch, PID state, CAN and UART counters", 0},
    {Verb::pid, "pid", "pid <Kp> <Ki> <Kd>", "set PID gains (finite, not negative)", 3},
    {Verb::arm, "arm", "arm", "arm (only if upright and safe)", 0},
    {Verb::disarm, "disarm", "disarm", "disarm immediately", 0},
    {Verb::estop, "estop", "estop", "emergency stop (latched; needs a fresh arming)", 0},
    {Verb::tilt_limit, "tilt_limit", "tilt_limit <deg>", "tilt cutoff angle, 5 to 25 degrees (default 25)", 1},
    {Verb::speed_limit, "speed_limit", "speed_limit <pct>", "speed cap, 10 to 100 % in steps of 10 (default 10)", 1},
    {Verb::can_stats, "can_stats", "can_stats", "CAN bus counters (tx rx errors busoff)", 0},
    {Verb::uart_stats, "uart_stats", "uart_stats", "inter-board UART frame counters", 0},
    {Verb::reboot, "reboot", "reboot", "soft reboot", 0},
}};

constexpr const CommandSpec& spec_of(Verb verb) noexcept { return kCommands[static_cast<std::size_t>(verb)]; }

/// Commands without arguments share one shape.
template <Verb V>
struct Plain {
  static constexpr Verb kVerb = V;
  static constexpr const char* kName = kCommands[static_cast<std::size_t>(V)].name;
  template <class F> constexpr void fields(F&&) const {}
  constexpr bool operator==(const Plain&) const = default;
};
using HelpCmd = Plain<Verb::help>;
using StatusCmd = Plain<Verb::status>;
using ArmCmd = Plain<Verb::arm>;
using DisarmCmd = Plain<Verb::disarm>;
using EstopCmd = Plain<Verb::estop>;
using CanStatsCmd = Plain<Verb::can_stats>;
using UartStatsCmd = Plain<Verb::uart_stats>;
using RebootCmd = Plain<Verb::reboot>;

/// pid <Kp> <Ki> <Kd>: all finite and >= 0 (a parsed "-0" is stored as +0).
struct PidCmd {
  static constexpr Verb kVerb = Verb::pid;
  static constexpr const char* kName = "pid";
  float kp = 0.0F;
  float ki = 0.0F;
  float kd = 0.0F;
  template <class V> constexpr void fields(V&& v) const { v("kp", kp); v("ki", ki); v("kd", kd); }
  constexpr bool operator==(const PidCmd&) const = default;
};

/// tilt_limit <deg>: 5.00..25.00 degrees, in hundredths (the unit of CAN 0x303). A value in range with more
/// than two decimals is rounded half up to 0.01 degree after the range check, so it never leaves the range.
struct TiltLimitCmd {
  static constexpr Verb kVerb = Verb::tilt_limit;
  static constexpr const char* kName = "tilt_limit";
  static constexpr std::uint16_t kMinX100 = 500;
  static constexpr std::uint16_t kMaxX100 = 2500;
  std::uint16_t tilt_limit_x100 = kMaxX100;
  template <class V> constexpr void fields(V&& v) const { v("tilt_limit_x100", tilt_limit_x100); }
  constexpr bool operator==(const TiltLimitCmd&) const = default;
};

/// speed_limit <pct>: 10, 20, ..., 100 (an integer value; "50.0" is 50).
struct SpeedLimitCmd {
  static constexpr Verb kVerb = Verb::speed_limit;
  static constexpr const char* kName = "speed_limit";
  static constexpr std::uint8_t kMin = 10;
  static constexpr std::uint8_t kMax = 100;
  static constexpr std::uint8_t kStep = 10;
  std::uint8_t percent = kMin;
  template <class V> constexpr void fields(V&& v) const { v("percent", percent); }
  constexpr bool operator==(const SpeedLimitCmd&) const = default;
};

/// A parsed command; alternative i is the command of Verb i.
using Command = std::variant<HelpCmd, StatusCmd, PidCmd, ArmCmd, DisarmCmd, EstopCmd, TiltLimitCmd, SpeedLimitCmd,
                             CanStatsCmd, UartStatsCmd, RebootCmd>;

constexpr Verb verb_of(const Command& command) noexcept { return static_cast<Verb>(command.index()); }
constexpr const char* name_of(const Command& command) noexcept { return spec_of(verb_of(command)).name; }

/// Why a line was refused.
///   reason    unknown_command, missing_argument, extra_argument, not_a_number, not_finite, negative,
///             out_of_range, or syntax (blank line);
///   message   short and static, e.g. "tilt limit must be 5 to 25 degrees";
///   argument  which word: 0 = the command word, 1 = its first argument, ...; for missing_argument the
///             first one missing;
///   command   the recognised command (for its usage), or nullptr when the command word was not one.
struct ParseError {
  Reason reason = Reason::ok;
  const char* message = "";
  std::uint8_t argument = 0;
  const CommandSpec* command = nullptr;
};

struct [[nodiscard]] ParseResult {
  Command command{};   ///< meaningful only when ok()
  ParseError error{};  ///< reason ok on success
  [[nodiscard]] constexpr bool ok() const noexcept { return error.reason == Reason::ok; }
  constexpr explicit operator bool() const noexcept { return ok(); }
};

/// Parses one command line (without or with its CR/LF). A blank line is a syntax error with message
/// "empty line": consoles usually just print the prompt again for it.
ParseResult parse(std::string_view line) noexcept;

/// Parses a whole word as a decimal number: [+-] digits [. digits] [e [+-] digits] (or [+-] . digits ...).
/// Fails with not_a_number, not_finite ("nan", "inf", "infinity", any case) or out_of_range (beyond float).
/// Converted through one correctly rounded double operation for up to 19 significant digits (exact powers of
/// ten up to 1e22), which reads back every float printed with 9 significant digits. No locale, no strtod.
Result<float> parse_float(std::string_view word) noexcept;

// ---- replies ------------------------------------------------------------------------------------------------

/// Which board is talking.
enum class Board : std::uint8_t { io = 0, balance = 1 };
const char* to_string(Board board) noexcept;

/// Reply to status. Units as on the CAN bus (docs/protocol.md): pitch in 0.01 degree (+ nose up), pid_out in
/// permille, tilt limit in 0.01 degree, battery in mV, faults as the 0x401 bits.
struct StatusReport {
  static constexpr const char* kName = "status";
  Board board = Board::balance;
  saulcan::RobotState state = saulcan::RobotState::off;
  std::int16_t pitch_x100 = 0;
  std::int16_t pid_out = 0;
  float kp = 0.0F;
  float ki = 0.0F;
  float kd = 0.0F;
  std::uint16_t tilt_limit_x100 = 2500;
  std::uint8_t speed_limit_pct = 10;
  std::uint8_t faults = 0;
  std::uint16_t battery_mv = 0;
  std::uint32_t uptime_ms = 0;

  template <class S, class V> static constexpr void each(S& s, V&& v) {
    v("board", s.board); v("state", s.state); v("pitch_x100", s.pitch_x100); v("pid_out", s.pid_out);
    v("kp", s.kp); v("ki", s.ki); v("kd", s.kd); v("tilt_limit_x100", s.tilt_limit_x100);
    v("speed_limit_pct", s.speed_limit_pct); v("faults", s.faults); v("battery_mv", s.battery_mv);
    v("uptime_ms", s.uptime_ms);
  }
  template <class V> constexpr void fields(V&& v) const { each(*this, v); }
  template <class V> constexpr void fields(V&& v) { each(*this, v); }
  constexpr bool operator==(const StatusReport&) const = default;
};

/// Reply to can_stats: the CAN controller's counters (what the ESP32-S3 TWAI driver reports).
struct CanStats {
  static constexpr const char* kName = "can_stats";
  std::uint32_t tx = 0;         ///< frames sent
  std::uint32_t rx = 0;         ///< frames received
  std::uint32_t errors = 0;     ///< bus errors seen
  std::uint32_t busoff = 0;     ///< times the controller went bus-off
  std::uint32_t tx_failed = 0;  ///< frames given up on
  std::uint32_t rx_missed = 0;  ///< frames lost to a full receive queue or overrun
  std::uint32_t arb_lost = 0;   ///< arbitrations lost
  std::uint16_t tec = 0;        ///< transmit error counter now
  std::uint16_t rec = 0;        ///< receive error counter now

  template <class S, class V> static constexpr void each(S& s, V&& v) {
    v("tx", s.tx); v("rx", s.rx); v("errors", s.errors); v("busoff", s.busoff); v("tx_failed", s.tx_failed);
    v("rx_missed", s.rx_missed); v("arb_lost", s.arb_lost); v("tec", s.tec); v("rec", s.rec);
  }
  template <class V> constexpr void fields(V&& v) const { each(*this, v); }
  template <class V> constexpr void fields(V&& v) { each(*this, v); }
  constexpr bool operator==(const CanStats&) const = default;
};

/// Reply to uart_stats: the inter-board StreamDecoder's counters, field for field.
struct UartStats {
  static constexpr const char* kName = "uart_stats";
  std::uint32_t frames = 0;
  std::uint32_t crc_errors = 0;
  std::uint32_t length_errors = 0;
  std::uint32_t unknown_types = 0;
  std::uint32_t bytes_skipped = 0;

  static constexpr UartStats from(const interboard::Counters& c) noexcept {
    return {c.frames, c.crc_errors, c.length_errors, c.unknown_types, c.bytes_skipped};
  }
  template <class S, class V> static constexpr void each(S& s, V&& v) {
    v("frames", s.frames); v("crc_errors", s.crc_errors); v("length_errors", s.length_errors);
    v("unknown_types", s.unknown_types); v("bytes_skipped", s.bytes_skipped);
  }
  template <class V> constexpr void fields(V&& v) const { each(*this, v); }
  template <class V> constexpr void fields(V&& v) { each(*this, v); }
  constexpr bool operator==(const UartStats&) const = default;
};

/// A buffer of this size holds any single reply the formatters below write (help is the longest).
inline constexpr std::size_t kMaxReply = 1024;
/// A buffer of this size holds any report=... line.
inline constexpr std::size_t kMaxKvLine = 256;

// Every formatter writes whole lines ending in '\n' and a terminating NUL (not counted), and returns the
// number of chars written, or buffer_too_small (the buffer then holds a truncated, NUL-terminated text).

/// "report=status board=balance state=BALANCE pitch_x100=-123 ... uptime_ms=5000\n"
Result<std::size_t> format_kv(const StatusReport& report, std::span<char> out) noexcept;
Result<std::size_t> format_kv(const CanStats& report, std::span<char> out) noexcept;
Result<std::size_t> format_kv(const UartStats& report, std::span<char> out) noexcept;

/// Lines for people, e.g. "pitch -1.23 deg, pid_out 45 permille".
Result<std::size_t> format_human(const StatusReport& report, std::span<char> out) noexcept;
Result<std::size_t> format_human(const CanStats& report, std::span<char> out) noexcept;
Result<std::size_t> format_human(const UartStats& report, std::span<char> out) noexcept;

/// One line per command: usage, padded, then summary.
Result<std::size_t> format_help(std::span<char> out) noexcept;
/// "ok\n": the last line of every successful reply.
Result<std::size_t> format_ok(std::span<char> out) noexcept;
/// "error: <message> (argument N; usage: <usage>) [<reason>]\n": the last line of every failed reply.
/// The parenthesis is left out for the command word, the usage when the command is unknown.
Result<std::size_t> format_error(const ParseError& error, std::span<char> out) noexcept;

/// Read a report=... line back (trailing CR/LF and extra spaces allowed). Fails with unknown_type (report= names
/// another report), syntax (no report= first, a word without '=', a key twice), not_a_number, out_of_range (a
/// value that does not fit its field), missing_argument (a key of the report absent). Unknown keys are skipped,
/// so a newer firmware that adds keys still reads. O(line length x fields).
Result<StatusReport> parse_status(std::string_view line) noexcept;
Result<CanStats> parse_can_stats(std::string_view line) noexcept;
Result<UartStats> parse_uart_stats(std::string_view line) noexcept;

/// Writes text into a char buffer, remembering when it ran out of room. Used by the formatters; public so the
/// firmware can add its own lines the same way.
class TextWriter {
 public:
  explicit TextWriter(std::span<char> out) noexcept : out_(out) {}
  TextWriter& text(std::string_view s) noexcept;
  TextWriter& ch(char c) noexcept;
  TextWriter& unsigned_number(std::uint32_t v) noexcept;
  TextWriter& signed_number(std::int32_t v) noexcept;
  /// scaled / 10^decimals with exactly `decimals` digits after the point, e.g. fixed(-123, 2) -> "-1.23".
  TextWriter& fixed(std::int32_t scaled, unsigned decimals) noexcept;
  /// Shortest decimal (at most 9 significant digits) that parse_float() reads back as exactly v: "0.1", "1.5",
  /// "1.5e-7" (exponent form below 1e-5 and from 1e9 on); "nan", "inf", "-inf".
  TextWriter& real(float v) noexcept;
  /// NUL-terminates and returns the length, or buffer_too_small if anything did not fit.
  Result<std::size_t> finish() noexcept;

 private:
  std::span<char> out_;
  std::size_t length_ = 0;
  bool overflow_ = false;
};

}  // namespace saul::console
