// Vector ASC text logs, as can-utils' log2asc and python-can's ASCWriter write them (and CANalyzer/CANoe, for the
// classic CAN lines):
//
//   date Tue Nov 14 22:13:20 2023
//   base hex  timestamps absolute
//   internal events logged
//   Begin Triggerblock Tue Nov 14 22:13:20 2023
//      0.000000 Start of measurement
//      0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA
//      0.002500 1  123             Rx   r 4
//      0.005000 1  ErrorFrame
//   End TriggerBlock
//
// Times are seconds since the start of the measurement even when the header says "timestamps absolute"; the
// wall clock comes from the date line (or the Begin Triggerblock line, which wins, as in python-can). A date is
// read as UTC: the format has no time zone, and log2asc and python-can write the local time of the converting
// machine. When no date parses, timestamps are the relative times alone. "timestamps relative" means each time
// is counted from the previous frame (as asc2log reads it). Extended ids carry an 'x' suffix; "base dec" switches ids, DLCs and data
// bytes to decimal. Channel N reads as interface "can<N-1>". An ErrorFrame line carries no SocketCAN class or
// data: it reads as a bus error (id 0x080, 8 zero bytes), as asc2log converts it. A classic DLC of 9..15 (CANoe
// writes "3FF Tx d D 55 AA ...") means 8 data bytes. CANFD lines ("<time> CANFD <ch> <dir> <id> [<name>] <brs>
// <esi> <dlc> <len> <data> <duration> <bits> <flags> ...") whose flags say classic CAN (no EDL bit 0x1000; remote
// bit 0x10), as `log2asc -f` and CANoe on FD channels write them, read as classic frames; real CAN FD frames are
// reported as unsupported.
//
// Reading is line by line; a corrupt line is reported with line and column and skipped. Lines of other events
// (Statistic:, Start of measurement, TxRq transmit requests, ...) are skipped silently.
// Writing: the header above, times relative to the whole second before the first frame (so date + time gives the
// frame's microsecond back), log2asc's column layout, channels numbered in order of first appearance of each
// interface name, "End TriggerBlock" at close().
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

class AscReader final : public RecordCaptureReader {
 public:
  explicit AscReader(std::istream& in) : in_(in) {}

  Status next() override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::asc; }

  /// True once a date or Begin Triggerblock line gave the wall clock of the measurement start.
  [[nodiscard]] bool wall_clock() const noexcept { return start_ns_.has_value(); }

 private:
  enum class Step { frame, corrupt, skipped };
  Step parse_line(std::string_view line);
  Step timed_line(std::string_view line);
  Step frame_line(std::string_view line, std::uint64_t time_ns);
  Step canfd_line(std::string_view line, std::uint64_t time_ns);
  bool parse_id(std::size_t token, CanFrame& frame);  ///< false after reporting it corrupt
  std::optional<std::uint64_t> channel(std::size_t token);  ///< 1..255; nullopt after reporting it corrupt
  bool data_bytes(std::size_t first, CanFrame& frame);  ///< frame.dlc bytes; false after reporting one corrupt
  Step emit(CanFrame frame, std::uint64_t channel, std::uint64_t time_ns);
  Step corrupt(std::size_t column, std::string message);
  [[nodiscard]] std::uint64_t absolute(std::uint64_t time_ns);

  std::istream& in_;
  std::string line_;
  std::uint64_t line_number_ = 0;
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
  void finish() override;
  void header(std::uint64_t first_ns);

  std::uint64_t start_ns_ = 0;
  bool header_written_ = false;
  InterfaceIndex channels_;  ///< index + 1 = ASC channel
};

}  // namespace saul::host
