// can-utils candump log lines: "(1700000000.000000) can0 300#E8030CFE", as `candump -L` prints and
// `candump -l` writes, and as canplayer reads them.
//
// Frame syntax: 3 hex digits = 11-bit id, 8 = 29-bit id; "#R" or "#R<len>" remote; an id with the error flag
// (0x20000000) is an error frame; a raw-DLC suffix "_9".."_F" after 8 data bytes (or "R8") is accepted and the frame
// keeps its 8 bytes. Lines that do not start with '(' are comments to canplayer and are skipped.
// CAN FD lines ("##") are recognised and reported as unsupported: the robot's bus is classic CAN.
// CandumpReader and CandumpWriter are the candump members of the capture interface (capture.hpp).
#pragma once

#include <cstdint>
#include <istream>
#include <ostream>
#include <string>
#include <string_view>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"

namespace saul::host {

struct CandumpLine {
  CanFrame frame;          ///< timestamp_ns always set
  std::string_view interface;  ///< points into the parsed line
};

/// Why a line did not parse: column (0-based, where the problem starts) and message. The reader also fills
/// the line number in position.
using CandumpError = CaptureError;

/// Parses one line (without its newline). On failure returns false and fills error.
bool parse_candump_line(std::string_view line, CandumpLine& out, CandumpError& error);

/// An interface name as one candump word: "" is "can0", white space and control characters become '_' (a pcapng
/// if_name such as text2pcap's "Fake IF, text2pcap" would otherwise split the line).
std::string candump_interface(std::string_view interface);

/// Formats one frame as a log line without newline: "(sec.usec) iface ID#DATA" (iface as candump_interface()
/// writes it). Frames without a timestamp get 0. Microsecond resolution, as `candump -l` writes by default.
std::string format_candump_line(const CanFrame& frame, std::string_view interface);

/// The compact frame text alone, e.g. "300#E8030CFE", "00000344#000005DC", "123#R4".
std::string format_candump_frame(const CanFrame& frame);

/// Reads a candump log line by line in constant memory. Comment lines are skipped; a corrupt line is
/// reported through next()'s error and the reader carries on with the next line.
class CandumpReader final : public CaptureReader {
 public:
  explicit CandumpReader(std::istream& in) : in_(in) {}

  /// Advances to the next frame. On Status::corrupt, error() and line_number() describe the bad line.
  Status next() override;

  [[nodiscard]] const CanFrame& frame() const override { return current_.frame; }
  [[nodiscard]] std::string_view interface() const override { return current_.interface; }
  [[nodiscard]] const CandumpError& error() const override { return error_; }
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::candump; }
  /// 1-based number of the line last read.
  [[nodiscard]] std::uint64_t line_number() const { return line_number_; }
  [[nodiscard]] const std::string& line() const { return line_; }

 private:
  std::istream& in_;
  std::string line_;
  CandumpLine current_;
  CandumpError error_;
  std::uint64_t line_number_ = 0;
};

/// Writes `candump -l` lines ("(sec.usec) iface ID#DATA", LF), which canplayer replays and candump's tools read.
/// Microsecond resolution. White space in an interface name is written as '_'.
class CandumpWriter final : public StreamCaptureWriter {
 public:
  explicit CandumpWriter(std::ostream& out) : StreamCaptureWriter(out, "candump") {}

  void write(const CanFrame& frame, std::string_view interface) override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::candump; }

 private:
};

}  // namespace saul::host
