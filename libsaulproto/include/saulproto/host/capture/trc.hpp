// PEAK trace files (.trc), as PCAN-View, PCAN-Explorer, PEAK-Converter and python-can write them (choices:
// docs/captures.md "PEAK TRC"). Lines starting with ';' are comments, except ";$FILEVERSION=", ";$STARTTIME=" and
// ";$COLUMNS=".
//
//   1.0  (no $FILEVERSION)  "     1)      1841  0001    8  00 00 ..."        number) time(ms) id dlc data
//   1.1   "     1)      1841.0  Rx         0001  8  00 00 ..."                 number) time type id dlc data
//   1.2   "     1)      1841.0 1  Rx         0001  8  00 00 ..."               ... time bus type id dlc data
//   1.3   "     1)      1841.0 1  Rx         0001 -  8  00 00 ..."             ... time bus type id reserved dlc data
//   2.0   "      1      1059.900 DT     0300 Rx 7  00 00 ..."                  columns N,O,T,I,d,l,D by default
//   2.1   "      1      1059.900 DT 1      0300 Rx -  7    00 00 ..."          columns N,O,T,B,I,d,R,L,D by default
//
// Version 2 lines follow $COLUMNS (N number, O offset, T type, B bus, I id, d direction, R reserved, l length, L DLC,
// D data). An id of more than 4 hex digits is 29-bit. Times are ms since $STARTTIME (days since 1899-12-30, read as
// UTC). Error frames read as a bus error (0x080, 8 zero bytes), CAN FD types are reported as unsupported, status
// lines are skipped; bus N reads as "can<N-1>" ("can0" without a bus column); a DLC of 9..15 reads as 8 bytes.
// Writing: version 2.1 in python-can's columns, from a $STARTTIME exact in the file (a multiple of 0.864 s), so that
// start + offset gives each frame's microsecond back; buses numbered in order of first appearance.
#pragma once

#include <array>
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

/// Parses a $STARTTIME value ("44548.6028595139", days since 1899-12-30) into ns since 1970 (UTC); nullopt when it
/// is not a number or lies before 1970.
std::optional<std::uint64_t> parse_trc_start_time(std::string_view days);

class TrcReader final : public LineCaptureReader {
 public:
  explicit TrcReader(std::istream& in) : LineCaptureReader(in) {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::trc; }

  /// 10 for 1.0 (no $FILEVERSION), 11, 12, 13, 20, 21.
  [[nodiscard]] int version() const { return version_; }

 private:
  Step parse_line(std::string_view line) override;
  Step directive(std::string_view line);
  Step v1_line();
  Step v2_line();
  /// The frame of a line from its tokens; id_token kErrorLine: an error frame, of the line's time and bus alone.
  Step frame_from(std::size_t time_token, std::optional<std::size_t> bus_token, std::size_t id_token,
                  std::size_t dlc_token, bool dlc_is_length, std::size_t data_token, bool remote);
  static constexpr std::size_t kErrorLine = SIZE_MAX;

  std::size_t line_length_ = 0;  // without its CR
  std::vector<std::pair<std::size_t, std::string_view>> tokens_;  // (column, text)
  int version_ = 10;
  std::optional<std::uint64_t> start_ns_;
  std::string columns_;  // version 2: one letter per column, "NOTBIdRLD"
};

class TrcWriter final : public StreamCaptureWriter {
 public:
  explicit TrcWriter(std::ostream& out) : StreamCaptureWriter(out, "TRC") {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::trc; }

 private:
  void put(const CanFrame& frame, std::string_view interface) override;
  void begin(std::uint64_t first_ns) override;
  InterfaceIndex buses_;
  std::uint64_t start_ns_ = 0;
  std::uint64_t number_ = 0;
};

}  // namespace saul::host
