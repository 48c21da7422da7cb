// saulctl decode of a CAN capture: the frames through the one read path (batches, or blocks on both cores) into
// FrameEmitter, written in file order: the same bytes, reports and counts however the file was read. Memory is
// bounded by the blocks in flight (2 per thread).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/report/fast_emit.hpp"

namespace saul::host {

struct FrameDecodeOptions {
  DecodeFormat format = DecodeFormat::text;
  TimeMode time = TimeMode::absolute;
  /// Only the frames this accepts (saulctl's --id filters); empty: every frame. Called from the decoding threads.
  std::function<bool(const CanFrame&)> keep;
  /// Each frame's output instead of FrameEmitter's (decode --format long), given the frame, its interface and its
  /// time as FrameEmitter would print it; the frames then go through it in order on one thread.
  std::function<void(const CanFrame&, std::string_view interface, fmt::memory_buffer& out, DecodeCounts& counts)>
      render;
  ReadOptions read;
};

struct FrameDecodeResult {
  DecodeCounts counts;        ///< frames that passed the id filter
  std::uint64_t records = 0;  ///< frames read, before the filter
  std::uint64_t corrupt = 0;
};

struct FrameDecodeSinks {
  std::function<void(std::string_view)> write;               ///< output, in big pieces, in file order
  std::function<void(const CaptureError&)> corrupt;          ///< each corrupt record, in file order
  std::function<void(std::uint64_t records, std::uint64_t bytes)> progress;  ///< so far (frames + corrupt); may be empty
};

/// Decodes every frame `reader` (opened from `path`: open_capture; `compressed` when gzip or zstd) holds. A large
/// file may be read again by path in blocks, and a candump log that cannot be cut up front (compressed, a pipe) is
/// read as text: `reader` may be given up for it. With options.read.live (a pipe from candump -L) what each read
/// brought is written at once.
FrameDecodeResult decode_capture(const std::string& path, std::unique_ptr<CaptureReader>& reader, bool compressed,
                                 const FrameDecodeOptions& options, const FrameDecodeSinks& sinks);

}  // namespace saul::host
