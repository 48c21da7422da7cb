// Pieces of the line per CAN frame that decode and sniff write (fast_emit.hpp writes the line):
//   (1763800000.600000) can0 301#000100000000C03F     pid_gain gain=kp sequence=1 value=1.5
// the time column and an error frame's meaning.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "saulproto/core/can_frame.hpp"

namespace saul::host {

enum class TimeMode { absolute, relative, delta };

/// The "(sec.usec)" column for a TimeMode; remembers the first and previous stamp. A relative or delta time
/// before its reference (times went back) is negative: "(  -0.050000)".
class TimeColumn {
 public:
  explicit TimeColumn(TimeMode mode) : mode_(mode) {}
  std::string operator()(std::uint64_t ns);
  /// The same written at `w` (room for kMaxChars characters), with or without the parentheses; returns its end.
  char* write(char* w, std::uint64_t ns, bool parens = true);
  static constexpr std::size_t kMaxChars = 30;  // "(" "-" 20 digits "." 6 digits ")"
  /// Counts a stamp written elsewhere (the FrameEmitter's lines) as the first or previous one, without text.
  void note(std::uint64_t ns) {
    if (!first_) first_ = ns;
    previous_ = ns;
  }
  /// The same value without parentheses, for JSON and CSV.
  static std::string bare(const std::string& column) { return column.substr(1, column.size() - 2); }

 private:
  TimeMode mode_;
  std::optional<std::uint64_t> first_;
  std::optional<std::uint64_t> previous_;
  std::optional<std::uint64_t> seconds_;  // the seconds in seconds_text_ ("1763800000." or "  -0."), and their sign
  bool seconds_negative_ = false;
  std::string seconds_text_;
};

/// The classes of error a SocketCAN error frame's id flags (linux/can/error.h), in bit order: the name stats counts
/// each under, and describe_error_frame()'s text ({n}: data byte n; nullptr: the controller's status bits).
struct ErrorClass {
  std::uint32_t bit;
  const char* kind;
  const char* text;
};
inline constexpr ErrorClass kErrorClasses[] = {
    {0x001, "tx_timeout", "tx timeout"},
    {0x002, "lost_arbitration", "lost arbitration at bit {0}"},
    {0x004, "controller", nullptr},
    {0x008, "protocol_violation", "protocol violation type 0x{2:02X} at 0x{3:02X}"},
    {0x010, "transceiver", "transceiver problem"},
    {0x020, "no_ack", "no ACK (is anything else on the bus? termination?)"},
    {0x040, "bus_off", "BUS-OFF"},
    {0x080, "bus_error", "bus error"},
    {0x100, "restarted", "controller restarted"},
    {0x200, "error_counters", "tec={6} rec={7}"},
};

/// What a SocketCAN error frame says (linux/can/error.h's layout), e.g. "BUS-OFF", "controller: tx-passive".
std::string describe_error_frame(const CanFrame& error_frame);

}  // namespace saul::host
