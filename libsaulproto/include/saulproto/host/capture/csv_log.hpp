// python-can's CSV log (can.CSVWriter / can.CSVReader): "timestamp,arbitration_id,extended,remote,error,dlc,data",
// e.g. "1700000000.00125,0x938,1,0,0,8,///7UAAjAPo=" (data in base64). The timestamp is read exactly as the decimal
// Python printed; an error frame keeps its SocketCAN class (the id) and data. No channel: every frame reads as
// "can0". Columns are found by their names in the header; a line that does not parse is reported and skipped.
// Writing: the same header, microseconds, LF line ends.
#pragma once

#include <cstdint>
#include <istream>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"

namespace saul::host {

/// Standard base64 (RFC 4648, with padding), as Python's base64.b64encode writes it.
std::string base64_encode(std::span<const std::uint8_t> bytes);
/// Decodes standard base64 (padding optional) into at most out.size() bytes; returns the count, or -1 when the text
/// is not base64 or holds more than out.size() bytes.
int base64_decode(std::string_view text, std::span<std::uint8_t> out);

class CsvLogReader final : public LineCaptureReader {
 public:
  explicit CsvLogReader(std::istream& in) : LineCaptureReader(in) {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::csv; }

 private:
  Step parse_line(std::string_view line) override;
  Step header(std::string_view line);
  Step row(std::string_view line);
  std::vector<std::size_t> field_;  // column index of timestamp, arbitration_id, extended, remote, error, dlc, data
  std::size_t columns_ = 0;
  bool have_header_ = false;
};

class CsvLogWriter final : public StreamCaptureWriter {
 public:
  explicit CsvLogWriter(std::ostream& out)
      : StreamCaptureWriter(out, "CSV", "timestamp,arbitration_id,extended,remote,error,dlc,data\n") {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::csv; }

 private:
  void put(const CanFrame& frame, std::string_view interface) override;
};

}  // namespace saul::host
