// slcan (Lawicel ASCII) lines, as CANable adapters with the slcan firmware speak them over USB CDC.
//
// Host -> adapter: commands ("C", "S6", "O", "M1", "V") and frames to send ("t3004E8030CFE", "T000003444000005DC",
// "r4007"), each ended by CR. Adapter -> host: received frames in the same syntax, optionally followed by a
// 4-digit millisecond (Z1) or 8-digit microsecond (Z2) timestamp; replies CR (ok) / BEL (error) from
// Lawicel-complete firmwares only (the stock CANable firmwares send none: never wait for one); "z"/"Z" transmit
// acknowledgements; "V..." version; "F.." status flags; Linux-style "e..." error and "s..." state reports.
//
// Lives in the core because the simulated robot's virtual CANable speaks it too. No allocation; the line
// decoder holds one line (kMaxLine bytes) and does O(1) work per byte.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/result.hpp"
#include "saulproto/core/stream_framer.hpp"

namespace saul::slcan {

inline constexpr char kCr = '\r';
inline constexpr char kBel = '\a';
/// Longest classic line: "T" + 8 id + 1 dlc + 16 data + 8 timestamp digits.
inline constexpr std::size_t kMaxClassicLine = 34;
/// The decoder's line buffer: room for CAN FD lines too, so they can be recognised and rejected whole.
inline constexpr std::size_t kMaxLine = 160;

/// "S<n>" preset for a bitrate, or nullopt when none exists (the slcan presets: 10k 20k 50k 100k 125k 250k
/// 500k 1M; 750k/800k differ between firmwares and are not offered).
std::optional<char> bitrate_preset(std::uint32_t bitrate) noexcept;

/// Encodes a frame to send, with its CR: "t3004E8030CFE\r". Refuses error frames and invalid frames.
/// out must hold kMaxClassicLine + 1 bytes. Returns the number of chars written.
Result<std::size_t> encode_frame(const CanFrame& frame, std::span<char> out) noexcept;

/// Same, with a device timestamp appended (what an adapter with Z1 sends): 4 hex digits of ms % 60000.
Result<std::size_t> encode_frame_with_ms(const CanFrame& frame, std::uint16_t ms, std::span<char> out) noexcept;

/// Parses one line without its CR/BEL terminator as a frame record (t/T/r/R).
/// On success, device_time reports an appended timestamp: in ms (4 digits) or µs (8 digits), else none.
struct DeviceTime {
  enum class Unit : std::uint8_t { none, milliseconds, microseconds };
  Unit unit = Unit::none;
  std::uint32_t value = 0;
};
Result<CanFrame> parse_frame(std::string_view line, DeviceTime* device_time = nullptr) noexcept;

/// One thing the adapter said.
struct Event {
  enum class Kind : std::uint8_t {
    frame,        ///< a received CAN frame (frame, device_time)
    ok,           ///< an empty line ended by CR: command accepted (Lawicel-complete firmwares only)
    error,        ///< BEL: command refused (Lawicel-complete firmwares only)
    tx_ack,       ///< "z" / "Z": a frame was sent (Lawicel CAN232 semantics)
    version,      ///< "V..." reply; text holds it
    status,       ///< "Fxx" status flags; value holds them
    bus_error,    ///< "e..." error report (Linux slcan extension); text holds it
    bus_state,    ///< "s..." state report (Linux slcan extension); text holds it
    rejected,     ///< a line that could not be parsed (counted); reason says why
  };
  Kind kind = Kind::rejected;
  CanFrame frame{};
  DeviceTime device_time{};
  std::uint32_t value = 0;
  Reason reason = Reason::ok;
  char text[24] = {};  ///< NUL-terminated, truncated
};

struct Counters {
  std::uint32_t frames = 0;
  std::uint32_t acks = 0;            ///< ok + error + tx_ack replies seen
  std::uint32_t rejected_lines = 0;  ///< unparseable lines, FD frames included
  std::uint32_t fd_frames = 0;       ///< CAN FD records (d/D/b/B): the robot's bus must never carry them
  std::uint32_t overlong_lines = 0;  ///< lines longer than kMaxLine, dropped
};

/// Incremental line decoder: feed whatever read() returned, get events. Does not care how input is chunked.
/// A line runs up to CR, BEL or LF; an LF right after a line end (CR LF) is ignored; a line longer than kMaxLine
/// is counted in overlong_lines and dropped up to its end. framing::StreamFramer (stream_framer.hpp) holds the
/// line; no line starts inside another, so nothing is ever rescanned. O(1) per byte.
class LineDecoder {
 public:
  /// Feeds one byte; returns an event when it ended a line.
  std::optional<Event> push(char c) noexcept;

  template <class F>
  void push(std::span<const std::uint8_t> input, F&& on_event) noexcept {
    for (std::uint8_t b : input)
      if (auto e = push(static_cast<char>(b))) on_event(*e);
  }

  [[nodiscard]] const Counters& counters() const noexcept { return rules_.counters; }

 private:
  struct Rules {
    Counters counters{};
    bool overlong = false;  // dropping the rest of an overlong line, up to its end
    framing::Verdict check(std::span<const std::uint8_t> candidate) noexcept;
    void skipped(std::size_t) noexcept {}  // slcan counts lines, not bytes
  };
  Event finish_line(std::string_view line, bool bel) noexcept;
  framing::StreamFramer<kMaxLine + 1> framer_;  // a line and its end
  Rules rules_;
};

}  // namespace saul::slcan
