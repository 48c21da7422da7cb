// CAN capture readers (make_capture_reader over a std::istringstream), one target per format
// (saul_fuzz_capture_<format>, listed in fuzz_targets.inc). Only CaptureOpenError (bad header) may be thrown; next()
// never throws. BLF inflates its log containers, so a few input bytes may stand for many records: its bound is per
// container, not per input byte.
#include <sstream>
#include <string>
#include <vector>

#include "fuzz_util.hpp"
#include "saulproto/host/capture/blf.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/mcap.hpp"
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
  // c: the same bytes in batches (next_batch: the usual packets read straight from memory, the rest by next()),
  // batch sizes varied; flattened in order, it must say what the stream reader says, record by record.
  std::unique_ptr<PcapngReader> c = std::make_unique<PcapngReader>(std::span<const std::uint8_t>(data, size));
  struct Record {
    bool frame;
    saul::CanFrame f;
    std::string interface;
    std::string error;
  };
  std::vector<Record> batched;
  FrameBatch batch;
  for (std::size_t max = 1; c->next_batch(batch, max); max = max % 7 + 1) {
    if (batch.frames.size() + batch.corrupt.size() > max) saul::fuzz::fail();
    std::size_t k = 0;
    for (std::size_t i = 0; i <= batch.frames.size(); ++i) {
      for (; k < batch.corrupt.size() && batch.corrupt[k].before == i; ++k)
        batched.push_back({false, {}, {}, format_capture_error("f", batch.corrupt[k].error)});
      if (i < batch.frames.size()) batched.push_back({true, batch.frames[i], std::string(batch.interfaces[i]), {}});
    }
    if (batched.size() > size + 1) saul::fuzz::fail();  // every record consumes input
  }
  std::size_t at = 0;
  for (std::size_t n = 0; n <= size + 1; ++n) {
    const auto sa = a->next();
    const auto sb = b->next();
    if (sa != sb) saul::fuzz::fail();
    if (sa == CaptureReader::Status::end) {
      if (at != batched.size()) saul::fuzz::fail();
      return;
    }
    if (at >= batched.size() || batched[at].frame != (sa == CaptureReader::Status::frame)) saul::fuzz::fail();
    const Record& r = batched[at++];
    if (sa == CaptureReader::Status::frame) {
      if (!a->frame().same_wire(b->frame()) || a->frame().timestamp_ns != b->frame().timestamp_ns ||
          a->interface() != b->interface())
        saul::fuzz::fail();
      if (!a->frame().same_wire(r.f) || a->frame().timestamp_ns != r.f.timestamp_ns || a->interface() != r.interface)
        saul::fuzz::fail();
    } else {
      const std::string error = format_capture_error("f", a->error());
      if (error != format_capture_error("f", b->error()) || error != r.error) saul::fuzz::fail();
    }
  }
}

int read_capture(saul::host::CaptureFormat format, const std::uint8_t* data, std::size_t size) {
  using namespace saul::host;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::unique_ptr<CaptureReader> reader;
  try {
    reader = make_capture_reader(in, format);
  } catch (const CaptureOpenError&) {
    return 0;
  }
  std::size_t records = 0;
  std::size_t max_records = size + 1;
  if (format == CaptureFormat::blf)  // an object is at least 16 bytes once inflated
    max_records = (size / 16 + 1) * (BlfReader::kMaxContainerBytes / 16 + 2);
  if (format == CaptureFormat::mcap)  // a chunk inflates to kMcapMaxRecord at most
    max_records = (size / 9 + 1) * (kMcapMaxRecord / 31 + 2);     // ... of records of 31 bytes or more
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
  if (format == CaptureFormat::pcapng) same_in_memory(data, size);
  return 0;
}

}  // namespace

SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, candump)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, pcap)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, pcapng)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, asc)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, blf)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, trc)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, csv)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, gvret_csv)
SAUL_FUZZ_FORMAT_TARGET(capture, read_capture, mcap)
