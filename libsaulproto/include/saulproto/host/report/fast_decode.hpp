// saulctl decode of a candump file at memory speed: CandumpScanner (large reads, lines scanned in place) feeding
// FrameEmitter (lines written straight into a big output buffer), flushed in big writes. Files of at least
// parallel_from bytes (4 MiB) are cut into blocks at line starts and decoded on `threads` threads; the output, the
// corrupt-line reports and the counts come out in file order, the same bytes as on one thread. Memory stays
// bounded by the blocks in flight (2 per thread), whatever the file size.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
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
  unsigned threads = 2;
  /// Candump and pcap files this big or bigger use `threads` (4 MiB: ~20 ms of work on one core, from where a
  /// second thread pays off).
  std::uint64_t parallel_from = std::uint64_t{4} << 20;
  std::uint64_t block = std::uint64_t{256} << 10;         ///< bytes of candump per block (multi-threaded)
  std::size_t flush_at = std::size_t{1} << 20;           ///< output bytes buffered before a write
};

struct FrameDecodeResult {
  DecodeCounts counts;        ///< frames that passed the id filter
  std::uint64_t records = 0;  ///< frames read, before the filter
  std::uint64_t corrupt = 0;
  /// A pipe's first line that was no candump line (CandumpScanner::first_other), for "not a capture" hints.
  std::string first_other;
};

struct FrameDecodeSinks {
  std::function<void(std::string_view)> write;               ///< output lines, in big pieces, in file order
  std::function<void(const CaptureError&)> corrupt;          ///< each corrupt line, in file order
  std::function<void(std::uint64_t records, std::uint64_t bytes)> progress;  ///< so far (frames + corrupt); may be empty
};

/// Decodes candump text from `fd` (not closed). `size` is the file's size when fd is a regular file (then it is
/// read with pread, on several threads when big enough); nullopt for a pipe (read sequentially, and what each read
/// brought is written at once: `candump -L can0 | saulctl decode -` stays live).
FrameDecodeResult decode_candump(int fd, std::optional<std::uint64_t> size, const FrameDecodeOptions& options,
                                   const FrameDecodeSinks& sinks);

/// The same for a pcap file (PcapScanner; large files in blocks of whole records on `threads` threads): nullopt
/// when `path` is not a regular, uncompressed pcap file. Open it with open_capture_reader first: that checks its
/// header and names what is wrong.
std::optional<FrameDecodeResult> decode_pcap_file(const std::string& path, const FrameDecodeOptions& options,
                                                    const FrameDecodeSinks& sinks);

/// The same for a large pcapng file on `threads` threads (pcapng_block_starts(): blocks of whole packet blocks,
/// each read by its own PcapngReader after the file's section and interface blocks): nullopt when `path` is not a
/// regular file of at least parallel_from bytes that can be cut, or the time mode is delta; then decode_reader().
std::optional<FrameDecodeResult> decode_pcapng_file(const std::string& path, const FrameDecodeOptions& options,
                                                      const FrameDecodeSinks& sinks);

/// The same for any reader (pcapng, ASC, TRC, BLF, compressed logs, ...): its frames in batches through the same
/// emitter. With `ahead` the reader (parsing, decompressing) runs on a second thread a few batches ahead of the
/// decoding and writing on this one; the output is the same bytes. Progress counts records and reader.bytes_read().
FrameDecodeResult decode_reader(CaptureReader& reader, bool ahead, const FrameDecodeOptions& options,
                                  const FrameDecodeSinks& sinks);

/// Whether decode_candump_text() decodes with these options (else it returns nullopt and the frames are read one by
/// one): ask before take_capture_text() gives the reader up for the text.
bool decodes_candump_text(const FrameDecodeOptions& options) noexcept;
/// Candump text from a stream (a compressed log, take_capture_text) on options.threads threads: the text is cut
/// into blocks of whole lines as it is read (one thread at a time, in order; a line longer than kMaxCandumpLine is
/// cut short there and reported as too long, as decode_candump does, so no block holds it), each block decoded by
/// whichever thread read it, the output in text order, and a decompression error at the end as CaptureReader
/// reports it. The bytes, reports and counts of decode_candump() over the uncompressed text. nullopt, having read
/// nothing, for a relative or delta time (they need the frames before) or one thread: then decode_reader().
std::optional<FrameDecodeResult> decode_candump_text(CaptureText& text, const FrameDecodeOptions& options,
                                                       const FrameDecodeSinks& sinks);

/// decode_candump() of the file at `path` when it is a regular file holding uncompressed candump text (told by its
/// first bytes, as detect_capture_format does); nullopt, having read nothing else, when it is not (or cannot be
/// opened): the caller reads it through open_capture_reader.
std::optional<FrameDecodeResult> decode_candump_file(const std::string& path, const FrameDecodeOptions& options,
                                                       const FrameDecodeSinks& sinks);

}  // namespace saul::host
