// CAN capture readers (make_capture_reader over a std::istringstream), one binary per format: built with
// -DSAUL_FUZZ_FORMAT=candump|pcap|pcapng|asc|blf|trc|csv|gvret_csv. Only CaptureOpenError (bad header) may be
// thrown; next() never throws. BLF inflates its log containers (on a second thread), so a few input bytes may
// stand for many records: its bound is per container, not per input byte.
#include <sstream>
#include <string>

#include "fuzz_util.hpp"
#include "saulproto/host/capture/blf.hpp"
#include "saulproto/host/capture/capture.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace saul::host;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::unique_ptr<CaptureReader> reader;
  try {
    reader = make_capture_reader(in, CaptureFormat::SAUL_FUZZ_FORMAT);
  } catch (const CaptureOpenError&) {
    return 0;
  }
  std::size_t records = 0;
  std::size_t max_records = size + 1;
  if (CaptureFormat::SAUL_FUZZ_FORMAT == CaptureFormat::blf)  // an object is at least 16 bytes once inflated
    max_records = (size / 16 + 1) * (BlfReader::kMaxContainerBytes / 16 + 2);
  for (;;) {
    auto status = reader->next();
    if (status == CaptureReader::Status::end) break;
    if (status == CaptureReader::Status::frame) {
      if (!reader->frame().valid()) saul::fuzz::fail();
      (void)reader->interface();
    } else {
      (void)format_capture_error("fuzz", reader->error());
    }
    if (++records > max_records) saul::fuzz::fail();  // every record consumes input
  }
  (void)detect_capture_format(std::span<const std::uint8_t>(data, size));
  return 0;
}
