#include "saulproto/host/report/fast_decode.hpp"

#include <optional>

#include "../capture/read_path.hpp"

namespace saul::host {
namespace {

/// decode's work on the read path: each piece (a block, or a batch) rendered into its own buffer.
struct DecodeWork {
  using Worker = FrameEmitter;
  struct Piece {
    fmt::memory_buffer out;
    DecodeCounts counts;
  };
  const FrameDecodeOptions& o;
  const FrameDecodeSinks& sinks;
  FrameDecodeResult result;
  std::optional<std::uint64_t> first;  // relative times in blocks: the first kept frame's

  Worker worker() { return FrameEmitter(o.format, o.time, first); }
  bool in_blocks(const CaptureBlocks* blocks) {
    // delta needs the previous frame's time, and render the frames in order; relative times the first frame's,
    // which only a file cut up front can tell before its blocks are read
    if (o.render || o.time == TimeMode::delta) return false;
    if (o.time == TimeMode::relative) {
      if (blocks == nullptr) return false;
      first = blocks->first_time(o.keep);
    }
    return true;
  }
  void start(Worker&, Piece& p, bool) {
    p.out.clear();
    p.counts = {};
  }
  CandumpLineTaker* taker(Worker&) { return nullptr; }
  void add(Worker& emitter, Piece& p, const FrameBatch& batch) {
    const std::size_t n = batch.frames.size();
    for (std::size_t i = 0; i < n; ++i) {
      const CanFrame& f = batch.frames[i];
      if (o.keep && !o.keep(f)) continue;
      if (o.render)
        o.render(f, batch.interfaces[i], p.out, p.counts);
      else
        emitter.add(f, batch.interfaces[i], p.out, p.counts);
    }
  }
  std::uint64_t finish(Worker&, Piece&) { return 0; }
  void take(Piece& p) {
    if (p.out.size() > 0) sinks.write(std::string_view(p.out.data(), p.out.size()));
    result.counts += p.counts;
  }
};

}  // namespace

FrameDecodeResult decode_capture(const std::string& path, std::unique_ptr<CaptureReader>& reader, bool compressed,
                                 const FrameDecodeOptions& options, const FrameDecodeSinks& sinks) {
  DecodeWork work{options, sinks, {}, std::nullopt};
  const auto counts = detail::read_capture(path, reader, compressed, options.read, work, {sinks.corrupt, sinks.progress});
  work.result.records = counts.frames;
  work.result.corrupt = counts.corrupt;
  return work.result;
}

}  // namespace saul::host
