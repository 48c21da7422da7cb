// SavvyCAN's native CSV log ("GVRET" logs, File > Save Frames > GVRET), read and written as SavvyCAN does:
//
//   Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8
//   1700000000001250,00000938,true,Rx,0,8,FF,FF,FB,50,00,23,00,FA,
//
// Time Stamp: microseconds (SavvyCAN's own clock or Unix time, as the capture was made); ID: hex; Extended:
// true/false (an id above 7FF is 29-bit whatever it says, as SavvyCAN reads it); Dir: Rx/Tx (absent in the first
// version of the format, "Time Stamp,ID,Extended,Bus,LEN,..."); Bus: 0-based, read as "can<Bus>"; LEN: 0..8, then
// that many hex bytes (the writer always fills D1..D8, zeros after LEN, and ends the line with a comma). The
// format has no remote and no error frames: the writer leaves them out (copy_frames counts them,
// conversion_losses says so). Buses are numbered 0, 1, ... in order of first appearance of each interface name.
#pragma once

#include <cstdint>
#include <istream>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/interface_index.hpp"

namespace saul::host {

class GvretCsvReader final : public RecordCaptureReader {
 public:
  explicit GvretCsvReader(std::istream& in) : in_(in) {}
  Status next() override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::gvret_csv; }

 private:
  bool header(std::string_view line);
  bool row(std::string_view line);
  bool fail(std::size_t column, std::string message);
  std::istream& in_;
  std::string line_;
  std::size_t time_ = 0, id_ = 1, extended_ = 2, bus_ = 3, len_ = 4, data_ = 5;  // column indexes
  bool have_header_ = false;
  std::uint64_t line_number_ = 0;
};

class GvretCsvWriter final : public StreamCaptureWriter {
 public:
  explicit GvretCsvWriter(std::ostream& out);
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::gvret_csv; }

 private:
  /// Remote and error frames are left out (the format has none).
  void put(const CanFrame& frame, std::string_view interface) override;
  InterfaceIndex buses_;
};

}  // namespace saul::host
