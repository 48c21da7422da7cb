// Serial capture readers (serial log and the sigrok / PulseView imports) over a std::istringstream, one target per
// format (saul_fuzz_serial_<format>, listed in fuzz_targets.inc).
#include <sstream>
#include <string>

#include "fuzz_util.hpp"
#include "saulproto/host/capture/serial_capture.hpp"

namespace {

int read_serial_capture(saul::host::CaptureFormat format, const std::uint8_t* data, std::size_t size) {
  using namespace saul::host;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  SerialReadOptions options;
  options.samplerate_hz = size & 1 ? 1'000'000 : 0;
  std::unique_ptr<SerialCaptureReader> reader;
  try {
    reader = make_serial_capture_reader(in, format, options);
  } catch (const CaptureOpenError&) {
    return 0;
  }
  std::size_t records = 0;
  for (;;) {
    auto status = reader->next();
    if (status == SerialCaptureReader::Status::end) break;
    if (status == SerialCaptureReader::Status::corrupt) (void)format_capture_error("fuzz", reader->error());
    if (++records > size + 1) saul::fuzz::fail();
  }
  return 0;
}

}  // namespace

SAUL_FUZZ_FORMAT_TARGET(serial, read_serial_capture, serial)
SAUL_FUZZ_FORMAT_TARGET(serial, read_serial_capture, sigrok)
SAUL_FUZZ_FORMAT_TARGET(serial, read_serial_capture, sigrok_json)
SAUL_FUZZ_FORMAT_TARGET(serial, read_serial_capture, pulseview_csv)
