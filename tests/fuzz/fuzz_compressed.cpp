// The decompressors under the capture readers (compressed.hpp), one target per method (saul_fuzz_compressed_<method>,
// listed in fuzz_targets.inc). Whatever the input, reading ends (at its end or at the first corrupt byte,
// with error() saying which), never throws, and what comes out is then read as a capture of the format its first
// bytes say, as open_capture_reader does.
#include <memory>
#include <sstream>
#include <string>

#include "fuzz_util.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/compressed.hpp"

namespace {

int inflate_and_read(saul::host::Compression method, const std::uint8_t* data, std::size_t size) {
  using namespace saul::host;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  auto inflater = make_decompressing_buf(*in.rdbuf(), method);
  // At most 1 MiB of output: a small input may stand for a lot (that is what compression is for).
  std::string out;
  char buffer[4096];
  for (;;) {
    const std::streamsize n = inflater->sgetn(buffer, sizeof buffer);
    if (n <= 0) break;
    out.append(buffer, static_cast<std::size_t>(n));
    if (out.size() > (1U << 20)) break;
  }
  if (inflater->compressed_bytes() > size) saul::fuzz::fail();
  (void)inflater->error();
  const auto head = std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(out.data()),
                                                  out.size() < 4096 ? out.size() : 4096);
  const auto format = detect_capture_format(head);
  if (!format || holds_serial_bytes(*format)) return 0;
  std::istringstream content(out);
  try {
    auto reader = make_capture_reader(content, *format);
    std::size_t records = 0;
    for (FrameBatch batch; reader->next_batch(batch);) {
      records += batch.frames.size() + batch.corrupt.size();
      if (records > (1U << 22)) saul::fuzz::fail();
    }
  } catch (const CaptureOpenError&) {
  }
  return 0;
}

}  // namespace

extern "C" int saul_fuzz_compressed_gzip(const std::uint8_t* data, std::size_t size) {
  return inflate_and_read(saul::host::Compression::gzip, data, size);
}
extern "C" int saul_fuzz_compressed_zstd(const std::uint8_t* data, std::size_t size) {
  return inflate_and_read(saul::host::Compression::zstd, data, size);
}
