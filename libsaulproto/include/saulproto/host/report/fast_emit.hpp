// saulctl decode's and sniff's lines for CAN frames (text, CSV, JSON Lines), each written once in place into a big
// output buffer. The message part is format.hpp's write_message(); this adds the time, interface and frame
// columns. Robot buses repeat payloads, so a frame's rendered columns are cached by its content.
#pragma once

#include <fmt/format.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/host/report/frame_key.hpp"
#include "saulproto/host/report/frame_text.hpp"

namespace saul::host {

enum class DecodeFormat : std::uint8_t { text, csv, jsonl };

/// How the frames of a decode came out.
struct DecodeCounts {
  std::uint64_t frames = 0;
  std::uint64_t decoded = 0;
  std::uint64_t unknown = 0;   ///< unknown id
  std::uint64_t rejected = 0;  ///< known id, bad content (wrong dlc, out of range)
  std::uint64_t errors = 0;    ///< error frames
  DecodeCounts& operator+=(const DecodeCounts& o) noexcept {
    frames += o.frames;
    decoded += o.decoded;
    unknown += o.unknown;
    rejected += o.rejected;
    errors += o.errors;
    return *this;
  }
  /// One frame's decode counted: decoded (ok), unknown id, error frame, or rejected (any other reason).
  void count(Reason reason) noexcept {
    ++frames;
    switch (reason) {
      case Reason::ok: ++decoded; break;
      case Reason::unknown_id: ++unknown; break;
      case Reason::error_frame: ++errors; break;
      default: ++rejected;
    }
  }
};

/// Writes decode's lines of CAN frames. Keeps the time column's state (first and previous frame) and a cache of
/// rendered lines by content (skipped by its MemoJudge while contents do not repeat).
class FrameEmitter {
 public:
  /// `first`: the first frame's time, for TimeMode::relative when this emitter starts in the middle of a file.
  FrameEmitter(DecodeFormat format, TimeMode time, std::optional<std::uint64_t> first = std::nullopt);
  FrameEmitter(const FrameEmitter&) = delete;
  FrameEmitter& operator=(const FrameEmitter&) = delete;
  ~FrameEmitter();

  /// Appends the frame's line and its newline to `out` and counts how it decoded.
  void add(const CanFrame& frame, std::string_view interface, fmt::memory_buffer& out, DecodeCounts& counts);
  /// Error frames with what they report (sniff's lines), not only "!error_frame" (decode's).
  void show_error_detail() noexcept { error_detail_ = true; }

 private:
  struct Entry {
    FrameKey key;
    bool used = false;
    Reason reason = Reason::ok;  // of the decode
    std::string text;
    std::size_t split = 0;  // where the timestamp and the interface go in JSON (head_chars, then message_chars)
  };
  DecodeFormat format_;
  TimeColumn time_;
  std::vector<Entry> cache_;
  MemoJudge judge_;  // random payloads: cache_ only costs
  std::string interface_, interface_column_;  // the last interface seen, and as its column writes it
  bool error_detail_ = false;
};

/// A frame as decode's text line shows it after the time and interface, error frames with what they report:
/// "300#E8030CFE             velocity_cmd speed_mmps=1000 steer_mrad=-500" (replay --step).
std::string frame_text(const CanFrame& frame);

}  // namespace saul::host
