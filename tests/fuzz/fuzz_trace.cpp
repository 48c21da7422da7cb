// The BALANCE console stream (trace.hpp ConsoleDecoder): byte by byte and in chunks must agree (records, lines,
// counters), and every byte is accounted for: records x 39 + text + skipped + pending = bytes pushed.
#include "fuzz_util.hpp"
#include "saulproto/core/trace.hpp"

namespace {
struct Count {
  std::size_t records = 0, lines = 0, rejections = 0;
  void record(const saul::trace::LoopTrace&, std::uint64_t) { ++records; }
  void line(std::string_view text, bool) {
    if (text.size() > saul::trace::ConsoleDecoder::kMaxLine) saul::fuzz::fail();
    ++lines;
  }
  void rejected(saul::Reason, std::uint64_t) { ++rejections; }
};
}  // namespace

extern "C" int saul_fuzz_trace(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  std::span<const std::uint8_t> in(data, size);
  trace::ConsoleDecoder one, chunked;
  Count a, b;
  for (std::uint8_t byte : in) one.push(byte, a);
  fuzz::in_chunks(in, [&](auto piece) { chunked.push(piece, b); });
  const auto& k = one.counters();
  if (k.records * trace::kFrameSize + k.text_bytes + k.bytes_skipped + one.pending() != size) fuzz::fail();
  one.finish(a);
  chunked.finish(b);
  if (a.records != b.records || a.lines != b.lines || a.rejections != b.rejections) fuzz::fail();
  if (!(one.counters() == chunked.counters()) || one.pending() != 0) fuzz::fail();
  return 0;
}
