// The pieces of the one greppable line per CAN frame that `saulctl decode`, `sniff` and logs write (the line itself
// is fast_emit.hpp's FrameEmitter):
//   (1763800000.600000) can0 301#000100000000C03F     pid_gain gain=kp sequence=1 value=1.5
// the time column, a frame's meaning, an error frame's meaning. The raw part is the candump compact syntax.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "saulproto/core/can_frame.hpp"

namespace saul::host {

enum class TimeMode { absolute, relative, delta };

/// Turns frame timestamps into the "(sec.usec)" column for a TimeMode; remembers the first and previous stamp.
/// Relative and delta times of a stamp before the first or the previous one (a log whose times went back) are
/// negative: "(  -0.050000)".
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

/// "velocity_cmd speed_mmps=1000 steer_mrad=-500", or "!wrong_dlc" / "!unknown_id" when it does not decode,
/// or the error frame's meaning for error frames.
std::string describe_frame(const CanFrame& frame);

/// One line naming what a SocketCAN error frame says (class bits in the id, details in the data, as
/// linux/can/error.h lays them out: live links and capture files carry the same layout), e.g. "bus-off",
/// "controller: tx-passive", "no ACK".
std::string describe_error_frame(const CanFrame& error_frame);

}  // namespace saul::host
