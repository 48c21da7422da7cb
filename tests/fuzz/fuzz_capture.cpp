// CAN capture readers (make_capture_reader over a std::istringstream), one binary per format: built with
// -DSAUL_FUZZ_FORMAT=candump|pcap|pcapng|asc|blf|trc|csv|gvret_csv. Only CaptureOpenError (bad header) may be
// thrown; next() never throws. BLF inflates its log containers (on a second thread), so a few input bytes may
// stand for many records: its bound is per container, not per input byte.
#include <sstream>
#include <string>

#include "fuzz_util.hpp"
#include "saulproto/host/capture/blf.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/pcapng.hpp"

namespace {

// pcapng: the reader over bytes in memory (what decode's blocks use) must say exactly what the stream reader says.
void same_in_memory(const std::uint8_t* data, std::size_t size) {
  using namespace saul::host;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::unique_ptr<PcapngReader> a, b;
  try {
    a = std::make_unique<PcapngReader>(in);
  } catch (const CaptureOpenError&) {
    a.reset();
  }
  try {
    b = std::make_unique<PcapngReader>(std::span<const std::uint8_t>(data, size));
  } catch (const CaptureOpenError&) {
    b.reset();
  }
  if (!a || !b) {
    if (a || b) saul::fuzz::fail();
    return;
  }
  for (std::size_t n = 0; n <= size + 1; ++n) {
    const auto sa = a->next();
    const auto sb = b->next();
    if (sa != sb) saul::fuzz::fail();
    if (sa == CaptureReader::Status::end) return;
    if (sa == CaptureReader::Status::frame) {
      if (!a->frame().same_wire(b->frame()) || a->frame().timestamp_ns != b->frame().timestamp_ns ||
          a->interface() != b->interface())
        saul::fuzz::fail();
    } else if (format_capture_error("f", a->error()) != format_capture_error("f", b->error())) {
      saul::fuzz::fail();
    }
  }
}

}  // namespace

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
  if (CaptureFormat::SAUL_FUZZ_FORMAT == CaptureFormat::pcapng) same_in_memory(data, size);
  return 0;
}
