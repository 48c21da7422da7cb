// CAN capture readers (make_capture_reader over a std::istringstream), one target per format
// (saul_fuzz_capture_<format>, listed in fuzz_targets.inc). Only CaptureOpenError (bad header) may be thrown;
// next_batch() never throws. BLF inflates its log containers, so a few input bytes may stand for many records: its
// bound is per container, not per input byte.
#include <sstream>
#include <string>
#include <vector>

#include "fuzz_util.hpp"
#include "saulproto/host/capture/blf.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/capture/pcapng.hpp"

namespace {

struct Record {
  bool frame;
  saul::CanFrame f;
  std::string interface;
  std::string error;
};

bool operator==(const Record& a, const Record& b) {
  return a.frame == b.frame && a.f.same_wire(b.f) && a.f.timestamp_ns == b.f.timestamp_ns &&
         a.interface == b.interface && a.error == b.error;
}

/// A pcapng reader's records in order, from batches of FrameBatch::kMax records or (varied) of 1, 2, ..., 7, 1, ...
std::vector<Record> records_of(saul::host::PcapngReader& reader, bool varied, std::size_t size) {
  using namespace saul::host;
  std::vector<Record> records;
  FrameBatch batch;
  for (std::size_t max = 1; reader.next_batch(batch, varied ? max : FrameBatch::kMax); max = max % 7 + 1) {
    if (varied && batch.frames.size() + batch.corrupt.size() > max) saul::fuzz::fail();
    std::size_t k = 0;
    for (std::size_t i = 0; i <= batch.frames.size(); ++i) {
      for (; k < batch.corrupt.size() && batch.corrupt[k].before == i; ++k)
        records.push_back({false, {}, {}, format_capture_error("f", batch.corrupt[k].error)});
      if (i < batch.frames.size()) records.push_back({true, batch.frames[i], std::string(batch.interfaces[i]), {}});
    }
    if (k != batch.corrupt.size()) saul::fuzz::fail();
    if (records.size() > size + 1) saul::fuzz::fail();  // every record consumes input
  }
  return records;
}

// pcapng: the reader over bytes in memory (what decode's blocks use) must say exactly what the stream reader says,
// record by record: in whole batches, and in batches of sizes varied (the usual packets read straight from memory,
// the rest by the reader's one-record path).
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
  PcapngReader c{std::span<const std::uint8_t>(data, size)};
  const std::vector<Record> streamed = records_of(*a, false, size);
  if (records_of(*b, false, size) != streamed || records_of(c, true, size) != streamed) saul::fuzz::fail();
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
  for (FrameBatch batch; reader->next_batch(batch);) {
    if (batch.interfaces.size() != batch.frames.size()) saul::fuzz::fail();
    for (std::size_t i = 0; i < batch.frames.size(); ++i) {
      if (!batch.frames[i].valid()) saul::fuzz::fail();
      (void)std::string(batch.interfaces[i]);  // the views point at live bytes
    }
    for (const auto& c : batch.corrupt) (void)format_capture_error("fuzz", c.error);
    records += batch.frames.size() + batch.corrupt.size();
    if (records > max_records) saul::fuzz::fail();  // every record consumes input
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
