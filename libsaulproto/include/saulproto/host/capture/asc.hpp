// Vector ASC text logs, as can-utils' log2asc, python-can's ASCWriter and CANalyzer/CANoe write them; the quirks
// and the choice made for each are in docs/captures.md ("Vector ASC"). Reading is line by line: times are seconds
// since the measurement start (its wall clock from the date or Begin Triggerblock line, read as UTC; "timestamps
// relative": from the previous frame), extended ids end in 'x', "base dec" makes numbers decimal, channel N reads
// as "can<N-1>", an ErrorFrame as a bus error (0x080, 8 zero bytes), a DLC of 9..15 as 8 bytes, and a CANFD line
// that nothing marks as FD as a classic frame (real FD frames are reported as unsupported). A corrupt line is
// reported with line and column and skipped; other events (Statistic:, TxRq, ...) are skipped silently.
// Writing: log2asc's layout, times from the whole second before the first frame (date + time gives each frame's
// microsecond back), channels numbered in order of first appearance, "End TriggerBlock" at close().
#pragma once

#include <cstdint>
#include <istream>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/interface_index.hpp"

namespace saul::host {

/// Parses an ASC date ("Tue Nov 14 22:13:20 2023", "Nov 14 10:13:20.123 pm 2023", the weekday optional, German
/// month abbreviations accepted) as UTC; nanoseconds since 1970, nullopt when it does not parse.
std::optional<std::uint64_t> parse_asc_date(std::string_view text);
/// "Tue Nov 14 22:13:20 2023" for the whole second of `ns` (UTC).
std::string format_asc_date(std::uint64_t ns);

class AscReader final : public LineCaptureReader {
 public:
  explicit AscReader(std::istream& in) : LineCaptureReader(in) {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::asc; }

  /// True once a date or Begin Triggerblock line gave the wall clock of the measurement start.
  [[nodiscard]] bool wall_clock() const noexcept { return start_ns_.has_value(); }

 private:
  Step parse_line(std::string_view line) override;
  Step timed_line(std::string_view line);
  Step frame_line(std::string_view line, std::uint64_t time_ns);
  Step canfd_line(std::string_view line, std::uint64_t time_ns);
  bool parse_id(std::size_t token, CanFrame& frame);  ///< false after reporting it corrupt
  std::optional<std::uint64_t> channel(std::size_t token);  ///< 1..255; nullopt after reporting it corrupt
  bool data_bytes(std::size_t first, CanFrame& frame);  ///< frame.dlc bytes; false after reporting one corrupt
  Step emit(CanFrame frame, std::uint64_t channel, std::uint64_t time_ns);
  [[nodiscard]] std::uint64_t absolute(std::uint64_t time_ns);

  std::vector<std::pair<std::size_t, std::string_view>> tokens_;  ///< column, text; reused for every line
  int base_ = 16;
  bool deltas_ = false;  ///< "timestamps relative"
  std::uint64_t elapsed_ns_ = 0;
  std::optional<std::uint64_t> start_ns_;
  bool trigger_block_date_ = false;
};

class AscWriter final : public StreamCaptureWriter {
 public:
  /// Nothing is written before the first frame (the header carries its date) or close().
  explicit AscWriter(std::ostream& out) : StreamCaptureWriter(out, "ASC") {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::asc; }

 private:
  /// Frames earlier than the measurement start (the first frame's whole second) are written at time 0.
  void put(const CanFrame& frame, std::string_view interface) override;
  void begin(std::uint64_t first_ns) override;
  void finish() override;

  std::uint64_t start_ns_ = 0;
  InterfaceIndex channels_;  ///< index + 1 = ASC channel
};

}  // namespace saul::host
