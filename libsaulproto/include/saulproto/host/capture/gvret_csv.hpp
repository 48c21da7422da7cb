// SavvyCAN's native CSV log ("GVRET"), read and written as SavvyCAN does:
//   Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8
//   1700000000001250,00000938,true,Rx,0,8,FF,FF,FB,50,00,23,00,FA,
// Microseconds; an id above 7FF is 29-bit whatever Extended says; no Dir column in the format's first version; bus
// N reads as "can<N>". No remote or error frames: the writer leaves them out (copy_frames counts them). Buses are
// numbered 0, 1, ... in order of first appearance.
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

class GvretCsvReader final : public LineCaptureReader {
 public:
  explicit GvretCsvReader(std::istream& in) : LineCaptureReader(in) {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::gvret_csv; }

 private:
  Step parse_line(std::string_view line) override;
  Step header(std::string_view line);
  Step row(std::string_view line);
  std::size_t time_ = 0, id_ = 1, extended_ = 2, bus_ = 3, len_ = 4, data_ = 5;  // column indexes
  bool have_header_ = false;
};

class GvretCsvWriter final : public StreamCaptureWriter {
 public:
  explicit GvretCsvWriter(std::ostream& out)
      : StreamCaptureWriter(out, "GVRET CSV", "Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n") {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::gvret_csv; }

 private:
  /// Remote and error frames are left out (the format has none).
  void put(const CanFrame& frame, std::string_view interface) override;
  InterfaceIndex buses_;
};

}  // namespace saul::host
